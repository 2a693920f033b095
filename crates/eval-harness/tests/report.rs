//! `report` on small hand-written record files (`tests/fixtures/report/`): six conditions on
//! two benchmarks — `ours` under constrained MCTS, unconstrained greedy and constrained
//! sampling (seeds 0 and 42), a `direct` policy, the planner (its run in two shard files) and
//! the expert — six tasks each. The Markdown tables are a snapshot; the HTML escapes what the
//! records hold; every page is linked and well-formed; faults in the input name file and line.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use eval_harness::report::{Report, ReportError, ReportOptions, build, load, record_paths};
use eval_harness::stats::{self, BootstrapConfig};
use tempfile::TempDir;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/report")
}

fn fixture_report() -> Report {
    let paths = record_paths(&[fixtures()]).expect("fixture files");
    let sets: Vec<_> = paths.iter().map(|p| load(p).expect("a record file")).collect();
    build(&sets, &ReportOptions::default()).expect("a report")
}

/// A scratch folder of its own for each test (`dir`, created), inside a temporary folder that is
/// removed when the returned guard is dropped, also when the test fails.
fn scratch(name: &str) -> (TempDir, PathBuf) {
    let tmp = tempfile::Builder::new().prefix("report-").tempdir().expect("temporary folder");
    let dir = tmp.path().join(name);
    std::fs::create_dir(&dir).expect("scratch folder");
    (tmp, dir)
}

/// A scratch folder holding a copy of the fixture records (the shards of one run, their
/// configuration).
fn fixture_copy(name: &str) -> (TempDir, PathBuf) {
    let (tmp, dir) = scratch(name);
    for entry in std::fs::read_dir(fixtures()).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.join(path.file_name().unwrap())).expect("copy");
    }
    (tmp, dir)
}

#[test]
fn markdown_tables() {
    insta::assert_snapshot!(fixture_report().markdown);
}

#[test]
fn table_7_numbers_are_the_statistics_modules() {
    // Constrained sampling on ALFWorld: seeds 0 and 42, the outcomes of the fixture files.
    let runs = [[1.0, 0.0, 1.0, 1.0, 0.0, 0.0], [1.0, 1.0, 0.0, 1.0, 1.0, 0.0]];
    let rates: Vec<f64> = runs.iter().map(|r| stats::mean(r).unwrap()).collect();
    let summary = stats::summarize_runs(&rates).unwrap();
    let tasks: Vec<Vec<f64>> = (0..6).map(|t| runs.iter().map(|r| r[t]).collect()).collect();
    let interval = stats::task_cluster_bootstrap(&tasks, &BootstrapConfig::PAPER).unwrap();
    // Bold: on six tasks no condition is significantly worse than the best.
    let cell = format!(
        "| **{:.1} ± {:.1}** | [{:.1}, {:.1}] |",
        100.0 * summary.mean,
        100.0 * summary.sample_std_dev.unwrap(),
        100.0 * interval.lower,
        100.0 * interval.upper
    );
    let markdown = fixture_report().markdown;
    let row = markdown.lines().find(|l| l.starts_with("| Constrained sampling | sweep / uniform prior | 2 |")).expect("Table 7's row");
    assert!(row.ends_with(&cell), "{row} does not end with {cell}");
    // Table 10: against both seeds, the larger exact p (seed 42 differs from ours on one task).
    let ablation =
        markdown.lines().find(|l| l.starts_with("| Ours (sweep / uniform prior) vs. Constrained sampling")).expect("Table 10's row");
    let p = stats::mcnemar_exact_max_p_over_runs(
        &[true, true, true, true, true, false],
        &[[true, false, true, true, false, false], [true, true, false, true, true, false]],
    )
    .unwrap();
    assert_eq!(p.run, 1);
    assert!(ablation.ends_with(&format!("| 6 (1/0) | {:.3} | 1.000 | – |", p.test.p_value)), "{ablation}");
}

#[test]
fn observations_are_escaped_in_the_episode_page() {
    let report = fixture_report();
    let page =
        report.episodes.iter().find(|p| p.html.contains("alert(")).expect("the page of the episode whose observation holds a script");
    assert!(!page.html.contains("<script"), "{} holds a raw <script>", page.path);
    assert!(page.html.contains("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; &quot;more&quot;"));
    assert!(page.html.contains("[WALK] &lt;kitchen&gt; (1)"));
    // What the page shows of the episode.
    for shown in [
        "inside(plate (10), kitchen (1))",
        "ON(stove (11))",
        "(:domain virtualhome-sound)",
        "✗ not executed",
        "Phase II",
        "top of the tree",
    ] {
        assert!(page.html.contains(shown), "{} lacks {shown}", page.path);
    }
    assert!(!report.index.contains("<script"));
}

/// The page of the constrained-MCTS episode whose record holds a search tree.
fn tree_page(report: &Report) -> &str {
    &report.episodes.iter().find(|p| p.html.contains("alert(")).expect("the constrained-MCTS episode's page").html
}

/// The part of a page under `heading`, up to the next `<h2>`.
fn section<'a>(html: &'a str, heading: &str) -> &'a str {
    let start = html.find(&format!("<h2>{heading}</h2>")).unwrap_or_else(|| panic!("no section {heading}"));
    let rest = &html[start + 4..];
    &rest[..rest.find("<h2>").unwrap_or(rest.len())]
}

#[test]
fn the_episode_page_shows_the_top_of_the_search_tree() {
    let report = fixture_report();
    let tree = section(tree_page(&report), "Phase II search (top of the tree)");
    assert!(tree.contains("12 simulation(s) backed up at the root"), "{tree}");
    assert!(tree.contains("value: the best value (Eq. 10) backed up through it"), "max backup: {tree}");
    // Most visited first, the action text escaped; the plan's first action marked, once per level.
    let rows = [
        "<tr><td class=\"num\">1</td><td><code>[WALK] &lt;kitchen&gt; (1)</code></td><td class=\"num\">6</td><td class=\"num\">-1.100</td><td class=\"num\">0.500</td><td></td></tr>",
        "<tr><td class=\"num\">2</td><td><code>[FIND] &lt;plate&gt; (10)</code></td><td class=\"num\">3</td>",
        "<tr><td class=\"num\">3</td><td><code>[GRAB] &lt;plate&gt; (10)</code></td><td class=\"num\">1</td><td class=\"num\">1.000</td><td class=\"num\">0.250</td><td><span class=\"ok\">✓ on plan</span></td></tr>",
        "<tr><td class=\"num\">4</td><td><code>[OPEN] &lt;cab</code> <em>(partial: the search stopped inside the action)</em>",
        "<tr><td class=\"num\">5</td><td><code>DONE</code> <em>(ends the plan)</em></td><td class=\"num\">1</td><td class=\"num\">-2.000</td><td class=\"num\">4.0e-4</td>",
    ];
    for row in rows {
        assert!(tree.contains(row), "no row {row} in {tree}");
    }
    assert_eq!(tree.matches("✓ on plan").count(), 1);
    // One level below the most visited first action.
    let below = "<h3>After <code>[WALK] &lt;kitchen&gt; (1)</code> (the most visited first action, 6 visit(s))</h3>";
    let second = &tree[tree.find(below).unwrap_or_else(|| panic!("no second level in {tree}"))..];
    assert!(second.contains("<td><code>[FIND] &lt;plate&gt; (10)</code></td><td class=\"num\">3</td>"), "{second}");
    assert!(second.contains("<code>&lt;|im_end|&gt;</code> <em>(ends the plan)</em>"), "{second}");
    assert!(!tree.contains("holds no search tree"));
    // The tree is not repeated among the other episode fields.
    assert!(!section(tree_page(&report), "Other episode fields").contains("search_tree"));
}

