//! Records: named by their configuration, resumed, cut back to whole records after a crash,
//! never mixed, sharded and merged back to what one run writes.

use std::path::{Path, PathBuf};

use eval_harness::records::{RecordError, RecordFile, Shard, config_hash, merge};
use serde_json::{Value, json};

/// A records folder that does not exist yet, inside a temporary folder that is removed when the
/// returned guard is dropped, also when the test fails.
fn scratch(name: &str) -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::Builder::new().prefix("eval-records-").tempdir().expect("temporary folder");
    let dir = tmp.path().join(name);
    (tmp, dir)
}

fn tasks(file: &RecordFile) -> Vec<String> {
    file.records().iter().map(|r| r["task"].as_str().unwrap_or_default().to_string()).collect()
}

#[test]
fn records_resume_and_carry_their_configuration() {
    let (_tmp_dir, dir) = scratch("resume");
    let config = json!({"agent": "expert", "benchmark": "alfworld-seen", "seed": 0});
    let mut file = RecordFile::open(&dir, "alfworld-seen-expert", &config, None, false).expect("opens");
    assert!(file.path().ends_with(format!("alfworld-seen-expert-{}.jsonl", config_hash(&config))));
    file.append(0, &json!({"task": "a", "success": true})).expect("appends");
    file.append(1, &json!({"task": "b", "success": false})).expect("appends");
    drop(file);
    let reopened = RecordFile::open(&dir, "alfworld-seen-expert", &config, None, false).expect("reopens");
    assert_eq!(tasks(&reopened), ["a", "b"]);
    assert!(reopened.done().contains("b"));
    assert_eq!(reopened.records()[1]["index"], 1);
    assert_eq!(reopened.records()[1]["config"], Value::from(config_hash(&config)));
    // Keys are sorted before hashing: the same configuration written in another order is the same run.
    let reordered: Value = serde_json::from_str(r#"{"seed": 0, "benchmark": "alfworld-seen", "agent": "expert"}"#).expect("json");
    assert_eq!(config_hash(&reordered), config_hash(&config));
    // Another setting is another file.
    let other = json!({"agent": "expert", "benchmark": "alfworld-seen", "seed": 42});
    assert_ne!(config_hash(&other), config_hash(&config));
    assert!(RecordFile::open(&dir, "alfworld-seen-expert", &other, None, false).expect("opens").records().is_empty());
    // A task recorded already is refused, and nothing is written.
    let mut reopened = reopened;
    assert!(matches!(reopened.append(2, &json!({"task": "a", "success": true})), Err(RecordError::Duplicate { task, .. }) if task == "a"));
    drop(reopened);
    let reopened = RecordFile::open(&dir, "alfworld-seen-expert", &config, None, false).expect("reopens");
    assert_eq!(tasks(&reopened), ["a", "b"]);
    // --fresh starts this configuration over (once the run that has it open is done).
    drop(reopened);
    assert!(RecordFile::open(&dir, "alfworld-seen-expert", &config, None, true).expect("opens").records().is_empty());
}

/// The configuration file beside the records is compared as the hash compares configurations:
/// the same settings written with the keys in another order (a build without serde_json's
/// `preserve_order`) are the same run; another setting is refused.
#[test]
fn a_configuration_file_is_compared_by_its_content_not_its_text() {
    let (_tmp_dir, dir) = scratch("config-text");
    let config = json!({"agent": "ours", "benchmark": "alfworld-seen", "seed": 0});
    let mut file = RecordFile::open(&dir, "run", &config, None, false).expect("opens");
    file.append(0, &json!({"task": "a", "success": true})).expect("appends");
    drop(file);
    let config_path = dir.join(format!("run-{}.config.json", config_hash(&config)));
    std::fs::write(&config_path, "{\"seed\":0,\n \"benchmark\": \"alfworld-seen\", \"agent\": \"ours\"}").expect("rewrites");
    assert_eq!(tasks(&RecordFile::open(&dir, "run", &config, None, false).expect("the same run")), ["a"]);
    std::fs::write(&config_path, r#"{"seed": 1, "benchmark": "alfworld-seen", "agent": "ours"}"#).expect("rewrites");
    let error = RecordFile::open(&dir, "run", &config, None, false).expect_err("another run's configuration");
    assert!(
        matches!(&error, RecordError::ConfigMismatch { expected, found, .. } if *expected == config_hash(&config) && found != expected),
        "{error}"
    );
}

#[test]
fn one_run_at_a_time_writes_a_record_file() {
    let (_tmp_dir, dir) = scratch("busy");
    let config = json!({"agent": "ours", "benchmark": "alfworld-seen"});
    let mut first = RecordFile::open(&dir, "alfworld-seen-ours", &config, None, false).expect("opens");
    first.append(0, &json!({"task": "a", "success": true})).expect("appends");
    // A second run of the same configuration into the same folder is refused, --fresh or not,
    // and leaves the first run's records alone.
    for fresh in [false, true] {
        let second = RecordFile::open(&dir, "alfworld-seen-ours", &config, None, fresh);
        assert!(matches!(&second, Err(RecordError::Busy { .. })), "{second:?}");
        let error = second.expect_err("busy").to_string();
        assert!(error.contains("another run is writing these records"), "{error}");
    }
    // Another configuration, or another shard of this one, is another file and runs beside it.
    let other = json!({"agent": "ours", "benchmark": "alfworld-seen", "seed": 42});
    RecordFile::open(&dir, "alfworld-seen-ours", &other, None, false).expect("another configuration");
    let shard: Shard = "1/2".parse().expect("shard");
    RecordFile::open(&dir, "alfworld-seen-ours", &config, Some(shard), false).expect("a shard");
    first.append(1, &json!({"task": "b", "success": false})).expect("appends");
    drop(first);
    // The lock ends with its run.
    assert_eq!(tasks(&RecordFile::open(&dir, "alfworld-seen-ours", &config, None, false).expect("reopens")), ["a", "b"]);
}

#[test]
fn a_record_cut_short_is_cut_off_and_its_task_runs_again() {
    let (_tmp_dir, dir) = scratch("torn");
    let config = json!({"agent": "expert"});
    let mut file = RecordFile::open(&dir, "run", &config, None, false).expect("opens");
    file.append(0, &json!({"task": "a"})).expect("appends");
    let path = file.path().to_path_buf();
    drop(file);
    // A crash in the middle of the second record.
    let mut text = std::fs::read_to_string(&path).expect("reads");
    text.push_str(r#"{"task":"b","succ"#);
    std::fs::write(&path, &text).expect("writes");
    let mut file = RecordFile::open(&dir, "run", &config, None, false).expect("recovers");
    assert_eq!(tasks(&file), ["a"]);
    file.append(1, &json!({"task": "b"})).expect("appends");
    let lines: Vec<Value> =
        std::fs::read_to_string(&path).expect("reads").lines().map(|l| serde_json::from_str(l).expect("whole records")).collect();
    assert_eq!(lines.len(), 2);
    drop(file);

    // Cut inside a character (a model's reply is written as raw UTF-8): the same.
    let mut bytes = std::fs::read(&path).expect("reads");
    bytes.extend_from_slice("{\"task\":\"c\",\"reply\":\"caf\u{e9}".as_bytes());
    bytes.pop();
    assert!(std::str::from_utf8(&bytes).is_err(), "the cut falls inside the character");
    std::fs::write(&path, &bytes).expect("writes");
    let mut file = RecordFile::open(&dir, "run", &config, None, false).expect("recovers");
    assert_eq!(tasks(&file), ["a", "b"]);
    // The cut record stays until the run has checked the file and settles it, or appends.
    assert_eq!(std::fs::read(&path).expect("reads"), bytes);
    file.settle().expect("settles");
    drop(file);
    assert_eq!(std::fs::read_to_string(&path).expect("UTF-8 again").lines().count(), 2);

    // Without `settle`, the first append cuts it off first.
    let mut bytes = std::fs::read(&path).expect("reads");
    bytes.extend_from_slice(b"{\"task\":\"c\",\"suc");
    std::fs::write(&path, &bytes).expect("writes");
    let mut file = RecordFile::open(&dir, "run", &config, None, false).expect("recovers");
    file.append(2, &json!({"task": "c"})).expect("appends");
    drop(file);
    let text = std::fs::read_to_string(&path).expect("whole lines");
    assert_eq!(text.lines().map(|l| serde_json::from_str::<Value>(l).expect("whole")["task"].clone()).collect::<Vec<_>>(), ["a", "b", "c"]);

    // A file that changed since it was read (another writer, where there are no locks): its
    // cut line is no longer the last, and nothing is cut.
    std::fs::write(&path, format!("{text}{{\"task\":\"d\"")).expect("writes");
    let mut file = RecordFile::open(&dir, "run", &config, None, false).expect("recovers");
    let grown = format!("{text}{{\"task\":\"d\"}}\n");
    std::fs::write(&path, &grown).expect("another writer");
    file.settle().expect("settles");
    drop(file);
    assert_eq!(std::fs::read_to_string(&path).expect("reads"), grown);
}

/// A file refused for damage before its cut record is left as it was: the cut is made only
/// once the run has checked the file.
#[test]
fn a_refused_file_keeps_its_cut_record() {
    let (_tmp_dir, dir) = scratch("refused-torn");
    let config = json!({"agent": "expert"});
    let path = RecordFile::open(&dir, "run", &config, None, false).expect("opens").path().to_path_buf();
    let damaged = format!("not json\n{{\"task\":\"a\",\"config\":\"{}\",\"succ", config_hash(&config));
    std::fs::write(&path, &damaged).expect("writes");
    let error = RecordFile::open(&dir, "run", &config, None, false).expect_err("damaged");
    assert!(matches!(error, RecordError::Bad { line: 1, .. }), "{error}");
    assert_eq!(std::fs::read_to_string(&path).expect("reads"), damaged);
    // A task that is not the run's is refused after the open, by `check_tasks`: the same.
    let whole = format!("{{\"task\":\"z\",\"config\":\"{}\"}}\n{{\"task\":\"a\"", config_hash(&config));
    std::fs::write(&path, &whole).expect("writes");
    let file = RecordFile::open(&dir, "run", &config, None, false).expect("opens");
    assert!(file.check_tasks(&["a"].into_iter().collect()).is_err());
    drop(file);
    assert_eq!(std::fs::read_to_string(&path).expect("reads"), whole);
}

#[test]
fn damage_other_than_a_cut_is_an_error_naming_the_line() {
    let (_tmp_dir, dir) = scratch("damage");
    let config = json!({"agent": "expert"});
    let path = RecordFile::open(&dir, "run", &config, None, false).expect("opens").path().to_path_buf();
    let hash = config_hash(&config);
    std::fs::write(&path, format!("{{\"task\":\"a\",\"config\":\"{hash}\"}}\nnot json\n")).expect("writes");
    let error = RecordFile::open(&dir, "run", &config, None, false).expect_err("damaged");
    assert!(matches!(error, RecordError::Bad { line: 2, .. }), "{error}");
    std::fs::write(&path, "{\"task\":\"a\",\"config\":\"0123456789ab\"}\n").expect("writes");
    let error = RecordFile::open(&dir, "run", &config, None, false).expect_err("another configuration's record");
    assert!(error.to_string().contains(":1:"), "{error}");
    std::fs::write(&path, format!("{{\"task\":\"a\",\"config\":\"{hash}\"}}\n{{\"task\":\"a\",\"config\":\"{hash}\"}}\n")).expect("writes");
    assert!(RecordFile::open(&dir, "run", &config, None, false).expect_err("twice").to_string().contains("twice"));
    // A whole line that is not UTF-8 is named, not the file as a whole.
    let mut bytes = format!("{{\"task\":\"a\",\"config\":\"{hash}\"}}\n").into_bytes();
    bytes.extend_from_slice(b"{\"task\":\"b\xff\"}\n");
    std::fs::write(&path, &bytes).expect("writes");
    let error = RecordFile::open(&dir, "run", &config, None, false).expect_err("not UTF-8");
    assert!(matches!(error, RecordError::Bad { line: 2, .. }), "{error}");
    // An edited configuration file is refused rather than silently resumed.
    std::fs::write(&path, "").expect("writes");
    std::fs::write(dir.join(format!("run-{hash}.config.json")), "{\"agent\": \"direct\"}\n").expect("writes");
    assert!(matches!(RecordFile::open(&dir, "run", &config, None, false), Err(RecordError::ConfigMismatch { .. })));
    // A configuration file that is not JSON is named as such, with its line.
    std::fs::write(dir.join(format!("run-{hash}.config.json")), "{\"agent\":\n nope}\n").expect("writes");
    let error = RecordFile::open(&dir, "run", &config, None, false).expect_err("not JSON");
    assert!(matches!(&error, RecordError::Bad { line: 2, path, .. } if path.ends_with(format!("run-{hash}.config.json"))), "{error}");
    assert!(error.to_string().contains("not a configuration"), "{error}");
}

/// A prior from a record of the unconstrained-MCTS run (`results/unc-mcts-cpu/`): serde_json
/// reads it back one ulp off, so a merge that wrote the parsed records again changed it.
const PRIOR: f64 = 1.8446783331942791e-07;

/// The merged file holds the shards' lines as they were written, byte for byte what one run
/// writes.
#[test]
fn shards_merge_into_what_one_run_writes() {
    let (_tmp_dir, dir) = scratch("shards");
    let config = json!({"agent": "expert", "benchmark": "ipc"});
    let names = ["t0", "t1", "t2", "t3", "t4", "t5", "t6"];
    let mut whole = RecordFile::open(&dir.join("whole"), "run", &config, None, false).expect("opens");
    for (i, name) in names.iter().enumerate() {
        whole.append(i, &json!({"task": name, "steps": i, "success": true, "prior": PRIOR})).expect("appends");
    }
    let mut shard_paths = Vec::new();
    for index in 1..=3 {
        let shard = Shard { index, count: 3 };
        let mut file = RecordFile::open(&dir.join("sharded"), "run", &config, Some(shard), false).expect("opens");
        for (i, name) in names.iter().enumerate().filter(|(i, _)| shard.selects(*i)) {
            file.append(i, &json!({"task": name, "steps": i, "success": true, "prior": PRIOR})).expect("appends");
        }
        shard_paths.push(file.path().to_path_buf());
    }
    // Every shard of the run is needed: the merged file stands for the whole run.
    let error = merge(&shard_paths[..2], false).expect_err("a shard short");
    assert!(error.to_string().contains("shard(s) 3 of 3 not given"), "{error}");
    let merged = merge(&shard_paths, false).expect("merges");
    assert_eq!((merged.records, merged.expected), (names.len(), None), "a configuration without a task count");
    assert_eq!(std::fs::read_to_string(&merged.path).expect("reads"), std::fs::read_to_string(whole.path()).expect("reads"));
    assert!(merge(&shard_paths, false).is_err(), "merging again over the result is refused");
    // Shards of another configuration do not merge.
    let other = RecordFile::open(&dir.join("sharded"), "run", &json!({"agent": "planner"}), Some(Shard { index: 1, count: 2 }), false);
    let mut other = other.expect("opens");
    other.append(0, &json!({"task": "x", "success": true})).expect("appends");
    std::fs::remove_file(&merged.path).expect("removes");
    let error = merge(&[shard_paths[0].clone(), other.path().to_path_buf()], false).expect_err("mixed");
    assert!(error.to_string().contains("different runs"), "{error}");
}

/// A merged file stands for the whole run: shards that stopped short (killed, not resumed) are
/// refused where the configuration gives the run's task count, unless the merge is asked to be
/// partial; a record filed in another shard's file, or a shard file renamed to another run's
/// name, is refused.
#[test]
fn a_merge_refuses_unfinished_shards_and_misfiled_records() {
    let (_tmp_dir, dir) = scratch("unfinished");
    let config = json!({"agent": "expert", "benchmark": "ipc", "tasks": {"count": 6}});
    let names = ["t0", "t1", "t2", "t3", "t4", "t5"];
    let shard_files = |dir: &Path, upto: usize| -> Vec<PathBuf> {
        (1..=2)
            .map(|index| {
                let shard = Shard { index, count: 2 };
                let mut file = RecordFile::open(dir, "run", &config, Some(shard), false).expect("opens");
                for (i, name) in names.iter().enumerate().take(upto).filter(|(i, _)| shard.selects(*i)) {
                    file.append(i, &json!({"task": name, "success": false})).expect("appends");
                }
                file.path().to_path_buf()
            })
            .collect()
    };
    // Shard 2 was killed after its first task (t1): t3 and t5 are missing.
    let short = shard_files(&dir.join("short"), 5);
    let mut file = RecordFile::open(&dir.join("short"), "run", &config, Some(Shard { index: 2, count: 2 }), true).expect("opens");
    file.append(1, &json!({"task": "t1", "success": false})).expect("appends");
    drop(file);
    let error = merge(&short, false).expect_err("short");
    assert!(error.to_string().contains("4 of the run's 6 tasks recorded (shard 2 of 2 has 1 of its 3)"), "{error}");
    let merged = merge(&short, true).expect("a partial merge, asked for");
    assert_eq!((merged.records, merged.expected), (4, Some(6)));
    // A record in the wrong shard's file (index 2 is shard 1's).
    let whole = shard_files(&dir.join("misfiled"), 6);
    let mut text = std::fs::read_to_string(&whole[1]).expect("reads");
    text = text.replace("\"index\":1,", "\"index\":2,");
    std::fs::write(&whole[1], text).expect("writes");
    let error = merge(&whole, false).expect_err("misfiled");
    assert!(error.to_string().contains("task t1 has index 2, which is not shard 2 of 2's"), "{error}");
    // A shard file renamed into another run's name.
    let renamed = shard_files(&dir.join("renamed"), 6);
    let name = renamed[1].file_name().unwrap().to_str().unwrap().to_string();
    let elsewhere = renamed[1].with_file_name(name.replacen("run-", "run-0", 1));
    std::fs::rename(&renamed[1], &elsewhere).expect("renames");
    let error = merge(&[renamed[0].clone(), elsewhere], false).expect_err("renamed");
    assert!(error.to_string().contains("shards of different runs do not merge"), "{error}");
    // A shard given twice, named; a record a report would refuse, named by the shard's line; an
    // index past the run's tasks; shards without their configuration.
    let whole = shard_files(&dir.join("checked"), 6);
    let error = merge(&[whole[0].clone(), whole[0].clone(), whole[1].clone()], false).expect_err("twice");
    assert!(error.to_string().contains(&format!("task t0 is in two shard files: {} is given twice", whole[0].display())), "{error}");
    let text = std::fs::read_to_string(&whole[1]).expect("reads");
    std::fs::write(&whole[1], text.replacen("\"success\":false", "\"success\":false,\"steps\":-1", 1)).expect("writes");
    let error = merge(&whole, false).expect_err("a negative count");
    assert_eq!(
        error.to_string(),
        format!("{}:1: `steps` is -1, not a count (a whole number from 0 to 9007199254740992)", whole[1].display())
    );
    std::fs::write(&whole[1], text.replace("\"index\":5,", "\"index\":7,")).expect("writes");
    let error = merge(&whole, false).expect_err("past the tasks");
    assert!(error.to_string().contains("task t5 has index 7, past the run's 6 tasks"), "{error}");
    std::fs::write(&whole[1], &text).expect("writes");
    std::fs::remove_file(
        whole[0].with_file_name(whole[0].file_name().unwrap().to_str().unwrap().replace(".shard-1-of-2.jsonl", ".config.json")),
    )
    .expect("removes");
    let error = merge(&whole, false).expect_err("no configuration");
    assert!(error.to_string().contains("cannot read the run's configuration beside the shards"), "{error}");
    // Shards that select none of the run's tasks ran nothing and are not asked for: a run of 3
    // tasks in 4 shards merges from the first 3.
    let config = json!({"agent": "expert", "benchmark": "ipc", "tasks": {"count": 3}});
    let three: Vec<PathBuf> = (1..=3)
        .map(|index| {
            let mut file = RecordFile::open(&dir.join("few"), "run", &config, Some(Shard { index, count: 4 }), false).expect("opens");
            file.append(index - 1, &json!({"task": names[index - 1], "success": true})).expect("appends");
            file.path().to_path_buf()
        })
        .collect();
    assert_eq!(merge(&three, false).expect("merges").records, 3);
}

#[test]
fn shards_are_given_as_i_of_n() {
    assert_eq!("2/5".parse::<Shard>(), Ok(Shard { index: 2, count: 5 }));
    for bad in ["0/3", "4/3", "1/0", "a/b", "3", ""] {
        assert!(bad.parse::<Shard>().is_err(), "{bad}");
    }
    let shard = Shard { index: 2, count: 3 };
    assert_eq!((0..9).filter(|&i| shard.selects(i)).collect::<Vec<_>>(), [1, 4, 7]);
    // Built by hand outside 1 <= index <= count: selects nothing, without dividing by zero.
    for shard in [Shard { index: 0, count: 3 }, Shard { index: 1, count: 0 }, Shard { index: 4, count: 3 }] {
        assert!(!(0..9).any(|i| shard.selects(i)), "{shard:?}");
    }
}

/// The hash is of the keys sorted at every level, whatever order serde_json's map keeps (it
/// keeps insertion order when any crate of the build turns on `preserve_order`, as the
/// workspace's build does): fields declared out of order hash as the sorted text.
#[test]
fn canonical_json_sorts_keys_at_every_level() {
    #[derive(serde::Serialize)]
    struct Inner {
        zeta: u8,
        alpha: u8,
    }
    #[derive(serde::Serialize)]
    struct Config {
        width: u8,
        agent: &'static str,
        inner: Inner,
        list: Vec<Inner>,
    }
    let config = Config { width: 16, agent: "ours", inner: Inner { zeta: 1, alpha: 2 }, list: vec![Inner { zeta: 3, alpha: 4 }] };
    let text = eval_harness::records::canonical_json(&config);
    assert_eq!(text, r#"{"agent":"ours","inner":{"alpha":2,"zeta":1},"list":[{"alpha":4,"zeta":3}],"width":16}"#);
    let sorted: Value = serde_json::from_str(&text).expect("json");
    assert_eq!(config_hash(&config), config_hash(&sorted));
}

/// Shards and their merged file stay one run: a shard a run is still writing is not merged, and
/// once the merged file holds records a shard with tasks left is not resumed beside it (it would
/// leave that file short of them), `fresh` included, whose refusal then deletes nothing; a
/// shard with nothing left, or an unsharded file holding records, passes; an unsharded file
/// with none beside shards holding records does not (they are to be merged into it).
#[test]
fn a_merged_run_is_not_resumed_by_its_shards_nor_a_written_shard_merged() {
    let (_tmp_dir, dir) = scratch("merged");
    let config = json!({"agent": "expert", "benchmark": "ipc", "tasks": {"count": 4}});
    let (one, two) = (Shard { index: 1, count: 2 }, Shard { index: 2, count: 2 });
    let mut first = RecordFile::open(&dir, "run", &config, Some(one), false).expect("opens");
    first.append(0, &json!({"task": "t0", "success": true})).expect("appends");
    let mut second = RecordFile::open(&dir, "run", &config, Some(two), false).expect("opens");
    second.append(1, &json!({"task": "t1", "success": true})).expect("appends");
    let paths = [first.path().to_path_buf(), second.path().to_path_buf()];
    // The first shard's run still holds its file.
    let error = merge(&paths, true).expect_err("a shard being written");
    assert_eq!(error.to_string(), format!("{}: a run is still writing this shard; merge once it has ended", paths[0].display()));
    drop((first, second));
    // A run without shards that has not recorded its first task holds the (empty) target.
    let unsharded = RecordFile::open(&dir, "run", &config, None, false).expect("opens");
    let error = merge(&paths, true).expect_err("a target being written");
    assert_eq!(error.to_string(), format!("{}: a run is writing it; merge once it has ended", unsharded.path().display()));
    drop(unsharded);
    let merged = merge(&paths, true).expect("a partial merge");
    assert_eq!(merged.records, 2);

    let before = std::fs::read(&paths[0]).expect("reads");
    for fresh in [false, true] {
        let file = RecordFile::open(&dir, "run", &config, Some(one), fresh).expect("opens");
        // t2 is the shard's one task left (t0 is recorded; with `fresh` neither is).
        let left = if fresh { 2 } else { 1 };
        let error = file.check_unmerged(left).expect_err("resumed past its merge");
        assert!(
            matches!(&error, RecordError::Merged { path, merged: m, left: l } if *path == paths[0] && *m == merged.path && *l == left),
            "{error}"
        );
        assert!(error.to_string().contains("resume without --shard"), "{error}");
        file.check_unmerged(0).expect("nothing left to run");
        drop(file);
        assert!(std::fs::read(&paths[0]).expect("reads") == before, "a refused shard is left as it was (fresh: {fresh})");
    }
    // The unsharded file itself resumes (it is the merged file), and a merged file with no
    // records (as a run without shards leaves before its first) stands for nothing.
    RecordFile::open(&dir, "run", &config, None, false).expect("opens").check_unmerged(2).expect("not a shard");
    std::fs::write(&merged.path, "").expect("empties");
    RecordFile::open(&dir, "run", &config, Some(one), false).expect("opens").check_unmerged(1).expect("no records beside it");
    // Nor is that empty unsharded file resumed beside the shards' records: they are merged
    // into it first (it would run their tasks again, and disagree with them).
    let error = RecordFile::open(&dir, "run", &config, None, false).expect("opens").check_unmerged(2).expect_err("unmerged shards");
    assert!(matches!(&error, RecordError::Unmerged { path, shards } if *path == merged.path && shards[..] == paths[..]), "{error}");
    assert!(error.to_string().contains("merge them first"), "{error}");
}

/// `fresh` deletes the earlier records when the run settles the file (or appends), not when it
/// opens it: a run refused in between leaves them as they were.
#[test]
fn a_fresh_start_deletes_the_earlier_records_once_settled() {
    let (_tmp_dir, dir) = scratch("fresh");
    let config = json!({"agent": "expert", "benchmark": "ipc"});
    let mut file = RecordFile::open(&dir, "run", &config, None, false).expect("opens");
    file.append(0, &json!({"task": "a", "success": true})).expect("appends");
    let path = file.path().to_path_buf();
    drop(file);
    let before = std::fs::read(&path).expect("reads");
    let file = RecordFile::open(&dir, "run", &config, None, true).expect("opens");
    assert!(file.records().is_empty() && file.done().is_empty());
    drop(file);
    assert!(std::fs::read(&path).expect("reads") == before, "opened fresh, not settled: kept");
    let mut file = RecordFile::open(&dir, "run", &config, None, true).expect("opens");
    file.settle().expect("settles");
    assert!(std::fs::read(&path).expect("reads").is_empty(), "settled fresh: deleted");
    file.append(0, &json!({"task": "b", "success": false})).expect("appends");
    drop(file);
    assert_eq!(tasks(&RecordFile::open(&dir, "run", &config, None, false).expect("reopens")), ["b"]);
}

/// `check_only` reads and refuses what `open` would, and creates or changes nothing: no
/// folder, configuration or record file for a run not started, no record cut or deleted, the
/// lock tried and given back; it settles and appends nothing.
#[test]
fn a_file_opened_to_check_only_is_read_and_refused_as_open_would_and_left_alone() {
    let (_tmp_dir, dir) = scratch("check-only");
    let config = json!({"agent": "expert", "benchmark": "ipc"});
    let mut absent = RecordFile::check_only(&dir, "run", &config, None, false).expect("nothing to refuse");
    assert!(absent.records().is_empty());
    assert!(!dir.exists(), "no folder made");
    assert!(matches!(absent.append(0, &json!({"task": "a", "success": true})), Err(RecordError::CheckOnly { .. })));
    assert!(!dir.exists(), "nothing written");

    let mut file = RecordFile::open(&dir, "run", &config, None, false).expect("opens");
    file.append(0, &json!({"task": "a", "success": true})).expect("appends");
    let path = file.path().to_path_buf();
    // Held by its run: busy, as to `open`.
    assert!(matches!(RecordFile::check_only(&dir, "run", &config, None, false), Err(RecordError::Busy { .. })));
    drop(file);
    // A record cut short stays, fresh or not, and the lock is given back with the value.
    let mut text = std::fs::read_to_string(&path).expect("reads");
    text.push_str("{\"task\": \"b\"");
    std::fs::write(&path, &text).expect("writes");
    for fresh in [false, true] {
        let mut checked = RecordFile::check_only(&dir, "run", &config, None, fresh).expect("checks");
        assert_eq!(tasks(&checked), if fresh { vec![] } else { vec!["a".to_string()] });
        assert!(matches!(checked.settle(), Err(RecordError::CheckOnly { .. })));
        drop(checked);
        assert_eq!(std::fs::read_to_string(&path).expect("reads"), text, "left alone (fresh: {fresh})");
    }
    RecordFile::open(&dir, "run", &config, None, false).expect("not held");
    // Another configuration's file is refused, as to `open`.
    let config_path = dir.join(format!("run-{}.config.json", config_hash(&config)));
    std::fs::write(&config_path, r#"{"agent": "planner", "benchmark": "ipc"}"#).expect("writes");
    let error = RecordFile::check_only(&dir, "run", &config, None, false).expect_err("another configuration");
    assert!(matches!(error, RecordError::ConfigMismatch { .. }), "{error}");
}

/// A whole run's merged records must be the tasks its configuration names, in its order
/// (`tasks.ids_sha256`): a record whose task was edited is refused (it used to be merged and
/// reported as one of the run's), the run's own records merge.
#[test]
fn a_merge_refuses_records_of_tasks_the_run_does_not_name() {
    let (_tmp_dir, dir) = scratch("task-list");
    let names = ["t0", "t1", "t2", "t3"];
    let config = json!({"agent": "expert", "benchmark": "ipc",
        "tasks": {"count": names.len(), "ids_sha256": eval_harness::records::task_list_digest(names)}});
    let mut paths = Vec::new();
    for index in 1..=2 {
        let shard = Shard { index, count: 2 };
        let mut file = RecordFile::open(&dir, "run", &config, Some(shard), false).expect("opens");
        for (i, name) in names.iter().enumerate().filter(|(i, _)| shard.selects(*i)) {
            file.append(i, &json!({"task": name, "steps": i, "success": true})).expect("appends");
        }
        paths.push(file.path().to_path_buf());
    }
    let original = std::fs::read_to_string(&paths[1]).expect("reads");
    std::fs::write(&paths[1], original.replace("\"t3\"", "\"zzz\"")).expect("writes");
    let error = merge(&paths, false).expect_err("a task the run does not name");
    assert!(error.to_string().contains("are not the run's"), "{error}");
    std::fs::write(&paths[1], original).expect("writes");
    let merged = merge(&paths, false).expect("the run's own tasks merge");
    assert_eq!(merged.records, names.len());
}
