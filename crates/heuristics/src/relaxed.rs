//! The delete relaxation of a task as unary-style operators over facts, shared by h_max,
//! h_add, h_FF and LM-cut.
//!
//! What the relaxation keeps of a grounded task:
//! - an action becomes one operator (its positive preconditions, its unconditional adds)
//!   plus one operator per conditional effect (preconditions and effect condition, the
//!   effect's adds), each with the action's cost, as Fast Downward does;
//! - a fact `f` that some condition needs false gets a *negation fact* `¬f`: true in a state
//!   where `f` is false, added by every operator whose action deletes `f` (and does not add
//!   it back). A precondition `(not f)` becomes the precondition `¬f`. This is what Fast
//!   Downward's translator does (a binary variable with the values `f` and `NegatedAtom f`),
//!   and it matters on the household domains: ALFWorld's `pickupobject` needs
//!   `(not (holdsAny ?a))`, so a relaxation that dropped it valued "holding the wrong object"
//!   as close to the goal as "holding the right one";
//! - a clause (a disjunctive precondition) becomes an auxiliary fact, achieved at zero cost by
//!   any of its literals (a negative literal through its negation fact);
//! - the goal becomes one auxiliary goal fact, achieved at zero cost by one operator per goal
//!   disjunct. Fast Downward compiles complex goals the same way (an artificial goal reached
//!   by zero-cost actions); for a conjunctive goal every heuristic value is unchanged by it;
//! - only operators and adds relevant to the goal (backward from it through preconditions)
//!   are kept, which changes no heuristic value and no tie-break; two rules for negation
//!   facts then prune further, keeping h_max, h_add and h⁺ (see `Builder::prune_irrelevant`
//!   and `Builder::keep_relevant`).

use grounding::{ActionId, Condition, FactId, Literal, Task};
use rustc_hash::FxHashMap;
use transition_model::State;

/// `action` of operators that stand for no action (clause and goal achievers).
pub const NO_ACTION: u32 = u32::MAX;

/// A precondition marked for removal while the relaxation is built.
const DROPPED: u32 = u32::MAX;

/// [`RelaxedTask::sole_pre_add`] of an operator with three or more add effects.
pub const NO_ADD: u32 = u32::MAX;

/// Flags [`RelaxedTask::sole_pre_add`]'s entry of an operator with two add effects: the
/// first, with this bit set (fact ids stay below it); the second is in
/// [`RelaxedTask::second_add`].
pub const TWO_ADDS: u32 = 1 << 31;

/// One relaxed operator: an action's unconditional part, one of its conditional effects, or a
/// zero-cost clause or goal achiever. Its preconditions and adds are ranges of
/// [`RelaxedTask::pre`] and [`RelaxedTask::add`].
#[derive(Debug, Clone, Copy)]
pub struct RelaxedOp {
    /// Start of its preconditions in [`RelaxedTask::pre`].
    pub pre_start: u32,
    /// End (exclusive) of its preconditions in [`RelaxedTask::pre`].
    pub pre_end: u32,
    /// Start of its add effects in [`RelaxedTask::add`].
    pub add_start: u32,
    /// End (exclusive) of its add effects in [`RelaxedTask::add`].
    pub add_end: u32,
    /// The action's cost (0 for clause and goal achievers).
    pub cost: u32,
    /// The action it comes from, or [`NO_ACTION`].
    pub action: u32,
}

/// The delete relaxation of a [`Task`] (see the module docs): operators over relaxed facts
/// (`u32` ids; those below [`RelaxedTask::task_facts`] are the task's [`FactId`]s), with the
/// per-fact indexes the explorations walk.
#[derive(Debug, Clone)]
pub struct RelaxedTask {
    /// Number of relaxed facts: task facts, then negation facts, then auxiliary clause facts and
    /// the goal fact (a clause first met in the goal gets an id after the goal fact's).
    pub num_facts: usize,
    /// The operators; an operator id is an index here.
    pub ops: Vec<RelaxedOp>,
    /// Every operator's preconditions (relaxed fact ids), concatenated; [`RelaxedOp::pre`]
    /// gives one operator's.
    pub pre: Vec<u32>,
    /// Every operator's add effects (relaxed fact ids, each operator's sorted and without
    /// duplicates), concatenated; [`RelaxedOp::add`] gives one operator's.
    pub add: Vec<u32>,
    /// Operators that have each fact as a precondition.
    pub preconditions_of: FactIndex,
    /// Operators that add each fact.
    pub achievers: FactIndex,
    /// Operators whose only precondition is each fact: their h_max supporter can only be it,
    /// so the explorations keep no supporter lists for them.
    pub sole_pre_of: FactIndex,
    /// Parallel to [`RelaxedTask::sole_pre_of`]'s lists: each listed operator's add effect
    /// when it has exactly one; its first one with [`TWO_ADDS`] set when it has two; else
    /// [`NO_ADD`]. The explorations read the effects beside the operator id instead of through
    /// the operator (two dependent loads fewer per visit), and test for one effect with one
    /// comparison.
    pub sole_pre_add: Vec<u32>,
    /// Per operator: its second add effect when it has exactly two, else [`NO_ADD`].
    pub second_add: Vec<u32>,
    /// Operators without preconditions.
    pub no_pre: Vec<u32>,
    /// The auxiliary goal fact: reached by a zero-cost operator per goal disjunct, so it holds
    /// where any disjunct does.
    pub goal: u32,
    /// Number of real task facts (state facts have ids below this).
    pub task_facts: usize,
    /// `(f, ¬f)` for every negation fact, by `f`: `¬f` holds in a state without `f`.
    pub negations: Vec<(u32, u32)>,
}