#[test]
fn the_episode_page_shows_what_the_engine_is_given_on_replay() {
    let report = fixture_report();
    let page = report
        .episodes
        .iter()
        .find(|p| p.html.contains("<code>walk kitchen</code>"))
        .expect("the direct episode that sent class-level commands");
    let script = section(&page.html, "Engine script");
    assert!(
        script.contains("<ol><li><span class=\"ok\">✓</span> <code>[WALK] &lt;kitchen&gt; (1)</code></li><li><span class=\"ok\">✓</span> <code>[GRAB] &lt;plate&gt; (10)</code></li></ol>"),
        "{script}"
    );
    assert!(!section(&page.html, "Other episode fields").contains("engine_script"));
    // Records written before the engine script have no such section.
    assert!(!tree_page(&report).contains("<h2>Engine script</h2>"));
}

#[test]
fn an_episode_page_without_a_tree_says_so() {
    // The same record as written before records kept the tree.
    let (_tmp_dir, dir) = scratch("no-tree");
    let path = copy_fixture("virtualhome-rearrange-ours-71477d57ab53", &dir);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut first: serde_json::Value = serde_json::from_str(&lines[0]).unwrap();
    assert!(first["episode"].as_object_mut().expect("an episode").remove("search_tree").is_some());
    lines[0] = first.to_string();
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let report = build(&[load(&path).expect("an older record loads")], &ReportOptions::default()).expect("a report");
    let page = tree_page(&report);
    let tree = section(page, "Phase II search (top of the tree)");
    assert!(tree.contains("This record holds no search tree"), "{tree}");
    assert!(!tree.contains("<table>") && !page.contains("✓ on plan"));
    well_formed(page).expect("well-formed");
}

#[test]
fn every_episode_page_is_linked_from_the_index() {
    let report = fixture_report();
    assert_eq!(report.episodes.len(), 60);
    let mut paths: Vec<&str> = report.episodes.iter().map(|p| p.path.as_str()).collect();
    paths.sort();
    paths.dedup();
    assert_eq!(paths.len(), report.episodes.len(), "two records share a page");
    for page in &report.episodes {
        assert!(report.index.contains(&format!("href=\"{}\"", page.path)), "{} is not linked from index.html", page.path);
        assert!(page.html.contains("href=\"../../index.html\""), "{} does not link back", page.path);
    }
    for figure in &report.figures {
        assert!(report.index.contains(&figure.svg), "{} is not inline in index.html", figure.name);
    }
}

#[test]
fn figures_and_pages_are_well_formed_xml() {
    let report = fixture_report();
    assert_eq!(
        report.figures.iter().map(|f| f.name).collect::<Vec<_>>(),
        ["tokens.svg", "images.svg", "observations.svg", "calls.svg", "attribution.svg"]
    );
    for figure in &report.figures {
        let root = well_formed(&figure.svg).unwrap_or_else(|e| panic!("{}: {e}", figure.name));
        assert_eq!(root, "svg", "{}", figure.name);
    }
    assert_eq!(well_formed(&report.index).expect("index.html"), "html");
    for page in &report.episodes {
        well_formed(&page.html).unwrap_or_else(|e| panic!("{}: {e}", page.path));
    }
    // The checker itself rejects what it should.
    for bad in ["<svg><g></svg>", "<svg a=1/>", "<svg>a < b</svg>", "<svg>&nbsp;</svg>", "<svg/><svg/>", "<svg>"] {
        assert!(well_formed(bad).is_err(), "{bad} passed");
    }
}

#[test]
fn the_attribution_figure_stacks_the_classes_of_each_condition() {
    let report = fixture_report();
    let svg = &report.figures.iter().find(|f| f.name == "attribution.svg").expect("attribution figure").svg;
    // The direct policy on ALFWorld fails 33.3% at grounding and 50% short of the goal.
    assert!(svg.contains("Direct VLM (Qwen3.5-4B)"));
    assert!(svg.contains("<title>alfworld-seen: 33.33%</title>"));
    assert!(svg.contains("<title>alfworld-seen: 50%</title>"));
    // The expert records no attribution, so it has no bars.
    assert!(!svg.contains("Expert plan"));
    let tokens = &report.figures[0].svg;
    assert!(tokens.contains("Direct VLM (Qwen3.5-4B)") && !tokens.contains("Expert plan"));
}

#[test]
fn tables_without_data_say_so() {
    let set = load(&fixtures().join("alfworld-seen-expert-8ab1a4359acc.jsonl")).expect("the expert's records");
    let report = build(&[set], &ReportOptions::default()).expect("a report");
    for said in [
        "_No records of the agent `ours`: the ablation",
        "_No records of the agent `ours`: the table compares its Phase II conditions",
        "_No main comparison",
        "_No ablation pair",
        "_No other pair of conditions shares a task",
        "_No records carry a terminal mechanism",
        "_No records carry a failure response",
        "_No records carry a failure attribution",
    ] {
        assert!(report.markdown.contains(said), "the report does not say {said}");
    }
    for figure in &report.figures {
        assert!(figure.svg.contains("No records carry"), "{} does not say it is empty", figure.name);
        well_formed(&figure.svg).expect("an empty figure is still SVG");
    }
}

fn copy_fixture(stem: &str, to: &Path) -> PathBuf {
    for suffix in [".jsonl", ".config.json"] {
        std::fs::copy(fixtures().join(format!("{stem}{suffix}")), to.join(format!("{stem}{suffix}"))).expect("copy");
    }
    to.join(format!("{stem}.jsonl"))
}

