//! The VirtualHome scene graph: nodes (class, category, properties, states) and labelled
//! edges held in a `petgraph` graph map, read from EAI's scene-graph JSON.

use std::fmt;

use petgraph::Direction;
use petgraph::graphmap::DiGraphMap;
use rustc_hash::FxHashMap;
use serde::Deserialize;

use super::VirtualhomeError;

/// Dense index of a node in a [`SceneGraph`] (not the VirtualHome id).
pub type NodeIx = u32;

macro_rules! flag_enum {
    ($(#[$doc:meta])* $name:ident, $set:ident, $bits:ty, [$($(#[$variant_doc:meta])* $variant:ident = $text:literal),* $(,)?]) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum $name { $($(#[$variant_doc])* $variant),* }

        impl $name {
            /// Every value, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$variant),*];
            /// The name as the executor writes it (`CLOSED`, `HOLDS_RH`, `CAN_OPEN`).
            pub fn as_str(self) -> &'static str {
                match self { $($name::$variant => $text),* }
            }
            /// Parses the executor's name, case-insensitively as `Enum[s.upper()]` does.
            pub fn parse(text: &str) -> Option<$name> {
                let upper = text.to_ascii_uppercase();
                match upper.as_str() { $($text => Some($name::$variant),)* _ => None }
            }
            fn bit(self) -> $bits { 1 << (self as u32) }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result { f.write_str(self.as_str()) }
        }

        #[doc = concat!("A set of [`", stringify!($name), "`] values as a bitset.")]
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
        pub struct $set($bits);

        impl $set {
            /// Whether `value` is in the set.
            pub fn contains(self, value: $name) -> bool { self.0 & value.bit() != 0 }
            /// Adds `value`; adding a member changes nothing.
            pub fn insert(&mut self, value: $name) { self.0 |= value.bit(); }
            /// Removes `value`; removing a non-member changes nothing.
            pub fn remove(&mut self, value: $name) { self.0 &= !value.bit(); }
            /// Whether the set has no member.
            pub fn is_empty(self) -> bool { self.0 == 0 }
            /// The members in declaration order.
            pub fn iter(self) -> impl Iterator<Item = $name> {
                $name::ALL.iter().copied().filter(move |v| self.contains(*v))
            }
        }
    };
}

flag_enum!(
    /// An edge label of the evolving graph (`environment.Relation`).
    Relation, RelationSet, u16,
    [
     /// The source rests on the target: an object on a surface, clothes on the character, the character on its seat.
     On = "ON",
     /// The source is in the target, a room or a container.
     Inside = "INSIDE",
     /// The source (a door, a doorjamb) joins the target room; no action here reads or writes it.
     Between = "BETWEEN",
     /// The source is within reach of the target; the actions add it in both directions.
     Close = "CLOSE",
     /// The source faces the target; `TURNTO` and `SIT` set the character's, the look and watch actions read them.
     Facing = "FACING",
     /// The character holds the target in its right hand.
     HoldsRh = "HOLDS_RH",
     /// The character holds the target in its left hand.
     HoldsLh = "HOLDS_LH",
     /// The source sits on the target; no action here reads or writes it (a seated character is ON its seat and has
     /// the node state [`NodeState::Sitting`]).
     Sitting = "SITTING"]
);

flag_enum!(
    /// A node state of the evolving graph (`environment.State`).
    NodeState, StateSet, u16,
    [
     /// Shut; what is INSIDE a closed node other than a room is hidden and cannot be grabbed or touched.
     Closed = "CLOSED",
     /// Opened, by `OPEN`.
     Open = "OPEN",
     /// Switched on, by `SWITCHON`; such a node cannot be opened.
     On = "ON",
     /// Switched off, by `SWITCHOFF`.
     Off = "OFF",
     /// The character sits, after `SIT`; cleared by `STANDUP` and `LIE`.
     Sitting = "SITTING",
     /// Dirty; `WIPE`, `WASH`, `RINSE` and `SCRUB` clear it.
     Dirty = "DIRTY",
     /// Clean, after `WIPE`, `WASH`, `RINSE` or `SCRUB`.
     Clean = "CLEAN",
     /// The character lies, after `LIE`; cleared by `STANDUP` and `SIT`.
     Lying = "LYING",
     /// Plugged in, by `PLUGIN`.
     PluggedIn = "PLUGGED_IN",
     /// Unplugged, by `PLUGOUT`; such a node cannot be switched on.
     PluggedOut = "PLUGGED_OUT"]
);