impl RelaxedOp {
    /// Whether the operator has no preconditions (it is applicable in every state).
    #[inline]
    pub fn has_no_pre(&self) -> bool {
        self.pre_start == self.pre_end
    }

    /// Its preconditions, relaxed fact ids; `task` must be the relaxed task it belongs to.
    #[inline]
    pub fn pre<'a>(&self, task: &'a RelaxedTask) -> &'a [u32] {
        &task.pre[self.pre_start as usize..self.pre_end as usize]
    }

    /// Its add effects, relaxed fact ids; `task` must be the relaxed task it belongs to.
    #[inline]
    pub fn add<'a>(&self, task: &'a RelaxedTask) -> &'a [u32] {
        &task.add[self.add_start as usize..self.add_end as usize]
    }
}

impl RelaxedTask {
    /// The operators whose only precondition is `fact`, with their
    /// [`RelaxedTask::sole_pre_add`] entries.
    #[inline]
    pub fn sole_pre_entries(&self, fact: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        let range = self.sole_pre_of.range(fact);
        self.sole_pre_of.ops[range.clone()].iter().copied().zip(self.sole_pre_add[range].iter().copied())
    }

    /// The add effects of `op`, listed in [`RelaxedTask::sole_pre_of`] with the entry
    /// `added` (`pair` holds two effects).
    #[inline]
    pub fn sole_pre_adds<'a>(&'a self, op: u32, added: &'a u32, pair: &'a mut [u32; 2]) -> &'a [u32] {
        if *added < TWO_ADDS {
            std::slice::from_ref(added)
        } else if *added != NO_ADD {
            *pair = [*added & !TWO_ADDS, self.second_add[op as usize]];
            &pair[..]
        } else {
            self.ops[op as usize].add(self)
        }
    }

    /// The facts true in `state` in the relaxed task: its own, and the negation facts of the
    /// facts it lacks.
    #[inline]
    pub fn state_facts<'a>(&'a self, state: &'a State) -> impl Iterator<Item = u32> + 'a {
        state
            .facts()
            .map(|f| f.0)
            .chain(self.negations.iter().filter(|&&(fact, _)| !state.contains(FactId(fact))).map(|&(_, negation)| negation))
    }

    /// The relaxation of `task`, keeping only the operators and add effects relevant to the
    /// goal (see the module docs).
    pub fn new(task: &Task) -> RelaxedTask {
        let mut builder = Builder {
            relaxed: RelaxedTask {
                num_facts: task.facts.len(),
                ops: Vec::new(),
                pre: Vec::new(),
                add: Vec::new(),
                preconditions_of: FactIndex::default(),
                achievers: FactIndex::default(),
                sole_pre_of: FactIndex::default(),
                sole_pre_add: Vec::new(),
                second_add: Vec::new(),
                no_pre: Vec::new(),
                goal: 0,
                task_facts: task.facts.len(),
                negations: Vec::new(),
            },
            clause_facts: FxHashMap::default(),
            pending_clauses: Vec::new(),
            negation_of: FxHashMap::default(),
        };
        builder.negation_facts(task);
        for (index, action) in task.actions.iter().enumerate() {
            let pre = builder.condition_facts(&action.pre);
            let add = builder.effect_facts(&action.add, &action.del, &[]);
            builder.push(pre.clone(), add, action.cost, index as u32);
            for effect in &action.conditional {
                let add = builder.effect_facts(&effect.add, &effect.del, &action.add);
                if add.is_empty() {
                    continue;
                }
                // A condition fact the precondition already has is one precondition, not two (h_add
                // would count it twice; Fast Downward deduplicates each unary operator's
                // preconditions). The order stays the precondition's, then the condition's: LM-cut
                // breaks ties by it, and an operator without a repeated fact is as before.
                let mut pre = pre.clone();
                for fact in builder.condition_facts(&effect.condition) {
                    if !pre.contains(&fact) {
                        pre.push(fact);
                    }
                }
                builder.push(pre, add, action.cost, index as u32);
            }
        }
        let goal = builder.relaxed.num_facts as u32;
        builder.relaxed.num_facts += 1;
        builder.relaxed.goal = goal;
        for disjunct in &task.goal.disjuncts {
            let pre = builder.condition_facts(disjunct);
            builder.push(pre, vec![goal], 0, NO_ACTION);
        }
        // Clause achievers: any literal of the clause reaches its auxiliary fact.
        for (fact, clause) in std::mem::take(&mut builder.pending_clauses) {
            for literal in clause {
                let pre = builder.literal_fact(literal);
                builder.push(vec![pre], vec![fact], 0, NO_ACTION);
            }
        }
        builder.finish()
    }

    /// Operators that have `fact` as a precondition.
    #[inline]
    pub fn pre_of(&self, fact: u32) -> &[u32] {
        self.preconditions_of.of(fact)
    }

    /// The action operator `op` comes from; `None` for clause and goal achievers. Panics if
    /// `op` is not an operator id.
    pub fn action_of(&self, op: u32) -> Option<ActionId> {
        let action = self.ops[op as usize].action;
        (action != NO_ACTION).then_some(ActionId(action))
    }
}