fn message(result: Result<impl std::fmt::Debug, ReportError>) -> String {
    result.expect_err("an error").to_string()
}

#[test]
fn faults_in_the_input_name_the_file_and_line() {
    let (_tmp_dir, dir) = scratch("faults");
    let stem = "alfworld-seen-expert-8ab1a4359acc";
    let path = copy_fixture(stem, &dir);
    let good = std::fs::read_to_string(&path).unwrap();
    let first = good.lines().next().unwrap().to_string();
    let second = good.lines().nth(1).unwrap().to_string();
    let shown = path.display().to_string();

    std::fs::write(&path, format!("{first}\nthis is not a record\n")).unwrap();
    assert!(message(load(&path)).starts_with(&format!("{shown}:2: not a JSON object")));

    std::fs::write(&path, format!("{first}\n{}\n", second.replace("\"success\":true", "\"success\":\"yes\""))).unwrap();
    assert_eq!(message(load(&path)), format!("{shown}:2: no boolean `success`: every record says whether its task succeeded"));

    std::fs::write(&path, format!("{}\n", first.replace("\"success\":true", "\"success\":false,\"terminal\":\"gave-up\""))).unwrap();
    assert!(message(load(&path)).starts_with(&format!("{shown}:1: `terminal` is \"gave-up\", not one of success, grounding")));

    std::fs::write(&path, format!("{}\n", first.replace("8ab1a4359acc", "000000000000"))).unwrap();
    assert!(message(load(&path)).starts_with(&format!("{shown}:1: a record of configuration 000000000000")));
    // The records as written, the configuration beside them edited: that file is named as the
    // one that changed.
    std::fs::write(&path, format!("{first}\n")).unwrap();
    let config = dir.join(format!("{stem}.config.json"));
    let written = std::fs::read_to_string(&config).unwrap();
    std::fs::write(&config, written.replacen("\"agent\"", "\"edited\": 1, \"agent\"", 1)).unwrap();
    let said = message(load(&path));
    assert!(said.contains("as the file's name says") && said.contains("edited after the run?"), "{said}");
    std::fs::write(&config, written).unwrap();

    std::fs::write(&path, format!("{first}\n{first}\n")).unwrap();
    assert!(message(load(&path)).contains(":2: task "));

    // The figures the tables and plots read: counts, a duration, fractions, the flags.
    for (from, to, said) in [
        ("\"steps\":4", "\"steps\":-1", "`steps` is -1, not a count"),
        ("\"steps\":4", "\"steps\":1e30", "`steps` is 1e+30, not a count"),
        ("\"millis\":20.0", "\"millis\":\"NaN\"", "`millis` is \"NaN\", not a duration"),
        ("{", "{\"precision\":2.5,", "`precision` is 2.5, not null or a fraction from 0 to 1"),
        ("{", "{\"episode\":\"oops\",", "`episode` is \"oops\", not an object"),
        ("{", "{\"failure_response\":{\"recovers\":7},", "`failure_response.recovers` is 7, not a boolean"),
        ("\"success\":true", "\"success\":false", "`outcome` is \"success\" but `success` is false"),
        ("\"outcome\":\"success\"", "\"outcome\":\"no-plan\"", "`outcome` is \"no-plan\" but `success` is true"),
        ("{", "{\"terminal\":\"grounding\",", "`terminal` is \"grounding\" but `success` is true"),
        ("\"task\":\"pick_and_place-Pen-2/trial_T2\"", "\"task\":\"\"", "no `task`"),
    ] {
        std::fs::write(&path, format!("{first}\n{}\n", second.replacen(from, to, 1))).unwrap();
        assert!(message(load(&path)).starts_with(&format!("{shown}:2: {said}")), "{to}: {}", message(load(&path)));
    }

    let config = dir.join(format!("{stem}.config.json"));
    assert!(message(load(&config)).starts_with(&format!("{}: not a record file", config.display())));

    let missing = dir.join("nothing-here-000000000000.jsonl");
    std::fs::write(&missing, format!("{first}\n")).unwrap();
    let text = message(load(&missing));
    assert!(text.starts_with(&missing.display().to_string()) && text.contains("nothing-here-000000000000.config.json"), "{text}");

    let absent = dir.join("absent-000000000000.jsonl");
    assert!(message(load(&absent)).contains("No such file"), "a missing records file is said to be missing, before its configuration");
    std::fs::write(dir.join("absent-000000000000.config.json"), "{\"agent\": \"expert\", \"benchmark\": \"alfworld-seen\"}\n").unwrap();
    assert!(message(load(&absent)).starts_with(&absent.display().to_string()));

    std::fs::write(dir.join("broken-000000000000.config.json"), "{\"agent\": \"expert\",\n").unwrap();
    std::fs::write(dir.join("broken-000000000000.jsonl"), format!("{first}\n")).unwrap();
    let text = message(load(&dir.join("broken-000000000000.jsonl")));
    assert!(text.contains("broken-000000000000.config.json") && text.contains("line 2"), "{text}");

    let (_tmp_empty, empty) = scratch("no-files");
    assert!(message(record_paths(&[empty])).contains("no `*.jsonl` record files"));
}

/// A record file named twice (itself, through its folder, under another spelling) is read once,
/// in the place its first naming puts it: it used to be loaded twice, and the report refused
/// every task as recorded again by the file itself.
#[test]
fn a_file_named_twice_is_read_once() {
    let once = record_paths(&[fixtures()]).expect("fixture files");
    let first = once[0].clone();
    let respelled = fixtures().join("..").join("report").join(first.file_name().unwrap());
    let twice = record_paths(&[first.clone(), fixtures(), respelled, fixtures()]).expect("fixture files");
    let mut expected = vec![first.clone()];
    expected.extend(once.iter().filter(|p| **p != first).cloned());
    assert_eq!(twice, expected);
}

#[test]
fn a_record_cut_short_is_left_out_with_a_warning() {
    let (_tmp_dir, dir) = scratch("cut");
    let path = copy_fixture("alfworld-seen-expert-8ab1a4359acc", &dir);
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(&path, &text[..text.len() - 20]).unwrap();
    let set = load(&path).expect("the whole records");
    assert_eq!(set.records.len(), 5);
    assert_eq!(set.warnings, [format!("{}:6: a record cut short (a run in progress, or killed) is left out", path.display())]);
    assert!(build(&[set], &ReportOptions::default()).unwrap().markdown.contains("warning:"));

    // Cut inside a character: the same.
    let mut bytes = text.into_bytes();
    bytes.extend_from_slice("{\"task\":\"x\",\"reply\":\"\u{e9}".as_bytes());
    bytes.pop();
    std::fs::write(&path, &bytes).unwrap();
    let set = load(&path).expect("the whole records");
    assert_eq!(set.records.len(), 6);
    assert_eq!(set.warnings, [format!("{}:7: a record cut short (a run in progress, or killed) is left out", path.display())]);
}

