//! LM-cut (Helmert and Domshlak 2009): repeatedly compute h_max, cut the justification
//! graph between the state and the goal zone, and charge the cheapest operator of the cut.
//!
//! As Fast Downward: one full h_max exploration per evaluation, then after each cut an
//! incremental update downstream of the cut's operators (costs only fall). Tie-breaking:
//! - an operator's h_max supporter (its precondition choice) is first the precondition
//!   whose arrival made it applicable (of maximal h_max; among ties the one reached last from
//!   the last-in-first-out bucket queue); when that fact gets cheaper in an update, the
//!   first precondition of strictly greater h_max, if any, takes over;
//! - when the goal zone is marked, a zero-cost operator's supporter is re-chosen among its
//!   preconditions of equal h_max: the first that no zero-cost operator achieves (the
//!   border), else the first already in the goal zone (Fast Downward's border and goal-zone
//!   detection);
//! - an operator with an effect in the goal zone ends the forward exploration there.
//!
//! The forward exploration walks each fact's supported operators (its one-precondition
//! operators, then the intrusive lists the exploration keeps for the others,
//! `Exploration::supported`) rather than every operator the fact is a precondition of,
//! and it stops as soon as the cut holds every operator that could join it (the achievers
//! of goal-zone facts whose supporter it reaches), which leaves the cut and its order
//! unchanged. Achievers whose supporter lies beyond the goal zone are ruled out first by a
//! short backward search where that pays (logistics: A* 2.2x faster).
//!
//! Conditional effects, which Fast Downward's LM-cut refuses: the relaxation has one operator
//! for an action's unconditional part and one per conditional effect, each priced at the
//! action's cost. Two ways to charge them:
//! - [`LmCut::new`] (`lmcut`) charges each apart. Where a goal needs several effects of one
//!   application this overestimates (`act` adds `q` and, where `p` holds, `r1` and `r2`; `fin`
//!   needs all three: LM-cut 4 where h* is 3), so on such tasks it is not admissible and A*
//!   with it may return a costlier plan. It is the informative one, and what the agent's
//!   search uses as a value and its symbolic control as A*'s heuristic.
//! - [`LmCut::admissible`] (`lmcut-admissible`) lets the operators of one action share its
//!   cost: a cut holding any of them lowers them all, once. Every cut is still a landmark of
//!   the relaxed task, and an action's charges across cuts sum to at most its cost, so the sum
//!   is admissible (Röger, Pommerening and Helmert 2014 extend LM-cut to conditional effects the
//!   same way, before their context splitting, which is not done here). Sharing can lower
//!   h_max by more than the cut's cost in one round, so the value is raised to h_max where it
//!   falls below. It is what proves a bound (no plan of ŝ0 within the steps left). Its cuts
//!   differ, so on a state it can be above `lmcut` too, but on VirtualHome's walks (a
//!   conditional effect per object carried) it is mostly much weaker: A* with it ran out of a
//!   million expansions on three of the 33 EAI fixture tasks (from their full problems) that
//!   A* with `lmcut` solves in seconds. On the agent's hand-overs, smaller, the two took about
//!   as long.
//!
//! On tasks without conditional effects the two are the same heuristic, value for value.
//!
//! On the IPC fixtures the per-domain means are within 4.1% of Fast Downward's 26.6 (1.041
//! on driverlog, 0.987 on elevators, within 0.6% elsewhere; `tests/fast_downward.rs`).
//! [`LmCut::full`] recomputes h_max from scratch every round instead: the same
//! informedness on these domains, slower.

use transition_model::{State, TransitionModel};

use crate::relaxation::{Combine, Exploration};
use crate::relaxed::{NO_ADD, RelaxedTask, TWO_ADDS};
use crate::{Heuristic, INFINITE};

