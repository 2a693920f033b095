//! Bad input is an error that names the problem, never a panic or a NaN.

use eval_harness::stats::{
    BootstrapConfig, StatsError, holm_adjust, mcnemar_exact, mcnemar_exact_max_p_over_runs, mean, percentile, sample_std_dev,
    summarize_runs, task_cluster_bootstrap,
};

/// `result` is an error that `is_expected` accepts, and its message mentions `words`.
fn check<T: std::fmt::Debug>(result: Result<T, StatsError>, is_expected: impl Fn(&StatsError) -> bool, words: &str) {
    let error = result.expect_err("bad input is an error");
    assert!(is_expected(&error), "unexpected error {error:?}");
    let message = error.to_string();
    assert!(message.contains(words), "{message:?} does not mention {words:?}");
}

#[test]
fn summaries_of_runs_need_finite_values() {
    check(mean(&[]), |e| *e == StatsError::TooFewValues { what: "mean", needed: 1, found: 0 }, "0 value(s), at least 1 needed");
    check(
        sample_std_dev(&[0.5]),
        |e| *e == StatsError::TooFewValues { what: "sample standard deviation", needed: 2, found: 1 },
        "1 value(s), at least 2 needed",
    );
    check(
        mean(&[0.5, f64::NAN]),
        |e| matches!(e, StatsError::NotFinite { what: "mean", index: 1, value } if value.is_nan()),
        "value 1 is NaN",
    );
    check(
        sample_std_dev(&[f64::INFINITY, 0.5]),
        |e| *e == StatsError::NotFinite { what: "sample standard deviation", index: 0, value: f64::INFINITY },
        "not a finite number",
    );
    check(sample_std_dev(&[f64::MAX, -f64::MAX]), |e| *e == StatsError::Overflow { what: "sample standard deviation" }, "overflows");
    assert_eq!(mean(&[f64::MAX, f64::MAX]), Ok(f64::MAX));
    check(summarize_runs(&[]), |e| matches!(e, StatsError::TooFewValues { what: "mean", .. }), "mean");
    // One run is a deterministic condition: a mean and no standard deviation.
    let one = summarize_runs(&[0.945]).expect("one run");
    assert_eq!((one.runs, one.mean, one.sample_std_dev), (1, 0.945, None));
    let three = summarize_runs(&[0.0, 0.5, 1.0]).expect("three runs");
    assert_eq!((three.runs, three.mean, three.sample_std_dev), (3, 0.5, Some(0.5)));
}

#[test]
fn the_bootstrap_needs_tasks_with_runs_and_a_valid_config() {
    let paper = BootstrapConfig::PAPER;
    let no_tasks: [Vec<f64>; 0] = [];
    check(task_cluster_bootstrap(&no_tasks, &paper), |e| matches!(e, StatsError::TooFewValues { found: 0, .. }), "bootstrap");
    check(task_cluster_bootstrap(&[vec![1.0], vec![]], &paper), |e| *e == StatsError::EmptyTask { task: 1 }, "task 1 has no runs");
    check(
        task_cluster_bootstrap(&[vec![1.0, 0.0], vec![f64::NAN]], &paper),
        |e| matches!(e, StatsError::NotFinite { index: 2, .. }),
        "value 2",
    );
    for confidence in [0.0, 1.0, 95.0, -0.5, f64::NAN] {
        check(
            task_cluster_bootstrap(&[vec![1.0]], &BootstrapConfig { confidence, ..paper }),
            |e| matches!(e, StatsError::InvalidConfidence(_)),
            "strictly between 0 and 1",
        );
    }
    for replicates in [0, usize::MAX] {
        check(
            task_cluster_bootstrap(&[vec![1.0]], &BootstrapConfig { replicates, ..paper }),
            |e| *e == StatsError::InvalidReplicates(replicates),
            "replicates",
        );
    }
    check(task_cluster_bootstrap(&[vec![f64::MAX, f64::MAX]], &paper), |e| *e == StatsError::Overflow { what: "bootstrap" }, "overflows");
}

#[test]
fn percentiles_need_values_and_a_percent() {
    check(percentile(&[], 50.0), |e| matches!(e, StatsError::TooFewValues { what: "percentile", .. }), "percentile");
    check(percentile(&[1.0, f64::NEG_INFINITY], 50.0), |e| matches!(e, StatsError::NotFinite { index: 1, .. }), "-inf");
    for percent in [-0.1, 100.5, f64::NAN] {
        check(percentile(&[1.0], percent), |e| matches!(e, StatsError::InvalidPercent(_)), "[0, 100]");
    }
    assert_eq!(percentile(&[3.0, 1.0, 2.0], 50.0), Ok(2.0));
    assert_eq!(percentile(&[3.0, 1.0, 2.0, 4.0], 50.0), Ok(2.5));
}

#[test]
fn mcnemar_needs_paired_outcomes() {
    check(
        mcnemar_exact(&[true, false], &[true]),
        |e| *e == StatsError::LengthMismatch { what: "McNemar", expected: 2, found: 1 },
        "lengths differ (2 and 1)",
    );
    check(mcnemar_exact(&[], &[]), |e| matches!(e, StatsError::TooFewValues { what: "McNemar", .. }), "McNemar");
    let no_runs: [Vec<bool>; 0] = [];
    check(mcnemar_exact_max_p_over_runs(&[true], &no_runs), |e| matches!(e, StatsError::TooFewValues { found: 0, .. }), "over runs");
    check(
        mcnemar_exact_max_p_over_runs(&[true, true], &[vec![true, false], vec![true]]),
        |e| matches!(e, StatsError::LengthMismatch { expected: 2, found: 1, .. }),
        "lengths differ",
    );
    // Equal outcomes: nothing discordant, p = 1.
    let same = mcnemar_exact(&[true, false, true], &[true, false, true]).expect("paired");
    assert_eq!((same.first_only, same.second_only, same.p_value), (0, 0, 1.0));
}

#[test]
fn holm_needs_a_family_of_p_values() {
    check(holm_adjust(&[]), |e| matches!(e, StatsError::TooFewValues { what: "Holm correction", .. }), "Holm");
    for bad in [1.5, -0.01, f64::NAN, f64::INFINITY] {
        check(holm_adjust(&[0.01, bad]), |e| matches!(e, StatsError::InvalidPValue { index: 1, .. }), "p-value 1 is");
    }
    assert_eq!(holm_adjust(&[0.01, 0.04, 0.03]), Ok(vec![0.03, 0.06, 0.06]));
}