/// An expert record with no plan to replay is not an episode: it is left out of the tables
/// (n counts the judged tasks) and the report says so.
#[test]
fn tasks_without_an_expert_plan_are_left_out_and_said() {
    let (_tmp_dir, dir) = scratch("no-plan");
    let path = copy_fixture("alfworld-seen-expert-8ab1a4359acc", &dir);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut first: serde_json::Value = serde_json::from_str(&lines[0]).unwrap();
    first["outcome"] = "no-plan".into();
    first["success"] = false.into();
    first["steps"] = 0.into();
    lines[0] = first.to_string();
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let set = load(&path).unwrap();
    let solved = set.records.iter().filter(|r| r.fields["success"] == true).count();
    let markdown = build(&[set], &ReportOptions::default()).unwrap().markdown;
    let row = markdown.lines().find(|l| l.starts_with("| Expert plan |")).expect("Table 1's row");
    assert!(row.contains(&format!("{:.1} (n=5)", 100.0 * solved as f64 / 5.0)), "{row}");
    assert!(markdown.contains("- left out: Expert plan on alfworld-seen: 1 task(s) with no plan to replay"), "{markdown}");
}

/// A copy of the fixture record set `stem` under `dir` with its configuration changed by
/// `edit`, renamed and re-stamped with the new configuration's hash, as `eval` would write it.
fn variant(dir: &Path, stem: &str, edit: impl FnOnce(&mut serde_json::Value)) {
    let mut config: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixtures().join(format!("{stem}.config.json"))).unwrap()).unwrap();
    edit(&mut config);
    let hash = eval_harness::records::config_hash(&config);
    let prefix = stem.rsplit_once('-').unwrap().0;
    let new_stem = format!("{prefix}-{hash}");
    std::fs::write(dir.join(format!("{new_stem}.config.json")), serde_json::to_string_pretty(&config).unwrap()).unwrap();
    // The set's records, its shard files joined.
    let mut files: Vec<PathBuf> = std::fs::read_dir(fixtures())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_str().unwrap().starts_with(stem) && p.extension().is_some_and(|e| e == "jsonl"))
        .collect();
    files.sort();
    let records: Vec<String> = files
        .iter()
        .flat_map(|f| std::fs::read_to_string(f).unwrap().lines().map(str::to_string).collect::<Vec<_>>())
        .map(|line| {
            let mut record: serde_json::Value = serde_json::from_str(&line).unwrap();
            record["config"] = hash.clone().into();
            record.to_string()
        })
        .collect();
    std::fs::write(dir.join(format!("{new_stem}.jsonl")), records.join("\n") + "\n").unwrap();
}

#[test]
fn the_model_column_names_each_phase_where_they_differ() {
    let (_tmp_dir, dir) = scratch("model-column");
    let ours = "alfworld-seen-ours-86924780c5c0";
    copy_fixture(ours, &dir);
    variant(&dir, ours, |c| {
        c["explorer"] = "smollm2".into();
        c["lm"]["lm"] = "smollm2".into();
    });
    variant(&dir, ours, |c| c["lm"]["lm"] = "smollm2".into());
    let planner = "virtualhome-rearrange-planner-1a1f05079ed4";
    for shard in ["shard-1-of-2", "shard-2-of-2"] {
        let file = format!("{planner}.{shard}.jsonl");
        std::fs::copy(fixtures().join(&file), dir.join(&file)).unwrap();
    }
    std::fs::copy(fixtures().join(format!("{planner}.config.json")), dir.join(format!("{planner}.config.json"))).unwrap();
    variant(&dir, planner, |c| c["explorer"] = "smollm2".into());
    let sets: Vec<_> = record_paths(&[dir]).unwrap().iter().map(|p| load(p).unwrap()).collect();
    let markdown = build(&sets, &ReportOptions::default()).unwrap().markdown;
    let table_1 = section_of(&markdown, "## Task success");
    for row in [
        "| Constrained sampling | SmolLM2-135M |",
        "| Constrained sampling | sweep / SmolLM2-135M |",
        "| Constrained sampling | sweep / uniform prior |",
        "| Planner (A*) | SmolLM2-135M |",
        "| Planner (A*) | — |",
    ] {
        assert_eq!(table_1.lines().filter(|l| l.starts_with(row)).count(), 1, "{row} in\n{table_1}");
    }
}