flag_enum!(
    /// An object property of the evolving graph (`environment.Property`).
    Property, PropertySet, u32,
    [
     /// A surface; no action here checks it (`PUTBACK` puts onto any close node).
     Surfaces = "SURFACES",
     /// `GRAB` accepts it (and `water` and `child` without it).
     Grabbable = "GRABBABLE",
     /// `SIT` accepts it while fewer nodes (sitters and objects) are ON it than a per-class number.
     Sittable = "SITTABLE",
     /// `LIE` accepts it while fewer nodes are ON it than a per-class number.
     Lieable = "LIEABLE",
     /// No action here reads it.
     Hangable = "HANGABLE",
     /// `DRINK` accepts it; `POUR` pours it.
     Drinkable = "DRINKABLE",
     /// `EAT` accepts such a node, or one with such a node ON it; `CUT` needs it with [`Property::Cuttable`].
     Eatable = "EATABLE",
     /// `POUR` pours into it; `DRINK` accepts it.
     Recipient = "RECIPIENT",
     /// `CUT` needs it, with [`Property::Eatable`].
     Cuttable = "CUTTABLE",
     /// `POUR` pours it.
     Pourable = "POURABLE",
     /// `OPEN` and `CLOSE` accept it (and `desk` and `window` without it); `PUTIN` into such a node needs it OPEN.
     CanOpen = "CAN_OPEN",
     /// `SWITCHON` and `SWITCHOFF` need it; `TYPE` accepts it.
     HasSwitch = "HAS_SWITCH",
     /// `READ` needs it.
     Readable = "READABLE",
     /// `WATCH` needs it.
     Lookable = "LOOKABLE",
     /// No action here reads it (`PUTIN` needs only closeness and, for a node that opens, OPEN).
     Containers = "CONTAINERS",
     /// `PUTON` and `PUTOFF` need it; `SQUEEZE` accepts it.
     Clothes = "CLOTHES",
     /// `GREET` needs it.
     Person = "PERSON",
     /// A part of the character's body: `WALK` makes the character close to every one, and `FIND` of one never walks.
     BodyPart = "BODY_PART",
     /// No action here reads it.
     CoverObject = "COVER_OBJECT",
     /// `PLUGIN` and `PLUGOUT` need it.
     HasPlug = "HAS_PLUG",
     /// No action here reads it.
     HasPaper = "HAS_PAPER",
     /// `PUSH`, `PULL` and `MOVE` accept it; as EAI's `check_movable` is written they also accept any `chair` or
     /// `curtain`, any `button`, and, for `PUSH`, any node at all.
     Movable = "MOVABLE",
     /// No action here reads it.
     Cream = "CREAM"]
);

/// One node of the scene: what never changes (id, class, category, properties) and its
/// states, which actions change.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneNode {
    /// The VirtualHome id (`<plate> (1001)`).
    pub id: u32,
    /// The class as script lines spell it (`plate`, `kitchencounter`, `character`).
    pub class_name: String,
    /// The category (`Rooms`, `Furniture`, `Appliances`, ...); empty when the JSON gives none.
    pub category: String,
    /// What the object affords; no action changes them.
    pub properties: PropertySet,
    /// The node's current states.
    pub states: StateSet,
}

impl SceneNode {
    /// Whether the node is a room: its category is `Rooms`.
    pub fn is_room(&self) -> bool {
        self.category == "Rooms"
    }
}

/// A scene graph: nodes in a dense vector, edges in a `petgraph` directed graph map from
/// node index to node index whose weight is the set of relations between the two.
#[derive(Debug, Clone)]
pub struct SceneGraph {
    pub(crate) nodes: Vec<SceneNode>,
    pub(crate) by_id: FxHashMap<u32, NodeIx>,
    pub(crate) edges: DiGraphMap<NodeIx, RelationSet>,
}

#[derive(Deserialize)]
struct JsonNode {
    id: i64,
    class_name: String,
    #[serde(default)]
    category: Option<String>,
    #[serde(default)]
    properties: Vec<String>,
    #[serde(default)]
    states: Vec<String>,
}

