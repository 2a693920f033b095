//! `cargo xtask report`: what it writes from eval-harness's hand-written record files, and
//! exit 2 with the file and line for input that is not records.

mod common;

use std::path::{Path, PathBuf};

use common::xtask;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../crates/eval-harness/tests/fixtures/report")
}

/// A scratch folder of its own for each test (`dir`, created), inside a temporary folder that is
/// removed when the returned guard is dropped, also when the test fails.
fn scratch(name: &str) -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::Builder::new().prefix("xtask-report-").tempdir().expect("temporary folder");
    let dir = tmp.path().join(name);
    std::fs::create_dir(&dir).expect("scratch folder");
    (tmp, dir)
}

#[test]
fn report_writes_tables_figures_and_a_page_per_episode() {
    let (_tmp_out, out) = scratch("out");
    let output = xtask(&["report", &fixtures().display().to_string(), "--out", &out.display().to_string(), "--replicates", "200"]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(String::from_utf8_lossy(&output.stdout).contains("11 record file(s), 60 record(s)"));
    let markdown = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    assert!(markdown.contains("## Task success (%) (Table 1)") && markdown.contains("200 replicates"));
    let index = std::fs::read_to_string(out.join("index.html")).expect("index.html");
    for figure in ["tokens.svg", "images.svg", "observations.svg", "calls.svg", "attribution.svg"] {
        let svg = std::fs::read_to_string(out.join(figure)).expect(figure);
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""), "{figure}");
        assert!(index.contains(&format!("href=\"{figure}\"")));
    }
    let (mut pages, mut trees) = (0, 0);
    for run in std::fs::read_dir(out.join("episodes")).expect("episodes/").flatten() {
        for page in std::fs::read_dir(run.path()).expect("a run's pages").flatten() {
            let relative = page.path().strip_prefix(&out).expect("under out").display().to_string();
            assert!(index.contains(&format!("href=\"{relative}\"")), "{relative} is not linked");
            let html = std::fs::read_to_string(page.path()).expect("a page");
            trees += usize::from(html.contains("<h2>Phase II search (top of the tree)</h2>") && html.contains("✓ on plan"));
            pages += 1;
        }
    }
    assert_eq!(pages, 60);
    assert_eq!(trees, 1, "the one record with a search tree shows it");

    // Another report into the same folder, of one file: the last report's pages of the other
    // files are gone with their folders (they stayed, linked from nothing), and a file that is
    // not the report's is left alone.
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let one = fixtures().join("alfworld-seen-expert-8ab1a4359acc.jsonl");
    let output = xtask(&["report", &one.display().to_string(), "--out", &out.display().to_string(), "--replicates", "200"]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let runs: Vec<String> =
        std::fs::read_dir(out.join("episodes")).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(runs, ["alfworld-seen-expert-8ab1a4359acc"]);
    let index = std::fs::read_to_string(out.join("index.html")).expect("index.html");
    for page in std::fs::read_dir(out.join("episodes/alfworld-seen-expert-8ab1a4359acc")).unwrap().flatten() {
        let relative = page.path().strip_prefix(&out).expect("under out").display().to_string();
        assert!(index.contains(&format!("href=\"{relative}\"")), "{relative} is not linked");
    }
    assert_eq!(std::fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
}

#[test]
fn input_that_is_not_records_exits_2_naming_file_and_line() {
    let (_tmp_dir, dir) = scratch("bad");
    let stem = "alfworld-seen-expert-8ab1a4359acc";
    std::fs::copy(fixtures().join(format!("{stem}.config.json")), dir.join(format!("{stem}.config.json"))).expect("copy");
    let records = std::fs::read_to_string(fixtures().join(format!("{stem}.jsonl"))).expect("records");
    let path = dir.join(format!("{stem}.jsonl"));
    std::fs::write(&path, format!("{}\n<html>not a record</html>\n", records.lines().next().unwrap())).expect("write");
    let out = dir.join("out").display().to_string();

    let output = xtask(&["report", &path.display().to_string(), "--out", &out]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.starts_with(&format!("error: {}:2: not a JSON object", path.display())), "{stderr}");
    assert!(!stderr.contains("panicked"));

    let missing = dir.join("missing.jsonl").display().to_string();
    let output = xtask(&["report", &missing, "--out", &out]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("missing.jsonl"));

    let output = xtask(&["report", &fixtures().display().to_string(), "--replicates", "0", "--out", &out]);
    assert_eq!(output.status.code(), Some(2));
}
