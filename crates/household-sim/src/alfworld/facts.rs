//! TextWorld's fact store and its conjunctive queries, which decide what the engine's text
//! says (`textworld.logic.State.all_assignments`).
//!
//! The store is not the planning state. TextWorld starts it from the problem's initial atoms
//! and, after each action, walks the Fast Downward operator's effect atoms in the operator's
//! order: for atom `p` it removes `not_p` and adds `p`; for a negated atom it removes `p` and
//! adds `not_p`. So it holds explicit `not_` facts once something deleted them, and a
//! conditional effect changes it whether or not its condition held (TextWorld applies every
//! effect atom the operator lists). The grammar's conditions read these facts, `not_` facts
//! included; the planning state (our `transition_model::State`) decides applicability and
//! the goal, as Fast Downward's state does inside the engine.

use std::collections::BTreeSet;

use rustc_hash::FxHashMap;
use smallvec::SmallVec;

/// An entity, numbered by the byte order of its id, so that comparing numbers compares ids
/// as TextWorld's sorted propositions do.
pub(crate) type Entity = u32;

pub(crate) type Args = SmallVec<[Entity; 4]>;

/// Interned predicate names (`inreceptacle`, `not_inreceptacle`, ...).
#[derive(Debug, Default, Clone)]
pub(crate) struct Predicates {
    ids: FxHashMap<String, u32>,
}

impl Predicates {
    pub(crate) fn intern(&mut self, name: &str) -> u32 {
        let next = self.ids.len() as u32;
        *self.ids.entry(name.to_string()).or_insert(next)
    }

    pub(crate) fn get(&self, name: &str) -> Option<u32> {
        self.ids.get(name).copied()
    }

    pub(crate) fn len(&self) -> usize {
        self.ids.len()
    }
}

/// The set of true propositions, per predicate, each set in sorted argument order.
#[derive(Debug, Clone, Default)]
pub(crate) struct FactStore {
    by_predicate: Vec<BTreeSet<Args>>,
}

impl FactStore {
    pub(crate) fn new(predicates: usize) -> FactStore {
        FactStore { by_predicate: vec![BTreeSet::new(); predicates] }
    }

    pub(crate) fn insert(&mut self, predicate: u32, args: Args) {
        self.by_predicate[predicate as usize].insert(args);
    }

    pub(crate) fn remove(&mut self, predicate: u32, args: &Args) {
        self.by_predicate[predicate as usize].remove(args);
    }

    fn sorted(&self, predicate: u32) -> impl Iterator<Item = &Args> {
        self.by_predicate[predicate as usize].iter()
    }
}

/// A placeholder of a query: its name and type (`r:receptacle`). Two placeholders are the
/// same only when both agree, as in TextWorld.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(crate) struct Placeholder {
    pub name: String,
    pub ty: String,
}

/// One conjunct: a predicate over placeholders (indices into [`Query::placeholders`]).
#[derive(Debug, Clone)]
struct Conjunct {
    /// `None` when no fact of that predicate can ever exist (the conjunct never matches).
    predicate: Option<u32>,
    params: SmallVec<[usize; 4]>,
}

/// A parsed conjunctive query `p(x:t, y:u) & q(y:u)`.
#[derive(Debug, Clone)]
pub(crate) struct Query {
    pub placeholders: Vec<Placeholder>,
    conjuncts: Vec<Conjunct>,
    /// The predicate names the query reads.
    pub predicate_names: Vec<String>,
}

/// A binding of placeholders to entities, in the order they were bound.
pub(crate) type Mapping = Vec<(Placeholder, Entity)>;

