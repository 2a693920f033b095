//! `cargo xtask report RECORDS... [--out DIR]`: the paper's tables, figures and a page per
//! episode from `eval` records ([`eval_harness::report`] makes them; this writes them):
//! `report.md`, `index.html`, `<figure>.svg`, `episodes/<file stem>/<index>.html`, and the list
//! of them (`.report-files`), by which the next report into the folder removes what it does
//! not write again.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use eval_harness::report::{ReportError, ReportOptions, build, load, record_paths};
use eval_harness::stats::BootstrapConfig;

use crate::input::InputError;

#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// Record files (`<benchmark>-<agent>-<hash>.jsonl`, the `.config.json` beside each), or
    /// folders of them.
    #[arg(required = true)]
    records: Vec<PathBuf>,
    /// Folder for the report.
    #[arg(long, default_value = "target/report")]
    out: PathBuf,
    /// Bootstrap replicates of Table 7's intervals.
    #[arg(long, default_value_t = 10_000, value_parser = crate::input::at_least_one::<usize>)]
    replicates: usize,
    /// Seed of the bootstrap.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

fn input(error: ReportError) -> anyhow::Error {
    InputError(error.to_string()).into()
}

fn write(path: &Path, text: &str) -> anyhow::Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create the folder", dir.display()))?;
    }
    std::fs::write(path, text).with_context(|| format!("{}: cannot write", path.display()))
}

pub fn run(args: ReportArgs) -> anyhow::Result<ExitCode> {
    crate::input::folder_to_write(&args.out, "--out")?;
    println!("{}", write_report(&args.records, &args.out, args.replicates, args.seed)?);
    Ok(ExitCode::SUCCESS)
}

/// The list of the files the last report in a folder wrote, relative to it, one a line.
const MANIFEST: &str = ".report-files";

/// Deletes the files the folder's last report wrote (its [`MANIFEST`]) that this one, `written`,
/// did not (the pages of records no longer reported: a page nothing links to would pass for one
/// of this report's), then the folders they leave empty, and keeps the new list. Only paths
/// inside `out` are touched; nothing without a manifest (another program's folder).
fn remove_stale(out: &Path, written: &std::collections::BTreeSet<PathBuf>) -> anyhow::Result<()> {
    let manifest = out.join(MANIFEST);
    let before = std::fs::read_to_string(&manifest).unwrap_or_default();
    let inside = |path: &Path| path.components().all(|c| matches!(c, std::path::Component::Normal(_)));
    for stale in before.lines().map(PathBuf::from).filter(|p| inside(p) && !written.contains(p)) {
        match std::fs::remove_file(out.join(&stale)) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(e).with_context(|| format!("{}: cannot remove the last report's file", out.join(&stale).display())),
        }
        // Its folders, where now empty (`remove_dir` removes only an empty one).
        for dir in stale.ancestors().skip(1).filter(|d| !d.as_os_str().is_empty()) {
            if std::fs::remove_dir(out.join(dir)).is_err() {
                break;
            }
        }
    }
    let list: String = written.iter().map(|p| format!("{}\n", p.display())).collect();
    write(&manifest, &list)
}

/// The report of the record files (or folders of them) `records` into `out`, with Table 7's
/// bootstrap at `replicates` and `seed`; returns the line that says what was written where.
pub fn write_report(records: &[PathBuf], out: &Path, replicates: usize, seed: u64) -> anyhow::Result<String> {
    let paths = record_paths(records).map_err(input)?;
    let sets = paths.iter().map(|p| load(p)).collect::<Result<Vec<_>, _>>().map_err(input)?;
    for warning in sets.iter().flat_map(|s| &s.warnings) {
        eprintln!("warning: {warning}");
    }
    let options = ReportOptions { bootstrap: BootstrapConfig { replicates, seed, ..BootstrapConfig::PAPER }, ..ReportOptions::default() };
    let report = build(&sets, &options).map_err(input)?;
    // The files left out (the report says which): shards beside their merged file, read once
    // through it, and files with no record yet.
    for note in &report.left_out {
        eprintln!("note: {note}");
    }
    let mut files: Vec<(PathBuf, &str)> = vec![("report.md".into(), &report.markdown), ("index.html".into(), &report.index)];
    files.extend(report.figures.iter().map(|figure| (PathBuf::from(figure.name), figure.svg.as_str())));
    files.extend(report.episodes.iter().map(|page| (PathBuf::from(&page.path), page.html.as_str())));
    for (path, text) in &files {
        write(&out.join(path), text)?;
    }
    remove_stale(out, &files.iter().map(|(path, _)| path.clone()).collect())?;
    Ok(format!(
        "{} record file(s), {} record(s) -> {} ({} episode pages), {}, {} figure(s)",
        report.files,
        report.records,
        out.join("index.html").display(),
        report.episodes.len(),
        out.join("report.md").display(),
        report.figures.len()
    ))
}