/// The LM-cut heuristic (Helmert and Domshlak 2009): the sum of the costs of disjunctive action
/// landmarks found by repeated h_max cuts; its values are Fast Downward's on every state
/// compared. Admissible without conditional effects; with them, admissible as
/// [`LmCut::admissible`] builds it (see the module docs). Evaluate it through
/// [`crate::Heuristic`].
#[derive(Debug, Clone)]
pub struct LmCut {
    exploration: Exploration,
    costs: Vec<u32>,
    /// Per fact, how many of its achievers cost 0 this evaluation (so far); reset from
    /// `base_zero_achievers`, raised as cuts bring operators to 0. The goal-zone tie-breaking
    /// asks it for every precondition of equal h_max instead of scanning the achievers.
    zero_achievers: Vec<u32>,
    base_zero_achievers: Vec<u32>,
    /// Per fact, this round: [`IN_GOAL_ZONE`], [`REACHED`] (by the forward exploration,
    /// before the goal zone) or 0; the two are exclusive, so one array and one reset.
    status: Vec<u8>,
    /// First-in-first-out queue of the goal-zone and forward walks: a plain vector read from
    /// a moving head (each fact enters at most once per walk, so it never wraps).
    queue: Vec<u32>,
    cut: Vec<u32>,
    /// Per operator, the round in which it was last counted as a cut candidate (`round`).
    candidate_round: Vec<u32>,
    round: u32,
    beyond: Beyond,
    /// Tests: walk to the end and check that the early stop would have missed nothing.
    #[cfg(test)]
    audit: Option<Audit>,
    /// Update h_max incrementally between rounds (the default) instead of recomputing it.
    incremental: bool,
    /// Per operator: the first of its action's operators in `sharing` where they share the
    /// action's cost ([`LmCut::admissible`], an action with several: an unconditional part and
    /// conditional effects), else `NONE`.
    shared_start: Vec<u32>,
    /// The operators of each action that share its cost, one action's after another; each
    /// list ends where the next action's starts (`shared_end`).
    sharing: Vec<u32>,
    /// Per operator that shares: the end of its action's list in `sharing`.
    shared_end: Vec<u32>,
    /// Per operator, the round in which its action's cost was last lowered (so a cut holding
    /// two of an action's operators lowers it once).
    lowered_round: Vec<u32>,
    /// Operators whose cost a round lowered: the cut's and, where they share, their siblings'.
    lowered: Vec<u32>,
    /// Built by [`LmCut::admissible`] (its name is `lmcut-admissible`, with or without
    /// conditional effects).
    admissible_mode: bool,
}

const NONE: u32 = u32::MAX;
const IN_GOAL_ZONE: u8 = 1;
const REACHED: u8 = 2;

impl LmCut {
    /// LM-cut as Fast Downward computes it (see the module docs).
    pub fn new(model: &TransitionModel) -> LmCut {
        let mut exploration = Exploration::new(model.task());
        exploration.track_supported();
        let relaxed = &exploration.relaxed;
        let facts = relaxed.num_facts;
        let mut base_zero_achievers = vec![0u32; facts];
        for op in relaxed.ops.iter().filter(|o| o.cost == 0) {
            for &added in op.add(relaxed) {
                base_zero_achievers[added as usize] += 1;
            }
        }
        LmCut {
            shared_start: vec![NONE; relaxed.ops.len()],
            sharing: Vec::new(),
            shared_end: vec![NONE; relaxed.ops.len()],
            lowered_round: vec![0; relaxed.ops.len()],
            lowered: Vec::new(),
            admissible_mode: false,
            costs: relaxed.ops.iter().map(|o| o.cost).collect(),
            zero_achievers: base_zero_achievers.clone(),
            base_zero_achievers,
            status: vec![0; facts],
            queue: Vec::new(),
            cut: Vec::new(),
            candidate_round: vec![0; relaxed.ops.len()],
            round: 0,
            beyond: Beyond {
                proved: vec![0; facts],
                visited: vec![0; facts],
                search: 0,
                stack: Vec::new(),
                seen: Vec::new(),
                enabled: true,
                rounds_tried: 0,
                rounds_useful: 0,
            },
            #[cfg(test)]
            audit: None,
            incremental: true,
            exploration,
        }
    }
}

impl LmCut {
    /// LM-cut that recomputes h_max from scratch after every cut (supporters re-chosen each
    /// round by the arrival rule).
    pub fn full(model: &TransitionModel) -> LmCut {
        LmCut::new(model).recomputing()
    }

    /// This LM-cut, recomputing h_max from scratch after every cut (as [`LmCut::full`]).
    pub fn recomputing(self) -> LmCut {
        LmCut { incremental: false, ..self }
    }

