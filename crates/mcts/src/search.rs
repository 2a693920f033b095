//! Token-level MCTS (paper §3.2, Eq. 9-10; Appendix A.4).
//!
//! A node is a token prefix of the plan, standing for `n = (s, u)`: the symbolic state `s`
//! the completed actions reach and the partial action `u`. Nodes do not store `(s, u)`: a
//! simulation replays its tokens from the root through the constraint (a byte-trie step per
//! token and one successor per completed action), which keeps a node at 32 bytes.
//!
//! **Simulation.** *Selection* descends from the root by
//! `argmax_v Q̄(n, v) + U(n, v)` over the node's open children, with
//! `U(n, v) = c(n) · p(v | n) · √N(n) / (1 + N(n, v))` (Eq. 9) and
//! `c(n) = c_explore + ln((N(n) + c_base + 1) / c_base)`: the exploration constant
//! (default 2.5) is the constant part of `c_N`, the base constant (default 10) sets how fast
//! it grows with the parent's visits, as AlphaZero's `c_init` and `c_base`. `p` is the
//! prior: the model's distribution renormalised over the tokens the mask allows (Eq. 8), or
//! the full distribution in unconstrained mode (with `renormalize_prior`, over the node's
//! open children only: a closed child's share goes to its open siblings). `Q` is the best value backed up through the
//! child (`Backup::Max`, a Bellman backup: the model is deterministic, so a prefix is worth
//! its best continuation found so far; `Backup::Mean` is the Monte-Carlo mean). `Q̄` is `Q`
//! min-max normalised over the node's visited open children (`Normalization::Siblings`: the
//! best sibling is 1, the worst 0), so that `Q̄ ∈ [0, 1]` and the prior term are on one
//! scale; `Normalization::Tree` normalises over every value the tree has seen, as MuZero
//! does. An unvisited child takes its parent's `Q̄`.
//!
//! **Why max and siblings by default.** The paper does not say how values are backed up or
//! scaled. With the mean over the tree's range, a one-step difference in `h` is a few
//! hundredths of `Q̄` (the range spans dead ends to the goal) while `U` is of order one, so
//! the search spread its visits almost by the prior: with a uniform prior it solved 231 of
//! the first 240 EAI tasks in 60 s and failed 11-step table-setting plans that A* with
//! LM-cut solves in 11 expansions. Max backup with sibling normalisation (and transposition
//! pruning, below) solves all 330 solvable EAI tasks and all 140 ALFWorld tasks
//! (docs/ARCHITECTURE.md has the figures).
//! *Expansion* asks the model once at the leaf and keeps the `width` (16) most likely
//! allowed tokens as children, with their priors as given (not renormalised over the 16).
//! The *rollout* then writes greedily — the most likely child, expanding each node on the
//! way — until the partial action completes (at most `tokens_per_expansion`, 128, tokens):
//! every simulation ends at an action boundary (or at the end of the plan), where Eq. 10
//! gives the value, which is *backed up* along the whole path. Distributions are asked for
//! once per node (the node keeps its children and priors: the cache by prefix); a token the
//! mask forces needs no model call at all; and the model's own caches make a request cost
//! only positions never computed before (a local model's prefix cache and branch store: a
//! return to a branch the search left copies its keys and values back).
//!
//! **Values.** At a boundary reaching state `s` after `|π|` actions: `R_G` at the goal, else
//! `−h(s, G) − λ|π|` ([`crate::value`]). A dead end (`h = ∞`), an unconstrained line that
//! names no applicable action, get `−(h(s₀) + λ·max_actions + 1)`: below every live prefix
//! within the length limit whose `h` has not grown more than `1 + λ·(max_actions − |π|)` past
//! `h(s₀)` (a prefix that takes a wrong object can grow it further and score lower; the value
//! is a floor for the usual case, not a bound). These, a plan that ended (EOS / `DONE`), a prefix
//! at `max_actions`, and a *transposition* — a prefix whose state another prefix reached
//! first with no more actions (`prune_transpositions`; with it off, `prune_cycles` closes
//! only a prefix that returns to a state of its own path) — are leaves: closed, never
//! selected again. States are compared on the facts relevant to the goal
//! ([`crate::value::Evaluator::project`]), so an action that changes only facts nothing reads
//! (ALFWorld's `examine`, `look` and `inventory` set `checked`) closes at once: before, such
//! lines kept the root's value and drew most of SmolLM2's visits on ALFWorld's heat-a-tomato
//! task. Every continuation of a transposition is open to the prefix that got
//! there first at no higher cost, so the tree holds each state once; on EAI 392_2 this took
//! the search from no plan in 60 s (3.5 M simulations over 5.5 k states) to a plan in 5 s.
//! A node whose children are all closed is closed; a closed root means the tree is
//! exhausted.
//!
//! **Result.** The first prefix that reaches the goal stops the search (`stop_at_goal`, the
//! paper's early termination). Otherwise, when a budget runs out, the best valid candidate:
//! every boundary the search reached is one; a goal-reaching one beats any other (the
//! cheapest of them), then the highest value. Ties break on token order, so a run is
//! deterministic.
//!
//! **Summary.** The run returns the top of the tree as a [`TreeSummary`]: the visited
//! branches from the root to the first action boundary (a row per action line completed, or
//! per branch that ended or stopped short of one), then the same from the most visited first
//! action. It replays the rows' tokens through the cursor (at most [`TreeSummary::STEPS`] per
//! level), so the nodes stay 32 bytes. The simulation that reaches the goal is backed up
//! before the search stops, so the plan's branch counts it.