struct Builder {
    relaxed: RelaxedTask,
    clause_facts: FxHashMap<Vec<Literal>, u32>,
    pending_clauses: Vec<(u32, Vec<Literal>)>,
    /// The negation fact of each fact some condition needs false.
    negation_of: FxHashMap<u32, u32>,
}

impl Builder {
    /// Gives a negation fact to every fact that a precondition, an effect condition or the goal
    /// needs false, in order of fact id.
    fn negation_facts(&mut self, task: &Task) {
        let mut negated: Vec<u32> = Vec::new();
        let mut collect = |condition: &Condition| {
            negated.extend(condition.neg.iter().map(|f| f.0));
            negated.extend(condition.clauses.iter().flatten().filter(|l| l.is_negated()).map(|l| l.fact().0));
        };
        for action in &task.actions {
            collect(&action.pre);
            action.conditional.iter().for_each(|effect| collect(&effect.condition));
        }
        task.goal.disjuncts.iter().for_each(&mut collect);
        negated.sort_unstable();
        negated.dedup();
        for fact in negated {
            let negation = self.relaxed.num_facts as u32;
            self.relaxed.num_facts += 1;
            self.negation_of.insert(fact, negation);
            self.relaxed.negations.push((fact, negation));
        }
    }

    /// The relaxed fact of a literal: the fact, or its negation fact.
    fn literal_fact(&self, literal: Literal) -> u32 {
        let fact = literal.fact().0;
        if literal.is_negated() { self.negation_of[&fact] } else { fact }
    }

    /// Relaxed adds of an effect: its adds, and the negation facts of its deletes that neither
    /// it nor `also_added` (the action's unconditional adds) adds back (an added fact stays
    /// true, PDDL semantics).
    fn effect_facts(&self, add: &[FactId], del: &[FactId], also_added: &[FactId]) -> Vec<u32> {
        let mut out: Vec<u32> = add.iter().map(|f| f.0).collect();
        for fact in del {
            if let Some(&negation) = self.negation_of.get(&fact.0)
                && add.binary_search(fact).is_err()
                && also_added.binary_search(fact).is_err()
            {
                out.push(negation);
            }
        }
        out
    }