    /// LM-cut whose operators of one action share the action's cost (see the module docs):
    /// admissible with conditional effects too, and the same as [`LmCut::new`] without them.
    pub fn admissible(model: &TransitionModel) -> LmCut {
        let mut lmcut = LmCut { admissible_mode: true, ..LmCut::new(model) };
        // The operators of each action that has several, grouped.
        let relaxed = &lmcut.exploration.relaxed;
        let mut by_action: rustc_hash::FxHashMap<u32, Vec<u32>> = rustc_hash::FxHashMap::default();
        for (id, op) in relaxed.ops.iter().enumerate() {
            if op.action != crate::relaxed::NO_ACTION {
                by_action.entry(op.action).or_default().push(id as u32);
            }
        }
        let mut groups: Vec<Vec<u32>> = by_action.into_values().filter(|ops| ops.len() > 1).collect();
        groups.sort_unstable();
        for ops in groups {
            let (start, end) = (lmcut.sharing.len() as u32, (lmcut.sharing.len() + ops.len()) as u32);
            for &op in &ops {
                (lmcut.shared_start[op as usize], lmcut.shared_end[op as usize]) = (start, end);
            }
            lmcut.sharing.extend(ops);
        }
        lmcut
    }
}

impl Heuristic for LmCut {
    fn name(&self) -> &'static str {
        if self.admissible_mode { "lmcut-admissible" } else { "lmcut" }
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        for (cost, op) in self.costs.iter_mut().zip(&self.exploration.relaxed.ops) {
            *cost = op.cost;
        }
        self.zero_achievers.copy_from_slice(&self.base_zero_achievers);
        let mut h: u32 = 0;
        let mut goal_cost = self.exploration.run(state, Combine::Max, Some(&self.costs));
        if goal_cost == INFINITE {
            return None;
        }
        // Where operators share their action's cost, at least h_max (see the module docs);
        // elsewhere LM-cut is at least h_max already.
        let h_max = goal_cost;
        loop {
            if goal_cost == 0 {
                return Some(h.max(h_max));
            }
            // Split borrows, so the loops below keep each buffer's pointer in a register.
            let Exploration { relaxed, fact_cost, op_supporter, supported, .. } = &mut self.exploration;
            let relaxed = &*relaxed;
            let (status, queue, cut, costs) = (&mut self.status, &mut self.queue, &mut self.cut, &self.costs);
            // Goal zone: facts from which the goal is reached through zero-cost operators.
            status.fill(0);
            let goal = relaxed.goal;
            status[goal as usize] = IN_GOAL_ZONE;
            queue.clear();
            queue.push(goal);
            let mut head = 0;
            while let Some(&fact) = queue.get(head) {
                head += 1;
                for &op in relaxed.achievers.of(fact) {
                    let current = op_supporter[op as usize];
                    if costs[op as usize] != 0 || current == NONE {
                        continue;
                    }
                    // The supporter of a zero-cost operator is re-chosen for this round among
                    // its preconditions of the supporter's h_max (Fast Downward's border and
                    // goal-zone detection): the first that no zero-cost operator achieves (on
                    // the border of the goal zone), else the first already in the goal zone,
                    // else the current one. An operator of one precondition keeps it.
                    let cost = fact_cost[current as usize];
                    let mut border = None;
                    let mut in_zone = None;
                    for &pre in relaxed.ops[op as usize].pre(relaxed) {
                        if fact_cost[pre as usize] != cost {
                            continue;
                        }
                        if self.zero_achievers[pre as usize] == 0 {
                            border = Some(pre);
                            break;
                        }
                        if in_zone.is_none() && status[pre as usize] == IN_GOAL_ZONE {
                            in_zone = Some(pre);
                        }
                    }
                    let supporter = border.or(in_zone).unwrap_or(current);
                    if supporter != current {
                        op_supporter[op as usize] = supporter;
                        supported.relink(op, current, supporter);
                    }
                    if status[supporter as usize] != IN_GOAL_ZONE {
                        status[supporter as usize] = IN_GOAL_ZONE;
                        queue.push(supporter);
                    }
                }
            }
            // Precondition choice function: the precondition whose arrival made the
            // operator applicable in this round's exploration, so one of maximal h_max and,
            // among ties, the one reached last (the bucket queue is last-in-first-out).
            let supported = &*supported;
            // The cut's candidates: operators with an effect in the goal zone that the forward
            // walk can trigger (no preconditions, or a supporter outside the zone). The cut
            // is the candidates whose supporter it reaches, so once it holds them all the walk
            // stops: the rest of it would find nothing (on the IPC fixtures it skips 10-65% of
            // the walk). A candidate whose supporter lies beyond the zone (reachable only
            // through it) would keep it going to the end, unless a backward search proves
            // that first ([`Beyond`]). The zone's facts are `queue`'s entries, in marking order.
            self.round = self.round.wrapping_add(1);
            if self.round == 0 {
                self.candidate_round.fill(0);
                self.lowered_round.fill(0);
                self.beyond.proved.fill(0);
                self.round = 1;
            }
            let (round, candidate_round, beyond) = (self.round, &mut self.candidate_round, &mut self.beyond);
            for fact in relaxed.state_facts(state) {
                // A state fact is never in the goal zone: the goal would cost 0.
                status[fact as usize] = REACHED;
            }
            let mut candidates = 0;
            let (mut tried, mut proved) = (false, false);
            for &fact in queue.iter() {
                for &op in relaxed.achievers.of(fact) {
                    let supporter = op_supporter[op as usize];
                    let triggerable =
                        if supporter == NONE { relaxed.ops[op as usize].has_no_pre() } else { status[supporter as usize] != IN_GOAL_ZONE };
                    if !triggerable || candidate_round[op as usize] == round {
                        continue;
                    }
                    candidate_round[op as usize] = round;
                    // A supporter costlier than the zone fact it leads to often lies beyond
                    // the zone (reached only through it, as a package loaded again at its
                    // destination in logistics); a short backward search proves that, so the
                    // walk need not wait for it.
                    if beyond.enabled
                        && supporter != NONE
                        && status[supporter as usize] == 0
                        && fact_cost[supporter as usize] > fact_cost[fact as usize]
                    {
                        tried = true;
                        if beyond.proves(supporter, round, relaxed, op_supporter, status) {
                            proved = true;
                            continue;
                        }
                    }
                    candidates += 1;
                }
            }
            #[cfg(test)]
            let counted = candidates;
            #[cfg(test)]
            if self.audit.is_some() {
                candidates = usize::MAX;
            }
            // Forward from the state along supporter edges until the goal zone: the cut.
            cut.clear();
            queue.clear();
            queue.extend(relaxed.state_facts(state));
            // An operator with an effect in the goal zone is in the cut, and its other
            // effects are not explored further (as in Fast Downward): the cut stays a
            // landmark, since reaching those effects needs the operator itself, and smaller
            // cuts leave more landmarks for later rounds.
            let triggered = |op: u32, status: &mut Vec<u8>, queue: &mut Vec<u32>, cut: &mut Vec<u32>| {
                let adds = relaxed.ops[op as usize].add(relaxed);
                if adds.iter().any(|&added| status[added as usize] == IN_GOAL_ZONE) {
                    cut.push(op);
                    return;
                }
                for &added in adds {
                    if status[added as usize] == 0 {
                        status[added as usize] = REACHED;
                        queue.push(added);
                    }
                }
            };
            for &op in &relaxed.no_pre {
                triggered(op, status, queue, cut);
            }
            let mut head = 0;
            while let Some(&fact) = queue.get(head) {
                if cut.len() == candidates {
                    break;
                }
                head += 1;
                for (op, added) in relaxed.sole_pre_entries(fact) {
                    // One or two add effects: the same rule, read without the operator and
                    // written out (through `RelaxedTask::sole_pre_adds` and `triggered`'s
                    // slice loop, visitall's two-effect moves cost 29% more instructions).
                    if added < TWO_ADDS {
                        match status[added as usize] {
                            0 => {
                                status[added as usize] = REACHED;
                                queue.push(added);
                            }
                            IN_GOAL_ZONE => cut.push(op),
                            _ => {}
                        }
                        continue;
                    }
                    if added == NO_ADD {
                        triggered(op, status, queue, cut);
                        continue;
                    }
                    let (first, second) = (added & !TWO_ADDS, relaxed.second_add[op as usize]);
                    let (first_status, second_status) = (status[first as usize], status[second as usize]);
                    if first_status == IN_GOAL_ZONE || second_status == IN_GOAL_ZONE {
                        cut.push(op);
                        continue;
                    }
                    if first_status == 0 {
                        status[first as usize] = REACHED;
                        queue.push(first);
                    }
                    if second_status == 0 {
                        status[second as usize] = REACHED;
                        queue.push(second);
                    }
                }
                for op in supported.of(fact) {
                    triggered(op, status, queue, cut);
                }
            }
            #[cfg(test)]
            if let Some(audit) = &mut self.audit {
                audit.rounds += 1;
                audit.proved_facts += beyond.proved.iter().filter(|&&r| r == round).count();
                // Every cut operator was counted, so the walk would have stopped no earlier
                // than it found the whole cut; and no fact proved beyond the zone was reached.
                assert!(cut.len() <= counted);
                for &op in cut.iter() {
                    assert_eq!(candidate_round[op as usize], round, "cut operator {op} was not counted");
                }
                for (fact, &proved_round) in beyond.proved.iter().enumerate() {
                    assert!(proved_round != round || status[fact] != REACHED, "fact {fact} proved beyond the zone was reached");
                }
                tried = false;
            }
            if tried {
                beyond.record(proved && head < queue.len());
            }
            // Each fact is reached once and each operator triggered by its supporter only,
            // so the cut has no duplicates.
            // A cut exists and costs more than zero whenever the goal does (the goal zone
            // holds every fact that reaches the goal at zero cost); stop rather than loop if not.
            let cheapest = self.cut.iter().map(|&op| self.costs[op as usize]).min().unwrap_or(0);
            if cheapest == 0 {
                return Some(h.max(h_max));
            }
            h = h.saturating_add(cheapest);
            // Each cut operator's cost falls; where operators share their action's cost, so do
            // its siblings', once per action (all of them cost the same throughout). A sibling
            // this state cannot reach (a conditional effect whose condition it cannot make
            // true) gets the lower cost but no part in the update: the update would take it for
            // one without preconditions and lend its effects a reach they do not have.
            let lowered = if self.sharing.is_empty() {
                &self.cut
            } else {
                self.lowered.clear();
                for &op in &self.cut {
                    let start = self.shared_start[op as usize];
                    if start == NONE {
                        self.costs[op as usize] -= cheapest;
                        self.lowered.push(op);
                    } else if self.lowered_round[op as usize] != round {
                        let end = self.shared_end[op as usize];
                        let relaxed = &self.exploration.relaxed;
                        for &sibling in &self.sharing[start as usize..end as usize] {
                            self.lowered_round[sibling as usize] = round;
                            self.costs[sibling as usize] -= cheapest;
                            if self.exploration.op_supporter[sibling as usize] != NONE || relaxed.ops[sibling as usize].has_no_pre() {
                                self.lowered.push(sibling);
                            }
                        }
                    }
                }
                &self.lowered
            };
            for &op in lowered {
                if self.sharing.is_empty() {
                    self.costs[op as usize] -= cheapest;
                }
                if self.costs[op as usize] == 0 {
                    let relaxed = &self.exploration.relaxed;
                    for &added in relaxed.ops[op as usize].add(relaxed) {
                        self.zero_achievers[added as usize] += 1;
                    }
                }
            }
            goal_cost = if self.incremental {
                self.exploration.lower(lowered, &self.costs)
            } else {
                self.exploration.run(state, Combine::Max, Some(&self.costs))
            };
        }
    }
}

