//! From reachable lifted instances to grounded actions and goal: quantifiers expanded over
//! objects, static atoms evaluated away, formulas brought into the [`Condition`] shape.

use rustc_hash::{FxHashMap, FxHashSet};
use smallvec::SmallVec;

use crate::ids::{FactId, ObjectId, PredicateId, SchemaId};
use crate::join::{Binding, Join, Tuple};
use crate::lifted::{Arg, CostTerm, Formula, Lifted, LiftedSchema};
use crate::reach::{Reachable, instantiate_args};
use crate::task::{Action, Atom, Condition, ConditionalEffect, Cost, Literal};
use crate::{GroundingError, PddlFile};

/// A ground formula over fluent facts, simplified as it is built.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum Ground {
    True,
    False,
    Lit(Literal),
    And(Vec<Ground>),
    Or(Vec<Ground>),
}

fn and(parts: Vec<Ground>) -> Ground {
    let mut out = Vec::with_capacity(parts.len());
    for part in parts {
        match part {
            Ground::True => {}
            Ground::False => return Ground::False,
            Ground::And(inner) => out.extend(inner),
            other => out.push(other),
        }
    }
    out.sort_unstable();
    out.dedup();
    match out.len() {
        0 => Ground::True,
        1 => out.pop().unwrap_or(Ground::True),
        _ => Ground::And(out),
    }
}

fn or(parts: Vec<Ground>) -> Ground {
    let mut out = Vec::with_capacity(parts.len());
    for part in parts {
        match part {
            Ground::False => {}
            Ground::True => return Ground::True,
            Ground::Or(inner) => out.extend(inner),
            other => out.push(other),
        }
    }
    out.sort_unstable();
    out.dedup();
    match out.len() {
        0 => Ground::False,
        1 => out.pop().unwrap_or(Ground::False),
        _ => Ground::Or(out),
    }
}

/// How many alternatives one formula may split into before grounding gives up on it.
const MAX_SPLIT: usize = 4096;

const ALWAYS_TRUE: u32 = u32::MAX;

/// What an atom is in every reachable state.
enum Status {
    Fluent(FactId),
    AlwaysTrue,
    AlwaysFalse,
}

pub(crate) struct Instantiator<'a> {
    lifted: &'a Lifted,
    reachable: &'a Reachable,
    fluent: FxHashMap<(PredicateId, Tuple), FactId>,
    init: FxHashSet<(PredicateId, Tuple)>,
    /// Every atom that is fluent or initially true: fluent facts map to their id, static
    /// true atoms to [`ALWAYS_TRUE`]. One lookup decides an atom's [`Status`].
    statuses: FxHashMap<(PredicateId, Tuple), u32>,
    pub facts: Vec<Atom>,
}

