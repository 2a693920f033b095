//! Exact relaxed reachability on the ground task, then a last simplification: actions whose
//! relaxed preconditions can never hold are dropped, facts that no remaining action changes
//! become constants, and facts are renumbered densely.

use crate::ids::FactId;
use crate::instantiate::make_condition;
use crate::task::{Action, Atom, Condition, ConditionalEffect, Goal, Literal};

/// Relaxed satisfaction: positive facts reached; a clause needs a reached positive literal
/// or any negative literal (negative conditions are free in the delete relaxation).
fn relaxed_holds(condition: &Condition, reached: &[bool]) -> bool {
    condition.pos.iter().all(|f| reached[f.index()])
        && condition.clauses.iter().all(|clause| clause.iter().any(|l| l.is_negated() || reached[l.fact().index()]))
}

pub(crate) struct Pruned {
    pub facts: Vec<Atom>,
    pub actions: Vec<Action>,
    pub init: Vec<FactId>,
    pub goal: Goal,
    /// Facts that turned out constant and true.
    pub now_static: Vec<Atom>,
}

pub(crate) fn prune(facts: Vec<Atom>, actions: Vec<Action>, init: Vec<FactId>, goal: Vec<Condition>) -> Pruned {
    let mut reached = vec![false; facts.len()];
    for f in &init {
        reached[f.index()] = true;
    }
    let mut applied = vec![false; actions.len()];
    loop {
        let mut grew = false;
        for (i, action) in actions.iter().enumerate() {
            if !applied[i] {
                if !relaxed_holds(&action.pre, &reached) {
                    continue;
                }
                applied[i] = true;
            }
            let mut reach = |fact: FactId| {
                if !reached[fact.index()] {
                    reached[fact.index()] = true;
                    grew = true;
                }
            };
            action.add.iter().for_each(|&f| reach(f));
            for effect in &action.conditional {
                if effect.add.iter().any(|f| !reached[f.index()]) && relaxed_holds(&effect.condition, &reached) {
                    for &f in &effect.add {
                        if !reached[f.index()] {
                            reached[f.index()] = true;
                            grew = true;
                        }
                    }
                }
            }
        }
        if !grew {
            break;
        }
    }
    let kept: Vec<Action> = actions.into_iter().zip(&applied).filter(|(_, a)| **a).map(|(action, _)| action).collect();

    // Which facts can change: true initially and deleted, or false initially and added.
    let mut initially = vec![false; facts.len()];
    for f in &init {
        initially[f.index()] = true;
    }
    let mut changes = vec![false; facts.len()];
    for action in &kept {
        let effects = std::iter::once((&action.add, &action.del, None))
            .chain(action.conditional.iter().map(|e| (&e.add, &e.del, Some(&e.condition))));
        for (add, del, condition) in effects {
            if condition.is_some_and(|c| !relaxed_holds(c, &reached)) {
                continue;
            }
            for f in add {
                if !initially[f.index()] {
                    changes[f.index()] = true;
                }
            }
            for f in del {
                if initially[f.index()] {
                    changes[f.index()] = true;
                }
            }
        }
    }
    let mut remap: Vec<Option<FactId>> = vec![None; facts.len()];
    let mut new_facts = Vec::new();
    let mut now_static = Vec::new();
    for (i, atom) in facts.into_iter().enumerate() {
        if changes[i] {
            remap[i] = Some(FactId::from_index(new_facts.len()));
            new_facts.push(atom);
        } else if initially[i] {
            now_static.push(atom);
        }
    }
    // A constant fact has its initial value everywhere.
    let simplify = |condition: &Condition| -> Option<Condition> {
        let mut pos = Vec::new();
        let mut neg = Vec::new();
        for literal in condition.literals() {
            let fact = literal.fact();
            match remap[fact.index()] {
                Some(new) => {
                    if literal.is_negated() {
                        neg.push(new)
                    } else {
                        pos.push(new)
                    }
                }
                None => {
                    if initially[fact.index()] == literal.is_negated() {
                        return None;
                    }
                }
            }
        }
        let mut clauses = Vec::new();
        'clauses: for clause in &condition.clauses {
            let mut rest = Vec::new();
            for &literal in clause {
                match remap[literal.fact().index()] {
                    Some(new) => rest.push(Literal::new(new, literal.is_negated())),
                    None if initially[literal.fact().index()] != literal.is_negated() => continue 'clauses,
                    None => {}
                }
            }
            clauses.push(rest);
        }
        make_condition(pos, neg, clauses)
    };
    let map_list = |list: &[FactId]| -> Vec<FactId> { list.iter().filter_map(|f| remap[f.index()]).collect() };
    let mut actions = Vec::with_capacity(kept.len());
    for action in kept {
        let Some(pre) = simplify(&action.pre) else { continue };
        let mut conditional = Vec::new();
        for effect in &action.conditional {
            let Some(condition) = simplify(&effect.condition) else { continue };
            let (add, del) = (map_list(&effect.add), map_list(&effect.del));
            if add.is_empty() && del.is_empty() {
                continue;
            }
            conditional.push(ConditionalEffect { condition, add, del });
        }
        let (mut add, mut del) = (map_list(&action.add), map_list(&action.del));
        // Effects whose condition became empty are unconditional now.
        conditional.retain(|effect| {
            if effect.condition.is_empty() {
                add.extend_from_slice(&effect.add);
                del.extend_from_slice(&effect.del);
                false
            } else {
                true
            }
        });
        add.sort();
        add.dedup();
        del.sort();
        del.dedup();
        // Effects that change nothing: a delete of a fact the precondition says is false or
        // that the action also adds (adds win), an add of a fact the precondition says is
        // true and that is not deleted.
        del.retain(|f| pre.neg.binary_search(f).is_err() && add.binary_search(f).is_err());
        add.retain(|f| pre.pos.binary_search(f).is_err() || conditional.iter().any(|e| e.del.contains(f)));
        // Actions without any effect stay (unlike in Fast Downward): VirtualHome's `watch`,
        // `read` or `find` change nothing in PDDL, yet the real executor's goals need them.
        actions.push(Action { pre, add, del, conditional, ..action });
    }
    actions.sort_by(|a, b| {
        (a.schema, &a.args, &a.pre.pos, &a.pre.neg, &a.pre.clauses).cmp(&(b.schema, &b.args, &b.pre.pos, &b.pre.neg, &b.pre.clauses))
    });
    actions.dedup();
    let init = init.iter().filter_map(|f| remap[f.index()]).collect();
    // Disjuncts needing a fact that is never reached simplify to false and are dropped.
    let mut disjuncts: Vec<Condition> = goal.iter().filter_map(simplify).collect();
    if disjuncts.iter().any(Condition::is_empty) {
        disjuncts = vec![Condition::default()];
    }
    Pruned { facts: new_facts, actions, init, goal: Goal { disjuncts }, now_static }
}
