//! The statistics of the paper's Appendix B, written out by hand: each is a few lines of
//! arithmetic, and no Rust crate computes exactly these with these conventions (the
//! task-cluster resampling, numpy's percentile interpolation, McNemar's exact two-sided
//! p-value from an exact binomial tail, Holm's adjusted p-values as statsmodels reports them).
//!
//! - [`mean`], [`sample_std_dev`], [`summarize_runs`]: the mean and the sample standard
//!   deviation (divisor n - 1) over repeated runs of one condition, e.g. the success rates of
//!   seeds 0, 42 and 1738 (Table 7: "accuracy ± sd"). A deterministic condition runs once and
//!   has no sample standard deviation; the paper prints it as ± 0.0.
//! - [`task_cluster_bootstrap`]: the percentile interval from resampling tasks with
//!   replacement, each task's runs kept together (Table 7's 95% intervals, 10,000 replicates);
//!   seeded ChaCha8, so a run is reproducible on every platform. [`percentile`] is numpy's
//!   default (`method="linear"`) percentile, the convention of the interval's end points.
//! - [`mcnemar_exact_p`], [`mcnemar_exact`], [`mcnemar_exact_max_p_over_runs`]: the exact
//!   two-sided McNemar test on paired binary outcomes, and its conservative form against a
//!   stochastic condition (the largest p-value over the runs) (Tables 9-10).
//! - [`holm_adjust`]: Holm's step-down adjusted p-values of one family of tests.
//!
//! Every function checks its input and returns a [`StatsError`] rather than panicking or
//! returning NaN. `tests/reference.rs` checks the values against numpy, scipy and statsmodels
//! (`tools/stats_reference.py` writes `tests/fixtures/stats_reference.json`).

mod bootstrap;
mod holm;
mod mcnemar;
mod runs;

pub use bootstrap::{BootstrapConfig, BootstrapInterval, percentile, task_cluster_bootstrap};
pub use holm::holm_adjust;
pub use mcnemar::{McNemar, McNemarOverRuns, mcnemar_exact, mcnemar_exact_max_p_over_runs, mcnemar_exact_p};
pub use runs::{RunSummary, mean, sample_std_dev, summarize_runs};

/// Why a statistic could not be computed from its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StatsError {
    /// Too few values: the mean needs one, the sample standard deviation two.
    #[error("{what}: {found} value(s), at least {needed} needed")]
    TooFewValues {
        /// The statistic asked for.
        what: &'static str,
        /// The fewest values it takes.
        needed: usize,
        /// The values given.
        found: usize,
    },
    /// A value is NaN or infinite.
    #[error("{what}: value {index} is {value}, not a finite number")]
    NotFinite {
        /// The statistic asked for.
        what: &'static str,
        /// The value's position, 0-based (for the bootstrap, counted over all runs in task order).
        index: usize,
        /// The value.
        value: f64,
    },
    /// A task in the bootstrap input has no runs; every task needs at least one outcome.
    #[error("bootstrap: task {task} has no runs; give every task at least one outcome")]
    EmptyTask {
        /// The task's position in the input, 0-based.
        task: usize,
    },
    /// Two sequences that must be paired element by element differ in length.
    #[error("{what}: lengths differ ({expected} and {found}); paired outcomes need one entry per task on both sides")]
    LengthMismatch {
        /// The statistic asked for.
        what: &'static str,
        /// The length of the first sequence.
        expected: usize,
        /// The length of the second sequence.
        found: usize,
    },
    /// A p-value outside [0, 1] (or NaN).
    #[error("p-value {index} is {value}; p-values lie in [0, 1]")]
    InvalidPValue {
        /// The p-value's position in the family, 0-based.
        index: usize,
        /// The p-value.
        value: f64,
    },
    /// A percent outside [0, 100] (or NaN).
    #[error("percentile: {0} is not a percent in [0, 100]")]
    InvalidPercent(f64),
    /// A confidence level not strictly between 0 and 1.
    #[error("bootstrap: confidence level {0} must lie strictly between 0 and 1 (0.95 for a 95% interval)")]
    InvalidConfidence(f64),
    /// Zero replicates, or more than fit in memory.
    #[error("bootstrap: {0} replicates; use at least 1 and few enough to hold in memory (the paper uses 10,000)")]
    InvalidReplicates(usize),
    /// The result is beyond the range of `f64` (values near `f64::MAX`).
    #[error("{what}: the result overflows f64; rescale the values")]
    Overflow {
        /// The statistic asked for.
        what: &'static str,
    },
    /// More tasks than the 32-bit counts hold (2^32 - 1).
    #[error("{what}: {tasks} tasks; at most 2^32 - 1 are supported")]
    TooManyTasks {
        /// The statistic asked for.
        what: &'static str,
        /// The task count that does not fit (for McNemar, the discordant tasks on one side).
        tasks: usize,
    },
}

/// The first value of `values` that is NaN or infinite, as an error.
fn check_finite(what: &'static str, values: impl IntoIterator<Item = f64>) -> Result<(), StatsError> {
    match values.into_iter().enumerate().find(|(_, value)| !value.is_finite()) {
        Some((index, value)) => Err(StatsError::NotFinite { what, index, value }),
        None => Ok(()),
    }
}