/// Facts the forward walk cannot reach: those whose every path from the state along
/// supporter edges passes through an operator with an effect in the goal zone.
#[derive(Debug, Clone)]
struct Beyond {
    /// Per fact, the round in which it was proved beyond the zone.
    proved: Vec<u32>,
    /// Per fact, the search that last visited it.
    visited: Vec<u32>,
    search: u32,
    stack: Vec<u32>,
    seen: Vec<u32>,
    /// Whether to search at all: on tasks where the searches rarely let the walk stop early
    /// (where the costlier supporters are reachable after all, as in visitall), they are
    /// turned off after a trial of [`BEYOND_TRIAL`] rounds. Values never depend on it.
    enabled: bool,
    /// Rounds with a search, and those where one succeeded and the walk stopped early.
    rounds_tried: u32,
    rounds_useful: u32,
}

/// Rounds with searches after which they are kept only if at least a quarter let the walk
/// stop early.
const BEYOND_TRIAL: u32 = 1024;

/// Facts a search may visit before it gives up (and proves nothing).
const BEYOND_BUDGET: usize = 8;

impl Beyond {
    fn record(&mut self, useful: bool) {
        self.rounds_tried += 1;
        self.rounds_useful += u32::from(useful);
        if self.rounds_tried == BEYOND_TRIAL {
            self.enabled = self.rounds_useful * 4 >= BEYOND_TRIAL;
        }
    }