use grounding::ActionId;
use rustc_hash::FxHashMap;
use token_constraint::TokenId;
use transition_model::{State, TransitionModel};

use crate::config::{DecodeConfig, DecodeError, MctsConfig, Normalization, Run, StopReason};
use crate::cursor::{Cursor, Event};
use crate::step::{Session, Stepper};
use crate::summary::{Backup, RowKind, TreeLevel, TreeRow, TreeSummary};
use crate::value::Evaluator;

const EXPANDED: u8 = 1;
const CLOSED: u8 = 2;

#[derive(Debug, Clone, Copy)]
struct Node {
    /// The sum of backed-up values (mean backup) or the best of them (max backup).
    value: f64,
    token: TokenId,
    prior: f32,
    visits: u32,
    first_child: u32,
    child_count: u16,
    flags: u8,
}

impl Node {
    fn new(token: TokenId, prior: f32) -> Node {
        Node { value: 0.0, token, prior, visits: 0, first_child: 0, child_count: 0, flags: 0 }
    }

    fn expanded(&self) -> bool {
        self.flags & EXPANDED != 0
    }

    fn closed(&self) -> bool {
        self.flags & CLOSED != 0
    }

    fn children(&self) -> std::ops::Range<usize> {
        self.first_child as usize..self.first_child as usize + self.child_count as usize
    }
}

/// The tree: nodes in one vector, each node's children contiguous.
#[derive(Debug)]
struct Tree {
    nodes: Vec<Node>,
    min: f64,
    max: f64,
    backup: Backup,
    normalization: Normalization,
}

impl Tree {
    fn new(config: &MctsConfig) -> Tree {
        Tree {
            nodes: vec![Node::new(0, 1.0)],
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            backup: config.backup,
            normalization: config.normalization,
        }
    }

    fn raw(&self, node: &Node) -> f64 {
        match self.backup {
            Backup::Mean => node.value / f64::from(node.visits),
            Backup::Max => node.value,
        }
    }

    fn normalize(&self, value: f64) -> f64 {
        if self.max > self.min { ((value - self.min) / (self.max - self.min)).clamp(0.0, 1.0) } else { 0.5 }
    }

    /// Adds `candidates` as the children of `node`, their priors mixed with the uniform over
    /// them by `mix` ([`MctsConfig::prior_mix`]).
    fn expand(&mut self, node: usize, candidates: &[(TokenId, f32)], mix: f32) {
        let first = self.nodes.len() as u32;
        let count = candidates.len().min(u16::MAX as usize);
        let uniform = mix / count.max(1) as f32;
        self.nodes.extend(candidates[..count].iter().map(|&(t, p)| Node::new(t, (1.0 - mix) * p + uniform)));
        let n = &mut self.nodes[node];
        n.first_child = first;
        n.child_count = count as u16;
        n.flags |= EXPANDED;
        if count == 0 {
            n.flags |= CLOSED;
        }
    }