impl<'a> Instantiator<'a> {
    pub fn new(lifted: &'a Lifted, reachable: &'a Reachable, fluent_atoms: Vec<(PredicateId, Tuple)>) -> Instantiator<'a> {
        let mut sorted = fluent_atoms;
        sorted.sort();
        sorted.dedup();
        let mut fluent = FxHashMap::default();
        let mut facts = Vec::with_capacity(sorted.len());
        for (predicate, tuple) in sorted {
            fluent.insert((predicate, tuple.clone()), FactId::from_index(facts.len()));
            facts.push(Atom { predicate, args: tuple });
        }
        let init: FxHashSet<(PredicateId, Tuple)> = lifted.init.iter().map(|(p, args)| (*p, args.iter().copied().collect())).collect();
        let mut statuses: FxHashMap<(PredicateId, Tuple), u32> = init.iter().map(|key| (key.clone(), ALWAYS_TRUE)).collect();
        for (key, fact) in &fluent {
            statuses.insert(key.clone(), fact.0);
        }
        Instantiator { lifted, reachable, fluent, init, statuses, facts }
    }

    fn status(&self, predicate: PredicateId, tuple: Tuple) -> Status {
        match self.statuses.get(&(predicate, tuple)) {
            Some(&ALWAYS_TRUE) => Status::AlwaysTrue,
            Some(&fact) => Status::Fluent(FactId(fact)),
            None => Status::AlwaysFalse,
        }
    }

    /// Fluent facts true initially.
    pub fn init_facts(&self) -> Vec<FactId> {
        let mut out: Vec<FactId> = self.init.iter().filter_map(|key| self.fluent.get(key).copied()).collect();
        out.sort();
        out.dedup();
        out
    }

    /// Atoms true initially that no action changes.
    pub fn static_facts(&self) -> Vec<Atom> {
        let mut out: Vec<Atom> =
            self.init.iter().filter(|key| !self.fluent.contains_key(*key)).map(|(p, t)| Atom { predicate: *p, args: t.clone() }).collect();
        out.sort();
        out
    }

    fn ground(&self, schema: &LiftedSchema, formula: &Formula, binding: &mut Binding) -> Ground {
        match formula {
            Formula::True => Ground::True,
            Formula::Atom { negated, atom } => {
                let tuple = instantiate_args(&atom.args, binding);
                let truth = match self.status(atom.predicate, tuple) {
                    Status::Fluent(fact) => return Ground::Lit(Literal::new(fact, *negated)),
                    Status::AlwaysTrue => true,
                    Status::AlwaysFalse => false,
                };
                if truth != *negated { Ground::True } else { Ground::False }
            }
            Formula::Eq { negated, a, b } => {
                let value = |arg: &Arg| match *arg {
                    Arg::Obj(o) => o,
                    Arg::Var(v) => binding[v as usize].unwrap_or_default(),
                };
                if (value(a) == value(b)) != *negated { Ground::True } else { Ground::False }
            }
            Formula::And(parts) => and(parts.iter().map(|p| self.ground(schema, p, binding)).collect()),
            Formula::Or(parts) => or(parts.iter().map(|p| self.ground(schema, p, binding)).collect()),
            Formula::Exists(vars, body, conjs) => {
                // Only bindings under which the body's relaxation holds on reachable atoms can
                // make the body true in a reachable state.
                let join =
                    Join { store: &self.reachable.atoms, domains: &self.lifted.domains, var_domains: &schema.var_domains, stop: None };
                let mut candidates: FxHashSet<SmallVec<[ObjectId; 4]>> = FxHashSet::default();
                let mut ordered = Vec::new();
                for conj in conjs {
                    let mut scratch = binding.clone();
                    join.run(conj, &mut scratch, vars, &mut |b| {
                        let values: SmallVec<[ObjectId; 4]> = vars.iter().map(|&v| b[v as usize].unwrap_or_default()).collect();
                        if candidates.insert(values.clone()) {
                            ordered.push(values);
                        }
                    });
                }
                let mut parts = Vec::with_capacity(ordered.len());
                for values in ordered {
                    for (&var, &value) in vars.iter().zip(&values) {
                        binding[var as usize] = Some(value);
                    }
                    let part = self.ground(schema, body, binding);
                    if part == Ground::True {
                        parts = vec![Ground::True];
                        break;
                    }
                    parts.push(part);
                }
                for &var in vars {
                    binding[var as usize] = None;
                }
                or(parts)
            }
            Formula::Forall(vars, body) => {
                let mut parts = Vec::new();
                let all_false = self.forall(schema, vars, 0, body, binding, &mut parts);
                if all_false { Ground::False } else { and(parts) }
            }
        }
    }

    /// Conjoins `body` over every binding of `vars[from..]`; true if some part was false.
    fn forall(
        &self,
        schema: &LiftedSchema,
        vars: &[u32],
        from: usize,
        body: &Formula,
        binding: &mut Binding,
        parts: &mut Vec<Ground>,
    ) -> bool {
        let Some(&var) = vars.get(from) else {
            let part = self.ground(schema, body, binding);
            if part == Ground::False {
                return true;
            }
            parts.push(part);
            return false;
        };
        for &object in &self.lifted.domains.lists[schema.var_domains[var as usize]] {
            binding[var as usize] = Some(object);
            if self.forall(schema, vars, from + 1, body, binding, parts) {
                binding[var as usize] = None;
                return true;
            }
        }
        binding[var as usize] = None;
        false
    }

    /// Grounds every reachable instance of every schema.
    pub fn actions(&self) -> Result<Vec<Action>, GroundingError> {
        let mut actions = Vec::new();
        for (schema_index, args) in &self.reachable.instances {
            let schema = &self.lifted.schemas[*schema_index];
            let mut binding: Binding = vec![None; schema.var_domains.len()];
            for (i, &object) in args.iter().enumerate() {
                binding[i] = Some(object);
            }
            let pre = self.ground(schema, &schema.pre, &mut binding);
            let variants = split(&pre).ok_or_else(|| GroundingError::TooManyAlternatives {
                what: self.describe(schema, args),
                file: PddlFile::Domain,
                span: schema.span,
            })?;
            if variants.is_empty() {
                continue;
            }
            let cost = self.cost(schema, args, &binding)?;
            let (add, del, conditional) = self.effects(schema, args, &mut binding)?;
            for pre in variants {
                actions.push(Action {
                    schema: SchemaId::from_index(*schema_index),
                    args: args.clone(),
                    pre,
                    add: add.clone(),
                    del: del.clone(),
                    conditional: conditional.clone(),
                    cost,
                });
            }
        }
        Ok(actions)
    }

    /// The goal's disjuncts.
    pub fn goal(&self) -> Result<Vec<Condition>, GroundingError> {
        let schema = &self.lifted.goal;
        let mut binding: Binding = vec![None; schema.var_domains.len()];
        let goal = self.ground(schema, &schema.pre, &mut binding);
        split(&goal).ok_or_else(|| GroundingError::TooManyAlternatives {
            what: "the goal".to_string(),
            file: PddlFile::Problem,
            span: schema.span,
        })
    }

    /// `(f o1 ... on)`, by the names the problem gives.
    fn describe_term(&self, function: usize, args: &[ObjectId]) -> String {
        let name = self.lifted.function_names.get(function).map_or("?", String::as_str);
        let names: Vec<&str> = args.iter().map(|o| self.lifted.objects[o.index()].name.as_str()).collect();
        if names.is_empty() { format!("({name})") } else { format!("({name} {})", names.join(" ")) }
    }

    fn describe(&self, schema: &LiftedSchema, args: &[ObjectId]) -> String {
        let names: Vec<&str> = args.iter().map(|o| self.lifted.objects[o.index()].name.as_str()).collect();
        if names.is_empty() { format!("action ({})", schema.name) } else { format!("action ({} {})", schema.name, names.join(" ")) }
    }

    fn cost(&self, schema: &LiftedSchema, args: &[ObjectId], binding: &Binding) -> Result<Cost, GroundingError> {
        if !self.lifted.uses_costs {
            return Ok(1);
        }
        let invalid = |v: f64| v < 0.0 || v.fract() != 0.0;
        let mut total = 0.0;
        // The first term that makes the cost invalid, where it is written.
        let mut culprit: Option<(PddlFile, pddl_syntax::Span)> = None;
        for term in &schema.costs {
            let (value, at) = match term {
                CostTerm::Number(value, span) => (*value, (PddlFile::Domain, *span)),
                CostTerm::Function(function, term_args, span) => {
                    let key = (*function, instantiate_args(term_args, binding).into_iter().collect::<Vec<ObjectId>>());
                    let Some(&(value, given)) = self.lifted.function_values.get(&key) else {
                        return Err(GroundingError::MissingCost {
                            action: self.describe(schema, args),
                            term: self.describe_term(key.0, &key.1),
                            span: *span,
                        });
                    };
                    (value, (PddlFile::Problem, given))
                }
            };
            if culprit.is_none() && invalid(value) {
                culprit = Some(at);
            }
            total += value;
        }
        if invalid(total) || total > Cost::MAX as f64 {
            // A sum that is bad while every term is fine (too large) points at the first term.
            let (file, span) = culprit.unwrap_or_else(|| match schema.costs.first() {
                Some(CostTerm::Number(_, span) | CostTerm::Function(_, _, span)) => (PddlFile::Domain, *span),
                None => (PddlFile::Domain, schema.span),
            });
            return Err(GroundingError::InvalidCost { action: self.describe(schema, args), value: total, file, span });
        }
        Ok(total as Cost)
    }

    #[allow(clippy::type_complexity)]
    fn effects(
        &self,
        schema: &LiftedSchema,
        args: &[ObjectId],
        binding: &mut Binding,
    ) -> Result<(Vec<FactId>, Vec<FactId>, Vec<ConditionalEffect>), GroundingError> {
        let mut add = Vec::new();
        let mut del = Vec::new();
        // Conditional effects with equal conditions are merged.
        let mut conditional: Vec<ConditionalEffect> = Vec::new();
        let mut by_condition: FxHashMap<Condition, usize> = FxHashMap::default();
        for effect in &schema.effects {
            let mut instances: Vec<(FactId, Ground)> = Vec::new();
            self.effect_instances(schema, effect, 0, binding, &mut instances);
            for (fact, condition) in instances {
                let variants = split(&condition).ok_or_else(|| GroundingError::TooManyAlternatives {
                    what: self.describe(schema, args),
                    file: PddlFile::Domain,
                    span: schema.span,
                })?;
                for variant in variants {
                    if variant.is_empty() {
                        if effect.delete {
                            del.push(fact)
                        } else {
                            add.push(fact)
                        }
                        continue;
                    }
                    let at = *by_condition.entry(variant.clone()).or_insert_with(|| {
                        conditional.push(ConditionalEffect { condition: variant, add: Vec::new(), del: Vec::new() });
                        conditional.len() - 1
                    });
                    if effect.delete { conditional[at].del.push(fact) } else { conditional[at].add.push(fact) }
                }
            }
        }
        for list in [&mut add, &mut del] {
            list.sort();
            list.dedup();
        }
        for effect in &mut conditional {
            effect.add.sort();
            effect.add.dedup();
            effect.del.sort();
            effect.del.dedup();
        }
        Ok((add, del, conditional))
    }

    /// Every binding of the effect's `forall` variables whose atom is fluent and whose
    /// condition is not always false.
    fn effect_instances(
        &self,
        schema: &LiftedSchema,
        effect: &crate::lifted::LiftedEffect,
        from: usize,
        binding: &mut Binding,
        out: &mut Vec<(FactId, Ground)>,
    ) {
        let Some(&var) = effect.forall.get(from) else {
            let tuple = instantiate_args(&effect.atom.args, binding);
            let Status::Fluent(fact) = self.status(effect.atom.predicate, tuple) else { return };
            let condition = self.ground(schema, &effect.condition, binding);
            if condition != Ground::False {
                out.push((fact, condition));
            }
            return;
        };
        for &object in &self.lifted.domains.lists[schema.var_domains[var as usize]] {
            binding[var as usize] = Some(object);
            self.effect_instances(schema, effect, from + 1, binding, out);
        }
        binding[var as usize] = None;
    }
}

