//! Loads the benchmark files the project ships in `fixtures/`.
//!
//! Every benchmark task becomes a [`TaskFiles`]: a domain text, a problem text, where each
//! came from (for diagnostics), and what the benchmark adds (an ALFWorld game's TextWorld
//! grammar and expert walkthrough; an EAI gold PDDL plan). The crate knows file layouts,
//! nothing about PDDL.
//!
//! Subsets (`fixtures/subsets/*.txt`, one task id per line) name fixed samples of a
//! benchmark; [`stratified_subset`] is the rule that made them, [`load_subset`] reads one.
//!
//! ```
//! use benchmark_data::{Benchmark, Extra, Fixtures, stratified_subset};
//! let fixtures = Fixtures::checkout();
//! let games = fixtures.load_subset(Benchmark::AlfworldSeen, "alfworld-seen-12")?;
//! assert_eq!(games.len(), 12);
//! let Extra::Alfworld(game) = &games[0].extra else { panic!("an ALFWorld game") };
//! assert!(games[0].problem.contains("(:goal") && !game.walkthrough.is_empty());
//! // The subset is the stratified rule's sample of the whole set: two games per task type.
//! let all = fixtures.load(Benchmark::AlfworldSeen)?;
//! let sample: Vec<&str> = stratified_subset(&all, 12).iter().map(|t| t.id.as_str()).collect();
//! assert_eq!(sample, games.iter().map(|t| t.id.as_str()).collect::<Vec<_>>());
//! assert_eq!(sample.iter().filter(|id| id.starts_with("pick_two_obj")).count(), 2);
//! # Ok::<(), benchmark_data::DataError>(())
//! ```

use std::path::{Path, PathBuf};

/// The benchmark sets in `fixtures/`.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    strum::EnumString,
    strum::IntoStaticStr,
    strum::VariantNames,
    strum::VariantArray,
)]
#[strum(serialize_all = "kebab-case", parse_err_ty = UnknownBenchmark, parse_err_fn = UnknownBenchmark::new)]
pub enum Benchmark {
    /// ALFWorld's `valid_seen` games (`fixtures/alfworld/valid_seen`); name `alfworld-seen`.
    AlfworldSeen,
    /// ALFWorld's `valid_train` games (`fixtures/alfworld/valid_train`); name `alfworld-train`.
    AlfworldTrain,
    /// The Embodied Agent Interface VirtualHome problems and gold plans (`fixtures/virtualhome-eai`); name `virtualhome-eai`.
    VirtualhomeEai,
    /// The IPC STRIPS sets, one folder per domain with `domain.pddl` and `instance-N.pddl` files (`fixtures/ipc`); name `ipc`.
    Ipc,
}

impl Benchmark {
    /// Every benchmark, in declaration order.
    pub const ALL: &[Benchmark] = <Benchmark as strum::VariantArray>::VARIANTS;

    /// The command-line name: `alfworld-seen`, `alfworld-train`, `virtualhome-eai`, `ipc`.
    pub fn name(self) -> &'static str {
        self.into()
    }

    /// The benchmark with command-line name `name` (see [`Benchmark::name`]); `None` for any other string.
    pub fn from_name(name: &str) -> Option<Benchmark> {
        name.parse().ok()
    }
}

/// A name that is none of [`Benchmark`]'s (the error of its [`FromStr`](std::str::FromStr)):
/// names what was given and lists the benchmarks. (This crate depends on no other of the
/// workspace, so it does not share `transition_model::UnknownName`.)
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a benchmark: the benchmarks are {names}", names = <Benchmark as strum::VariantNames>::VARIANTS.join(", "))]
pub struct UnknownBenchmark(pub String);

impl UnknownBenchmark {
    fn new(given: &str) -> UnknownBenchmark {
        UnknownBenchmark(given.to_string())
    }
}