    /// PUCB (Eq. 9) over the open children; the first of equals.
    fn select(&self, node: usize, config: &MctsConfig) -> Option<usize> {
        let n = &self.nodes[node];
        let visits = f64::from(n.visits);
        let coefficient = config.exploration + ((visits + config.base + 1.0) / config.base).ln();
        let scale = coefficient * visits.sqrt();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        if self.normalization == Normalization::Siblings {
            for child in n.children().map(|c| &self.nodes[c]).filter(|c| c.visits > 0 && !c.closed()) {
                lo = lo.min(self.raw(child));
                hi = hi.max(self.raw(child));
            }
        }
        let norm = |node: &Node| match self.normalization {
            Normalization::Tree => self.normalize(self.raw(node)),
            Normalization::Siblings if hi > lo => ((self.raw(node) - lo) / (hi - lo)).clamp(0.0, 1.0),
            Normalization::Siblings => 0.5,
        };
        let first_play = if n.visits > 0 { norm(n) } else { 0.5 };
        // With `renormalize_prior`, p(v | n) is conditioned on v being open: each open
        // child's prior over the open children's total (uniform over them if that is 0).
        let (prior_scale, uniform) = if config.renormalize_prior {
            let (mass, open) = n
                .children()
                .map(|c| &self.nodes[c])
                .filter(|c| !c.closed())
                .fold((0.0f64, 0usize), |(m, k), c| (m + f64::from(c.prior), k + 1));
            if mass > 0.0 { (1.0 / mass, 0.0) } else { (0.0, 1.0 / open.max(1) as f64) }
        } else {
            (1.0, 0.0)
        };
        let mut best: Option<(usize, f64)> = None;
        for c in n.children() {
            let child = &self.nodes[c];
            if child.closed() {
                continue;
            }
            let q = if child.visits > 0 { norm(child) } else { first_play };
            let prior = f64::from(child.prior) * prior_scale + uniform;
            let score = q + scale * prior / (1.0 + f64::from(child.visits));
            if best.is_none_or(|(_, b)| score > b) {
                best = Some((c, score));
            }
        }
        best.map(|(c, _)| c)
    }

    fn backup(&mut self, path: &[usize], value: f64) {
        self.min = self.min.min(value);
        self.max = self.max.max(value);
        for &n in path {
            let node = &mut self.nodes[n];
            node.value = match self.backup {
                Backup::Mean => node.value + value,
                Backup::Max if node.visits == 0 => value,
                Backup::Max => node.value.max(value),
            };
            node.visits += 1;
        }
    }

    fn visited_children(&self, node: usize) -> impl Iterator<Item = usize> + '_ {
        self.nodes[node].children().filter(|&c| self.nodes[c].visits > 0)
    }

    /// Closes the last node of `path`, and every ancestor left with no open child.
    fn close(&mut self, path: &[usize]) {
        let Some((&leaf, ancestors)) = path.split_last() else { return };
        self.nodes[leaf].flags |= CLOSED;
        for &n in ancestors.iter().rev() {
            let node = self.nodes[n];
            if node.children().any(|c| !self.nodes[c].closed()) {
                break;
            }
            self.nodes[n].flags |= CLOSED;
        }
    }
}

/// How a simulation's last node is valued.
enum Leaf {
    /// A live prefix: its value, and it stays open.
    Open(f64),
    /// A leaf of the search (closed).
    Terminal(f64),
    /// The goal: the search stops.
    Goal,
}

/// The best plan found so far.
struct Best {
    plan: Vec<ActionId>,
    state: State,
    goal: bool,
    cost: u64,
    value: f64,
}

impl Best {
    fn beaten_by(&self, goal: bool, cost: u64, value: f64) -> bool {
        match (self.goal, goal) {
            (false, true) => true,
            (true, false) => false,
            (true, true) => cost < self.cost,
            (false, false) => value > self.value,
        }
    }
}

/// The boundary states along the current path (for cycle pruning), reusing their buffers.
struct PathStates {
    states: Vec<State>,
    depth: usize,
}

impl PathStates {
    fn reset(&mut self, root: &State) {
        self.depth = 0;
        self.push(root);
    }