/// Phase II by a chat model (`eval --chat-planner M [--thinking [recommended]]`) is the
/// paper's unconstrained greedy or thinking condition: named so in every table (not `Ours`,
/// whose decoder settings its configuration also carries), its model the chat planner's, its
/// seeds its runs, tested against ours among the main comparisons (thinking, as the paper) or
/// the component ablations (greedy).
#[test]
fn a_chat_planner_is_the_unconstrained_greedy_or_thinking_condition() {
    let (_tmp_dir, dir) = scratch("chat-planner");
    let ours = "alfworld-seen-ours-86924780c5c0";
    let phase2 = |c: &mut serde_json::Value, mode: &str, seed: u64| {
        c["decode"]["mode"] = mode.into();
        c["decode"]["seed"] = seed.into();
    };
    variant(&dir, ours, |c| {
        phase2(c, "constrained-mcts", 0);
        c["lm"]["lm"] = "smollm2".into();
    });
    variant(&dir, ours, |c| {
        phase2(c, "constrained-greedy", 0);
        c["lm"]["lm"] = "smollm2".into();
    });
    // The chat planner's runs keep the decoder's defaults (`lm.lm` uniform) beside it.
    let chat = |c: &mut serde_json::Value, thinking: serde_json::Value, seed: u64| {
        phase2(c, "constrained-mcts", seed);
        c["planner"] = "chat".into();
        c["chat_planner"] = serde_json::json!({"chat_planner": "smollm2", "thinking": thinking});
    };
    variant(&dir, ours, |c| chat(c, serde_json::Value::Null, 0));
    variant(&dir, ours, |c| chat(c, "temperature-zero".into(), 0));
    for seed in [0, 42, 1738] {
        variant(&dir, ours, |c| chat(c, "recommended".into(), seed));
    }
    let sets: Vec<_> = record_paths(&[dir]).unwrap().iter().map(|p| load(p).unwrap()).collect();
    let markdown = build(&sets, &ReportOptions::default()).unwrap().markdown;
    let table_1 = section_of(&markdown, "## Task success");
    for row in [
        "| Ours | sweep / SmolLM2-135M |",
        "| Constrained greedy | sweep / SmolLM2-135M |",
        "| Unconstrained greedy | sweep / SmolLM2-135M |",
        "| Thinking | sweep / SmolLM2-135M |",
        "| Thinking, recommended sampling | sweep / SmolLM2-135M |",
    ] {
        assert_eq!(table_1.lines().filter(|l| l.starts_with(row)).count(), 1, "{row} in\n{table_1}");
    }
    assert_eq!(table_1.lines().filter(|l| l.starts_with("| ")).count(), 6, "five conditions and the header: {table_1}");
    let table_8 = section_of(&markdown, "## Component ablation");
    for row in ["| Greedy | – | – | sweep / SmolLM2-135M |", "| Greedy | – | ✓ |", "| Ours | ✓ | ✓ |"] {
        assert_eq!(table_8.lines().filter(|l| l.starts_with(row)).count(), 1, "{row} in\n{table_8}");
    }
    assert_eq!(table_8.lines().filter(|l| l.starts_with("| Thinking | – | – | sweep / SmolLM2-135M |")).count(), 2, "{table_8}");
    let table_7 = section_of(&markdown, "## Accuracy and robustness");
    let runs = |approach: &str| {
        let row = table_7.lines().find(|l| l.starts_with(&format!("| {approach} |"))).unwrap_or_else(|| panic!("{approach}: {table_7}"));
        row.split('|').map(str::trim).nth(3).unwrap().to_string()
    };
    assert_eq!((runs("Thinking"), runs("Thinking, recommended sampling")), ("1".to_string(), "3".to_string()));
    let main = section_of(&markdown, "## Paired significance: main comparisons");
    let ablation = section_of(&markdown, "## Paired significance: component ablations");
    let ours = "Ours (sweep / SmolLM2-135M)";
    for other in ["Thinking (sweep / SmolLM2-135M)", "Thinking, recommended sampling (sweep / SmolLM2-135M)"] {
        assert!(main.contains(&format!("| {ours} vs. {other} |")), "{other} in\n{main}");
    }
    // The paper's ablation family: constrained greedy and unconstrained MCTS only; the
    // unconstrained greedy condition is compared in a family of its own.
    assert!(ablation.contains(&format!("| {ours} vs. Constrained greedy (sweep / SmolLM2-135M) |")), "{ablation}");
    assert!(!ablation.contains("Thinking") && !ablation.contains("Unconstrained greedy"), "{ablation}");
    let other = section_of(&markdown, "## Paired significance: comparisons beyond");
    assert!(other.contains(&format!("| {ours} vs. Unconstrained greedy (sweep / SmolLM2-135M) |")), "{other}");
    assert!(!main.contains("Unconstrained greedy") && !main.contains("Constrained greedy"), "{main}");
    // Table 8: a row per condition, a column per model under each benchmark, accuracy ± sd.
    let table_8 = section_of(&markdown, "## Phase II conditions by model");
    let row = table_8.lines().find(|l| l.starts_with("| Thinking, recommended sampling |")).expect("the sampled condition's row");
    assert!(row.contains(" ± "), "{row}");
    assert_eq!(table_8.lines().filter(|l| l.starts_with("| ")).count(), 6, "five conditions and the header: {table_8}");
}

/// The Markdown from `heading` to the next `## `.
fn section_of<'a>(markdown: &'a str, heading: &str) -> &'a str {
    let start = markdown.find(heading).expect(heading);
    let rest = &markdown[start + heading.len()..];
    &markdown[start..start + heading.len() + rest.find("\n## ").unwrap_or(rest.len())]
}

/// A run of a subset (`eval --subset default` gives each benchmark its own) is a column of its
/// own, named by the subset; the subset does not make another condition.
#[test]
fn a_subset_names_a_column_not_a_condition() {
    let (_tmp_dir, dir) = scratch("subset");
    let stem = "alfworld-seen-ours-86924780c5c0";
    copy_fixture(stem, &dir);
    variant(&dir, stem, |c| c["subset"] = "alfworld-seen-6".into());
    let sets: Vec<_> = record_paths(&[dir]).unwrap().iter().map(|p| load(p).unwrap()).collect();
    let markdown = build(&sets, &ReportOptions::default()).unwrap().markdown;
    assert!(markdown.contains("| Approach | Model | alfworld-seen | alfworld-seen-6 |"), "{markdown}");
    assert!(!markdown.contains("subset="), "{markdown}");
}

#[test]
fn shard_files_of_one_run_make_one_run_and_a_task_twice_is_an_error() {
    let report = fixture_report();
    assert!(report.markdown.contains("| Planner (A*) | — | 83.3 (n=6) | — |"));
    let (_tmp_dir, dir) = scratch("twice");
    let stem = "virtualhome-rearrange-planner-1a1f05079ed4";
    std::fs::copy(fixtures().join(format!("{stem}.config.json")), dir.join(format!("{stem}.config.json"))).unwrap();
    let shard = fixtures().join(format!("{stem}.shard-1-of-2.jsonl"));
    // The first shard's records again as the second shard's.
    std::fs::copy(&shard, dir.join(format!("{stem}.shard-1-of-2.jsonl"))).unwrap();
    std::fs::copy(&shard, dir.join(format!("{stem}.shard-2-of-2.jsonl"))).unwrap();
    let sets: Vec<_> = record_paths(&[dir]).unwrap().iter().map(|p| load(p).unwrap()).collect();
    let text = message(build(&sets, &ReportOptions::default()));
    assert!(text.contains(":1: task clean-001 is recorded again") && text.contains("for the same configuration"), "{text}");
}

