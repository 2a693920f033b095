//! Relaxed reachability on the lifted task: the fixpoint of "an action instance is
//! reachable when its relaxed precondition holds on reachable atoms; its adds are then
//! reachable", computed with joins (semi-naively: a schema is re-joined only after one of
//! the predicates it reads gained atoms).

use std::cell::Cell;

use rustc_hash::FxHashSet;
use smallvec::SmallVec;

use crate::GroundingError;
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

/// Action instances grounding makes at most: past it, relaxed reachability stops with
/// [`GroundingError::TooLarge`] naming the action, where it would go on until memory ran out
/// (an action of five free parameters over 40 objects is 10^8 instances, about 10 GB). The
/// benchmarks stay far below it: ALFWorld's games ground at most 7,336 actions, EAI's
/// problems 786 (`cargo xtask eval --agent expert`).
pub const MAX_INSTANCES: usize = 10_000_000;

pub(crate) fn reachable(lifted: &Lifted) -> Result<Reachable, GroundingError> {
    reachable_within(lifted, MAX_INSTANCES)
}

pub(crate) fn reachable_within(lifted: &Lifted, limit: usize) -> Result<Reachable, GroundingError> {
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
            let full = Cell::new(false);
            let join = Join { store: &atoms, domains: &lifted.domains, var_domains: &schema.var_domains, stop: Some(&full) };
            for conj in &schema.relaxed_pre {
                let mut binding: Binding = vec![None; schema.var_domains.len()];
                join.run(conj, &mut binding, &params, &mut |binding| {
                    let args: SmallVec<[ObjectId; 6]> = binding[..schema.arity()].iter().map(|o| o.unwrap_or_default()).collect();
                    let instance = (index, args);
                    if seen.insert(instance.clone()) {
                        instances.push(instance);
                        full.set(instances.len() > limit);
                    }
                });
                if full.get() {
                    return Err(GroundingError::TooLarge { action: schema.name.clone(), limit, span: schema.span });
                }
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
    Ok(Reachable { atoms, instances })
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
    let join = Join { store: atoms, domains: &lifted.domains, var_domains: &schema.var_domains, stop: None };
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

#[cfg(test)]
mod tests {
    use super::*;

    /// An action whose five parameters nothing binds, over 40 objects (10^8 instances), stops
    /// at the limit with an error naming it, where grounding ran until memory ran out.
    #[test]
    fn an_action_past_the_limit_is_an_error_naming_it() {
        let objects: Vec<String> = (0..40).map(|i| format!("o{i}")).collect();
        let domain = pddl_syntax::parse_domain(
            "(define (domain big) (:predicates (p ?a) (g ?a))
               (:action a :parameters (?a ?b ?c ?d ?e) :precondition (and)
                 :effect (and (g ?a) (p ?b) (p ?c) (p ?d) (p ?e))))",
        )
        .expect("domain");
        let problem = pddl_syntax::parse_problem(&format!(
            "(define (problem b) (:domain big) (:objects {}) (:init) (:goal (g o1)))",
            objects.join(" ")
        ))
        .expect("problem");
        let lifted = crate::lifted::lift(&domain, &problem).expect("lifts");
        match reachable_within(&lifted, 1000) {
            Err(GroundingError::TooLarge { action, limit: 1000, .. }) => assert_eq!(action, "a"),
            Err(other) => panic!("another error: {other}"),
            Ok(reached) => panic!("{} instances reached", reached.instances.len()),
        }
        // Below the limit, the same as without one.
        let small =
            pddl_syntax::parse_problem("(define (problem s) (:domain big) (:objects o0 o1 o2) (:init) (:goal (g o1)))").expect("problem");
        let lifted = crate::lifted::lift(&domain, &small).expect("lifts");
        assert_eq!(reachable_within(&lifted, 1000).expect("243 instances").instances.len(), 243);
    }
}