#[derive(Deserialize)]
struct JsonEdge {
    from_id: i64,
    relation_type: String,
    to_id: i64,
}

#[derive(Deserialize)]
pub(crate) struct JsonGraph {
    nodes: Vec<JsonNode>,
    edges: Vec<JsonEdge>,
}

impl SceneGraph {
    /// Builds the graph from EAI's JSON (`{"nodes": [...], "edges": [...]}`); `origin` names
    /// the file in errors. Duplicate node ids keep the last, as the executor does.
    pub(crate) fn from_json(json: JsonGraph, origin: &str) -> Result<SceneGraph, VirtualhomeError> {
        let bad = |field: String, message: String| VirtualhomeError::BadGraph { origin: origin.to_string(), field, message };
        let mut graph = SceneGraph { nodes: Vec::new(), by_id: FxHashMap::default(), edges: DiGraphMap::new() };
        for (i, node) in json.nodes.into_iter().enumerate() {
            let id = u32::try_from(node.id).map_err(|_| bad(format!("nodes[{i}].id"), format!("{} is not a node id", node.id)))?;
            let mut properties = PropertySet::default();
            for (j, p) in node.properties.iter().enumerate() {
                let p = Property::parse(p).ok_or_else(|| bad(format!("nodes[{i}].properties[{j}]"), format!("unknown property {p:?}")))?;
                properties.insert(p);
            }
            let mut states = StateSet::default();
            for (j, s) in node.states.iter().enumerate() {
                let s = NodeState::parse(s).ok_or_else(|| bad(format!("nodes[{i}].states[{j}]"), format!("unknown state {s:?}")))?;
                states.insert(s);
            }
            let scene_node = SceneNode { id, class_name: node.class_name, category: node.category.unwrap_or_default(), properties, states };
            match graph.by_id.get(&id) {
                Some(&ix) => graph.nodes[ix as usize] = scene_node,
                None => {
                    let ix = graph.nodes.len() as NodeIx;
                    graph.nodes.push(scene_node);
                    graph.by_id.insert(id, ix);
                    graph.edges.add_node(ix);
                }
            }
        }
        for (i, edge) in json.edges.iter().enumerate() {
            let relation = Relation::parse(&edge.relation_type)
                .ok_or_else(|| bad(format!("edges[{i}].relation_type"), format!("unknown relation {:?}", edge.relation_type)))?;
            let end = |id: i64, field: &str| {
                u32::try_from(id)
                    .ok()
                    .and_then(|id| graph.by_id.get(&id).copied())
                    .ok_or_else(|| bad(format!("edges[{i}].{field}"), format!("no node with id {id}")))
            };
            let from = end(edge.from_id, "from_id")?;
            let to = end(edge.to_id, "to_id")?;
            graph.add_edge(from, relation, to);
        }
        Ok(graph)
    }

    /// The node at `ix`; panics when `ix` is not below [`SceneGraph::len`].
    pub fn node(&self, ix: NodeIx) -> &SceneNode {
        &self.nodes[ix as usize]
    }

    /// The node at `ix`, mutable; panics when `ix` is not below [`SceneGraph::len`]. Its `id`
    /// must stay as it is: [`SceneGraph::index_of`] keeps the id each index was loaded with.
    pub fn node_mut(&mut self, ix: NodeIx) -> &mut SceneNode {
        &mut self.nodes[ix as usize]
    }

    /// The node with VirtualHome id `id`.
    pub fn index_of(&self, id: u32) -> Option<NodeIx> {
        self.by_id.get(&id).copied()
    }

    /// The number of nodes (a node id given twice in the JSON counts once).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the graph has no node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Every node index, `0..len()`.
    pub fn indices(&self) -> impl Iterator<Item = NodeIx> {
        0..self.nodes.len() as NodeIx
    }

    /// Whether the edge `from` -`relation`-> `to` is in the graph.
    pub fn has_edge(&self, from: NodeIx, relation: Relation, to: NodeIx) -> bool {
        self.edges.edge_weight(from, to).is_some_and(|set| set.contains(relation))
    }

