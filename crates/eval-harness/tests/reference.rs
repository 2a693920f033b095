//! The statistics against numpy, scipy and statsmodels: `tests/fixtures/stats_reference.json`,
//! written by `tools/stats_reference.py` (which records the library versions), holds fixed
//! inputs and the reference libraries' outputs. Floats are stored as strings and parsed with
//! `str::parse`, which rounds correctly (serde_json's default float parser may not).

use eval_harness::stats::{holm_adjust, mcnemar_exact_p, mean, percentile, sample_std_dev};
use serde::Deserialize;

#[derive(Deserialize)]
struct Reference {
    versions: Versions,
    mcnemar: Vec<McNemarCase>,
    holm: Vec<HolmCase>,
    runs: Vec<RunsCase>,
    percentile: Vec<PercentileCase>,
}

#[derive(Deserialize)]
struct Versions {
    numpy: String,
    scipy: String,
    statsmodels: String,
}

#[derive(Deserialize)]
struct McNemarCase {
    b: u32,
    c: u32,
    /// `scipy.stats.binomtest(b, b + c, 0.5).pvalue`.
    p_scipy: String,
    /// min(1, 2 · Σ C(n, i) / 2^n) in exact rationals, correctly rounded.
    p_exact: String,
}

#[derive(Deserialize)]
struct HolmCase {
    p_values: Vec<String>,
    /// `statsmodels.stats.multitest.multipletests(p_values, method="holm")[1]`.
    adjusted: Vec<String>,
}

#[derive(Deserialize)]
struct RunsCase {
    values: Vec<String>,
    /// `numpy.mean`.
    mean: String,
    /// `numpy.std(ddof=1)`.
    std_ddof1: String,
}

#[derive(Deserialize)]
struct PercentileCase {
    #[serde(default)]
    values: Vec<String>,
    #[serde(default)]
    numerators: Vec<u32>,
    #[serde(default)]
    denominator: Option<u32>,
    percentiles: Vec<PercentilePoint>,
}

#[derive(Deserialize)]
struct PercentilePoint {
    percent: String,
    /// `numpy.percentile(values, percent)` (method "linear").
    value: String,
}

fn reference() -> Reference {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/stats_reference.json");
    let text = std::fs::read_to_string(path).expect("tests/fixtures/stats_reference.json (tools/stats_reference.py writes it)");
    serde_json::from_str(&text).expect("stats_reference.json parses")
}

fn float(text: &str) -> f64 {
    text.parse().unwrap_or_else(|_| panic!("{text:?} is not a float"))
}

fn floats(texts: &[String]) -> Vec<f64> {
    texts.iter().map(|text| float(text)).collect()
}

/// |ours - theirs| / max(|ours|, |theirs|); 0 when both are equal or both below f64's normal
/// range (where relative precision is not defined: subnormals and zero).
fn relative_error(ours: f64, theirs: f64) -> f64 {
    if ours == theirs || (ours.abs() < f64::MIN_POSITIVE && theirs.abs() < f64::MIN_POSITIVE) {
        return 0.0;
    }
    (ours - theirs).abs() / ours.abs().max(theirs.abs())
}

#[test]
fn mcnemar_matches_exact_rationals_and_scipy() {
    let reference = reference();
    assert!(reference.mcnemar.len() >= 40);
    let (mut worst_exact, mut worst_scipy) = (0.0_f64, 0.0_f64);
    for case in &reference.mcnemar {
        let ours = mcnemar_exact_p(case.b, case.c);
        let exact = relative_error(ours, float(&case.p_exact));
        let scipy = relative_error(ours, float(&case.p_scipy));
        assert!(exact <= 1e-12, "McNemar b={} c={}: ours {ours:e}, exact {}, relative error {exact:e}", case.b, case.c, case.p_exact);
        assert!(scipy <= 1e-9, "McNemar b={} c={}: ours {ours:e}, scipy {}, relative error {scipy:e}", case.b, case.c, case.p_scipy);
        assert_eq!(ours, mcnemar_exact_p(case.c, case.b), "symmetric in b and c");
        worst_exact = worst_exact.max(exact);
        worst_scipy = worst_scipy.max(scipy);
    }
    println!(
        "McNemar: {} cases, largest relative error {worst_exact:e} against exact rationals, {worst_scipy:e} against scipy {}",
        reference.mcnemar.len(),
        reference.versions.scipy
    );
}

#[test]
fn holm_matches_statsmodels_to_the_bit() {
    let reference = reference();
    for case in &reference.holm {
        let raw = floats(&case.p_values);
        let ours = holm_adjust(&raw).expect("valid family");
        assert_eq!(ours, floats(&case.adjusted), "Holm on {raw:?} (statsmodels {})", reference.versions.statsmodels);
    }
    println!("Holm: {} families equal statsmodels {}'s", reference.holm.len(), reference.versions.statsmodels);
}

#[test]
fn mean_and_sample_std_dev_match_numpy() {
    let reference = reference();
    let (mut worst_mean, mut worst_sd) = (0.0_f64, 0.0_f64);
    for case in &reference.runs {
        let values = floats(&case.values);
        let mean_error = relative_error(mean(&values).expect("mean"), float(&case.mean));
        let (ours, numpy) = (sample_std_dev(&values).expect("sd"), float(&case.std_ddof1));
        let sd_error = relative_error(ours, numpy);
        assert!(mean_error <= 1e-13, "mean of {values:?}: relative error {mean_error:e}");
        assert!(sd_error <= 1e-12, "sd of {values:?}: ours {ours:e}, numpy {numpy:e}, relative error {sd_error:e}");
        worst_mean = worst_mean.max(mean_error);
        worst_sd = worst_sd.max(sd_error);
    }
    println!(
        "runs: {} sets, largest relative error {worst_mean:e} (mean), {worst_sd:e} (sd) against numpy {}",
        reference.runs.len(),
        reference.versions.numpy
    );
}

#[test]
fn percentile_matches_numpy_to_the_bit() {
    let reference = reference();
    let mut points = 0;
    for case in &reference.percentile {
        let values: Vec<f64> = match case.denominator {
            Some(denominator) => case.numerators.iter().map(|&k| f64::from(k) / f64::from(denominator)).collect(),
            None => floats(&case.values),
        };
        for point in &case.percentiles {
            let ours = percentile(&values, float(&point.percent)).expect("valid percentile");
            assert_eq!(
                ours,
                float(&point.value),
                "percentile {} of {} values (numpy {})",
                point.percent,
                values.len(),
                reference.versions.numpy
            );
            points += 1;
        }
    }
    println!("percentile: {points} points equal numpy {}'s", reference.versions.numpy);
}
