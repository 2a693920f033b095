//! h_max, h_add and h_FF: a generalized Dijkstra over the relaxed task, with buffers kept
//! between evaluations (no allocation per call).
//!
//! Tie-breaking, which decides h_FF's relaxed plan: facts leave the queue in order of cost,
//! last in first out among equal costs (Fast Downward's bucket queue); a fact's best supporter is the first operator that reached it at its
//! final cost (a later operator replaces it only when strictly cheaper). Fast Downward uses
//! the same rule, but its queue and operator order differ, so relaxed plans (and h_FF) can
//! differ where several supporters tie; h_max and h_add do not depend on ties.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A monotone priority queue of facts: buckets by cost, last in first out within a bucket
/// (as Fast Downward's bucket queue), with a heap for costs too large for buckets.
#[derive(Debug, Clone, Default)]
struct FactQueue {
    buckets: Vec<Vec<u32>>,
    current: usize,
    len: usize,
    heap: BinaryHeap<Reverse<(u32, u32)>>,
}

const MAX_BUCKETS: u32 = 1 << 16;

impl FactQueue {
    fn clear(&mut self) {
        let from = self.current.min(self.buckets.len());
        for bucket in &mut self.buckets[from..] {
            bucket.clear();
        }
        self.current = 0;
        self.len = 0;
        self.heap.clear();
    }

    #[inline]
    fn push(&mut self, cost: u32, fact: u32) {
        if cost >= MAX_BUCKETS {
            self.heap.push(Reverse((cost, fact)));
            return;
        }
        let cost = cost as usize;
        if cost >= self.buckets.len() {
            self.buckets.resize_with(cost + 1, Vec::new);
        }
        self.buckets[cost].push(fact);
        self.len += 1;
        self.current = self.current.min(cost);
    }

    #[inline]
    fn pop(&mut self) -> Option<(u32, u32)> {
        if self.len > 0 {
            while self.buckets[self.current].is_empty() {
                self.current += 1;
            }
            self.len -= 1;
            let fact = self.buckets[self.current].pop()?;
            return Some((self.current as u32, fact));
        }
        self.heap.pop().map(|Reverse(entry)| entry)
    }
}

use grounding::{ActionId, Task};
use transition_model::{State, TransitionModel};

use crate::relaxed::RelaxedTask;
use crate::{Heuristic, INFINITE};

/// How [`Exploration::run`] combines an operator's precondition costs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Combine {
    /// h_max: an operator costs its costliest precondition plus its own cost.
    Max,
    /// h_add: an operator costs the sum of its preconditions plus its own cost; also records
    /// each fact's best supporter ([`Exploration::supporter`]).
    Add,
}

/// The shared exploration state.
#[derive(Debug, Clone)]
pub struct Exploration {
    /// The delete relaxation explored, built by [`Exploration::new`].
    pub relaxed: RelaxedTask,
    /// Per relaxed fact, its cost from the last run or [`Exploration::lower`] ([`INFINITE`]
    /// where not reached). A run without `costs` stops once the goal is final, so facts
    /// costlier than the goal may keep tentative values.
    pub fact_cost: Vec<u32>,
    /// Best supporter of each fact (an operator index), `u32::MAX` for state facts; kept by
    /// `Combine::Add` explorations only.
    pub supporter: Vec<u32>,
    /// Per operator: the precondition whose arrival made it applicable (the last one
    /// popped, so one of maximal cost), `u32::MAX` if none; kept by explorations with
    /// [`Exploration::track_supported`] only. Change it with
    /// [`Exploration::set_supporter`] so that `supported` follows (LM-cut, which holds split
    /// borrows of the exploration, moves the list entry itself with `Supported::relink`).
    pub op_supporter: Vec<u32>,
    /// With [`Exploration::track_supported`]: the operators each fact supports.
    pub supported: Supported,
    /// With [`Exploration::track_supported`], per operator of two or more preconditions:
    /// its supporter's cost when last looked at (the operator's h_max before its own cost).
    supporter_cost: Vec<u32>,
    track: bool,
    /// Per operator during a run: its preconditions not yet reached, and (h_add) the sum of
    /// their costs so far. One array, so that a visit touches one cache line.
    op_state: Vec<[u32; 2]>,
    /// `op_state` at the start of a run: each operator's precondition count, cost 0.
    op_state_start: Vec<[u32; 2]>,
    /// Precondition count of each operator.
    pre_count: Vec<u32>,
    queue: FactQueue,
}

