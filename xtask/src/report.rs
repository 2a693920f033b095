//! `cargo xtask report RECORDS... [--out DIR]`: the paper's tables, figures and a page per
//! episode from `eval` records ([`eval_harness::report`] makes them; this writes them):
//! `report.md`, `index.html`, `<figure>.svg`, `episodes/<file stem>/<index>.html`.

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
    write(&out.join("report.md"), &report.markdown)?;
    write(&out.join("index.html"), &report.index)?;
    for figure in &report.figures {
        write(&out.join(figure.name), &figure.svg)?;
    }
    for page in &report.episodes {
        write(&out.join(&page.path), &page.html)?;
    }
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