/// Brings a ground formula into disjunctive shape: a list of [`Condition`]s whose
/// disjunction is equivalent to it. A disjunction of literals under a conjunction stays a
/// clause; any other disjunction is split. `None` if it would split into more than
/// [`MAX_SPLIT`] alternatives.
fn split(formula: &Ground) -> Option<Vec<Condition>> {
    // Most formulas are a literal or a conjunction of literals: one condition, no product.
    let literals: Option<&[Ground]> = match formula {
        Ground::And(parts) => Some(parts),
        Ground::Lit(_) => Some(std::slice::from_ref(formula)),
        _ => None,
    };
    if let Some(parts) = literals.filter(|parts| parts.iter().all(|p| matches!(p, Ground::Lit(_)))) {
        let (mut pos, mut neg) = (Vec::new(), Vec::new());
        for part in parts {
            if let Ground::Lit(l) = part {
                if l.is_negated() { neg.push(l.fact()) } else { pos.push(l.fact()) }
            }
        }
        return Some(make_condition(pos, neg, Vec::new()).into_iter().collect());
    }
    let mut out = Vec::new();
    for (pos, neg, clauses) in split_raw(formula)? {
        if let Some(condition) = make_condition(pos, neg, clauses) {
            out.push(condition);
        }
    }
    out.sort_unstable_by(|a, b| (&a.pos, &a.neg, &a.clauses).cmp(&(&b.pos, &b.neg, &b.clauses)));
    out.dedup();
    Some(out)
}