    /// Whether `fact` is provably unreachable by the forward walk: a backward search over
    /// the supporters of its achievers that have no effect in the goal zone finds neither a
    /// state fact nor an operator without preconditions. `status` marks the goal zone and
    /// the state's facts ([`REACHED`]). Every fact of a search that succeeds is beyond as
    /// well (its predecessors are among the searched ones), so later searches of the round
    /// stop there. A search that would visit more than [`BEYOND_BUDGET`] facts gives up.
    fn proves(&mut self, fact: u32, round: u32, relaxed: &RelaxedTask, op_supporter: &[u32], status: &[u8]) -> bool {
        self.search = self.search.wrapping_add(1);
        if self.search == 0 {
            self.visited.fill(0);
            self.search = 1;
        }
        let search = self.search;
        self.stack.clear();
        self.seen.clear();
        self.stack.push(fact);
        self.seen.push(fact);
        self.visited[fact as usize] = search;
        let blocked = |op: u32| relaxed.ops[op as usize].add(relaxed).iter().any(|&added| status[added as usize] == IN_GOAL_ZONE);
        while let Some(current) = self.stack.pop() {
            for &op in relaxed.achievers.of(current) {
                let supporter = op_supporter[op as usize];
                if supporter == NONE {
                    if relaxed.ops[op as usize].has_no_pre() && !blocked(op) {
                        return false;
                    }
                    continue;
                }
                match status[supporter as usize] {
                    IN_GOAL_ZONE => continue,
                    REACHED => {
                        if blocked(op) {
                            continue;
                        }
                        return false;
                    }
                    _ => {}
                }
                if self.proved[supporter as usize] == round || self.visited[supporter as usize] == search || blocked(op) {
                    continue;
                }
                if self.seen.len() == BEYOND_BUDGET {
                    return false;
                }
                self.visited[supporter as usize] = search;
                self.seen.push(supporter);
                self.stack.push(supporter);
            }
        }
        for &seen in &self.seen {
            self.proved[seen as usize] = round;
        }
        true
    }
}