impl Exploration {
    /// Builds `task`'s delete relaxation ([`RelaxedTask::new`]) and buffers sized for it;
    /// [`Exploration::track_supported`] is off.
    pub fn new(task: &Task) -> Exploration {
        let relaxed = RelaxedTask::new(task);
        let facts = relaxed.num_facts;
        let ops = relaxed.ops.len();
        let pre_count: Vec<u32> = relaxed.ops.iter().map(|op| op.pre_end - op.pre_start).collect();
        let op_state_start: Vec<[u32; 2]> = pre_count.iter().map(|&count| [count, 0]).collect();
        Exploration {
            pre_count,
            relaxed,
            fact_cost: vec![INFINITE; facts],
            supporter: vec![u32::MAX; facts],
            op_supporter: vec![u32::MAX; ops],
            supported: Supported { head: vec![u32::MAX; facts], next: vec![u32::MAX; ops], prev: vec![u32::MAX; ops] },
            supporter_cost: vec![0; ops],
            track: false,
            op_state: op_state_start.clone(),
            op_state_start,
            queue: FactQueue::default(),
        }
    }

    /// Cost of the goal fact from `state` (INFINITE if unreachable), leaving per-fact costs
    /// and best supporters behind. `costs` overrides operator costs and makes the
    /// exploration run to the end (LM-cut needs every operator's supporter); without it the
    /// exploration stops once the goal's cost is final.
    pub fn run(&mut self, state: &State, combine: Combine, costs: Option<&[u32]>) -> u32 {
        // One body, specialised per combination so the inner loop carries no mode tests.
        match (combine, self.track) {
            (Combine::Add, false) => self.run_with::<true, false>(state, costs),
            (Combine::Add, true) => self.run_with::<true, true>(state, costs),
            (Combine::Max, false) => self.run_with::<false, false>(state, costs),
            (Combine::Max, true) => self.run_with::<false, true>(state, costs),
        }
    }

    fn run_with<const ADD: bool, const TRACK: bool>(&mut self, state: &State, costs: Option<&[u32]>) -> u32 {
        // Split borrows: the loops below keep each buffer's pointer in a register.
        let Exploration {
            relaxed,
            fact_cost,
            supporter,
            op_supporter,
            supported,
            supporter_cost,
            op_state,
            op_state_start,
            pre_count,
            queue,
            ..
        } = self;
        let relaxed = &*relaxed;
        let pre_count = &pre_count[..];
        fact_cost.fill(INFINITE);
        op_state.copy_from_slice(op_state_start);
        if TRACK {
            // Only LM-cut (which tracks the supported lists) reads operator supporters.
            op_supporter.fill(u32::MAX);
            supported.head.fill(u32::MAX);
        }
        if ADD {
            // Only h_add needs operator costs (for h_max an operator costs what its last
            // precondition popped at) and fact supporters (for h_FF's relaxed plan).
            supporter.fill(u32::MAX);
        }
        queue.clear();
        for fact in relaxed.state_facts(state) {
            fact_cost[fact as usize] = 0;
            queue.push(0, fact);
        }
        let op_base = |i: usize| costs.map_or(relaxed.ops[i].cost, |c| c[i]);
        for &op in &relaxed.no_pre {
            let cost = op_base(op as usize);
            for &fact in relaxed.ops[op as usize].add(relaxed) {
                if cost < fact_cost[fact as usize] {
                    fact_cost[fact as usize] = cost;
                    if ADD {
                        supporter[fact as usize] = op;
                    }
                    queue.push(cost, fact);
                }
            }
        }
        let goal = relaxed.goal;
        let stop_at_goal = costs.is_none();
        while let Some((cost, fact)) = queue.pop() {
            if cost > fact_cost[fact as usize] {
                continue;
            }
            if fact == goal && stop_at_goal {
                break;
            }
            for &op in relaxed.pre_of(fact) {
                let i = op as usize;
                let [unsatisfied, pre_sum] = &mut op_state[i];
                if ADD {
                    *pre_sum = pre_sum.saturating_add(cost);
                }
                *unsatisfied -= 1;
                if *unsatisfied == 0 {
                    if TRACK {
                        op_supporter[i] = fact;
                        if pre_count[i] > 1 {
                            supported.link(op, fact);
                            supporter_cost[i] = cost;
                        }
                    }
                    // Facts leave the queue in cost order, so for h_max the operator costs
                    // what its last precondition cost.
                    let pre_cost = if ADD { *pre_sum } else { cost };
                    let reached = pre_cost.saturating_add(op_base(i)).min(INFINITE - 1);
                    for &added in relaxed.ops[i].add(relaxed) {
                        if reached < fact_cost[added as usize] {
                            fact_cost[added as usize] = reached;
                            if ADD {
                                supporter[added as usize] = op;
                            }
                            queue.push(reached, added);
                        }
                    }
                }
            }
        }
        fact_cost[goal as usize]
    }
}

