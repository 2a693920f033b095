//! Reports from records (`cargo xtask report`): the paper's tables as Markdown, its figures
//! as SVG, and an HTML page per episode linked from one `index.html` — pure functions from
//! record sets to strings; writing them is the caller's.
//!
//! - [`load`] reads a record file and the `.config.json` beside it (any fault: an error naming
//!   file and line); [`record_paths`] expands folders to their `*.jsonl` files.
//! - [`build`] groups the records into *conditions* (configurations equal but for benchmark
//!   and seed), *benchmarks* and *runs* (one per seed; shard files of one run together), and
//!   writes: task success per condition and benchmark (Table 1); the component ablation of
//!   `ours`'s Phase II modes (Tables 2 and 8); accuracy ± sample sd over runs with the 95%
//!   task-cluster bootstrap interval (Table 7); exact McNemar between every two conditions on
//!   their shared tasks, Holm-corrected within its family (Tables 9-10); terminal mechanism
//!   (Table 11); failure response (Table 12); failure attribution (Figures 3 and 5, as a
//!   table and as stacked bars); mean generated tokens, images, observations and model calls
//!   per task (Figure 2). Every number goes through [`crate::stats`]. A table with nothing to
//!   show says so.
//! - Episode pages show what the record holds: Phase I's steps, the hand-over, the plan, each
//!   executed step, the verdict, the planner's summary (`phase2_detail`) and, for MCTS, the
//!   top of its search tree (`search_tree`: the actions tried with visits, values and priors).
//!
//! ```
//! use eval_harness::report::{Record, RecordSet, ReportOptions, build};
//! use serde_json::json;
//! let config = json!({"agent": "planner", "benchmark": "alfworld-seen"});
//! let record = |task: &str, success: bool| Record { line: 1, fields: json!({"task": task, "success": success}).as_object().unwrap().clone() };
//! let set = RecordSet {
//!     path: "alfworld-seen-planner.jsonl".into(),
//!     config: config.as_object().unwrap().clone(),
//!     hash: String::new(),
//!     records: vec![record("a", true), record("b", false)],
//!     warnings: vec![],
//! };
//! let report = build(&[set], &ReportOptions::default())?;
//! assert!(report.markdown.contains("| Planner (A*) | — | **50.0 (n=2)** |"));
//! assert_eq!(report.episodes.len(), 2);
//! # Ok::<(), eval_harness::report::ReportError>(())
//! ```

mod figures;
mod html;
mod load;
mod metrics;
mod study;
mod table;
mod tables;

use std::path::PathBuf;

pub use figures::Figure;
pub use html::{Page, escape};
pub(crate) use load::check as check_record;
pub use load::{Record, RecordSet, load, record_paths, without_merged_shards};

use crate::records::RecordError;
use crate::stats::{BootstrapConfig, StatsError};

/// Why a report cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A record file cannot be read, or a line of it is not a record (`file:line: ...`).
    #[error(transparent)]
    Records(#[from] RecordError),
    /// The configuration beside a record file is missing or unreadable.
    #[error(
        "{path}: its configuration {config} {reason}; a record file is read with the `.config.json` that `cargo xtask eval` writes beside it"
    )]
    Config {
        /// The record file.
        path: PathBuf,
        /// The configuration file expected beside it (`<stem>-<hash>.config.json`).
        config: PathBuf,
        /// What is wrong: unreadable, not a JSON object, or no string `agent` or `benchmark`.
        reason: String,
    },
    /// Nothing to report on.
    #[error("{0}")]
    NoRecords(String),
    /// A statistic could not be computed (the options are out of range, e.g. zero replicates).
    #[error("{context}: {source}")]
    Stats {
        /// Which number of the report was being computed.
        context: String,
        /// Why the statistic failed.
        source: StatsError,
    },
}

/// Settings of the statistics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReportOptions {
    /// Table 7's interval: 10,000 replicates, 95%, seed 0 by default.
    pub bootstrap: BootstrapConfig,
    /// Family-wise error rate of the Holm-corrected McNemar tests.
    pub alpha: f64,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions { bootstrap: BootstrapConfig::PAPER, alpha: 0.05 }
    }
}

/// Everything a report writes, by file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Report {
    /// `report.md`: the tables, and the figures by file name.
    pub markdown: String,
    /// `<name>.svg` each.
    pub figures: Vec<Figure>,
    /// `index.html`: the tables and figures, every episode page linked.
    pub index: String,
    /// `episodes/<file stem>/<index>.html`, one per record.
    pub episodes: Vec<Page>,
    /// The record files read and their records, shard files beside their merged file not
    /// counted (they are read through it).
    pub files: usize,
    /// The records in those files.
    pub records: usize,
    /// Each file left out ([`without_merged_shards`]): a shard read through its merged file, a
    /// file with no record yet.
    pub left_out: Vec<String>,
}

/// The report of `sets` (module documentation).
pub fn build(sets: &[RecordSet], options: &ReportOptions) -> Result<Report, ReportError> {
    if sets.iter().all(|s| s.records.is_empty()) {
        return Err(ReportError::NoRecords(format!(
            "the record files hold no records: {}",
            sets.iter().map(|s| s.path.display().to_string()).collect::<Vec<_>>().join(", ")
        )));
    }
    let (sets, merged) = without_merged_shards(sets)?;
    let sets = sets.as_slice();
    let mut study = study::study(sets)?;
    study.left_out.splice(0..0, merged.iter().cloned());
    let tables = tables::tables(&study, options)?;
    let figures = figures::figures(&study)?;

    let mut markdown = String::from("# Evaluation report\n\n");
    let records: usize = sets.iter().map(|s| s.records.len()).sum();
    markdown.push_str(&format!(
        "{} record file(s), {records} record(s), {} condition(s), {} benchmark(s).\n\n",
        sets.len(),
        study.conditions.len(),
        study.benchmarks.len()
    ));
    for set in sets {
        let name = set.path.file_name().map_or_else(|| set.path.display().to_string(), |n| n.to_string_lossy().into_owned());
        markdown.push_str(&format!("- `{name}`: {} record(s)\n", set.records.len()));
        for warning in &set.warnings {
            markdown.push_str(&format!("  - warning: {warning}\n"));
        }
    }
    for line in &study.left_out {
        markdown.push_str(&format!("- left out: {line}\n"));
    }
    for table in &tables {
        markdown.push('\n');
        markdown.push_str(&table.markdown());
    }
    markdown.push_str("\n## Figures\n\n");
    for figure in &figures {
        markdown.push_str(&format!("![{}]({})\n\n{}\n\n", figure.title, figure.name, figure.caption));
    }

    let paths = html::page_paths(sets);
    let index = html::index(&study, sets, &paths, &tables, &figures);
    let mut episodes = Vec::new();
    for (set, paths) in sets.iter().zip(&paths) {
        for (record, path) in set.records.iter().zip(paths) {
            episodes.push(Page { path: path.clone(), html: html::episode_page(&study, set, record) });
        }
    }
    Ok(Report { markdown, figures, index, episodes, files: sets.len(), records, left_out: merged })
}