    fn push(&mut self, state: &State) {
        if self.depth < self.states.len() {
            self.states[self.depth].clone_from(state);
        } else {
            self.states.push(state.clone());
        }
        self.depth += 1;
    }

    /// Whether the last state pushed equals an earlier one.
    fn last_repeats(&self) -> bool {
        let (last, earlier) = self.states[..self.depth].split_last().expect("the root state is always there");
        earlier.contains(last)
    }
}

/// What valuing a newly reached node needs besides the evaluator: the run's bookkeeping.
struct Arrivals<'a> {
    config: &'a DecodeConfig,
    states: PathStates,
    best: Best,
    prune_cycles: bool,
    /// With transposition pruning: the fewest actions any prefix reached each state with.
    reached: Option<FxHashMap<State, u32>>,
    dead_value: f64,
}

impl Arrivals<'_> {
    /// Values a node reached for the first time, after `event`: `None` inside an action (the
    /// rollout goes on), else the leaf it is.
    fn value(
        &mut self,
        model: &TransitionModel,
        evaluator: &mut Evaluator<'_>,
        cursor: &Cursor,
        event: Event,
        depth: usize,
    ) -> Option<Leaf> {
        let budget = &self.config.budget;
        let ended = match event {
            Event::Partial => {
                if depth >= budget.max_tokens {
                    return Some(Leaf::Terminal(evaluator.value(cursor.state(), cursor.plan().len()).unwrap_or(self.dead_value)));
                }
                return None;
            }
            Event::Invalid(_) => return Some(Leaf::Terminal(self.dead_value)),
            Event::Action => false,
            Event::End => true,
        };
        let state = cursor.state();
        let length = cursor.plan().len();
        if model.is_goal(state) {
            let reward = evaluator.config().goal_reward;
            let cost = transition_model::plan_cost(model.task(), cursor.plan());
            if self.best.beaten_by(true, cost, reward) {
                self.best = Best { plan: cursor.plan().to_vec(), state: state.clone(), goal: true, cost, value: reward };
            }
            return Some(if self.config.stop_at_goal { Leaf::Goal } else { Leaf::Terminal(reward) });
        }
        if !ended {
            // Transpositions and cycles are decided on the goal-relevant facts
            // ([`Evaluator::project`]): an action that changes only facts nothing reads leads
            // back to the state it left.
            let key = evaluator.project(state);
            let repeated = match self.reached.as_mut() {
                Some(reached) => match reached.get_mut(&key) {
                    Some(fewest) if *fewest as usize <= length => true,
                    Some(fewest) => {
                        *fewest = length as u32;
                        false
                    }
                    None => {
                        reached.insert(key, length as u32);
                        false
                    }
                },
                None if self.prune_cycles => {
                    self.states.push(&key);
                    self.states.last_repeats()
                }
                None => false,
            };
            if repeated {
                return Some(Leaf::Terminal(evaluator.value(state, length).unwrap_or(self.dead_value)));
            }
        }
        let Some(value) = evaluator.value(state, length) else { return Some(Leaf::Terminal(self.dead_value)) };
        if self.best.beaten_by(false, 0, value) {
            self.best = Best { plan: cursor.plan().to_vec(), state: state.clone(), goal: false, cost: 0, value };
        }
        Some(if ended || length >= budget.max_actions || depth >= budget.max_tokens { Leaf::Terminal(value) } else { Leaf::Open(value) })
    }
}