/// The operators of two or more preconditions each fact supports, as intrusive doubly
/// linked lists over operator ids: LM-cut walks a fact's supported operators instead of
/// every operator it is a precondition of, and a supporter change costs O(1). Operators of
/// one precondition are not listed (their supporter never changes): walk
/// [`RelaxedTask::sole_pre_of`] beside these lists. That keeps list upkeep off the common
/// case and walks those operators from a contiguous array instead of by pointer chasing.
#[derive(Debug, Clone)]
pub struct Supported {
    head: Vec<u32>,
    next: Vec<u32>,
    prev: Vec<u32>,
}

impl Supported {
    #[inline]
    fn link(&mut self, op: u32, fact: u32) {
        let head = self.head[fact as usize];
        self.next[op as usize] = head;
        self.prev[op as usize] = u32::MAX;
        if head != u32::MAX {
            self.prev[head as usize] = op;
        }
        self.head[fact as usize] = op;
    }

    #[inline]
    fn unlink(&mut self, op: u32, fact: u32) {
        let (prev, next) = (self.prev[op as usize], self.next[op as usize]);
        if prev == u32::MAX {
            self.head[fact as usize] = next;
        } else {
            self.next[prev as usize] = next;
        }
        if next != u32::MAX {
            self.prev[next as usize] = prev;
        }
    }

    /// Moves `op` from `from`'s list to `to`'s.
    #[inline]
    pub(crate) fn relink(&mut self, op: u32, from: u32, to: u32) {
        self.unlink(op, from);
        self.link(op, to);
    }

    /// The operators of two or more preconditions that `fact` supports.
    #[inline]
    pub fn of(&self, fact: u32) -> impl Iterator<Item = u32> + '_ {
        let mut op = self.head[fact as usize];
        std::iter::from_fn(move || {
            (op != u32::MAX).then(|| {
                let current = op;
                op = self.next[op as usize];
                current
            })
        })
    }
}

impl Exploration {
    /// Keep [`Exploration::supported`] up to date (LM-cut); off by default.
    pub fn track_supported(&mut self) {
        self.track = true;
    }

    /// Makes `fact` the supporter of `op`.
    pub fn set_supporter(&mut self, op: u32, fact: u32) {
        let old = self.op_supporter[op as usize];
        if old == fact {
            return;
        }
        if self.track && self.pre_count[op as usize] > 1 {
            if old != u32::MAX {
                self.supported.unlink(op, old);
            }
            self.supported.link(op, fact);
        }
        self.op_supporter[op as usize] = fact;
    }

    /// After a run with `costs` (which must be `Combine::Max`, with
    /// [`Exploration::track_supported`] on), the operators in `lowered` got cheaper: update
    /// h_max incrementally (costs only fall, so only what lies downstream of those operators
    /// changes) and return the goal's new cost. An operator's supporter is looked at only when
    /// that fact got cheaper; the first precondition of strictly greater h_max then takes
    /// over, if any (Fast Downward's rule).
    pub fn lower(&mut self, lowered: &[u32], costs: &[u32]) -> u32 {
        assert!(self.track, "Exploration::lower walks the supported-operator lists: call track_supported first");
        let Exploration { relaxed, fact_cost, op_supporter, supported, supporter_cost, queue, .. } = self;
        let relaxed = &*relaxed;
        queue.clear();
        for &op in lowered {
            let supporter = op_supporter[op as usize];
            let base = if supporter == u32::MAX { 0 } else { fact_cost[supporter as usize] };
            let target = base.saturating_add(costs[op as usize]);
            for &added in relaxed.ops[op as usize].add(relaxed) {
                if target < fact_cost[added as usize] {
                    fact_cost[added as usize] = target;
                    queue.push(target, added);
                }
            }
        }
        while let Some((cost, fact)) = queue.pop() {
            if cost > fact_cost[fact as usize] {
                continue;
            }
            for (op, added) in relaxed.sole_pre_entries(fact) {
                let target = cost.saturating_add(costs[op as usize]);
                let mut pair = [0; 2];
                for &added in relaxed.sole_pre_adds(op, &added, &mut pair) {
                    if target < fact_cost[added as usize] {
                        fact_cost[added as usize] = target;
                        queue.push(target, added);
                    }
                }
            }
            // The list is walked while its operators move to other lists: `next` is read
            // before the current operator is unlinked.
            let mut op = supported.head[fact as usize];
            while op != u32::MAX {
                let next = supported.next[op as usize];
                let i = op as usize;
                // Costs only fall, so no precondition costs more than the supporter did
                // (`old`): the first precondition still at `old`, if any, is the new supporter
                // and leaves the operator's cost unchanged, so the scan stops there and
                // nothing is propagated. Otherwise the first of strictly greater cost than
                // `fact` takes over (Fast Downward's rule).
                let old = supporter_cost[i];
                let mut supporter = fact;
                let mut best = cost;
                for &pre in relaxed.ops[i].pre(relaxed) {
                    let pre_cost = fact_cost[pre as usize];
                    if pre_cost > best {
                        best = pre_cost;
                        supporter = pre;
                        if pre_cost == old {
                            break;
                        }
                    }
                }
                if supporter != fact {
                    op_supporter[i] = supporter;
                    supported.unlink(op, fact);
                    supported.link(op, supporter);
                }
                supporter_cost[i] = best;
                if best != old {
                    let target = best.saturating_add(costs[i]);
                    for &added in relaxed.ops[i].add(relaxed) {
                        if target < fact_cost[added as usize] {
                            fact_cost[added as usize] = target;
                            queue.push(target, added);
                        }
                    }
                }
                op = next;
            }
        }
        fact_cost[relaxed.goal as usize]
    }
}

