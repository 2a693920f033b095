//! Files that do not load are named with what an editor needs to find the fault.

use benchmark_data::{Benchmark, DataError};

/// A game file that is not JSON is named with a line and column an editor can go to, also when
/// it is empty (serde_json says column 0 there).
#[test]
fn a_game_file_that_is_not_json_is_named_at_its_line_and_column() {
    let tmp = tempfile::Builder::new().prefix("benchmark-data-game-").tempdir().expect("temp dir");
    for (text, at) in [("", ":1:1:"), ("{\n  \"pddl_domain\": oops", ":2:18:")] {
        std::fs::write(tmp.path().join("game.tw-pddl"), text).expect("write");
        let error = benchmark_data::load_alfworld_game(tmp.path(), Benchmark::AlfworldSeen, "g".into()).expect_err("not JSON");
        assert!(matches!(error, DataError::Json { .. }), "{error}");
        assert!(error.to_string().contains(&format!("game.tw-pddl{at} not valid JSON")), "{text:?}: {error}");
    }
}

/// A benchmark by name: every name parses back to its benchmark, and another name is refused
/// with the names there are.
#[test]
fn a_benchmark_name_that_is_none_of_them_is_refused_with_the_list() {
    for &benchmark in Benchmark::ALL {
        assert_eq!(benchmark.name().parse::<Benchmark>(), Ok(benchmark));
    }
    let error = "alfworld-unseen".parse::<Benchmark>().expect_err("not shipped");
    assert_eq!(error, benchmark_data::UnknownBenchmark("alfworld-unseen".into()));
    assert_eq!(
        error.to_string(),
        "`alfworld-unseen` is not a benchmark: the benchmarks are alfworld-seen, alfworld-train, virtualhome-eai, ipc"
    );
    assert_eq!(Benchmark::from_name("alfworld-unseen"), None);
}
