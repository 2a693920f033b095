//! The evaluation harness: batch runs of the agent and its baselines over the benchmarks, and
//! the statistics the paper reports about them (Appendix B).
//!
//! - [`behaviour`]: how an episode ended and how the agent met failure (Tables 11-12).
//! - [`report`]: the paper's tables (Markdown), figures (SVG) and a page per episode (HTML)
//!   from record files, every number through [`stats`].
//! - [`records`]: per-task JSON-line records in a file named by the run's configuration,
//!   appended whole (a killed run resumes to exactly what an uninterrupted run writes),
//!   sharded and merged.
//! - [`stats`]: mean and sample standard deviation over repeated runs (Table 7's
//!   "accuracy ± sd"), the 95% percentile task-cluster bootstrap interval (Table 7's intervals),
//!   the exact two-sided McNemar test on paired task outcomes and Holm's step-down correction
//!   within a family of tests (Tables 9-10).
//!
//! ```
//! use eval_harness::stats::{BootstrapConfig, holm_adjust, mcnemar_exact_p, task_cluster_bootstrap};
//! // Three runs (seeds 0, 42, 1738) of four tasks, 1.0 = success.
//! let tasks = [vec![1.0, 1.0, 1.0], vec![0.0, 1.0, 0.0], vec![1.0, 1.0, 1.0], vec![0.0, 0.0, 0.0]];
//! let interval = task_cluster_bootstrap(&tasks, &BootstrapConfig::default())?;
//! assert!(interval.lower <= interval.estimate && interval.estimate <= interval.upper);
//! // 40 tasks only the first condition solves, 18 only the second.
//! let p = mcnemar_exact_p(40, 18);
//! let adjusted = holm_adjust(&[p, 0.2, 0.01])?;
//! assert!(adjusted.iter().zip([p, 0.2, 0.01]).all(|(a, raw)| *a >= raw));
//! # Ok::<(), eval_harness::stats::StatsError>(())
//! ```

pub mod behaviour;
pub mod records;
pub mod report;
pub mod stats;