/// Token-level MCTS from `root` until the goal, the budget, or an exhausted tree.
pub(crate) fn run(stepper: &mut Stepper<'_>, session: &mut Session<'_>, root: Cursor, mcts: &MctsConfig) -> Result<Run, DecodeError> {
    let model = stepper.model;
    let config = session.config;
    let prompt = session.prompt;
    let budget = &config.budget;
    let start = root.state().clone();
    let finish =
        |best: &Best, stop| Run { plan: best.plan.clone(), end_state: best.state.clone(), invalid: None, stop, text: None, tree: None };
    let lambda = stepper.evaluator.config().length_penalty;
    let mut best = Best { plan: Vec::new(), state: start.clone(), goal: model.is_goal(&start), cost: 0, value: 0.0 };
    if best.goal {
        return Ok(finish(&best, StopReason::Goal));
    }
    let Some(h0) = stepper.evaluator.heuristic(&start) else {
        return Ok(finish(&best, StopReason::DeadEnd));
    };
    best.value = -h0;
    let dead_value = -(h0 + lambda * budget.max_actions as f64 + 1.0);
    let width = mcts.width.clamp(1, u16::MAX as usize);
    let prior_mix = mcts.prior_mix.clamp(0.0, 1.0) as f32;

    let mut tree = Tree::new(mcts);
    let mut sequence = prompt.to_vec();
    let mut path: Vec<usize> = Vec::new();
    // The path's states are kept only to close cycles without transposition pruning, which
    // closes them too.
    let path_cycles = mcts.prune_cycles && !mcts.prune_transpositions;
    let projected_start = stepper.evaluator.project(&start);
    let reached = mcts.prune_transpositions.then(|| FxHashMap::from_iter([(projected_start.clone(), 0)]));
    let mut arrivals = Arrivals {
        config,
        states: PathStates { states: Vec::new(), depth: 0 },
        best,
        prune_cycles: mcts.prune_cycles,
        reached,
        dead_value,
    };
    let stop = loop {
        if budget.simulations.is_some_and(|limit| session.stats.simulations >= limit) {
            break StopReason::Simulations;
        }
        if let Some(stop) = session.out_of_budget() {
            break stop;
        }
        if tree.nodes[0].closed() {
            break StopReason::Exhausted;
        }
        session.stats.simulations += 1;
        let mut cursor = root.clone();
        sequence.truncate(prompt.len());
        path.clear();
        path.push(0);
        arrivals.states.reset(&projected_start);

        // Selection: replay the tree's tokens while the nodes were visited before; a node
        // reached for the first time is valued on arrival.
        let mut arrived: Option<Leaf> = None;
        while tree.nodes[*path.last().expect("root")].expanded() {
            let Some(child) = tree.select(*path.last().expect("root"), mcts) else {
                // Not reached: a node with no open child is closed, and closed nodes are not
                // selected. Close it here all the same rather than expand it twice.
                arrived = Some(Leaf::Terminal(dead_value));
                break;
            };
            let token = tree.nodes[child].token;
            sequence.push(token);
            path.push(child);
            let event = stepper.advance(&mut cursor, token)?;
            if tree.nodes[child].visits == 0 {
                arrived = arrivals.value(model, &mut stepper.evaluator, &cursor, event, sequence.len() - prompt.len());
                break;
            }
            if event == Event::Action && path_cycles {
                arrivals.states.push(&stepper.evaluator.project(cursor.state()));
            }
        }

        // Expansion and rollout to the next action boundary.
        let mut steps = 0;
        let leaf = loop {
            if let Some(leaf) = arrived.take() {
                break leaf;
            }
            let node = *path.last().expect("root");
            let distribution = stepper.distribution(session.lm, &sequence, &cursor, width)?;
            tree.expand(node, &distribution.candidates, prior_mix);
            let Some(&(token, _)) = distribution.candidates.first() else { break Leaf::Terminal(dead_value) };
            let child = tree.nodes[node].first_child as usize;
            session.push(&mut sequence, token, distribution.forced);
            path.push(child);
            steps += 1;
            let event = stepper.advance(&mut cursor, token)?;
            arrived = arrivals.value(model, &mut stepper.evaluator, &cursor, event, sequence.len() - prompt.len());
            if arrived.is_none() && steps >= mcts.tokens_per_expansion {
                let value = stepper.evaluator.value(cursor.state(), cursor.plan().len());
                break value.map_or(Leaf::Terminal(dead_value), Leaf::Open);
            }
        };
        match leaf {
            Leaf::Goal => {
                // Counted in the tree for the summary: the search stops here.
                tree.backup(&path, stepper.evaluator.config().goal_reward);
                tree.close(&path);
                break StopReason::Goal;
            }
            Leaf::Open(value) => tree.backup(&path, value),
            Leaf::Terminal(value) => {
                tree.backup(&path, value);
                tree.close(&path);
            }
        }
    };
    session.stats.nodes = tree.nodes.len() as u64;
    let mut run = finish(&arrivals.best, stop);
    run.tree = Some(summarize(&tree, stepper, &root, &run.plan)?);
    Ok(run)
}

