//! The percentile task-cluster bootstrap (Appendix B, "Multiple Runs"; Table 7's intervals).
//!
//! A replicate draws as many task indices as there are tasks, uniformly with replacement, and
//! takes every run of each drawn task: the runs of one task (seeds 0, 42 and 1738) stay
//! together, which keeps their dependence in the interval. The replicate's statistic is the
//! mean outcome over all runs of the drawn tasks. With the same number of runs per task this
//! is the mean over runs of each run's success rate on the drawn tasks, the paper's "same
//! indices applied to all three runs".

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{StatsError, check_finite};

/// How to bootstrap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BootstrapConfig {
    /// Number of bootstrap replicates (the paper: 10,000).
    pub replicates: usize,
    /// Confidence level of the two-sided interval, strictly between 0 and 1 (the paper: 0.95).
    pub confidence: f64,
    /// Seed of the ChaCha8 stream that draws the task indices; report it with the interval.
    pub seed: u64,
}

impl BootstrapConfig {
    /// The paper's settings: 10,000 replicates, a 95% interval; seed 0.
    pub const PAPER: Self = Self { replicates: 10_000, confidence: 0.95, seed: 0 };
}

impl Default for BootstrapConfig {
    fn default() -> Self {
        Self::PAPER
    }
}

/// A point estimate and its percentile bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BootstrapInterval {
    /// The statistic on the tasks as given: the mean outcome over all runs of all tasks.
    pub estimate: f64,
    /// The lower end: the (1 - confidence) / 2 percentile of the replicates.
    pub lower: f64,
    /// The upper end: the (1 + confidence) / 2 percentile of the replicates.
    pub upper: f64,
    /// The confidence level.
    pub confidence: f64,
    /// The number of replicates.
    pub replicates: usize,
}

/// The percentile task-cluster bootstrap interval of the mean outcome.
///
/// `tasks[t]` holds task t's run outcomes (1.0 for a success, 0.0 for a failure, or any finite
/// value); tasks may have different numbers of runs. Each of `config.replicates` replicates
/// draws `tasks.len()` task indices with replacement (index i as
/// `rng.random_range(0..n as u32)` from `ChaCha8Rng::seed_from_u64(config.seed)`, one stream
/// per call) and computes Σ (sum of the drawn tasks' outcomes) / Σ (their run counts).
///
/// **Percentile convention:** the interval's ends are numpy's default percentile
/// (`np.percentile(replicates, [2.5, 97.5])`, `method="linear"`, Hyndman and Fan's type 7) of
/// the replicate values at 50 (1 - confidence) and 50 (1 + confidence) percent; see
/// [`percentile`]. With 10,000 replicates the 2.5% end lies between the 250th and 251st
/// smallest replicate, 97.5% of the way to the 251st.
///
/// The interval lies within [smallest task mean, largest task mean], since every replicate is
/// a weighted mean of task means (exactly for 0/1 outcomes, whose sums are exact; up to
/// rounding for other values). It usually contains the estimate (the
/// replicates are centred on it), but the percentile method does not guarantee that.
///
/// Errors: no tasks ([`StatsError::TooFewValues`]); a task without runs
/// ([`StatsError::EmptyTask`]); a NaN or infinite outcome ([`StatsError::NotFinite`], its index
/// counted over all runs in task order); a confidence level outside (0, 1)
/// ([`StatsError::InvalidConfidence`]); zero replicates or more than memory holds
/// ([`StatsError::InvalidReplicates`]); more than `u32::MAX` tasks
/// ([`StatsError::TooManyTasks`]); sums beyond `f64` ([`StatsError::Overflow`]).
pub fn task_cluster_bootstrap<T: AsRef<[f64]>>(tasks: &[T], config: &BootstrapConfig) -> Result<BootstrapInterval, StatsError> {
    const WHAT: &str = "bootstrap";
    if tasks.is_empty() {
        return Err(StatsError::TooFewValues { what: WHAT, needed: 1, found: 0 });
    }
    let task_count = u32::try_from(tasks.len()).map_err(|_| StatsError::TooManyTasks { what: WHAT, tasks: tasks.len() })?;
    if let Some(task) = tasks.iter().position(|runs| runs.as_ref().is_empty()) {
        return Err(StatsError::EmptyTask { task });
    }
    check_finite(WHAT, tasks.iter().flat_map(|runs| runs.as_ref().iter().copied()))?;
    if !(config.confidence > 0.0 && config.confidence < 1.0) {
        return Err(StatsError::InvalidConfidence(config.confidence));
    }
    let mut replicates = Vec::new();
    if config.replicates == 0 || replicates.try_reserve_exact(config.replicates).is_err() {
        return Err(StatsError::InvalidReplicates(config.replicates));
    }

    // Per task: the sum of its outcomes and its run count (exact in f64 below 2^53 runs).
    let sums: Vec<f64> = tasks.iter().map(|runs| runs.as_ref().iter().sum()).collect();
    let counts: Vec<f64> = tasks.iter().map(|runs| runs.as_ref().len() as f64).collect();
    let estimate = sums.iter().sum::<f64>() / counts.iter().sum::<f64>();
    if !estimate.is_finite() {
        return Err(StatsError::Overflow { what: WHAT });
    }

    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    for _ in 0..config.replicates {
        let (mut sum, mut count) = (0.0, 0.0);
        for _ in 0..task_count {
            let task = rng.random_range(0..task_count) as usize;
            sum += sums[task];
            count += counts[task];
        }
        replicates.push(sum / count);
    }
    if replicates.iter().any(|value| !value.is_finite()) {
        return Err(StatsError::Overflow { what: WHAT });
    }
    replicates.sort_by(f64::total_cmp);

    // 100 · 0.95 is exactly 95.0 in f64, so the paper's ends are exactly 2.5 and 97.5.
    let outside = 100.0 - 100.0 * config.confidence;
    let lower = percentile_of_sorted(&replicates, outside / 2.0);
    let upper = percentile_of_sorted(&replicates, 100.0 - outside / 2.0);
    Ok(BootstrapInterval { estimate, lower, upper, confidence: config.confidence, replicates: config.replicates })
}

