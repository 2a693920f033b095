//! Planning heuristics and classical search on [`transition_model`] states.
//!
//! Heuristics: [`Blind`], [`GoalCount`], [`HMax`], [`HAdd`], [`HFF`] (with its relaxed plan
//! and preferred operators), [`LmCut`] (charging conditional effects apart, or admissibly:
//! [`LmCut::admissible`]), [`RemainingPlanCost`], and a [`WeightedMix`] of any of
//! them, as the paper's MCTS value uses. All take every goal the grounder produces, and all but
//! [`GoalCount`] (unmet goal literals, costs aside) honour action costs: the delete relaxation
//! ([`relaxed`]) compiles the goal — a disjunction of conditions — into one auxiliary goal
//! fact reached by zero-cost operators, one per disjunct, as Fast Downward compiles complex
//! goals. h_max, h_add, h_FF and LM-cut keep their buffers between calls: evaluating
//! allocates nothing ([`GoalCount`] collects each disjunct's unmet literals,
//! [`RemainingPlanCost`] runs a search, [`Memo`] keeps each new state). `None` is a dead end
//! (h = ∞).
//!
//! Search ([`search`]): A*, eager and lazy greedy best-first search with optional
//! preferred operators, over a compact [`search::StateRegistry`].
//!
//! ```
//! use heuristics::{Heuristic, LmCut, search::{search, Algorithm, SearchConfig, SearchStatus}};
//! let domain = pddl_syntax::parse_domain("(define (domain d) (:predicates (at ?x) (road ?x ?y))
//!     (:action go :parameters (?x ?y) :precondition (and (at ?x) (road ?x ?y)) :effect (and (at ?y) (not (at ?x)))))").unwrap();
//! let problem = pddl_syntax::parse_problem("(define (problem p) (:domain d) (:objects a b c)
//!     (:init (at a) (road a b) (road b c)) (:goal (at c)))").unwrap();
//! let model = transition_model::TransitionModel::new(grounding::ground(&domain, &problem).unwrap());
//! let mut lmcut = LmCut::new(&model);
//! assert_eq!(lmcut.evaluate(&model.initial_state()), Some(2));
//! let result = search(&model, &mut lmcut, &SearchConfig::new(Algorithm::AStar), None);
//! assert_eq!((result.status, result.cost), (SearchStatus::Solved, 2));
//! ```

mod lmcut;
mod memo;
mod mix;
pub mod relaxation;
pub mod relaxed;
mod remaining;
pub mod search;
mod simple;

pub use lmcut::LmCut;
pub use memo::Memo;
pub use mix::WeightedMix;
pub use relaxation::{HAdd, HFF, HMax};
pub use remaining::RemainingPlanCost;
pub use simple::{Blind, GoalCount};

/// The model and states every heuristic and search takes, and the ids of plans: a user needs
/// no direct dependency on `transition-model` or `grounding` to name them.
pub use transition_model::{ActionId, State, TransitionModel};

/// The value of an unreachable fact inside the explorations; never returned (dead ends are `None`).
pub const INFINITE: u32 = u32::MAX;

/// A state evaluator. Implementations keep their buffers between calls.
pub trait Heuristic {
    /// Short name, as on the command line (`hmax`, `ff`, `lmcut`, ...).
    fn name(&self) -> &'static str;

    /// The estimated cost to the goal from `state`, or `None` for a dead end.
    fn evaluate(&mut self, state: &State) -> Option<u32>;

    /// Actions the last evaluation recommends (applicable in the evaluated state).
    fn preferred_operators(&self) -> &[ActionId] {
        &[]
    }
}

impl<H: Heuristic + ?Sized> Heuristic for Box<H> {
    fn name(&self) -> &'static str {
        (**self).name()
    }

    fn evaluate(&mut self, state: &State) -> Option<u32> {
        (**self).evaluate(state)
    }

    fn preferred_operators(&self) -> &[ActionId] {
        (**self).preferred_operators()
    }
}

/// The heuristics by command-line name (`blind`, `goalcount`, `hmax`, `hadd`, `ff`, `lmcut`,
/// `lmcut-admissible`): the names are the variants' (`FromStr`, `Into<&str>`,
/// [`strum::VariantNames`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, strum::EnumString, strum::IntoStaticStr, strum::VariantNames, strum::VariantArray)]
#[strum(serialize_all = "lowercase", parse_err_ty = UnknownName, parse_err_fn = HeuristicName::unknown)]
pub enum HeuristicName {
    /// [`Blind`], `blind`.
    Blind,
    /// [`GoalCount`], `goalcount`.
    Goalcount,
    /// [`HMax`], `hmax`.
    Hmax,
    /// [`HAdd`], `hadd`.
    Hadd,
    /// [`HFF`], `ff`.
    Ff,
    /// [`LmCut::new`], `lmcut`: not admissible with conditional effects (they are charged
    /// apart; see [`LmCut`]).
    Lmcut,
    /// [`LmCut::admissible`], `lmcut-admissible`: conditional effects of one action share its
    /// cost; the same as `lmcut` without them.
    #[strum(serialize = "lmcut-admissible")]
    LmcutAdmissible,
}

impl HeuristicName {
    fn unknown(given: &str) -> UnknownName {
        UnknownName::of::<HeuristicName>("heuristic", given)
    }

    /// The command-line name (`blind`, `goalcount`, `hmax`, `hadd`, `ff`, `lmcut`,
    /// `lmcut-admissible`), which is also what the built heuristic's [`Heuristic::name`]
    /// returns.
    pub fn name(self) -> &'static str {
        self.into()
    }

    /// The heuristic on `model`.
    pub fn build<'m>(self, model: &'m transition_model::TransitionModel) -> Box<dyn Heuristic + 'm> {
        match self {
            HeuristicName::Blind => Box::new(Blind::new(model)),
            HeuristicName::Goalcount => Box::new(GoalCount::new(model)),
            HeuristicName::Hmax => Box::new(HMax::new(model)),
            HeuristicName::Hadd => Box::new(HAdd::new(model)),
            HeuristicName::Ff => Box::new(HFF::new(model)),
            HeuristicName::Lmcut => Box::new(LmCut::new(model)),
            HeuristicName::LmcutAdmissible => Box::new(LmCut::admissible(model)),
        }
    }
}

/// The error of [`HeuristicName`]'s, [`search::Algorithm`]'s and [`search::Clock`]'s
/// [`FromStr`](std::str::FromStr): the name given and the names there are.
pub use transition_model::UnknownName;

/// The heuristics' command-line names, in [`HeuristicName`]'s order.
pub const NAMES: &[&str] = <HeuristicName as strum::VariantNames>::VARIANTS;

/// A heuristic by its command-line name.
pub fn by_name<'m>(name: &str, model: &'m transition_model::TransitionModel) -> Option<Box<dyn Heuristic + 'm>> {
    name.parse::<HeuristicName>().ok().map(|h| h.build(model))
}