/// Why a benchmark file could not be loaded; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A file or folder could not be read (missing, unreadable, not a folder).
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A JSON file (an ALFWorld `game.tw-pddl`, EAI's `gold_pddl_plan.json`) does not parse.
    #[error("{path}:{line}:{column}: not valid JSON: {message}")]
    Json {
        /// The file.
        path: PathBuf,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// `serde_json`'s message.
        message: String,
    },
    /// A JSON file parses but lacks a field, or the field has the wrong type.
    #[error("{path}: field `{field}` is missing or is not {expected}")]
    Field {
        /// The file.
        path: PathBuf,
        /// The field's JSON key (`"gold plan"` for an entry of `gold_pddl_plan.json`).
        field: &'static str,
        /// What the field should have been, e.g. `a list of strings`.
        expected: &'static str,
    },
    /// A subset file lists a task id the benchmark does not have.
    #[error("{path}:{line}: no task `{id}` in {benchmark}")]
    UnknownSubsetTask {
        /// The subset file.
        path: PathBuf,
        /// 1-based line of the id.
        line: usize,
        /// The id as listed (trimmed).
        id: String,
        /// The benchmark's command-line name ([`Benchmark::name`]).
        benchmark: &'static str,
    },
    /// A subset name with no `subsets/<name>.txt` file in the fixtures.
    #[error("no subset {name} (there is no {path}); the subsets: {known}")]
    UnknownSubset {
        /// The name asked for (the file stem).
        name: String,
        /// The file that does not exist.
        path: PathBuf,
        /// The subsets that do exist, comma-separated and sorted.
        known: String,
    },
    /// A subset file lists the same task id twice.
    #[error("{path}:{line}: task `{id}` is listed twice")]
    DuplicateSubsetTask {
        /// The subset file.
        path: PathBuf,
        /// 1-based line of the second listing.
        line: usize,
        /// The repeated id.
        id: String,
    },
    /// A text file holds a byte sequence that is not UTF-8.
    #[error("{path}:{line}:{column}: not UTF-8 text (byte 0x{byte:02x})")]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// 1-based line of the first invalid byte.
        line: usize,
        /// 1-based column of the first invalid byte, in characters.
        column: usize,
        /// The first invalid byte.
        byte: u8,
    },
}

/// The text of the file at `path`: UTF-8, without a byte-order mark (which editors on Windows
/// write, and which would otherwise be read as part of the first word); a byte that is not
/// UTF-8 is an error naming its line and column.
pub fn read_text(path: &Path) -> Result<String, DataError> {
    let bytes = std::fs::read(path).map_err(|source| DataError::Io { path: path.to_path_buf(), source })?;
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").map(<[u8]>::to_vec).unwrap_or(bytes);
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let before = &e.as_bytes()[..at];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let line_start = before.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        // The column in characters, as an editor counts it.
        let column = String::from_utf8_lossy(&before[line_start..]).chars().count() + 1;
        DataError::NotUtf8 { path: path.to_path_buf(), line, column, byte: e.as_bytes()[at] }
    })
}

fn read(path: &Path) -> Result<String, DataError> {
    read_text(path)
}

fn read_json(path: &Path) -> Result<serde_json::Value, DataError> {
    let text = read(path)?;
    serde_json::from_str(&text).map_err(|e| DataError::Json {
        path: path.to_path_buf(),
        line: e.line(),
        column: e.column().max(1), // serde_json says 0 at the start of a line (an empty file)
        message: e.to_string(),
    })
}

/// One planning task's files.
#[derive(Debug, Clone)]
pub struct TaskFiles {
    /// Stable id: the ALFWorld game folder (`<family>/<trial>`), the EAI problem id, or `<domain>/instance-N`.
    pub id: String,
    /// The benchmark the task was loaded from.
    pub benchmark: Benchmark,
    /// Where the domain text came from (for `file:line:column` diagnostics).
    pub domain_path: PathBuf,
    /// The PDDL domain text (shared by every task of an EAI or IPC domain).
    pub domain: String,
    /// Where the problem text came from (the game file for ALFWorld, whose PDDL is embedded).
    pub problem_path: PathBuf,
    /// The PDDL problem text.
    pub problem: String,
    /// What the benchmark adds beyond the PDDL.
    pub extra: Extra,
}

