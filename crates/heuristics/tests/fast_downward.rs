//! Exactness against Fast Downward 26.6 on the IPC fixtures, from the reference values in
//! `fixtures/ipc/fd-reference.tsv` (so the tests need not run it): h_max and h_add of every
//! initial state are equal; h_FF and LM-cut are reported beside Fast Downward's (they depend
//! on tie-breaking) and LM-cut must be at least as informed on average per domain, within 5%.
//! Every heuristic's initial-state value beside Fast Downward's is an insta snapshot
//! (`tests/snapshots/fast_downward__*.snap`), so any change of a value shows as a diff.

use std::collections::BTreeMap;
use std::fmt::Write;

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

fn model(files: &benchmark_data::TaskFiles) -> TransitionModel {
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

/// Fast Downward's name for one of ours, where the reference records it.
fn fd_name(name: &str) -> Option<&'static str> {
    match name {
        "hmax" => Some("hmax"),
        "hadd" => Some("hadd"),
        "ff" => Some("hff"),
        "lmcut" => Some("lmcut"),
        _ => None,
    }
}

/// Fast Downward's optimal plan costs (`astar(lmcut())` runs that finished), by (domain, instance file).
fn optimal_costs() -> BTreeMap<(String, String), u64> {
    let text = std::fs::read_to_string(benchmark_data::fixtures_dir().join("ipc/fd-reference.tsv")).expect("fd-reference.tsv");
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split('\t').collect::<Vec<_>>())
        .filter(|f| f.len() >= 8 && f[2] == "fd-astar-lmcut" && f[3] == "ok")
        .map(|f| ((f[0].to_string(), f[1].to_string()), f[7].parse().expect("plan cost")))
        .collect()
}

/// The initial-state value of every heuristic of `heuristics::NAMES` on every IPC fixture,
/// ours beside Fast Downward's where it recorded one (`-`: not recorded; `inf`: dead end),
/// and h* where Fast Downward's A* finished. h_max and h_add must equal Fast Downward's;
/// h_FF and LM-cut depend on tie-breaking, but h_max ≤ LM-cut ≤ h_FF and LM-cut ≤ h*.
#[test]
fn initial_state_values_beside_fast_downward() {
    let reference = reference();
    let optimal = optimal_costs();
    // `lmcut-admissible` is `lmcut` on tasks without conditional effects: asserted, not shown.
    let names: Vec<&str> = heuristics::NAMES.iter().copied().filter(|&n| n != "lmcut-admissible").collect();
    let show = |value: Option<u32>| value.map_or_else(|| "inf".to_string(), |v| v.to_string());
    let mut table = format!("{:<28}", "task (ours / Fast Downward)");
    for name in &names {
        write!(table, " {name:>13}").unwrap();
    }
    table.push_str("    h*\n");
    for files in load(Benchmark::Ipc).expect("fixtures") {
        let (domain, instance) = files.id.split_once('/').expect("domain/instance");
        let key = (domain.to_string(), format!("{instance}.pddl"));
        let expected = reference.get(&key).unwrap_or_else(|| panic!("no reference for {}", files.id));
        let model = model(&files);
        let state = model.initial_state();
        write!(table, "{:<28}", files.id).unwrap();
        let mut ours = BTreeMap::new();
        for &name in &names {
            let value = heuristics::by_name(name, &model).unwrap_or_else(|| panic!("{name} is a heuristic")).evaluate(&state);
            let theirs = fd_name(name).and_then(|fd| expected.get(fd).copied());
            if matches!(name, "hmax" | "hadd") {
                assert_eq!(value, theirs, "{}: {name}", files.id);
            }
            let theirs = fd_name(name).map_or_else(|| "-".to_string(), |_| show(theirs));
            write!(table, " {:>13}", format!("{} / {theirs}", show(value))).unwrap();
            ours.insert(name, value.expect("every IPC fixture is relaxed-solvable"));
        }
        let admissible = LmCut::admissible(&model).evaluate(&state);
        assert_eq!(admissible, Some(ours["lmcut"]), "{}: admissible LM-cut without conditional effects", files.id);
        let h_star = optimal.get(&key).copied();
        assert!(ours["hmax"] <= ours["lmcut"] && ours["lmcut"] <= ours["ff"], "{}: h_max ≤ LM-cut ≤ h_FF", files.id);
        if let Some(h_star) = h_star {
            assert!(u64::from(ours["lmcut"]) <= h_star, "{}: LM-cut {} > h* {h_star}", files.id, ours["lmcut"]);
        }
        writeln!(table, " {:>5}", h_star.map_or_else(|| "-".to_string(), |h| h.to_string())).unwrap();
    }
    insta::assert_snapshot!(table);
}