/// The name of the root element if `text` is well-formed XML (after an optional doctype),
/// else what is wrong: tags nest and close, attribute values are quoted and hold no `<`, text
/// holds no raw `<`, and `&` starts a character reference XML knows.
fn well_formed(text: &str) -> Result<String, String> {
    let mut stack: Vec<String> = Vec::new();
    let mut root: Option<String> = None;
    let mut rest = text.trim_start();
    if let Some(after) = rest.strip_prefix("<!DOCTYPE") {
        rest = &after[after.find('>').ok_or("unclosed doctype")? + 1..];
    }
    let references: BTreeMap<&str, ()> = ["amp", "lt", "gt", "quot", "apos"].into_iter().map(|r| (r, ())).collect();
    let check_text = |text: &str| -> Result<(), String> {
        let mut parts = text.split('&');
        parts.next();
        for part in parts {
            let name = part
                .split(';')
                .next()
                .filter(|_| part.contains(';'))
                .ok_or_else(|| format!("bare & before {:?}", &part[..part.len().min(20)]))?;
            let numeric = name.strip_prefix('#').is_some_and(|n| !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()));
            if !numeric && !references.contains_key(name) {
                return Err(format!("unknown reference &{name};"));
            }
        }
        Ok(())
    };
    while !rest.is_empty() {
        let Some(open) = rest.find('<') else {
            if !stack.is_empty() {
                return Err(format!("unclosed <{}>", stack.last().unwrap()));
            }
            check_text(rest)?;
            if !rest.trim().is_empty() {
                return Err("text after the root element".into());
            }
            break;
        };
        let before = &rest[..open];
        check_text(before)?;
        if stack.is_empty() && !before.trim().is_empty() {
            return Err("text outside the root element".into());
        }
        rest = &rest[open..];
        if let Some(after) = rest.strip_prefix("<!--") {
            rest = &after[after.find("-->").ok_or("unclosed comment")? + 3..];
            continue;
        }
        // A tag: up to the first `>` outside a quoted value.
        let mut quote: Option<char> = None;
        let mut end = None;
        for (i, c) in rest.char_indices().skip(1) {
            match (quote, c) {
                (Some(q), c) if c == q => quote = None,
                (Some(_), '<') => return Err("< inside an attribute value".into()),
                (Some(_), _) => {}
                (None, '"' | '\'') => quote = Some(c),
                (None, '<') => return Err(format!("< inside a tag: {:?}", &rest[..i.min(40)])),
                (None, '>') => {
                    end = Some(i);
                    break;
                }
                _ => {}
            }
        }
        let end = end.ok_or("unclosed tag")?;
        let tag = &rest[1..end];
        rest = &rest[end + 1..];
        if let Some(name) = tag.strip_prefix('/') {
            match stack.pop() {
                Some(open) if open == name.trim() => {}
                other => return Err(format!("</{name}> closes {other:?}")),
            }
            continue;
        }
        let self_closing = tag.ends_with('/');
        let body = tag.trim_end_matches('/');
        let name = body.split_whitespace().next().ok_or("empty tag")?.to_string();
        let mut attributes = body[name.len()..].trim();
        while !attributes.is_empty() {
            let eq = attributes.find('=').ok_or_else(|| format!("attribute without a value in <{name}>"))?;
            let value = attributes[eq + 1..].trim_start();
            let q = value.chars().next().filter(|c| *c == '"' || *c == '\'').ok_or_else(|| format!("unquoted attribute in <{name}>"))?;
            let close = value[1..].find(q).ok_or("unclosed attribute value")? + 1;
            check_text(&value[1..close])?;
            attributes = value[close + 1..].trim_start();
        }
        if stack.is_empty() {
            if root.is_some() {
                return Err("a second root element".into());
            }
            root = Some(name.clone());
        }
        if !self_closing {
            stack.push(name);
        }
    }
    if let Some(open) = stack.last() {
        return Err(format!("unclosed <{open}>"));
    }
    root.ok_or_else(|| "no element".into())
}

/// Table 7's bold: the best condition on a benchmark and those not significantly worse than it
/// (exact McNemar against the best, Holm within the benchmark). On 12 tasks: the best solves all
/// 12; one solves 11 (b/c = 1/0, p = 1: bold); one solves 2 (b/c = 10/0, p = 0.002, 0.004 after
/// Holm: not bold).
#[test]
fn table_7_bolds_the_best_and_what_is_not_significantly_worse() {
    let (_tmp_dir, dir) = scratch("table-7-bold");
    for (mode, solved) in [("constrained-mcts", 12), ("constrained-greedy", 11), ("unconstrained-greedy", 2)] {
        let config = serde_json::json!({"agent": "ours", "benchmark": "alfworld-seen", "mode": mode, "lm": "uniform"});
        let mut file = eval_harness::records::RecordFile::open(&dir, "alfworld-seen-ours", &config, None, false).expect("opens");
        for task in 0..12 {
            let record = serde_json::json!({"task": format!("t{task:02}"), "agent": "ours", "success": task < solved});
            file.append(task, &record).expect("appends");
        }
    }
    let paths = record_paths(&[dir]).expect("record files");
    let sets: Vec<_> = paths.iter().map(|p| load(p).expect("a record file")).collect();
    let markdown = build(&sets, &ReportOptions::default()).expect("a report").markdown;
    let table = markdown.split("## ").find(|s| s.starts_with("Accuracy and robustness (Table 7)")).expect("Table 7");
    let row =
        |approach: &str| table.lines().find(|l| l.starts_with(&format!("| {approach} |"))).unwrap_or_else(|| panic!("{approach}: {table}"));
    assert!(row("Ours").contains("| **100.0 ± 0.0** |"), "{table}");
    assert!(row("Constrained greedy").contains("| **91.7 ± 0.0** |"), "{table}");
    assert!(row("Unconstrained greedy").contains("| 16.7 ± 0.0 |"), "{table}");
    let p = stats::holm_adjust(&[stats::mcnemar_exact_p(1, 0), stats::mcnemar_exact_p(10, 0)]).unwrap();
    assert!(p[0] >= 0.05 && p[1] < 0.05, "{p:?}");
}

/// Table 7 averages a condition's runs as they are; runs of different task sets (one seed's
/// run cut short) are marked with each run's task count, not averaged silently.
#[test]
fn table_7_marks_runs_of_different_task_sets() {
    let (_tmp_dir, dir) = scratch("table-7-runs");
    for (seed, tasks) in [(0, 12), (42, 12), (1738, 9)] {
        let config = serde_json::json!({"agent": "ours", "benchmark": "alfworld-seen", "mode": "sample", "lm": "uniform", "seed": seed});
        let mut file = eval_harness::records::RecordFile::open(&dir, "alfworld-seen-ours", &config, None, false).expect("opens");
        for task in 0..tasks {
            let record = serde_json::json!({"task": format!("t{task:02}"), "agent": "ours", "success": task % 2 == 0, "seed": seed});
            file.append(task, &record).expect("appends");
        }
    }
    let paths = record_paths(&[dir]).expect("record files");
    let sets: Vec<_> = paths.iter().map(|p| load(p).expect("a record file")).collect();
    let markdown = build(&sets, &ReportOptions::default()).expect("a report").markdown;
    let table = markdown.split("## ").find(|s| s.starts_with("Accuracy and robustness (Table 7)")).expect("Table 7");
    assert!(table.contains("(runs of 12/12/9 tasks)"), "{table}");
}