/// The `percent` percentile of `values`, as numpy's `np.percentile(values, percent)` computes
/// it by default (`method="linear"`, Hyndman and Fan's type 7): with the values sorted
/// ascending as x₀ ≤ … ≤ x₍ₙ₋₁₎, the virtual index h = (n - 1) · percent / 100 and the value
/// x⌊h⌋ + (h - ⌊h⌋) (x⌊h⌋₊₁ - x⌊h⌋). The interpolation is numpy's `_lerp`, step for step, so
/// results agree with numpy to the last bit.
///
/// Errors: no values ([`StatsError::TooFewValues`]); a NaN or infinite value
/// ([`StatsError::NotFinite`]); `percent` outside [0, 100] ([`StatsError::InvalidPercent`]).
pub fn percentile(values: &[f64], percent: f64) -> Result<f64, StatsError> {
    const WHAT: &str = "percentile";
    if values.is_empty() {
        return Err(StatsError::TooFewValues { what: WHAT, needed: 1, found: 0 });
    }
    check_finite(WHAT, values.iter().copied())?;
    if !(0.0..=100.0).contains(&percent) {
        return Err(StatsError::InvalidPercent(percent));
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    Ok(percentile_of_sorted(&sorted, percent))
}

/// [`percentile`] of values sorted ascending; `sorted` is non-empty, `percent` in [0, 100].
fn percentile_of_sorted(sorted: &[f64], percent: f64) -> f64 {
    let last = sorted.len() - 1;
    let virtual_index = last as f64 * (percent / 100.0);
    if virtual_index >= last as f64 {
        return sorted[last];
    }
    let below = virtual_index.floor();
    let gamma = virtual_index - below;
    // `below` is in [0, last): the cast is exact.
    let (a, b) = (sorted[below as usize], sorted[below as usize + 1]);
    let difference = b - a;
    if gamma >= 0.5 { b - difference * (1.0 - gamma) } else { a + difference * gamma }
}