/// What a benchmark adds to the PDDL.
#[derive(Debug, Clone)]
pub enum Extra {
    /// Nothing: an IPC task.
    None,
    /// An ALFWorld game's TextWorld grammar and expert walkthrough.
    Alfworld(AlfworldGame),
    /// An EAI VirtualHome task's category and gold plan.
    Virtualhome {
        /// The task's category: the name of its folder under `problem_pddl/`.
        category: String,
        /// EAI gold PDDL plan (`"walk_towards character shower"` per step); `None` when
        /// `gold_pddl_plan.json` has no entry for the task.
        gold_plan: Option<Vec<String>>,
    },
}

/// The parts of an ALFWorld `game.tw-pddl` beyond its PDDL.
#[derive(Debug, Clone)]
pub struct AlfworldGame {
    /// The TextWorld grammar (templates and feedback texts).
    pub grammar: String,
    /// The expert plan as TextWorld commands.
    pub walkthrough: Vec<String>,
}

/// Reads one ALFWorld game (`game.tw-pddl`, or the folder holding it). Its PDDL is embedded
/// as JSON strings, so `domain_path` and `problem_path` both name the game file and
/// diagnostics' line numbers count inside the embedded text.
pub fn load_alfworld_game(path: &Path, benchmark: Benchmark, id: String) -> Result<TaskFiles, DataError> {
    let path = if path.is_dir() { path.join("game.tw-pddl") } else { path.to_path_buf() };
    let json = read_json(&path)?;
    let field = |field: &'static str| -> Result<String, DataError> {
        json.get(field).and_then(|v| v.as_str()).map(str::to_string).ok_or(DataError::Field {
            path: path.clone(),
            field,
            expected: "a string",
        })
    };
    let walkthrough = json
        .get("walkthrough")
        .and_then(|v| v.as_array())
        .and_then(|steps| steps.iter().map(|s| s.as_str().map(str::to_string)).collect::<Option<Vec<_>>>())
        .ok_or(DataError::Field { path: path.clone(), field: "walkthrough", expected: "a list of strings" })?;
    Ok(TaskFiles {
        id,
        benchmark,
        domain: field("pddl_domain")?,
        problem: field("pddl_problem")?,
        domain_path: path.clone(),
        problem_path: path.clone(),
        extra: Extra::Alfworld(AlfworldGame { grammar: field("grammar")?, walkthrough }),
    })
}

/// The fixtures folder to use: `compiled` (the build's checkout) when it is a folder, else the
/// first `fixtures/` holding `subsets/` in `cwd` or a folder above it, else `compiled` (so that
/// the error names it). The compiled path alone goes stale when the checkout moves: a build
/// cache shared between two checkouts keeps the first one's path (cargo's fingerprints are
/// relative to the workspace, so the same sources built from another path are not rebuilt),
/// and a binary copied elsewhere keeps its build's.
pub fn locate_fixtures(compiled: &Path, cwd: &Path) -> PathBuf {
    if compiled.is_dir() {
        return compiled.to_path_buf();
    }
    cwd.ancestors()
        .map(|folder| folder.join("fixtures"))
        .find(|candidate| candidate.join("subsets").is_dir())
        .unwrap_or_else(|| compiled.to_path_buf())
}

/// Where the benchmark files are: a folder laid out as this repository's `fixtures/`
/// (`alfworld/valid_seen`, `alfworld/valid_train`, `virtualhome-eai`, `ipc`, `subsets`). A
/// caller that ships or moves the data passes its own root ([`Fixtures::at`]); the free
/// functions ([`load`], [`load_subset`], [`fixtures_dir`]) use [`Fixtures::from_env`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Fixtures {
    root: PathBuf,
}

/// The environment variable that points the free functions at another `fixtures/` folder.
pub const FIXTURES_ENV: &str = "NSEA_FIXTURES";