#[cfg(test)]
#[derive(Debug, Clone, Default)]
struct Audit {
    rounds: usize,
    proved_facts: usize,
}

#[cfg(test)]
mod tests {
    use super::*;
    use benchmark_data::{Benchmark, load};

    fn model(files: &benchmark_data::TaskFiles) -> TransitionModel {
        let domain = pddl_syntax::parse_domain(&files.domain).expect("domain");
        let problem = pddl_syntax::parse_problem(&files.problem).expect("problem");
        TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"))
    }

    /// The early stop of the forward walk and the proofs that supporters lie beyond the goal
    /// zone change no value, and the audit finds every cut operator counted and no proved
    /// fact reached, on states along random walks in every IPC fixture and some ALFWorld and
    /// VirtualHome tasks.
    #[test]
    fn the_early_stop_changes_nothing() {
        let ipc = load(Benchmark::Ipc).expect("fixtures");
        let alfworld = load(Benchmark::AlfworldSeen).expect("fixtures");
        let virtualhome = load(Benchmark::VirtualhomeEai).expect("fixtures");
        let mut proved_on = Vec::new();
        for files in ipc.iter().chain(alfworld.iter().step_by(35)).chain(virtualhome.iter().step_by(40)) {
            let model = model(files);
            let mut fast = LmCut::new(&model);
            let mut audited = LmCut::new(&model);
            audited.audit = Some(Audit::default());
            for state in model.random_walk(0x5EED, 15) {
                assert_eq!(fast.evaluate(&state), audited.evaluate(&state), "{}", files.id);
            }
            let audit = audited.audit.as_ref().expect("audit");
            assert!(audit.rounds > 0, "{}", files.id);
            if audit.proved_facts > 0 {
                proved_on.push(files.id.clone());
            }
        }
        assert!(proved_on.iter().any(|id| id.starts_with("logistics00/")), "proofs ran on logistics: {proved_on:?}");
    }
}