    /// Relaxed preconditions of a condition: its positive facts, the negation facts of its
    /// negative ones, and one auxiliary fact per clause.
    fn condition_facts(&mut self, condition: &Condition) -> Vec<u32> {
        let mut out: Vec<u32> = condition.pos.iter().map(|f: &FactId| f.0).collect();
        out.extend(condition.neg.iter().map(|f| self.negation_of[&f.0]));
        for clause in &condition.clauses {
            let next = self.relaxed.num_facts as u32;
            let fact = *self.clause_facts.entry(clause.clone()).or_insert_with(|| {
                self.pending_clauses.push((next, clause.clone()));
                next
            });
            if fact == next {
                self.relaxed.num_facts += 1;
            }
            out.push(fact);
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    fn push(&mut self, pre: Vec<u32>, mut add: Vec<u32>, cost: u32, action: u32) {
        add.sort_unstable();
        add.dedup();
        if add.is_empty() {
            return;
        }
        let relaxed = &mut self.relaxed;
        let pre_start = relaxed.pre.len() as u32;
        relaxed.pre.extend_from_slice(&pre);
        let add_start = relaxed.add.len() as u32;
        relaxed.add.extend_from_slice(&add);
        relaxed.ops.push(RelaxedOp {
            pre_start,
            pre_end: relaxed.pre.len() as u32,
            add_start,
            add_end: relaxed.add.len() as u32,
            cost,
            action,
        });
    }

    /// Drops every operator that cannot contribute to the goal: one is kept when it adds a
    /// *relevant* fact (the goal fact, or a precondition of a kept operator), found by a
    /// backward fixpoint from the goal; a kept operator keeps only its relevant adds. h_max,
    /// h_add, the relaxed plan and LM-cut's cuts only ever look at the goal's supporters,
    /// transitively, which are all kept; and a dropped operator or effect reaches only
    /// irrelevant facts, which no kept operator needs, so the order in which the kept facts
    /// leave the queue, and with it every tie-break, is unchanged. With the rules below, this
    /// keeps about half of the actions' operators on ALFWorld (48–49% on four tasks) and 5–85%
    /// on EAI VirtualHome.
    ///
    /// Then a precondition `¬f` of an operator whose only relevant add is `f` is dropped, and
    /// the fixpoint runs again: where `f` holds, the operator adds nothing new, and where it
    /// does not, `¬f` holds. Values are unchanged, and the achievers of `¬f` are no longer
    /// relevant through it: ALFWorld's `openobject` needs `(not (opened ?r))` and adds
    /// `(opened ?r)`, and without this rule every `closeobject` would be kept for it.
    fn prune_irrelevant(&mut self) {
        loop {
            self.keep_relevant();
            let relaxed = &mut self.relaxed;
            let negation_of = &self.negation_of;
            let mut dropped = false;
            for op in &relaxed.ops {
                let [added] = relaxed.add[op.add_start as usize..op.add_end as usize] else { continue };
                let Some(&negation) = negation_of.get(&added) else { continue };
                let pre = &mut relaxed.pre[op.pre_start as usize..op.pre_end as usize];
                if let Some(at) = pre.iter().position(|&p| p == negation) {
                    // Marked here, removed by the next `keep_relevant`.
                    pre[at] = DROPPED;
                    dropped = true;
                }
            }
            if !dropped {
                return;
            }
        }
    }

    /// One backward relevance fixpoint: keeps the operators with a relevant add, and only
    /// their relevant adds (and drops preconditions marked [`DROPPED`]).
    ///
    /// An operator reached only as an achiever of a negation fact `¬f` does not make its
    /// *guarded* preconditions relevant: those whose every achiever needs `¬f`. Such a
    /// precondition `p` can be reached before `¬f` only when the state has it, so where the
    /// state lacks `p` the operator is never `¬f`'s first achiever, and `p`'s achievers (which
    /// need `¬f` already) add nothing that counts. This is ALFWorld's hand: `¬holdsAny` is
    /// added by `putobject ?o ?r` for every object, each needing `(holds ?o)`, which only
    /// `pickupobject` adds, after `¬holdsAny`; without the rule every object's pick-up and
    /// put-down would be relevant (2.6 times the operators). The operator keeps `p` as a
    /// precondition, so it adds `¬f` exactly where the state holds `p`. h_max and h_add are
    /// unchanged (the dropped operators only ever reach a fact after its cheapest achiever),
    /// and so is h⁺: no relaxed plan needs them.
    fn keep_relevant(&mut self) {
        const PARTIAL: u8 = 1;
        const FULL: u8 = 2;
        let relaxed = &mut self.relaxed;
        let adders = FactIndex::new(relaxed.num_facts, &relaxed.ops, |op| &relaxed.add[op.add_start as usize..op.add_end as usize]);
        let negations: rustc_hash::FxHashSet<u32> = relaxed.negations.iter().map(|&(_, negation)| negation).collect();
        let mut relevant_fact = vec![false; relaxed.num_facts];
        let mut kept = vec![0u8; relaxed.ops.len()];
        let mut stack = vec![relaxed.goal];
        relevant_fact[relaxed.goal as usize] = true;
        let pre_of = |op: &RelaxedOp| &relaxed.pre[op.pre_start as usize..op.pre_end as usize];
        while let Some(fact) = stack.pop() {
            for &index in adders.of(fact) {
                let op = relaxed.ops[index as usize];
                let guarded = |p: u32| {
                    negations.contains(&fact)
                        && !negations.contains(&p)
                        && adders.of(p).iter().all(|&a| pre_of(&relaxed.ops[a as usize]).contains(&fact))
                };
                let mode = if pre_of(&op).iter().any(|&p| p != DROPPED && guarded(p)) { PARTIAL } else { FULL };
                let before = kept[index as usize];
                if before >= mode {
                    continue;
                }
                kept[index as usize] = mode;
                for &pre in pre_of(&op) {
                    if pre == DROPPED || (mode == PARTIAL && guarded(pre)) {
                        continue;
                    }
                    if !std::mem::replace(&mut relevant_fact[pre as usize], true) {
                        stack.push(pre);
                    }
                }
            }
        }
        let (mut pre, mut add, mut ops) = (Vec::new(), Vec::new(), Vec::new());
        for (op, _) in relaxed.ops.iter().zip(&kept).filter(|(_, k)| **k > 0) {
            let pre_start = pre.len() as u32;
            pre.extend(relaxed.pre[op.pre_start as usize..op.pre_end as usize].iter().filter(|&&p| p != DROPPED));
            let add_start = add.len() as u32;
            add.extend(relaxed.add[op.add_start as usize..op.add_end as usize].iter().filter(|&&a| relevant_fact[a as usize]));
            ops.push(RelaxedOp { pre_start, pre_end: pre.len() as u32, add_start, add_end: add.len() as u32, ..*op });
        }
        (relaxed.pre, relaxed.add, relaxed.ops) = (pre, add, ops);
        relaxed.negations.retain(|&(_, negation)| relevant_fact[negation as usize]);
    }

    fn finish(mut self) -> RelaxedTask {
        self.prune_irrelevant();
        let relaxed = &mut self.relaxed;
        relaxed.no_pre = (0..relaxed.ops.len() as u32).filter(|&i| relaxed.ops[i as usize].has_no_pre()).collect();
        relaxed.preconditions_of =
            FactIndex::new(relaxed.num_facts, &relaxed.ops, |op| &relaxed.pre[op.pre_start as usize..op.pre_end as usize]);
        relaxed.achievers = FactIndex::new(relaxed.num_facts, &relaxed.ops, |op| &relaxed.add[op.add_start as usize..op.add_end as usize]);
        relaxed.sole_pre_of = FactIndex::new(relaxed.num_facts, &relaxed.ops, |op| {
            let pre = &relaxed.pre[op.pre_start as usize..op.pre_end as usize];
            if pre.len() == 1 { pre } else { &[] }
        });
        // Fact ids stay below the flag bit, or no operator is listed as having two effects.
        let two_adds = relaxed.num_facts < TWO_ADDS as usize;
        relaxed.sole_pre_add = relaxed
            .sole_pre_of
            .ops
            .iter()
            .map(|&op| match relaxed.ops[op as usize].add(relaxed) {
                [added] => *added,
                [first, _] if two_adds => first | TWO_ADDS,
                _ => NO_ADD,
            })
            .collect();
        relaxed.second_add = relaxed
            .ops
            .iter()
            .map(|op| match op.add(relaxed) {
                [_, second] => *second,
                _ => NO_ADD,
            })
            .collect();
        self.relaxed
    }
}

/// For each fact, a list of operators (compressed rows: the lists of all facts in one vector).
#[derive(Debug, Clone, Default)]
pub struct FactIndex {
    start: Vec<u32>,
    ops: Vec<u32>,
}

impl FactIndex {
    /// Lists each operator under every fact of `facts(op)`, operators in index order.
    fn new<'a>(num_facts: usize, ops: &[RelaxedOp], facts: impl Fn(&RelaxedOp) -> &'a [u32]) -> FactIndex {
        let mut start = vec![0u32; num_facts + 1];
        for op in ops {
            for &f in facts(op) {
                start[f as usize + 1] += 1;
            }
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut fill = start.clone();
        let mut listed = vec![0u32; start[num_facts] as usize];
        for (index, op) in ops.iter().enumerate() {
            for &f in facts(op) {
                listed[fill[f as usize] as usize] = index as u32;
                fill[f as usize] += 1;
            }
        }
        FactIndex { start, ops: listed }
    }

    /// The operators listed under `fact`.
    #[inline]
    pub fn of(&self, fact: u32) -> &[u32] {
        &self.ops[self.range(fact)]
    }

    /// Where `fact`'s list lies in the concatenation of all lists (for parallel arrays).
    #[inline]
    pub fn range(&self, fact: u32) -> std::ops::Range<usize> {
        self.start[fact as usize] as usize..self.start[fact as usize + 1] as usize
    }
}