impl Fixtures {
    /// The files under `root`.
    pub fn at(root: impl Into<PathBuf>) -> Fixtures {
        Fixtures { root: root.into() }
    }

    /// The `fixtures/` folder of the checkout this crate was built from (a path fixed at
    /// compile time) when it is there; else the `fixtures/` of the working directory or the
    /// nearest folder above it that has one (see [`locate_fixtures`]).
    pub fn checkout() -> Fixtures {
        let compiled = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
        let cwd = std::env::current_dir().unwrap_or_default();
        Fixtures::at(locate_fixtures(&compiled, &cwd))
    }

    /// `$NSEA_FIXTURES` when it is set and not empty, else [`Fixtures::checkout`].
    pub fn from_env() -> Fixtures {
        match std::env::var_os(FIXTURES_ENV) {
            Some(root) if !root.is_empty() => Fixtures::at(root),
            _ => Fixtures::checkout(),
        }
    }

    /// The root folder, as given; not checked to exist.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Every task of a benchmark, in a stable order.
    pub fn load(&self, benchmark: Benchmark) -> Result<Vec<TaskFiles>, DataError> {
        load_from(&self.root, benchmark)
    }

    /// Where a subset lives: `name_or_path` itself when it names a file (has a `/` or ends in
    /// `.txt`), else `subsets/<name>.txt` under the root.
    pub fn subset_path(&self, name_or_path: &str) -> PathBuf {
        if name_or_path.contains('/') || name_or_path.ends_with(".txt") {
            PathBuf::from(name_or_path)
        } else {
            self.root.join("subsets").join(format!("{name_or_path}.txt"))
        }
    }

    /// The tasks of a subset (see [`Fixtures::subset_path`], [`subset_ids`]) of `benchmark`,
    /// in the file's order; an id the benchmark does not have is an error naming its
    /// `path:line`.
    pub fn load_subset(&self, benchmark: Benchmark, name_or_path: &str) -> Result<Vec<TaskFiles>, DataError> {
        let path = self.subset_path(name_or_path);
        let ids = subset_ids(&path)?;
        let mut tasks: Vec<Option<TaskFiles>> = self.load(benchmark)?.into_iter().map(Some).collect();
        let mut out = Vec::with_capacity(ids.len());
        for (line, id) in ids {
            let found = tasks.iter_mut().find(|t| t.as_ref().is_some_and(|t| t.id == id)).and_then(Option::take);
            match found {
                Some(task) => out.push(task),
                None => return Err(DataError::UnknownSubsetTask { path, line, id, benchmark: benchmark.name() }),
            }
        }
        Ok(out)
    }
}

/// The `fixtures/` folder the free functions read ([`Fixtures::from_env`]).
pub fn fixtures_dir() -> PathBuf {
    Fixtures::from_env().root
}

fn sorted_entries(dir: &Path) -> Result<Vec<PathBuf>, DataError> {
    let entries = std::fs::read_dir(dir).map_err(|source| DataError::Io { path: dir.to_path_buf(), source })?;
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    Ok(paths)
}

/// Every task of a benchmark, in a stable order ([`Fixtures::from_env`]).
pub fn load(benchmark: Benchmark) -> Result<Vec<TaskFiles>, DataError> {
    Fixtures::from_env().load(benchmark)
}