/// One run over two benchmarks is one condition: the task list a configuration names (`tasks`,
/// its count and digest, which differ by benchmark) belongs to the benchmark, as `subset` does.
#[test]
fn the_task_list_names_the_benchmark_not_the_condition() {
    let (_tmp_dir, dir) = scratch("task-lists");
    for (benchmark, count, digest) in [("alfworld-seen", 4, "aaaaaa"), ("virtualhome-eai", 3, "bbbbbb")] {
        let config = serde_json::json!({"agent": "ours", "benchmark": benchmark, "mode": "constrained-mcts", "lm": "uniform",
            "tasks": {"count": count, "ids_sha256": digest}, "files_sha256": {"/m.gguf": "cc"}});
        let mut file = eval_harness::records::RecordFile::open(&dir, &format!("{benchmark}-ours"), &config, None, false).expect("opens");
        for task in 0..count {
            file.append(task, &serde_json::json!({"task": format!("t{task}"), "agent": "ours", "success": true})).expect("appends");
        }
    }
    let paths = record_paths(&[dir]).expect("record files");
    let sets: Vec<_> = paths.iter().map(|p| load(p).expect("a record file")).collect();
    let markdown = build(&sets, &ReportOptions::default()).expect("a report").markdown;
    let table = markdown.split("## ").find(|s| s.starts_with("Accuracy and robustness (Table 7)")).expect("Table 7");
    let rows: Vec<&str> = table.lines().filter(|l| l.starts_with("| Ours")).collect();
    assert_eq!(rows.len(), 1, "{table}");
    assert!(!rows[0].contains('—') && !rows[0].contains("ids_sha256"), "{table}");
}

/// A folder after `merge` holds the shards and the merged file: the report reads the merged
/// file once, says the shards were left out, and its tables are those of the shards alone; a
/// shard resumed after the merge (a record the merged file lacks) asks for the merge again.
#[test]
fn shards_beside_their_merged_file_are_read_once() {
    let (_tmp_dir, dir) = fixture_copy("merged");
    let stem = "virtualhome-rearrange-planner-1a1f05079ed4";
    let shards: Vec<PathBuf> = (1..=2).map(|i| dir.join(format!("{stem}.shard-{i}-of-2.jsonl"))).collect();
    let merged = eval_harness::records::merge(&shards, false).expect("the shards merge");
    assert_eq!(merged.path, dir.join(format!("{stem}.jsonl")));

    let report_of = |dir: &Path| {
        let sets: Vec<_> = record_paths(&[dir.to_path_buf()]).unwrap().iter().map(|p| load(p).unwrap()).collect();
        build(&sets, &ReportOptions::default())
    };
    let report = report_of(&dir).expect("a report");
    let tables = |markdown: &str| markdown[markdown.find("\n## ").expect("a table")..].to_string();
    assert_eq!(tables(&report.markdown), tables(&fixture_report().markdown), "the same tables as from the shards alone");
    for shard in &shards {
        let note = format!("- left out: {}: its records are those of the merged {}", shard.display(), merged.path.display());
        assert!(report.markdown.contains(&note), "{}", report.markdown);
    }
    assert_eq!(report.episodes.len(), fixture_report().episodes.len(), "one page per episode, not one per copy");

    // A shard resumed after the merge: its new record is not in the merged file.
    let text = std::fs::read_to_string(&shards[1]).unwrap();
    let mut last: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    last["task"] = "a-task-run-after-the-merge".into();
    last["index"] = 99.into();
    std::fs::write(&shards[1], format!("{text}{last}\n")).unwrap();
    let error = message(report_of(&dir));
    let line = text.lines().count() + 1;
    assert!(error.starts_with(&format!("{}:{line}:", shards[1].display())), "{error}");
    assert!(error.contains("merge the shards again"), "{error}");
}

/// A file with no record yet (a run that has not finished its first task) is left out with a
/// note, and an empty unsharded file beside the shards is not their merged file: the shards
/// are read as they are, as `eval` resumes them beside it.
#[test]
fn files_without_records_are_left_out_and_stand_for_no_merge() {
    let (_tmp_dir, dir) = fixture_copy("empty");
    let stem = "virtualhome-rearrange-planner-1a1f05079ed4";
    let empty = dir.join(format!("{stem}.jsonl"));
    std::fs::write(&empty, "").unwrap();
    let sets: Vec<_> = record_paths(std::slice::from_ref(&dir)).unwrap().iter().map(|p| load(p).unwrap()).collect();
    let report = build(&sets, &ReportOptions::default()).expect("a report");
    let tables = |markdown: &str| markdown[markdown.find("\n## ").expect("a table")..].to_string();
    assert_eq!(tables(&report.markdown), tables(&fixture_report().markdown), "the shards' tables");
    assert!(report.markdown.contains(&format!("- left out: {}: no record yet", empty.display())), "{}", report.markdown);
    assert!(!report.markdown.contains("its records are those of the merged"), "{}", report.markdown);
}

/// One run of `ours`: its mode, its seed, the tasks it ran (`t00`, ...), which of them it solved.
type RunSpec<'a> = (&'a str, Option<u64>, &'a [usize], fn(usize) -> bool);

/// Record files of `ours` on ALFWorld, one per run, and the report's Markdown.
fn runs_of(dir: &Path, runs: &[RunSpec<'_>]) -> String {
    for &(mode, seed, ran, solves) in runs {
        let mut config = serde_json::json!({"agent": "ours", "benchmark": "alfworld-seen", "mode": mode, "lm": "uniform"});
        if let Some(seed) = seed {
            config["seed"] = seed.into();
        }
        let mut file = eval_harness::records::RecordFile::open(dir, "alfworld-seen-ours", &config, None, false).expect("opens");
        for (index, &task) in ran.iter().enumerate() {
            let record = serde_json::json!({"task": format!("t{task:02}"), "agent": "ours", "success": solves(task)});
            file.append(index, &record).expect("appends");
        }
    }
    let paths = record_paths(&[dir.to_path_buf()]).expect("record files");
    let sets: Vec<_> = paths.iter().map(|p| load(p).expect("a record file")).collect();
    build(&sets, &ReportOptions::default()).expect("a report").markdown
}

/// The one row of the McNemar section `heading` that compares two conditions.
fn comparison_row<'a>(markdown: &'a str, heading: &str) -> &'a str {
    let section = section_of(markdown, heading);
    let rows: Vec<&str> = section.lines().filter(|l| l.contains(" vs. ")).collect();
    assert_eq!(rows.len(), 1, "{section}");
    rows[0]
}

