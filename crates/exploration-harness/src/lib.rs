//! Phase I of the paper's agent (§3.1): from the benchmark's own goal annotation and what the
//! environment shows, a grounded initial state for Phase II.
//!
//! Built so far: [`goal`], the fixed, rule-based parse of each benchmark's goal annotation
//! into G at class level (never an instance identifier), and [`ontology`], F_str, the fixed
//! class-level ontology of each benchmark (committed in `fixtures/ontology/`), and
//! [`evidence`], the evidence update U with ALFWorld's perceiver. The controller H, the policy f_φ,
//! the evidence update U, Ready and the binding β are the next parts of this crate.

pub mod alfworld;
pub mod evidence;
pub mod goal;
pub mod ontology;

pub use evidence::{Belief, Fact, Percept, perceive_alfworld};
pub use goal::{ClassGoal, ClassLiteral, GoalError, Symbol, parse_goal};
pub use ontology::{Ontology, OntologyError};
