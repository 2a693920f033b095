//! Exactness against Fast Downward 26.6 on the IPC fixtures, from the reference values in
//! `fixtures/ipc/fd-reference.tsv` (so the tests need not run it): h_max and h_add of every
//! initial state are equal; h_FF and LM-cut are reported beside Fast Downward's (they depend
//! on tie-breaking) and LM-cut must be at least as informed on average per domain, within 5%.

use std::collections::BTreeMap;

use benchmark_data::{Benchmark, load};
use heuristics::{HAdd, HFF, HMax, Heuristic, LmCut};
use transition_model::TransitionModel;

/// (domain, instance file) → heuristic name → value.
fn reference() -> BTreeMap<(String, String), BTreeMap<String, u32>> {
    let path = benchmark_data::fixtures_dir().join("ipc/fd-reference.tsv");
    let text = std::fs::read_to_string(path).expect("fd-reference.tsv");
    let mut out = BTreeMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let fields: Vec<&str> = line.split('\t').collect();
        if fields.len() < 9 || fields[2] != "fd-h0" || fields[3] != "ok" {
            continue;
        }
        let values =
            fields[8].split(';').filter_map(|kv| kv.split_once('=')).map(|(k, v)| (k.to_string(), v.parse().expect("number"))).collect();
        out.insert((fields[0].to_string(), fields[1].to_string()), values);
    }
    out
}

pub fn model(files: &benchmark_data::TaskFiles) -> TransitionModel {
    let domain = pddl_syntax::parse_domain(&files.domain).expect("domain");
    let problem = pddl_syntax::parse_problem(&files.problem).expect("problem");
    TransitionModel::new(grounding::ground(&domain, &problem).expect("grounds"))
}

#[test]
fn initial_state_values_match_fast_downward() {
    let reference = reference();
    let mut lmcut_sums: BTreeMap<String, (u64, u64, usize)> = BTreeMap::new();
    let mut rows = Vec::new();
    for files in load(Benchmark::Ipc).expect("fixtures") {
        let (domain, instance) = files.id.split_once('/').expect("domain/instance");
        let key = (domain.to_string(), format!("{instance}.pddl"));
        let expected = reference.get(&key).unwrap_or_else(|| panic!("no reference for {}", files.id));
        let model = model(&files);
        let state = model.initial_state();
        let hmax = HMax::new(&model).evaluate(&state);
        let hadd = HAdd::new(&model).evaluate(&state);
        let ff = HFF::new(&model).evaluate(&state);
        let lmcut = LmCut::new(&model).evaluate(&state);
        assert_eq!(hmax, expected.get("hmax").copied(), "{}: h_max", files.id);
        assert_eq!(hadd, expected.get("hadd").copied(), "{}: h_add", files.id);
        let entry = lmcut_sums.entry(domain.to_string()).or_default();
        entry.0 += u64::from(lmcut.unwrap_or(0));
        entry.1 += u64::from(expected["lmcut"]);
        entry.2 += 1;
        rows.push(format!(
            "{:<32} ff {:>4} (FD {:>4})  lmcut {:>4} (FD {:>4})",
            files.id,
            ff.unwrap_or(0),
            expected["hff"],
            lmcut.unwrap_or(0),
            expected["lmcut"]
        ));
    }
    println!("{}", rows.join("\n"));
    for (domain, (ours, theirs, n)) in &lmcut_sums {
        let ratio = *ours as f64 / *theirs as f64;
        println!("{domain:<16} LM-cut mean ours {:.1} FD {:.1} ratio {ratio:.3}", *ours as f64 / *n as f64, *theirs as f64 / *n as f64);
        assert!(ratio >= 0.95, "{domain}: LM-cut mean is {ratio:.3} of Fast Downward's");
    }
}
