//! Relaxed reachability on the lifted task: the fixpoint of "an action instance is
//! reachable when its relaxed precondition holds on reachable atoms; its adds are then
//! reachable", computed with joins (semi-naively: a schema is re-joined only after one of
//! the predicates it reads gained atoms).

use rustc_hash::FxHashSet;
use smallvec::SmallVec;

use crate::ids::{ObjectId, PredicateId};
use crate::join::{AtomStore, Binding, Join, Tuple};
use crate::lifted::{Arg, Lifted, LiftedSchema, RelaxedConj};

/// A reachable action instance: schema index and parameter values.
pub(crate) type Instance = (usize, SmallVec<[ObjectId; 6]>);

pub(crate) struct Reachable {
    pub atoms: AtomStore,
    pub instances: Vec<Instance>,
}

fn reads(conjs: &[RelaxedConj], changed: &[bool]) -> bool {
    conjs.iter().any(|c| c.atoms.iter().any(|a| changed[a.predicate.index()]))
}

pub(crate) fn instantiate_args(args: &[Arg], binding: &Binding) -> Tuple {
    args.iter()
        .map(|a| match *a {
            Arg::Obj(o) => o,
            Arg::Var(v) => binding[v as usize].unwrap_or_default(),
        })
        .collect()
}

pub(crate) fn reachable(lifted: &Lifted) -> Reachable {
    let predicates = lifted.predicates.len();
    let mut atoms = AtomStore::new(predicates);
    for (predicate, args) in &lifted.init {
        atoms.insert(*predicate, args);
    }
    let mut instances: Vec<Instance> = Vec::new();
    let mut seen: FxHashSet<Instance> = FxHashSet::default();
    let mut changed = vec![true; predicates];
    let mut first_round = true;
    loop {
        let mut new_atoms: Vec<(PredicateId, Tuple)> = Vec::new();
        let instances_before = instances.len();
        for (index, schema) in lifted.schemas.iter().enumerate() {
            let has_atoms = schema.relaxed_pre.iter().any(|c| !c.atoms.is_empty());
            // After the first round, only schemas reading a predicate that gained atoms can
            // gain instances.
            let may_grow = first_round || (has_atoms && reads(&schema.relaxed_pre, &changed));
            if !may_grow {
                continue;
            }
            let params: Vec<u32> = (0..schema.arity() as u32).collect();
            let join = Join { store: &atoms, domains: &lifted.domains, var_domains: &schema.var_domains };
            for conj in &schema.relaxed_pre {
                let mut binding: Binding = vec![None; schema.var_domains.len()];
                join.run(conj, &mut binding, &params, &mut |binding| {
                    let args: SmallVec<[ObjectId; 6]> = binding[..schema.arity()].iter().map(|o| o.unwrap_or_default()).collect();
                    let instance = (index, args);
                    if seen.insert(instance.clone()) {
                        instances.push(instance);
                    }
                });
            }
        }
        // Effects: every item of a new instance; for old instances, the conditional items
        // whose conditions read a predicate that changed.
        for (at, (schema_index, args)) in instances.iter().enumerate() {
            let schema = &lifted.schemas[*schema_index];
            let is_new = at >= instances_before || first_round;
            for effect in schema.effects.iter().filter(|e| !e.delete) {
                if !is_new && !reads(&effect.relaxed_condition, &changed) {
                    continue;
                }
                add_effect_atoms(lifted, schema, args, effect, &atoms, &mut new_atoms);
            }
        }
        changed.iter_mut().for_each(|c| *c = false);
        let mut grew = false;
        for (predicate, tuple) in new_atoms {
            if atoms.insert(predicate, &tuple) {
                changed[predicate.index()] = true;
                grew = true;
            }
        }
        first_round = false;
        if !grew {
            break;
        }
    }
    Reachable { atoms, instances }
}

/// Calls `emit` with the ground atom of `effect` for every binding of its `forall`
/// variables under which its relaxed condition holds on `atoms` (the instance's parameters
/// bound to `args`).
fn effect_atoms(
    lifted: &Lifted,
    schema: &LiftedSchema,
    args: &[ObjectId],
    effect: &crate::lifted::LiftedEffect,
    atoms: &AtomStore,
    emit: &mut dyn FnMut(Tuple),
) {
    let join = Join { store: atoms, domains: &lifted.domains, var_domains: &schema.var_domains };
    for conj in &effect.relaxed_condition {
        let mut binding: Binding = vec![None; schema.var_domains.len()];
        for (i, &object) in args.iter().enumerate() {
            binding[i] = Some(object);
        }
        join.run(conj, &mut binding, &effect.forall, &mut |binding| emit(instantiate_args(&effect.atom.args, binding)));
    }
}

fn add_effect_atoms(
    lifted: &Lifted,
    schema: &LiftedSchema,
    args: &[ObjectId],
    effect: &crate::lifted::LiftedEffect,
    atoms: &AtomStore,
    out: &mut Vec<(PredicateId, Tuple)>,
) {
    effect_atoms(lifted, schema, args, effect, atoms, &mut |tuple| {
        if !atoms.contains(effect.atom.predicate, &tuple) {
            out.push((effect.atom.predicate, tuple));
        }
    });
}

/// Every ground atom some reachable instance deletes (relaxed conditions), for deciding
/// which facts are fluent.
pub(crate) fn deleted_atoms(lifted: &Lifted, reachable: &Reachable) -> Vec<(PredicateId, Tuple)> {
    let mut out = Vec::new();
    for (schema_index, args) in &reachable.instances {
        let schema = &lifted.schemas[*schema_index];
        for effect in schema.effects.iter().filter(|e| e.delete) {
            effect_atoms(lifted, schema, args, effect, &reachable.atoms, &mut |tuple| {
                if reachable.atoms.contains(effect.atom.predicate, &tuple) {
                    out.push((effect.atom.predicate, tuple));
                }
            });
        }
    }
    out
}
