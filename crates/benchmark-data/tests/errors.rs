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
