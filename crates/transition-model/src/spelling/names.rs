//! How objects are named in text a model reads (planning prompts, beliefs): each surface
//! language's names, the class names a class-level goal uses, which arguments and
//! predicates are left out. It sits beside the action spellings so that prompts name
//! objects exactly as the actions the model writes do.

use grounding::{Atom, Literal, ObjectId, Task};

use super::SurfaceLanguage;

/// How objects are named in text a model reads: in a surface language's way, never by an id
/// the agent could not have perceived.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ObjectNames {
    /// The instance name (`apple 1`); `None`: facts naming the object are not shown.
    pub instance: Vec<Option<String>>,
    /// The class name for the goal (`apple`).
    pub class: Vec<String>,
    /// Left out of literal lines (ALFWorld's agent, VirtualHome's character).
    pub omitted: Vec<bool>,
    /// Predicates never shown (ALFWorld's `receptacleatlocation`, said by the location names).
    pub hidden_predicates: Vec<bool>,
    /// ALFWorld: the receptacles at each location, which name it.
    pub receptacles_at: Vec<Vec<ObjectId>>,
    /// ALFWorld: receptacles, which get a `receptacle <name>` line when relevant and named by
    /// no other line.
    pub receptacle: Vec<bool>,
}

impl ObjectNames {
    /// The names `language` gives the objects of `task`:
    /// - ALFWorld ([`crate::alfworld::display_names`]): `apple 1`, `countertop 2`; the agent is
    ///   left out; a location is named by the receptacles standing at it (`drawer 1 and
    ///   drawer 2`), a location without one has no name; `receptacleatlocation` is hidden.
    /// - VirtualHome: object names as they are (class names in EAI); the character is left out.
    /// - PDDL: object names as they are.
    pub fn new(task: &Task, language: SurfaceLanguage) -> ObjectNames {
        Self::with_instances(task, language, None)
    }

    /// The names a spelling writes its commands with: [`ObjectNames::new`], except that an
    /// ALFWorld spelling built from given names ([`crate::Spelling::object_names`], a grounded
    /// problem's objects as the agent perceived them) names the objects by those instead of by
    /// ALFWorld's display names of the problem's ids.
    pub fn for_spelling(task: &Task, spelling: &crate::Spelling) -> ObjectNames {
        Self::with_instances(task, spelling.language(), spelling.object_names().map(<[Option<String>]>::to_vec))
    }

    fn with_instances(task: &Task, language: SurfaceLanguage, given: Option<Vec<Option<String>>>) -> ObjectNames {
        let has_type = |o: usize, t: &str| task.objects[o].types.iter().any(|x| x == t);
        let count = task.objects.len();
        let plain = |omitted: Vec<bool>| ObjectNames {
            instance: task.objects.iter().map(|o| Some(o.name.clone())).collect(),
            class: task.objects.iter().map(|o| o.name.clone()).collect(),
            omitted,
            hidden_predicates: vec![false; task.predicates.len()],
            receptacles_at: vec![Vec::new(); count],
            receptacle: vec![false; count],
        };
        match language {
            SurfaceLanguage::Pddl => plain(vec![false; count]),
            SurfaceLanguage::Virtualhome => plain((0..count).map(|o| has_type(o, "character")).collect()),
            SurfaceLanguage::Alfworld => {
                let mut instance = given.unwrap_or_else(|| crate::alfworld::display_names(task));
                let type_name = |o: usize| task.objects[o].types.first().cloned().unwrap_or_else(|| "object".into());
                let mut class: Vec<String> = (0..count)
                    .map(|o| match &instance[o] {
                        Some(name) => name.rsplit_once(' ').map_or(name.as_str(), |(c, _)| c).to_string(),
                        None => type_name(o),
                    })
                    .collect();
                let mut hidden_predicates = vec![false; task.predicates.len()];
                let at_location = task.predicates.iter().position(|p| p.name == "receptacleatlocation");
                if let Some(p) = at_location {
                    hidden_predicates[p] = true;
                }
                let mut receptacles_at: Vec<Vec<ObjectId>> = vec![Vec::new(); count];
                for atom in &task.static_facts {
                    if Some(atom.predicate.index()) == at_location && atom.args.len() == 2 {
                        receptacles_at[atom.args[1].index()].push(atom.args[0]);
                    }
                }
                for (location, at) in receptacles_at.iter_mut().enumerate() {
                    if !has_type(location, "location") {
                        at.clear();
                        continue;
                    }
                    at.retain(|r| instance[r.index()].is_some());
                    at.sort_by(|a, b| {
                        natural_order(instance[a.index()].as_deref().unwrap_or(""), instance[b.index()].as_deref().unwrap_or(""))
                    });
                    if at.is_empty() {
                        instance[location] = None;
                        continue;
                    }
                    let join = |names: Vec<&str>| names.join(" and ");
                    let mut classes: Vec<&str> = at.iter().map(|r| class[r.index()].as_str()).collect();
                    classes.dedup();
                    let class_name = join(classes);
                    instance[location] = Some(join(at.iter().map(|r| instance[r.index()].as_deref().unwrap_or("")).collect()));
                    class[location] = class_name;
                }
                ObjectNames {
                    instance,
                    class,
                    omitted: (0..count).map(|o| has_type(o, "agent")).collect(),
                    hidden_predicates,
                    receptacles_at,
                    receptacle: (0..count).map(|o| has_type(o, "receptacle")).collect(),
                }
            }
        }
    }

    /// `predicate arg ...` with instance names; `None` if the atom is not shown.
    pub fn atom_line(&self, task: &Task, atom: &Atom) -> Option<String> {
        if self.hidden_predicates[atom.predicate.index()] {
            return None;
        }
        let mut out = task.predicates[atom.predicate.index()].name.clone();
        for arg in &atom.args {
            if self.omitted[arg.index()] {
                continue;
            }
            out.push(' ');
            out.push_str(self.instance[arg.index()].as_deref()?);
        }
        Some(out)
    }

    /// `predicate arg ...` with class names (goal lines), or `not ...`.
    pub fn class_literal_line(&self, task: &Task, literal: Literal) -> String {
        let atom = task.fact(literal.fact());
        let mut out = if literal.is_negated() { String::from("not ") } else { String::new() };
        out.push_str(&task.predicates[atom.predicate.index()].name);
        for arg in atom.args.iter().filter(|a| !self.omitted[a.index()]) {
            out.push(' ');
            out.push_str(&self.class[arg.index()]);
        }
        out
    }
}

/// `drawer 2` before `drawer 10`: names compared word by word, numbers as numbers.
pub fn natural_order(a: &str, b: &str) -> std::cmp::Ordering {
    let key = |s: &str| -> Vec<(u64, String)> {
        s.split(' ').map(|w| w.parse::<u64>().map_or((u64::MAX, w.to_string()), |n| (n, String::new()))).collect()
    };
    key(a).cmp(&key(b))
}