/// Every task of a benchmark under `fixtures`, in a stable order.
pub fn load_from(fixtures: &Path, benchmark: Benchmark) -> Result<Vec<TaskFiles>, DataError> {
    match benchmark {
        Benchmark::AlfworldSeen | Benchmark::AlfworldTrain => {
            let split = if benchmark == Benchmark::AlfworldSeen { "valid_seen" } else { "valid_train" };
            let mut tasks = Vec::new();
            for family in sorted_entries(&fixtures.join("alfworld").join(split))? {
                for trial in sorted_entries(&family)? {
                    let id = format!(
                        "{}/{}",
                        family.file_name().unwrap_or_default().to_string_lossy(),
                        trial.file_name().unwrap_or_default().to_string_lossy()
                    );
                    tasks.push(load_alfworld_game(&trial, benchmark, id)?);
                }
            }
            Ok(tasks)
        }
        Benchmark::VirtualhomeEai => {
            let root = fixtures.join("virtualhome-eai");
            let domain_path = root.join("virtualhome.pddl");
            let domain = read(&domain_path)?;
            let plans_path = root.join("gold_pddl_plan.json");
            let plans = read_json(&plans_path)?;
            let mut tasks = Vec::new();
            for category in sorted_entries(&root.join("problem_pddl"))? {
                let category_name = category.file_name().unwrap_or_default().to_string_lossy().into_owned();
                for problem_path in sorted_entries(&category)? {
                    if problem_path.extension().is_none_or(|e| e != "pddl") {
                        continue;
                    }
                    let id = problem_path.file_stem().unwrap_or_default().to_string_lossy().into_owned();
                    let gold_plan = match plans.get(&id) {
                        None => None,
                        Some(value) => Some(
                            value
                                .as_array()
                                .and_then(|steps| steps.iter().map(|s| s.as_str().map(str::to_string)).collect::<Option<Vec<_>>>())
                                .ok_or(DataError::Field { path: plans_path.clone(), field: "gold plan", expected: "a list of strings" })?,
                        ),
                    };
                    tasks.push(TaskFiles {
                        id,
                        benchmark,
                        domain_path: domain_path.clone(),
                        domain: domain.clone(),
                        problem: read(&problem_path)?,
                        problem_path,
                        extra: Extra::Virtualhome { category: category_name.clone(), gold_plan },
                    });
                }
            }
            Ok(tasks)
        }
        Benchmark::Ipc => {
            let mut tasks = Vec::new();
            for dir in sorted_entries(&fixtures.join("ipc"))? {
                if !dir.is_dir() {
                    continue;
                }
                let domain_path = dir.join("domain.pddl");
                let domain = read(&domain_path)?;
                let mut instances: Vec<(u32, PathBuf)> = sorted_entries(&dir)?
                    .into_iter()
                    .filter_map(|p| {
                        let stem = p.file_stem()?.to_str()?;
                        let n = stem.strip_prefix("instance-")?.parse().ok()?;
                        Some((n, p))
                    })
                    .collect();
                instances.sort();
                for (n, problem_path) in instances {
                    tasks.push(TaskFiles {
                        id: format!("{}/instance-{n}", dir.file_name().unwrap_or_default().to_string_lossy()),
                        benchmark,
                        domain_path: domain_path.clone(),
                        domain: domain.clone(),
                        problem: read(&problem_path)?,
                        problem_path,
                        extra: Extra::None,
                    });
                }
            }
            Ok(tasks)
        }
    }
}

/// The family a task belongs to, for stratified subsets: ALFWorld's task type (the game
/// folder's name up to its first `-`, e.g. `pick_and_place_simple`), the EAI category
/// (`Extra::Virtualhome::category`), an IPC domain (the id up to `/`).
pub fn task_family(task: &TaskFiles) -> &str {
    match &task.extra {
        Extra::Virtualhome { category, .. } => category,
        Extra::Alfworld(_) => task.id.split(['/', '-']).next().unwrap_or(&task.id),
        Extra::None => task.id.split('/').next().unwrap_or(&task.id),
    }
}