type RawCondition = (Vec<FactId>, Vec<FactId>, Vec<Vec<Literal>>);

fn split_raw(formula: &Ground) -> Option<Vec<RawCondition>> {
    Some(match formula {
        Ground::True => vec![(Vec::new(), Vec::new(), Vec::new())],
        Ground::False => Vec::new(),
        Ground::Lit(literal) => {
            if literal.is_negated() {
                vec![(Vec::new(), vec![literal.fact()], Vec::new())]
            } else {
                vec![(vec![literal.fact()], Vec::new(), Vec::new())]
            }
        }
        Ground::Or(parts) if parts.iter().all(|p| matches!(p, Ground::Lit(_))) => {
            let clause = parts.iter().filter_map(|p| if let Ground::Lit(l) = p { Some(*l) } else { None }).collect();
            vec![(Vec::new(), Vec::new(), vec![clause])]
        }
        Ground::Or(parts) => {
            let mut out = Vec::new();
            for part in parts {
                out.extend(split_raw(part)?);
                if out.len() > MAX_SPLIT {
                    return None;
                }
            }
            out
        }
        Ground::And(parts) => {
            let mut acc = vec![(Vec::new(), Vec::new(), Vec::new())];
            for part in parts {
                let alternatives = split_raw(part)?;
                if acc.len() * alternatives.len() > MAX_SPLIT {
                    return None;
                }
                let mut next = Vec::with_capacity(acc.len() * alternatives.len());
                for (pos, neg, clauses) in &acc {
                    for (p, n, c) in &alternatives {
                        let mut merged: RawCondition = (pos.clone(), neg.clone(), clauses.clone());
                        merged.0.extend_from_slice(p);
                        merged.1.extend_from_slice(n);
                        merged.2.extend(c.iter().cloned());
                        next.push(merged);
                    }
                }
                acc = next;
            }
            acc
        }
    })
}

