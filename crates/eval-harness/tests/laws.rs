//! Laws of the tests and summaries, property-tested: Holm's adjusted p-values against the raw
//! ones, McNemar's p-value against exact integer arithmetic, its symmetry and its monotonicity,
//! the conservative pairing over runs, the mean and standard deviation's bounds.

use eval_harness::stats::{holm_adjust, mcnemar_exact, mcnemar_exact_max_p_over_runs, mcnemar_exact_p, mean, sample_std_dev};
use proptest::prelude::*;

fn config(cases: u32, seed: u64) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(seed),
        failure_persistence: Some(Box::new(proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    }
}

/// p-values in [0, 1], often tied or at the ends.
fn p_value() -> impl Strategy<Value = f64> {
    prop_oneof![3 => 0.0f64..=1.0, 1 => prop::sample::select(vec![0.0, 1e-12, 0.01, 0.05, 0.5, 1.0])]
}

/// min(1, 2 · Σ_{i ≤ min(b, c)} C(n, i) / 2^n) in exact integers, rounded once (n ≤ 120, so
/// every sum fits in a u128 and 2^-n is a normal f64).
fn exact_mcnemar(b: u32, c: u32) -> f64 {
    let n = b + c;
    if n == 0 {
        return 1.0;
    }
    let mut binomial: u128 = 1;
    let mut tail: u128 = 0;
    for i in 0..=b.min(c) {
        tail += binomial;
        binomial = binomial * u128::from(n - i) / u128::from(i + 1);
    }
    // 2 · tail ≤ 2^(n+1): converting to f64 rounds once, dividing by 2^n is exact.
    ((2 * tail) as f64 / 2f64.powi(n as i32)).min(1.0)
}

proptest! {
    #![proptest_config(config(500, 20_261_203))]

    #[test]
    fn holm_adjusted_p_values_are_at_least_raw_at_most_one_and_monotone(raw in prop::collection::vec(p_value(), 1..30)) {
        let adjusted = holm_adjust(&raw).expect("valid family");
        prop_assert_eq!(adjusted.len(), raw.len());
        for (i, (&p, &a)) in raw.iter().zip(&adjusted).enumerate() {
            prop_assert!(p <= a && a <= 1.0, "test {}: raw {}, adjusted {}", i, p, a);
            for (j, (&q, &b)) in raw.iter().zip(&adjusted).enumerate() {
                if p <= q {
                    prop_assert!(a <= b, "raw {} ≤ {} (tests {}, {}) but adjusted {} > {}", p, q, i, j, a, b);
                }
            }
        }
        // The smallest raw value is multiplied by the family size.
        let smallest = raw.iter().copied().fold(1.0, f64::min);
        let smallest_adjusted = adjusted.iter().copied().fold(1.0, f64::min);
        prop_assert_eq!(smallest_adjusted, (raw.len() as f64 * smallest).min(1.0));
    }

    #[test]
    fn mcnemar_p_is_in_zero_one_and_symmetric(b in 0u32..=500, c in 0u32..=500) {
        let p = mcnemar_exact_p(b, c);
        prop_assert!(p > 0.0 && p <= 1.0, "p({}, {}) = {}", b, c, p);
        prop_assert_eq!(p, mcnemar_exact_p(c, b));
        if b == c {
            prop_assert_eq!(p, 1.0);
        }
    }

    /// More discordant tasks on the larger side give a smaller p-value.
    #[test]
    fn mcnemar_p_falls_as_the_larger_count_grows(small in 0u32..=300, extra in 0u32..=300) {
        let larger = small + extra;
        prop_assert!(mcnemar_exact_p(small, larger + 1) <= mcnemar_exact_p(small, larger));
    }

    #[test]
    fn mcnemar_p_is_the_exact_binomial_tail(b in 0u32..=60, c in 0u32..=60) {
        let (ours, exact) = (mcnemar_exact_p(b, c), exact_mcnemar(b, c));
        prop_assert!((ours - exact).abs() <= 1e-14 * exact, "p({}, {}): ours {:e}, exact {:e}", b, c, ours, exact);
    }

    #[test]
    fn paired_outcomes_count_the_discordant_tasks(pairs in prop::collection::vec(any::<(bool, bool)>(), 1..200)) {
        let (first, second): (Vec<bool>, Vec<bool>) = pairs.iter().copied().unzip();
        let test = mcnemar_exact(&first, &second).expect("same length");
        let b = pairs.iter().filter(|&&(x, y)| x && !y).count() as u32;
        let c = pairs.iter().filter(|&&(x, y)| !x && y).count() as u32;
        prop_assert_eq!((test.first_only, test.second_only), (u64::from(b), u64::from(c)));
        prop_assert_eq!(test.p_value, mcnemar_exact_p(b, c));
        prop_assert_eq!(mcnemar_exact(&second, &first).expect("same length").p_value, test.p_value);
    }

    #[test]
    fn the_conservative_test_keeps_the_largest_p_value(
        (reference, runs) in (1usize..80).prop_flat_map(|n| (
            prop::collection::vec(any::<bool>(), n),
            prop::collection::vec(prop::collection::vec(any::<bool>(), n), 1..4),
        ))
    ) {
        let conservative = mcnemar_exact_max_p_over_runs(&reference, &runs).expect("same lengths");
        let each: Vec<f64> = runs.iter().map(|run| mcnemar_exact(&reference, run).expect("same length").p_value).collect();
        let largest = each.iter().copied().fold(0.0, f64::max);
        prop_assert_eq!(conservative.test.p_value, largest);
        prop_assert_eq!(each[conservative.run], largest);
        prop_assert!(each[..conservative.run].iter().all(|&p| p < largest), "the first run with the largest p-value");
    }

    #[test]
    fn the_mean_lies_between_the_extremes_and_the_sd_is_non_negative(values in prop::collection::vec(-1e6f64..1e6, 2..20)) {
        let (lowest, highest) = values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
        let mean = mean(&values).expect("non-empty");
        prop_assert!(lowest <= mean && mean <= highest);
        let sd = sample_std_dev(&values).expect("two values");
        prop_assert!(sd >= 0.0);
        // No value lies further than sqrt(n - 1) sample standard deviations from the mean.
        let bound = sd * ((values.len() - 1) as f64).sqrt() * (1.0 + 1e-9) + 1e-9;
        prop_assert!(values.iter().all(|x| (x - mean).abs() <= bound), "sd {} too small", sd);
    }

    #[test]
    fn equal_runs_have_exactly_their_value_as_mean_and_zero_sd(value in -1e6f64..1e6, runs in 2usize..20) {
        let values = vec![value; runs];
        prop_assert_eq!(mean(&values).expect("non-empty"), value);
        prop_assert_eq!(sample_std_dev(&values).expect("two values"), 0.0);
    }
}
