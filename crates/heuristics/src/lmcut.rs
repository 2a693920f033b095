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
//! of goal-zone facts that it can trigger), which leaves the cut and its order unchanged.
//!
//! On the IPC fixtures the per-domain means are within 4.1% of Fast Downward's 26.6 (1.041
//! on driverlog, 0.987 on elevators, within 0.6% elsewhere; `tests/fast_downward.rs`).
//! [`LmCut::full`] recomputes h_max from scratch every round instead: the same
//! informedness on these domains, slower.

use transition_model::{State, TransitionModel};

use crate::relaxation::{Combine, Exploration};
use crate::relaxed::NO_ADD;
use crate::{Heuristic, INFINITE};

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
    /// Update h_max incrementally between rounds (the default) instead of recomputing it.
    incremental: bool,
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
            costs: relaxed.ops.iter().map(|o| o.cost).collect(),
            zero_achievers: base_zero_achievers.clone(),
            base_zero_achievers,
            status: vec![0; facts],
            queue: Vec::new(),
            cut: Vec::new(),
            candidate_round: vec![0; relaxed.ops.len()],
            round: 0,
            incremental: true,
            exploration,
        }
    }
}

impl LmCut {
    /// LM-cut that recomputes h_max from scratch after every cut (supporters re-chosen each
    /// round by the arrival rule).
    pub fn full(model: &TransitionModel) -> LmCut {
        LmCut { incremental: false, ..LmCut::new(model) }
    }
}

impl Heuristic for LmCut {
    fn name(&self) -> &'static str {
        "lmcut"
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
        loop {
            if goal_cost == 0 {
                return Some(h);
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
            // the walk; it cannot stop early when some candidate's supporter lies beyond the
            // zone). The zone's facts are `queue`'s entries, in marking order.
            self.round = self.round.wrapping_add(1);
            if self.round == 0 {
                self.candidate_round.fill(0);
                self.round = 1;
            }
            let (round, candidate_round) = (self.round, &mut self.candidate_round);
            let mut candidates = 0;
            for &fact in queue.iter() {
                for &op in relaxed.achievers.of(fact) {
                    let supporter = op_supporter[op as usize];
                    let triggerable = if supporter == NONE {
                        relaxed.ops[op as usize].pre_start == relaxed.ops[op as usize].pre_end
                    } else {
                        status[supporter as usize] != IN_GOAL_ZONE
                    };
                    if triggerable && candidate_round[op as usize] != round {
                        candidate_round[op as usize] = round;
                        candidates += 1;
                    }
                }
            }
            // Forward from the state along supporter edges until the goal zone: the cut.
            cut.clear();
            queue.clear();
            for fact in state.facts() {
                // A state fact is never in the goal zone: the goal would cost 0.
                status[fact.index()] = REACHED;
                queue.push(fact.0);
            }
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
                    if added == NO_ADD {
                        triggered(op, status, queue, cut);
                        continue;
                    }
                    // One add effect: the same rule, read without the operator.
                    match status[added as usize] {
                        0 => {
                            status[added as usize] = REACHED;
                            queue.push(added);
                        }
                        IN_GOAL_ZONE => cut.push(op),
                        _ => {}
                    }
                }
                for op in supported.of(fact) {
                    triggered(op, status, queue, cut);
                }
            }
            // Each fact is reached once and each operator triggered by its supporter only,
            // so the cut has no duplicates.
            // A cut exists and costs more than zero whenever the goal does (the goal zone
            // holds every fact that reaches the goal at zero cost); stop rather than loop if not.
            let cheapest = self.cut.iter().map(|&op| self.costs[op as usize]).min().unwrap_or(0);
            if cheapest == 0 {
                return Some(h);
            }
            h = h.saturating_add(cheapest);
            for &op in &self.cut {
                self.costs[op as usize] -= cheapest;
                if self.costs[op as usize] == 0 {
                    let relaxed = &self.exploration.relaxed;
                    for &added in relaxed.ops[op as usize].add(relaxed) {
                        self.zero_achievers[added as usize] += 1;
                    }
                }
            }
            goal_cost = if self.incremental {
                self.exploration.lower(&self.cut, &self.costs)
            } else {
                self.exploration.run(state, Combine::Max, Some(&self.costs))
            };
        }
    }
}