/// h_max (Bonet and Geffner): the costliest precondition decides.
#[derive(Debug, Clone)]
pub struct HMax {
    exploration: Exploration,
}

impl HMax {
    /// h_max over `model`'s delete relaxation.
    pub fn new(model: &TransitionModel) -> HMax {
        HMax { exploration: Exploration::new(model.task()) }
    }
}

impl Heuristic for HMax {
    fn name(&self) -> &'static str {
        "hmax"
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        let h = self.exploration.run(state, Combine::Max, None);
        (h != INFINITE).then_some(h)
    }
}

/// h_add: preconditions' costs are summed.
#[derive(Debug, Clone)]
pub struct HAdd {
    exploration: Exploration,
}

impl HAdd {
    /// h_add over `model`'s delete relaxation.
    pub fn new(model: &TransitionModel) -> HAdd {
        HAdd { exploration: Exploration::new(model.task()) }
    }
}

impl Heuristic for HAdd {
    fn name(&self) -> &'static str {
        "hadd"
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        let h = self.exploration.run(state, Combine::Add, None);
        (h != INFINITE).then_some(h)
    }
}

/// h_FF (Hoffmann and Nebel): the cost of a relaxed plan extracted from h_add's best
/// supporters, each action counted once. Its preferred operators are the relaxed plan's
/// actions that are applicable in the evaluated state.
#[derive(Debug)]
pub struct HFF<'m> {
    model: &'m TransitionModel,
    exploration: Exploration,
    in_plan: Vec<bool>,
    marked_fact: Vec<bool>,
    stack: Vec<u32>,
    plan_actions: Vec<u32>,
    preferred: Vec<ActionId>,
}

impl<'m> HFF<'m> {
    /// h_FF over `model`'s delete relaxation (it borrows the model to compute preferred
    /// operators, the relaxed plan's actions applicable in the evaluated state).
    pub fn new(model: &'m TransitionModel) -> HFF<'m> {
        let exploration = Exploration::new(model.task());
        let facts = exploration.relaxed.num_facts;
        HFF {
            model,
            exploration,
            in_plan: vec![false; model.task().actions.len()],
            marked_fact: vec![false; facts],
            stack: Vec::new(),
            plan_actions: Vec::new(),
            preferred: Vec::new(),
        }
    }

    /// The actions of the last relaxed plan.
    pub fn relaxed_plan(&self) -> impl Iterator<Item = ActionId> + '_ {
        self.plan_actions.iter().map(|&a| ActionId(a))
    }
}

impl Heuristic for HFF<'_> {
    fn name(&self) -> &'static str {
        "ff"
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        self.preferred.clear();
        for &a in &self.plan_actions {
            self.in_plan[a as usize] = false;
        }
        self.plan_actions.clear();
        let goal_cost = self.exploration.run(state, Combine::Add, None);
        if goal_cost == INFINITE {
            return None;
        }
        let relaxed = &self.exploration.relaxed;
        self.marked_fact.fill(false);
        self.stack.clear();
        self.stack.push(relaxed.goal);
        self.marked_fact[relaxed.goal as usize] = true;
        let mut h: u32 = 0;
        while let Some(fact) = self.stack.pop() {
            let op = self.exploration.supporter[fact as usize];
            if op == u32::MAX {
                continue; // true in the state
            }
            let relaxed_op = relaxed.ops[op as usize];
            for &pre in relaxed_op.pre(relaxed) {
                if !self.marked_fact[pre as usize] {
                    self.marked_fact[pre as usize] = true;
                    self.stack.push(pre);
                }
            }
            let action = relaxed_op.action;
            if action != crate::relaxed::NO_ACTION && !self.in_plan[action as usize] {
                self.in_plan[action as usize] = true;
                self.plan_actions.push(action);
                h = h.saturating_add(self.model.task().actions[action as usize].cost);
                if self.model.is_applicable(state, ActionId(action)) {
                    self.preferred.push(ActionId(action));
                }
            }
        }
        Some(h)
    }

    fn preferred_operators(&self) -> &[ActionId] {
        &self.preferred
    }
}
