//! Mean and sample standard deviation over repeated runs of one condition (Appendix B,
//! "Multiple Runs"; Table 7's "accuracy ± sd").

use super::{StatsError, check_finite};

/// The arithmetic mean of `values`.
///
/// Computed as sum / n and then corrected by the mean residual, so that n equal values have
/// exactly that value as their mean (a plain sum / n can be one unit in the last place off,
/// which would give equal runs a tiny non-zero standard deviation).
///
/// Errors: no values ([`StatsError::TooFewValues`]); a NaN or infinite value
/// ([`StatsError::NotFinite`]); a mean beyond `f64` ([`StatsError::Overflow`]).
pub fn mean(values: &[f64]) -> Result<f64, StatsError> {
    check("mean", values, 1)?;
    finite("mean", corrected_mean(values))
}

/// The sample standard deviation of `values`, with divisor n - 1 (numpy's `std(ddof=1)`).
///
/// Two passes: the residuals from the [`mean`], then sqrt((Σd² - (Σd)²/n) / (n - 1)) (the
/// second term cancels the mean's rounding error). Equal values give exactly 0.
///
/// Errors: fewer than two values ([`StatsError::TooFewValues`]: one run has no sample
/// standard deviation); a NaN or infinite value ([`StatsError::NotFinite`]); residuals beyond
/// `f64` ([`StatsError::Overflow`], only for values near `f64::MAX`).
pub fn sample_std_dev(values: &[f64]) -> Result<f64, StatsError> {
    check("sample standard deviation", values, 2)?;
    let mean = corrected_mean(values);
    let n = values.len() as f64;
    let (sum, sum_of_squares) = values.iter().fold((0.0, 0.0), |(sum, squares), value| {
        let residual = value - mean;
        (sum + residual, squares + residual * residual)
    });
    let variance = ((sum_of_squares - sum * sum / n) / (n - 1.0)).max(0.0);
    finite("sample standard deviation", variance.sqrt())
}

/// Mean and sample standard deviation of one condition's runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSummary {
    /// How many runs.
    pub runs: usize,
    /// Their mean.
    pub mean: f64,
    /// Their sample standard deviation (divisor n - 1); `None` for a single run (a
    /// deterministic condition, which the paper prints as ± 0.0).
    pub sample_std_dev: Option<f64>,
}

/// [`mean`] and, from two runs on, [`sample_std_dev`] of one condition's per-run values
/// (e.g. its success rate under seeds 0, 42 and 1738).
///
/// Errors: those of [`mean`] and [`sample_std_dev`].
pub fn summarize_runs(values: &[f64]) -> Result<RunSummary, StatsError> {
    let mean = mean(values)?;
    let sample_std_dev = if values.len() >= 2 { Some(sample_std_dev(values)?) } else { None };
    Ok(RunSummary { runs: values.len(), mean, sample_std_dev })
}

fn check(what: &'static str, values: &[f64], needed: usize) -> Result<(), StatsError> {
    if values.len() < needed {
        return Err(StatsError::TooFewValues { what, needed, found: values.len() });
    }
    check_finite(what, values.iter().copied())
}

fn finite(what: &'static str, result: f64) -> Result<f64, StatsError> {
    if result.is_finite() { Ok(result) } else { Err(StatsError::Overflow { what }) }
}

/// sum / n, plus the mean of the residuals from it. `values` is non-empty and finite.
fn corrected_mean(values: &[f64]) -> f64 {
    let n = values.len() as f64;
    let first = values.iter().sum::<f64>() / n;
    // A sum of finite values can still overflow; the correction would then be NaN.
    if !first.is_finite() {
        return values.iter().map(|value| value / n).sum();
    }
    first + values.iter().map(|value| value - first).sum::<f64>() / n
}