/// Normalises a conjunction; `None` if it is contradictory.
pub(crate) fn make_condition(mut pos: Vec<FactId>, mut neg: Vec<FactId>, clauses: Vec<Vec<Literal>>) -> Option<Condition> {
    pos.sort();
    pos.dedup();
    neg.sort();
    neg.dedup();
    if pos.iter().any(|f| neg.binary_search(f).is_ok()) {
        return None;
    }
    let mut kept = Vec::new();
    for clause in clauses {
        // A clause with a literal the unit part guarantees is satisfied; literals the unit
        // part falsifies are dropped.
        let satisfied =
            clause.iter().any(|l| if l.is_negated() { neg.binary_search(&l.fact()).is_ok() } else { pos.binary_search(&l.fact()).is_ok() });
        if satisfied {
            continue;
        }
        let mut rest: Vec<Literal> = clause
            .into_iter()
            .filter(|l| if l.is_negated() { pos.binary_search(&l.fact()).is_err() } else { neg.binary_search(&l.fact()).is_err() })
            .collect();
        rest.sort();
        rest.dedup();
        match rest.len() {
            0 => return None,
            1 => {
                let l = rest[0];
                if l.is_negated() {
                    if pos.binary_search(&l.fact()).is_ok() {
                        return None;
                    }
                    if let Err(at) = neg.binary_search(&l.fact()) {
                        neg.insert(at, l.fact());
                    }
                } else {
                    if neg.binary_search(&l.fact()).is_ok() {
                        return None;
                    }
                    if let Err(at) = pos.binary_search(&l.fact()) {
                        pos.insert(at, l.fact());
                    }
                }
            }
            _ => kept.push(rest),
        }
    }
    kept.sort();
    kept.dedup();
    Some(Condition { pos, neg, clauses: kept })
}