    /// Adds the edge `from` -`relation`-> `to`; adding one already there changes nothing. Panics
    /// when an index is not below [`SceneGraph::len`], as [`SceneGraph::node`] does (the edge
    /// map would otherwise hold a node with no [`SceneNode`]).
    pub fn add_edge(&mut self, from: NodeIx, relation: Relation, to: NodeIx) {
        assert!(
            (from as usize) < self.nodes.len() && (to as usize) < self.nodes.len(),
            "edge {from} -> {to} names a node index past the graph's {}",
            self.nodes.len()
        );
        match self.edges.edge_weight_mut(from, to) {
            Some(set) => set.insert(relation),
            None => {
                let mut set = RelationSet::default();
                set.insert(relation);
                self.edges.add_edge(from, to, set);
            }
        }
    }

    /// Removes the edge `from` -`relation`-> `to`; removing one not there changes nothing.
    pub fn remove_edge(&mut self, from: NodeIx, relation: Relation, to: NodeIx) {
        if let Some(set) = self.edges.edge_weight_mut(from, to) {
            set.remove(relation);
            if set.is_empty() {
                self.edges.remove_edge(from, to);
            }
        }
    }

    /// The nodes `from` has a `relation` edge to, in ascending index order.
    pub fn targets(&self, from: NodeIx, relation: Relation) -> Vec<NodeIx> {
        self.neighbours(from, relation, Direction::Outgoing)
    }

    /// The nodes with a `relation` edge to `to`, in ascending index order.
    pub fn sources(&self, to: NodeIx, relation: Relation) -> Vec<NodeIx> {
        self.neighbours(to, relation, Direction::Incoming)
    }

    /// The other ends of `node`'s `relation` edges in `direction`, in ascending index order.
    fn neighbours(&self, node: NodeIx, relation: Relation, direction: Direction) -> Vec<NodeIx> {
        let mut out: Vec<NodeIx> = self
            .edges
            .edges_directed(node, direction)
            .filter(|(_, _, set)| set.contains(relation))
            .map(|(from, to, _)| if from == node { to } else { from })
            .collect();
        out.sort_unstable();
        out
    }

    /// Removes every `relation` edge from `node` and, with `reverse`, every one to it
    /// (`DeleteEdges(node, relations, AnyNode(), delete_reverse)`).
    pub fn remove_all(&mut self, node: NodeIx, relations: &[Relation], reverse: bool) {
        for &relation in relations {
            for to in self.targets(node, relation) {
                self.remove_edge(node, relation, to);
            }
            if reverse {
                for from in self.sources(node, relation) {
                    self.remove_edge(from, relation, node);
                }
            }
        }
    }

    /// Every edge as `(from, relation, to)`, sorted.
    pub fn all_edges(&self) -> Vec<(NodeIx, Relation, NodeIx)> {
        let mut out = Vec::new();
        for (from, to, set) in self.edges.all_edges() {
            for relation in set.iter() {
                out.push((from, relation, to));
            }
        }
        out.sort_unstable();
        out
    }

    /// For every node, the nodes it has a `relation` edge to, in ascending index order: one
    /// pass over the edges, for callers that would otherwise ask [`SceneGraph::targets`] of
    /// most nodes (each such call walks all of a node's edges, most of them CLOSE).
    pub fn targets_of_all(&self, relation: Relation) -> Vec<Vec<NodeIx>> {
        let mut out = vec![Vec::new(); self.nodes.len()];
        for (from, to, set) in self.edges.all_edges() {
            if set.contains(relation) {
                out[from as usize].push(to);
            }
        }
        for list in &mut out {
            list.sort_unstable();
        }
        out
    }

    /// Gives node `ix` the id `ids[ix]`, for every node (`ids` holds one distinct id per node):
    /// the ids an environment shows in place of the scene's own ([`crate::VirtualhomeEnv`]).
    pub(crate) fn relabel(&mut self, ids: &[u32]) {
        debug_assert_eq!(ids.len(), self.nodes.len());
        self.by_id.clear();
        for (ix, (node, &id)) in self.nodes.iter_mut().zip(ids).enumerate() {
            node.id = id;
            self.by_id.insert(id, ix as NodeIx);
        }
    }

    /// `<class> (id)`, as the executor prints a node.
    pub fn label(&self, ix: NodeIx) -> String {
        let node = self.node(ix);
        format!("<{}> ({})", node.class_name, node.id)
    }
}
