//! The successor generator: applicable actions without scanning every action.
//!
//! Fast Downward's decision tree, for binary facts: each action's positive preconditions,
//! sorted by fact id, are a path from the root; an action sits at the node where its path
//! ends. Generation walks from the root and only descends into children whose fact holds,
//! so the work is proportional to the matching paths, not to the number of actions. Negative
//! preconditions and clauses are then checked on the few candidates reached.
//! Nodes are stored flat (children and actions as ranges into shared arrays).

use grounding::{ActionId, FactId, Task};

use crate::state::State;

#[derive(Debug, Clone, Copy)]
struct Node {
    actions_start: u32,
    actions_end: u32,
    children_start: u32,
    children_end: u32,
}

/// Fast Downward's decision tree over the actions' positive preconditions (see the module
/// docs); it yields exactly the actions whose whole precondition holds.
#[derive(Debug, Clone)]
pub struct SuccessorGenerator {
    nodes: Vec<Node>,
    /// (fact to test, child node), per node in `children_start..children_end`.
    children: Vec<(FactId, u32)>,
    actions: Vec<ActionId>,
    /// Actions whose preconditions have more than positive facts.
    needs_check: Vec<bool>,
}

impl SuccessorGenerator {
    /// Builds the tree for every action of `task`; `task` must be the one later passed to
    /// [`Self::applicable`].
    pub fn new(task: &Task) -> SuccessorGenerator {
        let mut order: Vec<ActionId> = task.action_ids().collect();
        order.sort_by(|a, b| task.action(*a).pre.pos.cmp(&task.action(*b).pre.pos));
        let mut generator = SuccessorGenerator {
            nodes: Vec::new(),
            children: Vec::new(),
            actions: Vec::with_capacity(order.len()),
            needs_check: task.actions.iter().map(|a| !a.pre.neg.is_empty() || !a.pre.clauses.is_empty()).collect(),
        };
        generator.build(task, &order, 0);
        generator
    }

    /// Builds the node for `actions` (sorted by precondition list), which share their first
    /// `depth` preconditions. Returns its index.
    fn build(&mut self, task: &Task, actions: &[ActionId], depth: usize) -> u32 {
        let index = self.nodes.len() as u32;
        self.nodes.push(Node { actions_start: 0, actions_end: 0, children_start: 0, children_end: 0 });
        let pre = |a: ActionId| &task.action(a).pre.pos;
        let ends_here = actions.iter().take_while(|&&a| pre(a).len() == depth).count();
        let actions_start = self.actions.len() as u32;
        self.actions.extend_from_slice(&actions[..ends_here]);
        let actions_end = self.actions.len() as u32;
        // Group the rest by their next precondition; sorted order makes groups contiguous.
        let mut groups: Vec<(FactId, &[ActionId])> = Vec::new();
        let mut rest = &actions[ends_here..];
        while let Some(&first) = rest.first() {
            let fact = pre(first)[depth];
            let len = rest.iter().take_while(|&&a| pre(a)[depth] == fact).count();
            groups.push((fact, &rest[..len]));
            rest = &rest[len..];
        }
        let children: Vec<(FactId, u32)> = groups.into_iter().map(|(fact, group)| (fact, self.build(task, group, depth + 1))).collect();
        let children_start = self.children.len() as u32;
        self.children.extend(children);
        let children_end = self.children.len() as u32;
        self.nodes[index as usize] = Node { actions_start, actions_end, children_start, children_end };
        index
    }

    /// Appends the actions applicable in `state` to `out` (cleared first), in no particular
    /// order.
    pub fn applicable(&self, task: &Task, state: &State, out: &mut Vec<ActionId>) {
        out.clear();
        let mut stack: Vec<u32> = Vec::with_capacity(32);
        stack.push(0);
        while let Some(node) = stack.pop() {
            let node = self.nodes[node as usize];
            for &action in &self.actions[node.actions_start as usize..node.actions_end as usize] {
                if !self.needs_check[action.index()] || task.action(action).pre.holds(|f| state.contains(f)) {
                    out.push(action);
                }
            }
            for &(fact, child) in &self.children[node.children_start as usize..node.children_end as usize] {
                if state.contains(fact) {
                    stack.push(child);
                }
            }
        }
    }

    /// The number of nodes in the tree, the root included (a size measure for benchmarks).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }
}
