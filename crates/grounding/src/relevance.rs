//! Backward goal relevance: which facts a plan for the goal can depend on, and after how
//! many regression steps. One analysis, two closures: the planner's state projection
//! (`heuristics`' state registry, [`Closure::Facts`]) and the Phase II prompt's choice of
//! lines (`mcts::prompt`, [`Closure::Literals`], bounded depth).
//!
//! - Step 0: every literal of every goal disjunct (positive and negative literals, and each
//!   literal of each clause).
//! - Step k+1: for every literal `l` found at step k, every action that *affects* `l`
//!   contributes its precondition literals (once, at the first step that reaches the
//!   action), and, when `l` comes from a conditional effect, that effect's condition
//!   literals. Under [`Closure::Literals`] an action affects `l` when it *achieves* it (an
//!   add of `f` for `l = f`, a delete for `l = ¬f`); under [`Closure::Facts`] when it adds or
//!   deletes `l`'s fact at all — a literal found brings its complement with it.
//!
//! A fact is relevant when either of its literals is. Static facts have no [`FactId`]:
//! grounding evaluated them away. Each step visits every achiever of a new literal once, so
//! the whole analysis is linear in the task's size; it stops at the fixpoint or the depth.
//! (Fast Downward's translator prunes irrelevant variables over its causal graph; this is
//! the fact-level version, written by hand since no crate analyses our task type.)

use crate::{Condition, FactId, Literal, Task};

/// Which actions a relevant literal pulls in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Closure {
    /// Actions that achieve the literal. Right for choosing what to show a planner: an action
    /// enters only through the literal it makes true.
    Literals,
    /// Actions that change the literal's fact either way. Every other fact is never read by
    /// the goal nor by an action that can change a relevant fact, so dropping it from states
    /// loses no plan and keeps applicability exact: right for projecting states. (The literal
    /// closure would leave out the precondition of an action that only deletes relevant
    /// facts.)
    Facts,
}

const UNREACHED: u32 = u32::MAX;

/// The facts within `depth` regression steps of the goal (`None`: to the fixpoint).
pub fn relevant_facts(task: &Task, closure: Closure, depth: Option<usize>) -> RelevantFacts {
    let literal_index = |l: Literal| l.fact().index() * 2 + usize::from(l.is_negated());
    // The actions affecting each literal: (action, conditional effect index + 1, or 0).
    let mut affecting: Vec<Vec<(u32, u32)>> = vec![Vec::new(); task.facts.len() * 2];
    let mut add = |effect: u32, action: u32, adds: &[FactId], dels: &[FactId]| {
        for &f in adds {
            affecting[literal_index(Literal::positive(f))].push((action, effect));
        }
        for &f in dels {
            affecting[literal_index(Literal::negative(f))].push((action, effect));
        }
    };
    for (a, action) in task.actions.iter().enumerate() {
        add(0, a as u32, &action.add, &action.del);
        for (e, effect) in action.conditional.iter().enumerate() {
            add(e as u32 + 1, a as u32, &effect.add, &effect.del);
        }
    }
    // The step at which each literal became relevant.
    let mut steps = vec![UNREACHED; task.facts.len() * 2];
    let mark = |condition: &Condition, step: u32, steps: &mut Vec<u32>, frontier: &mut Vec<Literal>| {
        let clause_literals = condition.clauses.iter().flatten().copied();
        for literal in condition.literals().chain(clause_literals) {
            let both = [Some(literal), (closure == Closure::Facts).then(|| literal.negate())];
            for literal in both.into_iter().flatten() {
                let i = literal_index(literal);
                if steps[i] == UNREACHED {
                    steps[i] = step;
                    frontier.push(literal);
                }
            }
        }
    };
    let mut frontier = Vec::new();
    for disjunct in &task.goal.disjuncts {
        mark(disjunct, 0, &mut steps, &mut frontier);
    }
    let mut action_seen = vec![false; task.actions.len()];
    let last = depth.unwrap_or(usize::MAX).min(UNREACHED as usize - 1) as u32;
    for step in 1..=last {
        if frontier.is_empty() {
            break;
        }
        let mut next = Vec::new();
        for literal in std::mem::take(&mut frontier) {
            for &(a, e) in &affecting[literal_index(literal)] {
                let action = &task.actions[a as usize];
                if !std::mem::replace(&mut action_seen[a as usize], true) {
                    mark(&action.pre, step, &mut steps, &mut next);
                }
                if e > 0 {
                    mark(&action.conditional[e as usize - 1].condition, step, &mut steps, &mut next);
                }
            }
        }
        frontier = next;
    }
    RelevantFacts { steps: steps.chunks(2).map(|pair| pair[0].min(pair[1])).collect() }
}

/// The result of [`relevant_facts`]: a set of fluent facts, each with the regression step
/// that found it (0: a goal fact).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RelevantFacts {
    steps: Vec<u32>,
}

impl RelevantFacts {
    /// Whether `fact` is relevant (found within the depth).
    pub fn contains(&self, fact: FactId) -> bool {
        self.step(fact).is_some()
    }

    /// The regression step that made `fact` relevant, if any.
    pub fn step(&self, fact: FactId) -> Option<usize> {
        self.steps.get(fact.index()).filter(|&&s| s != UNREACHED).map(|&s| s as usize)
    }

    /// How many facts are relevant.
    pub fn len(&self) -> usize {
        self.steps.iter().filter(|&&s| s != UNREACHED).count()
    }

    /// Whether no fact is relevant.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The relevant facts, in id order.
    pub fn iter(&self) -> impl Iterator<Item = FactId> + '_ {
        self.steps.iter().enumerate().filter(|(_, s)| **s != UNREACHED).map(|(i, _)| FactId::from_index(i))
    }

    /// The relevant facts as a bit mask over fact ids (64 a word, fact `f` at bit `f % 64` of
    /// word `f / 64`).
    pub fn mask(&self) -> Vec<u64> {
        let mut mask = vec![0u64; self.steps.len().div_ceil(64)];
        for fact in self.iter() {
            mask[fact.index() / 64] |= 1 << (fact.index() % 64);
        }
        mask
    }
}
