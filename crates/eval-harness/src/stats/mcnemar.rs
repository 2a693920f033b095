//! The exact two-sided McNemar test on paired binary outcomes (Appendix B, "Paired Significance
//! Testing"; Tables 9-10).
//!
//! Of the tasks two conditions disagree on, b are solved by the first only and c by the second
//! only. Under the null hypothesis each discordant task is the first's with probability 1/2, so
//! b ~ Binomial(b + c, 1/2), and the two-sided p-value is
//! p = min(1, 2 · P(X ≤ min(b, c))), X ~ Binomial(b + c, 1/2); p = 1 when b + c = 0.
//! At probability 1/2 the binomial is symmetric, so this doubling equals scipy's
//! `binomtest(b, b + c, 0.5).pvalue` (the sum of all outcomes no more likely than b), which
//! `tests/reference.rs` checks.

use super::StatsError;

/// An exact McNemar test on one pairing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct McNemar {
    /// b: tasks the first condition solves and the second does not.
    pub first_only: u64,
    /// c: tasks the second condition solves and the first does not.
    pub second_only: u64,
    /// The exact two-sided p-value, [`mcnemar_exact_p`]`(b, c)`.
    pub p_value: f64,
}

/// The exact two-sided McNemar p-value from the discordant counts b and c:
/// min(1, 2 · Σ_{i ≤ min(b, c)} C(b + c, i) / 2^(b + c)), and 1 when b + c = 0.
///
/// Symmetric in b and c, and in (0, 1] wherever the true value is within f64's range (see
/// below). Computed in floating point without logarithms:
/// P(X = k) for k = min(b, c) as the product Π_{j<k} (n - j)/(j + 1) with the factor 2^-n kept
/// as a separate binary exponent (rescaling by powers of two is exact), times the sum of the
/// ratios P(X = i)/P(X = k) for i ≤ k (each at most 1, so nothing overflows). The relative
/// error is a few units in the last place per term, below 1e-12 for n up to several thousand
/// (checked against exact rationals). Cost O(min(b, c)).
///
/// A p-value below f64's smallest subnormal (about 4.9e-324; e.g. b = 0, c > 1,074) rounds to
/// 0.0; from about 2.2e-308 down it has fewer significant bits.
pub fn mcnemar_exact_p(b: u32, c: u32) -> f64 {
    let n = u64::from(b) + u64::from(c);
    if n == 0 {
        return 1.0;
    }
    let k = u64::from(b.min(c));

    // P(X = k) = mantissa · 2^exponent.
    let mut mantissa = 1.0_f64;
    // n < 2^33: exact as i64 and as f64.
    let mut exponent = -(n as i64);
    for j in 0..k {
        mantissa = mantissa * (n - j) as f64 / (j + 1) as f64;
        if mantissa > TWO_TO_512 {
            mantissa /= TWO_TO_512;
            exponent += 512;
        }
    }

    // Σ_{i ≤ k} P(X = i) / P(X = k), smallest terms last; each ratio P(i-1)/P(i) = i/(n-i+1) < 1.
    let mut ratio = 1.0_f64;
    let mut tail = 1.0_f64;
    for i in (1..=k).rev() {
        ratio = ratio * i as f64 / (n - i + 1) as f64;
        if ratio == 0.0 {
            break;
        }
        tail += ratio;
    }

    let doubled = scale_by_power_of_two(2.0 * tail * mantissa, exponent);
    doubled.min(1.0)
}

/// The exact McNemar test on two conditions' outcomes on the same tasks (`first[t]`: the first
/// condition solved task t).
///
/// Errors: the two differ in length ([`StatsError::LengthMismatch`]) or are empty
/// ([`StatsError::TooFewValues`]); more than `u32::MAX` discordant tasks on one side
/// ([`StatsError::TooManyTasks`]).
pub fn mcnemar_exact(first: &[bool], second: &[bool]) -> Result<McNemar, StatsError> {
    const WHAT: &str = "McNemar";
    if first.len() != second.len() {
        return Err(StatsError::LengthMismatch { what: WHAT, expected: first.len(), found: second.len() });
    }
    if first.is_empty() {
        return Err(StatsError::TooFewValues { what: WHAT, needed: 1, found: 0 });
    }
    let first_only = first.iter().zip(second).filter(|&(&a, &b)| a && !b).count();
    let second_only = first.iter().zip(second).filter(|&(&a, &b)| !a && b).count();
    let b = u32::try_from(first_only).map_err(|_| StatsError::TooManyTasks { what: WHAT, tasks: first_only })?;
    let c = u32::try_from(second_only).map_err(|_| StatsError::TooManyTasks { what: WHAT, tasks: second_only })?;
    Ok(McNemar { first_only: u64::from(b), second_only: u64::from(c), p_value: mcnemar_exact_p(b, c) })
}

/// The conservative McNemar test of a condition run once against one run several times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct McNemarOverRuns {
    /// Index of the run whose pairing has the largest p-value (the first such run on ties).
    pub run: usize,
    /// That pairing's test; its `p_value` is the one to correct with Holm.
    pub test: McNemar,
}

/// The paper's test against a stochastic condition: pair `reference` (a deterministic
/// condition's outcomes per task) with each of the stochastic condition's `runs` separately
/// and keep the largest p-value ("yielding a conservative test across runs"). `reference` is
/// the first condition of every pairing.
///
/// Errors: no runs ([`StatsError::TooFewValues`]); those of [`mcnemar_exact`] for any run.
pub fn mcnemar_exact_max_p_over_runs<R: AsRef<[bool]>>(reference: &[bool], runs: &[R]) -> Result<McNemarOverRuns, StatsError> {
    let mut best: Option<McNemarOverRuns> = None;
    for (run, outcomes) in runs.iter().enumerate() {
        let test = mcnemar_exact(reference, outcomes.as_ref())?;
        if best.is_none_or(|best| test.p_value > best.test.p_value) {
            best = Some(McNemarOverRuns { run, test });
        }
    }
    best.ok_or(StatsError::TooFewValues { what: "McNemar over runs", needed: 1, found: 0 })
}

const TWO_TO_512: f64 = f64::from_bits((512 + 1023) << 52);

/// x · 2^exponent, exact unless the result is subnormal or out of range (rounded once there).
fn scale_by_power_of_two(mut x: f64, mut exponent: i64) -> f64 {
    while exponent != 0 && x != 0.0 && x.is_finite() {
        let step = exponent.clamp(-1022, 1023);
        // 2^step for step in [-1022, 1023] is a normal f64: biased exponent step + 1023, zero mantissa.
        x *= f64::from_bits(((step + 1023) as u64) << 52);
        exponent -= step;
    }
    x
}
