//! The stratified subsets in `fixtures/subsets/`: they load, cover every family, and are what
//! the rule derives today, so a file cannot silently drift from the fixtures or the rule.

use benchmark_data::{Benchmark, DataError, TaskFiles, load_subset, stratified_subset, subset_ids, subset_path, task_family};

const SUBSETS: [(Benchmark, &str); 2] = [(Benchmark::AlfworldSeen, "alfworld-seen-50"), (Benchmark::VirtualhomeEai, "virtualhome-eai-50")];

/// The stratified subsets of other sizes: `cargo xtask eval`'s default for ALFWorld.
const SMALL_SUBSETS: [(Benchmark, &str, usize); 1] = [(Benchmark::AlfworldSeen, "alfworld-seen-12", 12)];

fn families(tasks: &[TaskFiles]) -> Vec<&str> {
    let mut out: Vec<&str> = tasks.iter().map(task_family).collect();
    out.sort();
    out.dedup();
    out
}

#[test]
fn subset_files_list_fifty_known_tasks_from_every_family() {
    for (benchmark, name) in SUBSETS {
        let all = benchmark_data::load(benchmark).expect("benchmark loads");
        let subset = load_subset(benchmark, name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(subset.len(), 50, "{name}");
        let mut ids: Vec<&str> = subset.iter().map(|t| t.id.as_str()).collect();
        ids.sort();
        ids.dedup();
        assert_eq!(ids.len(), 50, "{name}: ids are unique");
        assert_eq!(families(&subset), families(&all), "{name}: every family is present");
    }
}

#[test]
fn subset_files_are_what_the_rule_derives() {
    for (benchmark, name) in SUBSETS {
        let all = benchmark_data::load(benchmark).expect("benchmark loads");
        let derived: Vec<String> = stratified_subset(&all, 50).into_iter().map(|t| t.id.clone()).collect();
        let listed: Vec<String> = subset_ids(&subset_path(name)).expect("subset file reads").into_iter().map(|(_, id)| id).collect();
        assert_eq!(listed, derived, "{name} differs from `stratified_subset(load({}), 50)`", benchmark.name());
    }
    for (benchmark, name, size) in SMALL_SUBSETS {
        let all = benchmark_data::load(benchmark).expect("benchmark loads");
        let derived: Vec<String> = stratified_subset(&all, size).into_iter().map(|t| t.id.clone()).collect();
        if std::env::var_os("NSEA_PRINT_SUBSETS").is_some() {
            eprintln!("{name}:\n{}", derived.join("\n"));
        }
        let listed: Vec<String> = subset_ids(&subset_path(name)).expect("subset file reads").into_iter().map(|(_, id)| id).collect();
        assert_eq!(listed, derived, "{name} differs from `stratified_subset(load({}), {size})`", benchmark.name());
    }
}

#[test]
fn the_rule_gives_alfworld_families_seats_by_largest_remainder() {
    // 140 games in 6 types (13, 35, 27, 25, 16, 24): one each, then 44 seats over the
    // remaining 134 in proportion: floors 3, 11, 8, 7, 4, 7 leave 4 seats, which go to the
    // largest remainders (look 0.94, heat 0.93, cool 0.88, two 0.55).
    let all = benchmark_data::load(Benchmark::AlfworldSeen).expect("benchmark loads");
    let subset = stratified_subset(&all, 50);
    let count = |family: &str| subset.iter().filter(|t| task_family(t) == family).count();
    let counts: Vec<usize> = families(&all).into_iter().map(count).collect();
    assert_eq!(families(&all).len(), 6);
    assert_eq!(counts, [5, 12, 9, 9, 6, 9]);
}

#[test]
fn the_rule_spreads_picks_over_a_family_and_never_repeats_one() {
    let all = benchmark_data::load(Benchmark::VirtualhomeEai).expect("benchmark loads");
    for size in [26, 27, 50, 100, 337] {
        let subset = stratified_subset(&all, size);
        assert_eq!(subset.len(), size);
        let mut ids: Vec<&str> = subset.iter().map(|t| t.id.as_str()).collect();
        ids.dedup();
        assert_eq!(ids.len(), size, "sorted and without repeats");
        assert_eq!(families(&subset.into_iter().cloned().collect::<Vec<_>>()), families(&all));
    }
    assert_eq!(stratified_subset(&all, 10).len(), all.len(), "fewer seats than families: the whole set");
}

#[test]
fn an_unknown_or_repeated_id_is_reported_at_its_line() {
    let tmp = tempfile::Builder::new().prefix("benchmark-data-subsets-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let unknown = dir.join("unknown.txt");
    std::fs::write(&unknown, "# header\n384_1\n\nno_such_task\n").expect("write");
    let error = load_subset(Benchmark::VirtualhomeEai, unknown.to_str().expect("utf-8 path")).expect_err("unknown id");
    assert!(matches!(&error, DataError::UnknownSubsetTask { line: 4, id, .. } if id == "no_such_task"), "{error}");
    assert!(error.to_string().contains("unknown.txt:4: no task `no_such_task` in virtualhome-eai"), "{error}");
    let repeated = dir.join("repeated.txt");
    std::fs::write(&repeated, "384_1\n384_1\n").expect("write");
    let error = load_subset(Benchmark::VirtualhomeEai, repeated.to_str().expect("utf-8 path")).expect_err("repeated id");
    assert!(matches!(&error, DataError::DuplicateSubsetTask { line: 2, .. }), "{error}");
    // A name that is no subset lists the subsets there are; a path is named as given.
    let error = load_subset(Benchmark::AlfworldSeen, "alfworld-seen-13").expect_err("no such subset");
    assert!(matches!(&error, DataError::UnknownSubset { name, .. } if name == "alfworld-seen-13"), "{error}");
    assert!(error.to_string().contains("alfworld-seen-12, alfworld-seen-50"), "{error}");
    let error = load_subset(Benchmark::AlfworldSeen, dir.join("absent.txt").to_str().expect("utf-8 path")).expect_err("no file");
    assert!(matches!(&error, DataError::Io { .. }), "{error}");
}

#[test]
fn the_alfworld_heldout_subset_is_the_rule_over_the_tasks_outside_the_fifty() {
    let all = benchmark_data::load(Benchmark::AlfworldSeen).expect("benchmark loads");
    let fifty: Vec<String> = load_subset(Benchmark::AlfworldSeen, "alfworld-seen-50").expect("subset").into_iter().map(|t| t.id).collect();
    let rest: Vec<TaskFiles> = all.iter().filter(|t| !fifty.contains(&t.id)).cloned().collect();
    let derived: Vec<String> = stratified_subset(&rest, 24).into_iter().map(|t| t.id.clone()).collect();
    let name = "alfworld-seen-heldout-24";
    let listed: Vec<String> = subset_ids(&subset_path(name)).expect("subset file reads").into_iter().map(|(_, id)| id).collect();
    assert_eq!(listed, derived, "{name} differs from the rule over valid_seen minus alfworld-seen-50");
    assert!(listed.iter().all(|id| !fifty.contains(id)), "disjoint from alfworld-seen-50");
    assert_eq!(families(&load_subset(Benchmark::AlfworldSeen, name).expect("loads")), families(&all));
}

/// A caller passes its own root: a copy of one IPC domain elsewhere loads from there, ids and
/// subsets resolve against it, and a root without the data is an error naming the path.
#[test]
fn fixtures_load_from_a_root_the_caller_passes() {
    let tmp = tempfile::Builder::new().prefix("nsea-fixtures-root-").tempdir().expect("temp dir");
    let root = tmp.path();
    let domain = root.join("ipc").join("blocks");
    std::fs::create_dir_all(&domain).expect("temp dir");
    std::fs::create_dir_all(root.join("subsets")).expect("temp dir");
    let checkout = benchmark_data::Fixtures::checkout();
    for file in ["domain.pddl", "instance-10.pddl"] {
        std::fs::copy(checkout.root().join("ipc/blocks").join(file), domain.join(file)).expect("copy");
    }
    std::fs::write(root.join("subsets").join("mine.txt"), "# one task\nblocks/instance-10\n").expect("subset");
    let fixtures = benchmark_data::Fixtures::at(root);
    let tasks = fixtures.load(Benchmark::Ipc).expect("loads");
    assert_eq!(tasks.iter().map(|t| t.id.as_str()).collect::<Vec<_>>(), ["blocks/instance-10"]);
    assert!(tasks[0].problem_path.starts_with(root));
    let original = benchmark_data::load(Benchmark::Ipc).expect("checkout loads");
    let same = original.iter().find(|t| t.id == "blocks/instance-10").expect("in the checkout");
    assert_eq!(tasks[0].problem, same.problem);
    assert_eq!(fixtures.load_subset(Benchmark::Ipc, "mine").expect("subset").len(), 1);
    let missing = benchmark_data::Fixtures::at(root.join("nowhere")).load(Benchmark::Ipc).expect_err("no data there");
    assert!(missing.to_string().contains("nowhere"), "{missing}");
}

/// The rearrangement set's subsets: every k-th task id in sorted order from the first (the rule
/// written in each file).
#[test]
fn rearrangement_subsets_are_every_kth_task() {
    let dir = benchmark_data::fixtures_dir().join("virtualhome-rearrange");
    let mut ids: Vec<String> = std::fs::read_dir(&dir)
        .expect("the rearrangement set is in fixtures/")
        .flatten()
        .filter_map(|e| e.file_name().to_str().and_then(|n| n.strip_suffix(".json.gz")).map(str::to_string))
        .collect();
    ids.sort();
    assert_eq!(ids.len(), 200);
    for (name, step, size) in [("virtualhome-rearrange-50", 4, 50), ("virtualhome-rearrange-8", 25, 8)] {
        let listed: Vec<String> = subset_ids(&subset_path(name)).expect("subset file reads").into_iter().map(|(_, id)| id).collect();
        let expected: Vec<String> = ids.iter().step_by(step).cloned().collect();
        assert_eq!(listed.len(), size, "{name}");
        assert_eq!(listed, expected, "{name}: every {step}th id");
    }
}

/// The build's checkout is used while it is there; when it is gone (a moved checkout, a build
/// cache filled from another path), the `fixtures/` of the working directory or a folder above
/// it; with neither, the build's path, so that the error names it.
#[test]
fn fixtures_are_found_above_the_working_directory_when_the_build_path_is_gone() {
    let tmp = tempfile::Builder::new().prefix("nsea-fixtures-locate-").tempdir().expect("temp dir");
    let root = tmp.path();
    let found = root.join("checkout").join("fixtures");
    let deep = root.join("checkout").join("crates").join("xtask");
    std::fs::create_dir_all(found.join("subsets")).expect("temp dir");
    std::fs::create_dir_all(&deep).expect("temp dir");
    let gone = root.join("moved-away").join("fixtures");
    assert_eq!(benchmark_data::locate_fixtures(&gone, &deep), found);
    assert_eq!(benchmark_data::locate_fixtures(&gone, &root.join("checkout")), found);
    let built = benchmark_data::Fixtures::checkout();
    assert_eq!(benchmark_data::locate_fixtures(built.root(), &deep), built.root(), "the build's checkout comes first");
    assert_eq!(benchmark_data::locate_fixtures(&gone, root), gone, "nothing above: the build's path");
}