/// A branch of a summary level: the node that ends it, where the cursor stands there, and
/// what it wrote.
struct Branch {
    node: usize,
    cursor: Cursor,
    tokens: Vec<TokenId>,
    prior: f64,
    kind: RowKind,
}

/// The top of the tree (module documentation, **Summary**).
fn summarize(tree: &Tree, stepper: &mut Stepper<'_>, root: &Cursor, plan: &[ActionId]) -> Result<TreeSummary, DecodeError> {
    let (first, branches) = level(tree, stepper, 0, root, plan)?;
    let next = branches.into_iter().find(|b| b.kind == RowKind::Action && tree.visited_children(b.node).next().is_some());
    let second = match next {
        Some(branch) => Some(level(tree, stepper, branch.node, &branch.cursor, plan)?.0),
        None => None,
    };
    Ok(TreeSummary { visits: u64::from(tree.nodes[0].visits), backup: tree.backup, first, second })
}

/// The visited branches from `from` (where `cursor` stands) to the next action boundary, as a
/// level, and the branches themselves, most visited first (ties: the node made first).
fn level(
    tree: &Tree,
    stepper: &mut Stepper<'_>,
    from: usize,
    cursor: &Cursor,
    plan: &[ActionId],
) -> Result<(TreeLevel, Vec<Branch>), DecodeError> {
    let mut branches = Vec::new();
    let mut steps = 0;
    let mut truncated = false;
    // Depth first, the most visited child first, so that a level cut short keeps those.
    let mut stack = vec![(from, cursor.clone(), Vec::new(), 1.0)];
    'walk: while let Some((node, cursor, tokens, prior)) = stack.pop() {
        let mut children: Vec<usize> = tree.visited_children(node).collect();
        if children.is_empty() {
            if node != from {
                branches.push(Branch { node, cursor, tokens, prior, kind: RowKind::Partial });
            }
            continue;
        }
        children.sort_by_key(|&c| (tree.nodes[c].visits, std::cmp::Reverse(c)));
        for c in children {
            if steps == TreeSummary::STEPS {
                truncated = true;
                break 'walk;
            }
            steps += 1;
            let child = tree.nodes[c];
            let mut next = cursor.clone();
            let event = stepper.advance(&mut next, child.token)?;
            let mut tokens = tokens.clone();
            tokens.push(child.token);
            let prior = prior * f64::from(child.prior);
            let kind = match event {
                Event::Partial => {
                    stack.push((c, next, tokens, prior));
                    continue;
                }
                Event::Action => RowKind::Action,
                Event::End => RowKind::End,
                Event::Invalid(_) => RowKind::Invalid,
            };
            branches.push(Branch { node: c, cursor: next, tokens, prior, kind });
        }
    }
    branches.sort_by_key(|b| (std::cmp::Reverse(tree.nodes[b.node].visits), b.node));
    let base = cursor.plan().len();
    let rows = branches
        .iter()
        .take(TreeSummary::LISTED)
        .map(|b| {
            let node = &tree.nodes[b.node];
            let text = match b.kind {
                RowKind::Action => b.cursor.plan()[base..].iter().map(|&a| spell(stepper, a)).collect::<Vec<_>>().join("; "),
                RowKind::End | RowKind::Invalid | RowKind::Partial => {
                    String::from_utf8_lossy(&stepper.vocab.decode(&b.tokens)).trim().to_string()
                }
            };
            TreeRow {
                text,
                kind: b.kind,
                tokens: b.tokens.len(),
                visits: u64::from(node.visits),
                value: tree.raw(node),
                prior: b.prior,
                on_plan: b.kind == RowKind::Action && plan.starts_with(b.cursor.plan()),
                closed: node.closed(),
            }
        })
        .collect();
    let rest = branches.get(TreeSummary::LISTED..).unwrap_or_default();
    let level = TreeLevel {
        after: cursor.plan().iter().map(|&a| spell(stepper, a)).collect(),
        visits: u64::from(tree.nodes[from].visits),
        rows,
        omitted: rest.len(),
        omitted_visits: rest.iter().map(|b| u64::from(tree.nodes[b.node].visits)).sum(),
        truncated,
    };
    Ok((level, branches))
}