/// A stratified sample of `size` tasks, deterministic, in id order.
///
/// Families ([`task_family`]) in name order, of sizes `n_f`, `N` tasks, `F` families:
/// 1. every family gets one task; the other `R = size - F` go to families in proportion to
///    `n_f - 1` (the tasks each has left) by largest remainder: family `f` first gets
///    `floor(R (n_f - 1) / (N - F))`, and the seats left over go one each to the largest
///    remainders `R (n_f - 1) mod (N - F)`, ties to the larger family, then to the family
///    name first in order;
/// 2. a family given `k` of its `n` tasks (sorted by id) contributes those at positions
///    `floor((2j + 1) n / 2k)`, `j = 0..k`: the midpoints of `k` equal slices.
///
/// No family gets more tasks than it has. With `size < F` (not every family can be present)
/// or `size >= N`, the whole set is returned.
pub fn stratified_subset(tasks: &[TaskFiles], size: usize) -> Vec<&TaskFiles> {
    let mut families: Vec<(&str, Vec<&TaskFiles>)> = Vec::new();
    let mut sorted: Vec<&TaskFiles> = tasks.iter().collect();
    sorted.sort_by(|a, b| task_family(a).cmp(task_family(b)).then_with(|| a.id.cmp(&b.id)));
    for task in sorted {
        match families.last_mut() {
            Some((family, members)) if *family == task_family(task) => members.push(task),
            _ => families.push((task_family(task), vec![task])),
        }
    }
    let total = tasks.len();
    if size < families.len() || size >= total {
        let mut all: Vec<&TaskFiles> = tasks.iter().collect();
        all.sort_by(|a, b| a.id.cmp(&b.id));
        return all;
    }
    let rest = size - families.len();
    let pool = total - families.len();
    let mut seats: Vec<usize> = families.iter().map(|(_, m)| 1 + rest * (m.len() - 1) / pool.max(1)).collect();
    let mut order: Vec<usize> = (0..families.len()).collect();
    let remainder = |f: usize| rest * (families[f].1.len() - 1) % pool.max(1);
    order.sort_by(|&a, &b| remainder(b).cmp(&remainder(a)).then(families[b].1.len().cmp(&families[a].1.len())).then(a.cmp(&b)));
    let given: usize = seats.iter().sum();
    for &f in order.iter().take(size - given) {
        seats[f] += 1;
    }
    let mut chosen: Vec<&TaskFiles> = Vec::with_capacity(size);
    for ((_, members), k) in families.iter().zip(seats) {
        let n = members.len();
        chosen.extend((0..k).map(|j| members[(2 * j + 1) * n / (2 * k)]));
    }
    chosen.sort_by(|a, b| a.id.cmp(&b.id));
    chosen
}

/// [`Fixtures::subset_path`] under [`Fixtures::from_env`].
pub fn subset_path(name_or_path: &str) -> PathBuf {
    Fixtures::from_env().subset_path(name_or_path)
}

/// The task ids a subset file lists, with their line numbers: one id per line, white space
/// trimmed; blank lines and lines starting with `#` are skipped. A repeated id is an error.
pub fn subset_ids(path: &Path) -> Result<Vec<(usize, String)>, DataError> {
    let text = read(path).map_err(|e| match e {
        // A name that is not a subset of the fixtures' (a path given as such is named as read).
        DataError::Io { source, .. }
            if source.kind() == std::io::ErrorKind::NotFound && path.parent().is_some_and(|dir| dir.ends_with("subsets")) =>
        {
            let mut known: Vec<String> = std::fs::read_dir(path.parent().unwrap_or(path))
                .into_iter()
                .flatten()
                .flatten()
                .filter_map(|entry| entry.file_name().to_str().and_then(|n| n.strip_suffix(".txt")).map(str::to_string))
                .collect();
            known.sort();
            let name = path.file_stem().map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into_owned());
            DataError::UnknownSubset { name, path: path.to_path_buf(), known: known.join(", ") }
        }
        other => other,
    })?;
    let mut ids: Vec<(usize, String)> = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let id = line.trim();
        if id.is_empty() || id.starts_with('#') {
            continue;
        }
        if ids.iter().any(|(_, seen)| seen == id) {
            return Err(DataError::DuplicateSubsetTask { path: path.to_path_buf(), line: index + 1, id: id.to_string() });
        }
        ids.push((index + 1, id.to_string()));
    }
    Ok(ids)
}

/// [`Fixtures::load_subset`] under [`Fixtures::from_env`].
pub fn load_subset(benchmark: Benchmark, name_or_path: &str) -> Result<Vec<TaskFiles>, DataError> {
    Fixtures::from_env().load_subset(benchmark, name_or_path)
}