impl Query {
    /// Parses `name(ph:type, ...) & ...` (TextWorld's `conjunctiveQuery`). Placeholders
    /// without a type take their name as type, as TextWorld's do.
    pub(crate) fn parse(text: &str, predicates: &Predicates) -> Result<Query, String> {
        let mut placeholders: Vec<Placeholder> = Vec::new();
        let mut conjuncts = Vec::new();
        let mut predicate_names = Vec::new();
        for part in text.split('&') {
            let part = part.trim();
            let open = part.find('(').ok_or_else(|| format!("`{part}` is not a predicate `name(args)`"))?;
            if !part.ends_with(')') {
                return Err(format!("`{part}` does not end with `)`"));
            }
            let name = part[..open].trim();
            if name.is_empty() || !name.chars().all(|c| c.is_alphanumeric() || c == '_' || c == '-' || c == '/') {
                return Err(format!("bad predicate name `{name}`"));
            }
            let inner = &part[open + 1..part.len() - 1];
            let mut params = SmallVec::new();
            for arg in inner.split(',').map(str::trim).filter(|a| !a.is_empty()) {
                let (ph, ty) = match arg.split_once(':') {
                    Some((ph, ty)) => (ph.trim(), ty.trim()),
                    None => (arg, arg),
                };
                if ph.is_empty() || ty.is_empty() {
                    return Err(format!("bad placeholder `{arg}` in `{part}`"));
                }
                let placeholder = Placeholder { name: ph.to_string(), ty: ty.to_string() };
                let index = match placeholders.iter().position(|p| *p == placeholder) {
                    Some(i) => i,
                    None => {
                        placeholders.push(placeholder);
                        placeholders.len() - 1
                    }
                };
                params.push(index);
            }
            predicate_names.push(name.to_string());
            conjuncts.push(Conjunct { predicate: predicates.get(name), params });
        }
        if conjuncts.is_empty() {
            return Err("empty query".into());
        }
        Ok(Query { placeholders, conjuncts, predicate_names })
    }

    /// Every assignment that satisfies the query in `facts`, extending `mapping`, in
    /// TextWorld's order: conjuncts left to right, each over its facts in sorted order,
    /// depth first. Distinct placeholders take distinct entities, also distinct from the
    /// entities `mapping` already uses.
    pub(crate) fn assignments(&self, facts: &FactStore, mapping: &Mapping) -> Vec<Mapping> {
        let mut bound: Vec<Option<Entity>> =
            self.placeholders.iter().map(|p| mapping.iter().find(|(q, _)| q == p).map(|&(_, e)| e)).collect();
        let mut used: Vec<Entity> = mapping.iter().map(|&(_, e)| e).collect();
        let mut out = Vec::new();
        self.recurse(facts, 0, &mut bound, &mut used, mapping, &mut out, usize::MAX);
        out
    }

    /// Whether some assignment exists.
    pub(crate) fn holds(&self, facts: &FactStore, mapping: &Mapping) -> bool {
        let mut bound: Vec<Option<Entity>> =
            self.placeholders.iter().map(|p| mapping.iter().find(|(q, _)| q == p).map(|&(_, e)| e)).collect();
        let mut used: Vec<Entity> = mapping.iter().map(|&(_, e)| e).collect();
        let mut out = Vec::new();
        self.recurse(facts, 0, &mut bound, &mut used, mapping, &mut out, 1);
        !out.is_empty()
    }

    #[allow(clippy::too_many_arguments)] // the recursion's state, kept on the stack
    fn recurse(
        &self,
        facts: &FactStore,
        depth: usize,
        bound: &mut Vec<Option<Entity>>,
        used: &mut Vec<Entity>,
        base: &Mapping,
        out: &mut Vec<Mapping>,
        limit: usize,
    ) {
        if out.len() >= limit {
            return;
        }
        let Some(conjunct) = self.conjuncts.get(depth) else {
            let mut mapping = base.clone();
            for (i, entity) in bound.iter().enumerate() {
                let placeholder = &self.placeholders[i];
                if let Some(entity) = entity
                    && !mapping.iter().any(|(p, _)| p == placeholder)
                {
                    mapping.push((placeholder.clone(), *entity));
                }
            }
            out.push(mapping);
            return;
        };
        let Some(predicate) = conjunct.predicate else { return };
        for args in facts.sorted(predicate) {
            if args.len() != conjunct.params.len() {
                continue;
            }
            let mut newly = SmallVec::<[usize; 4]>::new();
            let mut ok = true;
            for (&param, &entity) in conjunct.params.iter().zip(args.iter()) {
                match bound[param] {
                    None => {
                        if used.contains(&entity) {
                            ok = false;
                            break;
                        }
                        bound[param] = Some(entity);
                        used.push(entity);
                        newly.push(param);
                    }
                    Some(existing) if existing != entity => {
                        ok = false;
                        break;
                    }
                    Some(_) => {}
                }
            }
            if ok {
                self.recurse(facts, depth + 1, bound, used, base, out, limit);
            }
            for param in newly {
                if let Some(entity) = bound[param].take()
                    && let Some(at) = used.iter().rposition(|&e| e == entity)
                {
                    used.remove(at);
                }
            }
            if out.len() >= limit {
                return;
            }
        }
    }
}