/// Two conditions with several runs are paired seed with seed (Appendix B pairs runs, it does
/// not cross them): seed 0 of sampling solves all ten tasks where seed 0 of constrained sampling
/// solves none, and seed 42 the other way round, so each seed's pair differs on every task (b/c
/// 10/0 and 0/10, p = 2/2^10). Crossed, seed 0 against seed 42 is the same outcome twice (p = 1).
#[test]
fn two_conditions_with_several_runs_are_paired_seed_with_seed() {
    let (_tmp_dir, dir) = scratch("seed-pairs");
    let all: &[usize] = &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9];
    let markdown = runs_of(
        &dir,
        &[
            ("sample", Some(0), all, |_| true),
            ("sample", Some(42), all, |_| false),
            ("constrained-sample", Some(0), all, |_| false),
            ("constrained-sample", Some(42), all, |_| true),
        ],
    );
    let row = comparison_row(&markdown, "## Paired significance: comparisons beyond the paper's families");
    let p = stats::mcnemar_exact_p(10, 0);
    assert!((p - 2.0 / 1024.0).abs() < 1e-12, "{p}");
    assert!(row.contains(&format!("| 10 (10/0) | {p:.3} |")) || row.contains(&format!("| 10 (0/10) | {p:.3} |")), "{row}");
}

/// Each run pair is tested on the tasks its own two runs share, not on the tasks every run
/// holds: seed 1738 of sampling ran the first six of the twelve tasks. Constrained MCTS solves all twelve;
/// seeds 0 and 42 solve tasks 0-5 only (b/c 6/0 over twelve tasks, p = 2/2^6), seed 1738
/// fails its six (6/0, the same p). Cut to the six tasks every run holds, seeds 0 and 42 would
/// equal constrained MCTS there (p = 1) and hide the difference.
#[test]
fn each_run_pair_is_tested_on_the_tasks_it_shares() {
    let (_tmp_dir, dir) = scratch("run-pair-tasks");
    let all: &[usize] = &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11];
    let markdown = runs_of(
        &dir,
        &[
            ("constrained-mcts", None, all, |_| true),
            ("sample", Some(0), all, |t| t < 6),
            ("sample", Some(42), all, |t| t < 6),
            ("sample", Some(1738), &[0, 1, 2, 3, 4, 5], |_| false),
        ],
    );
    let row = comparison_row(&markdown, "## Paired significance: comparisons beyond the paper's families");
    let p = stats::mcnemar_exact_p(6, 0);
    assert!(p < 0.05, "{p}");
    assert!(row.contains(&format!("| 12 (6/0) | {p:.3} | {p:.3} | ✓ |")), "{row}");
}

/// A run whose seed the other condition lacks is in a pair all the same, against each run of
/// the other: sampling has seeds 0 and 42, constrained sampling 0 and 1738. Seed 0 with seed 0
/// differs on all ten tasks (p = 0.002), but seed 42 and seed 1738 solve the same tasks (p = 1),
/// and the largest p is kept.
#[test]
fn a_run_without_a_seed_to_match_is_paired_with_every_run() {
    let (_tmp_dir, dir) = scratch("unmatched-seeds");
    let all: &[usize] = &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9];
    let markdown = runs_of(
        &dir,
        &[
            ("sample", Some(0), all, |_| true),
            ("sample", Some(42), all, |_| true),
            ("constrained-sample", Some(0), all, |_| false),
            ("constrained-sample", Some(1738), all, |_| true),
        ],
    );
    let row = comparison_row(&markdown, "## Paired significance: comparisons beyond the paper's families");
    assert!(row.contains("| 10 (0/0) | 1.000 |"), "{row}");
}

/// Table 8 says whether its conditions planned from the same Phase I state, as the paper's
/// Phase II comparisons do: three conditions of one model, the same hand-over on t00 and t01,
/// another on t02 in one of them, and t03 run by two of the three only (not shared).
#[test]
fn table_8_says_whether_the_conditions_planned_from_the_same_hand_over() {
    let (_tmp_dir, dir) = scratch("shared-handover");
    let handover = |task: usize, mode: &str| {
        let at = if task == 2 && mode == "constrained-greedy" { "(at mug_1 drawer_2)" } else { "(at mug_1 drawer_1)" };
        serde_json::json!({"problem": format!("(define (problem t{task:02}) (:init {at}))"), "binding": {"mug_1": "mug 1"}})
    };
    for (mode, tasks) in [("constrained-mcts", 4), ("unconstrained-mcts", 4), ("constrained-greedy", 3)] {
        let config = serde_json::json!({"agent": "ours", "benchmark": "alfworld-seen", "mode": mode, "lm": "uniform"});
        let mut file = eval_harness::records::RecordFile::open(&dir, "alfworld-seen-ours", &config, None, false).expect("opens");
        for task in 0..tasks {
            let record = serde_json::json!({
                "task": format!("t{task:02}"), "agent": "ours", "success": task == 0,
                "episode": {"handover": handover(task, mode)},
            });
            file.append(task, &record).expect("appends");
        }
    }
    let sets: Vec<_> = record_paths(std::slice::from_ref(&dir)).unwrap().iter().map(|p| load(p).unwrap()).collect();
    let markdown = build(&sets, &ReportOptions::default()).unwrap().markdown;
    let table_8 = section_of(&markdown, "## Phase II conditions by model");
    let expected = "alfworld-seen, uniform prior: Phase I's hand-over (ŝ0 and β) is the same in all 3 runs on 2 of the 3 tasks they \
                    share; on the other 1 (t02) the conditions planned from different states, so they differ in more than planning.";
    assert!(table_8.contains(expected), "{table_8}");
    // The same three with the one state mended: every shared task agrees.
    let greedy = sets.iter().find(|s| s.config_str("mode") == Some("constrained-greedy")).unwrap();
    let mut mended = greedy.clone();
    for record in &mut mended.records {
        let task: usize = record.fields["task"].as_str().unwrap()[1..].parse().unwrap();
        record.fields["episode"]["handover"] = handover(task, "constrained-mcts");
    }
    let sets: Vec<_> = sets.iter().map(|s| if s.path == greedy.path { mended.clone() } else { s.clone() }).collect();
    let markdown = build(&sets, &ReportOptions::default()).unwrap().markdown;
    assert!(markdown.contains("is the same in all 3 runs on 3 of the 3 tasks they share."), "{markdown}");
    // A record without its episode says nothing of its hand-over: left out, and said.
    let mut cut = mended.clone();
    cut.records[0].fields.remove("episode");
    let sets: Vec<_> = sets.iter().map(|s| if s.path == greedy.path { cut.clone() } else { s.clone() }).collect();
    let markdown = build(&sets, &ReportOptions::default()).unwrap().markdown;
    let expected = "is the same in all 3 runs on 2 of the 2 tasks they share and whose records hold the episode (1 without it left out).";
    assert!(markdown.contains(expected), "{markdown}");
}