/// An action's line as the model writes it.
fn spell(stepper: &Stepper<'_>, action: ActionId) -> String {
    let spelling = stepper.languages.bytes.spelling();
    spelling.spell(action).map_or_else(|| stepper.model.task().action_name(action), str::to_string)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Selections at the root (each backed up with -1) before PUCB selects `token`'s child,
    /// at most `limit`; a closed child is never selected.
    fn selections_until(tree: &mut Tree, config: &MctsConfig, token: TokenId, limit: u32) -> Option<u32> {
        for visit in 0..limit {
            let child = tree.select(0, config).expect("an open child");
            assert!(!tree.nodes[child].closed(), "a closed child is never selected");
            if tree.nodes[child].token == token {
                return Some(visit);
            }
            tree.backup(&[0, child], -1.0);
        }
        None
    }

    /// Visits to the root, all valued alike, before PUCB first selects the unlikely child.
    fn visits_until_unlikely_child(prior_mix: f32) -> Option<u32> {
        let config = MctsConfig::default();
        let mut tree = Tree::new(&config);
        tree.expand(0, &[(1, 0.999), (2, 0.001)], prior_mix);
        selections_until(&mut tree, &config, 2, 100_000)
    }

    #[test]
    fn the_prior_mix_blends_in_the_uniform_over_the_children() {
        let config = MctsConfig::default();
        let mut tree = Tree::new(&config);
        tree.expand(0, &[(7, 0.75), (8, 0.25)], 0.5);
        let priors: Vec<f32> = tree.nodes[1..].iter().map(|n| n.prior).collect();
        assert_eq!(priors, [0.625, 0.375]);
        let mut unmixed = Tree::new(&config);
        unmixed.expand(0, &[(7, 0.75), (8, 0.25)], 0.0);
        assert_eq!(unmixed.nodes[2].prior, 0.25, "no mix keeps the model's prior");
    }

    /// Selections at the root before PUCB returns to its worse-valued open child, once the
    /// child the model was sure of is closed: the model's 95% token closed, the best-valued
    /// open child (4%) and a worse one (1%) visited once each.
    fn selections_until_worse_child_again(renormalize_prior: bool) -> Option<u32> {
        let config = MctsConfig { renormalize_prior, ..MctsConfig::default() };
        let mut tree = Tree::new(&config);
        tree.expand(0, &[(1, 0.95), (2, 0.04), (3, 0.01)], 0.0);
        tree.backup(&[0, 1], -1.0);
        tree.close(&[0, 1]);
        tree.backup(&[0, 2], -1.0);
        tree.backup(&[0, 3], -2.0);
        selections_until(&mut tree, &config, 3, 1_000_000)
    }

    #[test]
    fn a_closed_childs_prior_goes_to_its_open_siblings_when_renormalised() {
        // The open children's priors are 0.8 and 0.2 of what is left, twenty times the 0.01
        // the worse child keeps otherwise: its exploration term outweighs its value gap after
        // tens of selections instead of hundreds.
        let kept = selections_until_worse_child_again(false).expect("selected eventually");
        let renormalised = selections_until_worse_child_again(true).expect("selected");
        assert!(kept > 20 * renormalised.max(1), "{kept} vs {renormalised}");
        // All priors zero: uniform over the open children.
        let config = MctsConfig { renormalize_prior: true, ..MctsConfig::default() };
        let mut tree = Tree::new(&config);
        tree.expand(0, &[(1, 0.0), (2, 0.0)], 0.0);
        tree.backup(&[0, 1], -1.0);
        assert_eq!(tree.select(0, &config), Some(2), "the unvisited child, by its uniform prior");
    }

    #[test]
    fn a_prior_mix_bounds_the_wait_for_an_unlikely_token() {
        // The model's prior alone: the 0.1% child waits for hundreds of visits to its sibling.
        let alone = visits_until_unlikely_child(0.0).expect("visited eventually");
        let mixed = visits_until_unlikely_child(0.25).expect("visited");
        assert!(alone > 300, "{alone}");
        assert!(mixed < 10, "{mixed}");
    }
}
