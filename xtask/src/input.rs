//! Loading a task from the command line: `--domain D --problem P` or `--game G`.

use std::path::{Path, PathBuf};

use anyhow::bail;
use benchmark_data::{AlfworldGame, Benchmark, Extra, TaskFiles};
use grounding::Task;

#[derive(Debug, Clone, clap::Args)]
pub struct TaskArgs {
    /// PDDL domain file.
    #[arg(long, requires = "problem", conflicts_with = "game")]
    pub domain: Option<PathBuf>,
    /// PDDL problem file.
    #[arg(long, requires = "domain")]
    pub problem: Option<PathBuf>,
    /// ALFWorld game (`game.tw-pddl`, or the folder holding it).
    #[arg(long)]
    pub game: Option<PathBuf>,
}

/// The innermost subcommand's matches of this process's command line ([`keep_command_line`]).
static COMMAND_LINE: std::sync::OnceLock<clap::ArgMatches> = std::sync::OnceLock::new();

/// Keeps the command line's matches, for [`given`] to tell an option typed from a default.
pub fn keep_command_line(matches: &clap::ArgMatches) {
    let mut innermost = matches;
    while let Some((_, sub)) = innermost.subcommand() {
        innermost = sub;
    }
    COMMAND_LINE.get_or_init(|| innermost.clone());
}

/// The options of the group `T` (flattened into the running command) typed on its command
/// line, each as `--name`, in the group's order, `except` left out: for a command to refuse
/// settings that its other choices would pass over in silence. A default is never named, also
/// where the command changes the group's own (`eval`'s `--lm smollm2`); nothing is named where
/// no command line was kept (a test calling a command's function).
pub fn given<T: clap::Args>(except: &[&str]) -> Vec<String> {
    let group = T::augment_args(clap::Command::new("group"));
    group.get_arguments().map(|arg| arg.get_id().as_str()).filter(|id| !except.contains(id) && typed(id)).map(option_name).collect()
}

/// The option of a field: `max_expansions` → `--max-expansions`.
pub fn option_name(id: &str) -> String {
    format!("--{}", id.replace('_', "-"))
}

/// Bad input naming `options` (a command's settings its other choices pass over) as settings
/// of `whose`; `None` for none.
pub fn settings_of(options: &[String], whose: &str) -> Option<InputError> {
    let what = match options {
        [] => return None,
        [one] => format!("{one} is a setting"),
        _ => format!("{} are settings", options.join(", ")),
    };
    Some(InputError(format!("{what} of {whose}")))
}

/// Whether the option of id `id` (its field's name) was typed on the running command's line.
pub fn typed(id: &str) -> bool {
    COMMAND_LINE.get().is_some_and(|matches| {
        matches!(matches.try_contains_id(id), Ok(true)) && matches.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
    })
}

/// The environment the commands read, checked once before any command runs: bad input (exit
/// 2) naming the variable, not a failure hours into a run.
pub fn check_environment() -> Result<(), InputError> {
    check_thread_counts()?;
    check_cache_folders()
}

/// The caches (`NSEA_MODEL_DIR`, `NSEA_DATA_DIR`, or their folders under `XDG_CACHE_HOME` or
/// `~/.cache`) must be folders where they exist: a file there failed late, as an error of the
/// run (exit 3) when a model or the task files were first fetched or read.
fn check_cache_folders() -> Result<(), InputError> {
    for (name, folder) in [("NSEA_MODEL_DIR", lm::model_dir()), ("NSEA_DATA_DIR", crate::fetch_data::data_dir())] {
        if folder.exists() && !folder.is_dir() {
            let set = std::env::var_os(name).is_some_and(|value| !value.is_empty());
            let which =
                if set { format!("{name}={}", folder.display()) } else { format!("{} (the cache {name} would name)", folder.display()) };
            return Err(InputError(format!("{which}: not a folder")));
        }
    }
    Ok(())
}

/// The worker counts the environment asks of candle's pool (`CANDLE_NUM_THREADS`,
/// `RAYON_NUM_THREADS`): empty or `0` for the default (one per processor, as candle and rayon
/// read them), else a whole number up to the larger of 1,024 and four per processor; anything
/// else is bad input naming the variable. Unchecked, `abc` was taken as unset, and 99999 made
/// the pool abort the process (no stack left for its threads).
fn check_thread_counts() -> Result<(), InputError> {
    let most = std::thread::available_parallelism().map_or(1, usize::from).saturating_mul(4).max(1024);
    for name in ["CANDLE_NUM_THREADS", "RAYON_NUM_THREADS"] {
        let Some(value) = std::env::var_os(name) else { continue };
        let text = value.to_string_lossy();
        match text.trim() {
            "" => {}
            trimmed => match trimmed.parse::<usize>() {
                Ok(n) if n <= most => {}
                _ => {
                    return Err(InputError(format!("{name}={text}: not a number of threads up to {most} (0 or empty: one per processor)")));
                }
            },
        }
    }
    Ok(())
}

/// A user error: bad input, reported with exit code 2.
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}

/// The text of a file the command line names: UTF-8 without a byte-order mark; an unreadable
/// file, or a byte that is not UTF-8 (named by line and column), is bad input.
pub fn read_text(path: &Path) -> anyhow::Result<String> {
    benchmark_data::read_text(path).map_err(|e| match e {
        benchmark_data::DataError::Io { source, .. } => InputError(format!("{}: cannot read: {source}", path.display())).into(),
        other => InputError(other.to_string()).into(),
    })
}

/// The median of timings (the upper one of an even count); `xs` is not empty.
pub fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

/// Refuses `path` as a folder to write into when something else is there (a file): bad input
/// named by its option, before any work.
pub fn folder_to_write(path: &Path, option: &str) -> anyhow::Result<()> {
    if path.exists() && !path.is_dir() {
        return Err(InputError(format!("{option} {}: a file is there, not a folder", path.display())).into());
    }
    Ok(())
}

/// Refuses, before any work, an output file `option` names that cannot be written: a folder
/// is there, or the folder it would go in does not exist.
pub fn file_to_write(path: &Path, option: &str) -> anyhow::Result<()> {
    if path.is_dir() {
        return Err(InputError(format!("{option} {}: a folder is there, not a file", path.display())).into());
    }
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(dir) if !dir.is_dir() => {
            Err(InputError(format!("{option} {}: no folder {} to write it in", path.display(), dir.display())).into())
        }
        _ => Ok(()),
    }
}

/// Writes the output file `option` names: a path the system refuses (no such folder, a folder
/// in its place, no permission) is bad input naming the option; any other failure (a full
/// disk) is not.
pub fn write_output(path: &Path, option: &str, bytes: impl AsRef<[u8]>) -> anyhow::Result<()> {
    use std::io::ErrorKind::*;
    std::fs::write(path, bytes).map_err(|e| match e.kind() {
        NotFound | PermissionDenied | IsADirectory | NotADirectory | ReadOnlyFilesystem | InvalidFilename => {
            InputError(format!("{option} {}: cannot write: {e}", path.display())).into()
        }
        _ => anyhow::Error::new(e).context(format!("cannot write {}", path.display())),
    })
}

/// A PDDL plan line without the time stamp and duration of VAL's timed format
/// (`0: (pick b1 left)`, `0.001: (pick b1 left) [1]`), which VAL reads in a sequential plan too.
pub fn untimed(step: &str) -> &str {
    let mut step = step.trim();
    if let Some((stamp, rest)) = step.split_once(':')
        && !stamp.trim().is_empty()
        && stamp.trim().chars().all(|c| c.is_ascii_digit() || c == '.')
    {
        step = rest.trim();
    }
    if let Some(open) = step.rfind('[')
        && step.ends_with(']')
        && step[open + 1..step.len() - 1].trim().chars().all(|c| c.is_ascii_digit() || c == '.')
    {
        step = step[..open].trim();
    }
    step
}

/// Whether `step` is one PDDL action, `(name arg ...)` or without its parentheses (`name arg
/// ...`, which `Spelling::pddl` reads too): one group, nothing nested, nothing before or after.
pub fn one_action(step: &str) -> bool {
    let inner = step.strip_prefix('(').and_then(|s| s.strip_suffix(')')).unwrap_or(step);
    !inner.trim().is_empty() && !inner.contains(['(', ')'])
}

impl TaskArgs {
    pub fn load(&self) -> anyhow::Result<TaskFiles> {
        match (&self.domain, &self.problem, &self.game) {
            (Some(domain), Some(problem), None) => {
                let files = TaskFiles {
                    id: problem.display().to_string(),
                    benchmark: Benchmark::Ipc,
                    domain: read_text(domain)?,
                    problem: read_text(problem)?,
                    domain_path: domain.clone(),
                    problem_path: problem.clone(),
                    extra: Extra::None,
                };
                warn(&files);
                Ok(files)
            }
            (None, None, Some(game)) => {
                let files = benchmark_data::load_alfworld_game(game, Benchmark::AlfworldSeen, game.display().to_string())
                    .map_err(|e| InputError(e.to_string()))?;
                warn(&files);
                Ok(files)
            }
            _ => bail!(InputError("give either --domain D --problem P, or --game G".into())),
        }
    }

    pub fn is_game(&self) -> bool {
        self.game.is_some()
    }
}

/// The checker's warnings on the user's own PDDL files or game (a problem for another domain, an object
/// declared twice, a type its own ancestor), each `file:line:column: warning[kind]: ...` on
/// standard error: they do not stop the command, but are not dropped. Errors are [`ground`]'s.
fn warn(files: &TaskFiles) {
    let (Ok(domain), Ok(problem)) = (pddl_syntax::parse_domain(&files.domain), pddl_syntax::parse_problem(&files.problem)) else {
        return;
    };
    let report = pddl_syntax::check(&domain, Some(&problem));
    let domain_path = embedded(files, &files.domain_path, "pddl_domain");
    let problem_path = embedded(files, &files.problem_path, "pddl_problem");
    for (diagnostics, path, source) in [(&report.domain, &domain_path, &files.domain), (&report.problem, &problem_path, &files.problem)] {
        for warning in diagnostics.iter().filter(|d| !d.is_error()) {
            eprintln!("{}", warning.render(path, source));
        }
    }
}

/// How a diagnostic names the file of PDDL text: the path, and for an ALFWorld game (whose
/// PDDL is a JSON string field) the field, since lines and columns count inside it.
fn embedded(files: &TaskFiles, path: &Path, field: &str) -> String {
    if matches!(files.extra, Extra::Alfworld(_)) { format!("{} (embedded {field})", path.display()) } else { path.display().to_string() }
}

/// Parses and grounds, turning diagnostics into `file:line:column` errors (exit code 2).
pub fn ground(files: &TaskFiles) -> anyhow::Result<Task> {
    let where_ = |path: &Path, field: &str| embedded(files, path, field);
    let domain = pddl_syntax::parse_domain(&files.domain)
        .map_err(|e| InputError(e.render(&where_(&files.domain_path, "pddl_domain"), &files.domain)))?;
    let problem = pddl_syntax::parse_problem(&files.problem)
        .map_err(|e| InputError(e.render(&where_(&files.problem_path, "pddl_problem"), &files.problem)))?;
    // Each error (names that do not check included) at its line and column in the file it is about.
    grounding::ground(&domain, &problem).map_err(|e| {
        let domain_at = where_(&files.domain_path, "pddl_domain");
        let problem_at = where_(&files.problem_path, "pddl_problem");
        InputError(e.render((&domain_at, &files.domain), (&problem_at, &files.problem))).into()
    })
}

/// The game's grammar, for ALFWorld spelling.
pub fn alfworld_game(files: &TaskFiles) -> Option<&AlfworldGame> {
    match &files.extra {
        Extra::Alfworld(game) => Some(game),
        _ => None,
    }
}

/// Bad input: a `what` named `name` that is not one of `known`.
pub fn unknown<'a>(what: &str, name: &str, known: impl IntoIterator<Item = &'a str>) -> InputError {
    InputError(format!("unknown {what} `{}` (known: {})", name.trim(), known.into_iter().collect::<Vec<_>>().join(", ")))
}

/// `seconds` as a duration; bad input (exit 2) when it is not a positive number of seconds.
pub fn seconds(seconds: f64) -> Result<std::time::Duration, InputError> {
    positive_seconds(&seconds.to_string()).map(std::time::Duration::from_secs_f64).map_err(InputError)
}

/// A clap parser for durations in seconds: finite, from a nanosecond and below a billion
/// seconds, so that `Duration::from_secs_f64` can never panic on what a user typed (`-1`,
/// `inf`, `nan`), nor round a positive number to no time at all (`1e-10`: a deadline of 0).
pub fn positive_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if (1e-9..1e9).contains(&s) => Ok(s),
        _ => Err(format!("`{text}` is not a positive number of seconds (from 1e-9 to below 1e9)")),
    }
}

/// A clap parser for a library enum whose names its variants give (`strum`): the names are
/// the option's possible values (listed in `--help`, anything else refused with exit 2), and
/// the value comes back typed. One list per enum: the enum itself.
pub fn choice<T>() -> impl clap::builder::TypedValueParser<Value = T>
where
    T: strum::VariantNames + std::str::FromStr + Clone + Send + Sync + 'static,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(T::VARIANTS).try_map(|name| name.parse::<T>())
}

/// A clap parser for `--clock`: a name of [`mcts::Clock`] (clap lists them, as [`choice`] does
/// for every enum option), refused where this platform cannot read that clock.
pub fn clock() -> impl clap::builder::TypedValueParser<Value = mcts::Clock> {
    use clap::builder::TypedValueParser;
    choice::<mcts::Clock>().try_map(|clock: mcts::Clock| {
        if clock.available() {
            Ok(clock)
        } else {
            let name: &'static str = clock.into();
            Err(format!("the `{name}` clock cannot be read on this platform (it needs clock_gettime's process CPU-time clock)"))
        }
    })
}

/// Serialises an enum field by its command-line name, as the `String` fields it replaced did
/// (record configurations hash these names, so a typed field keeps the record file's name).
pub fn serialize_name<T, S>(value: &T, serializer: S) -> Result<S::Ok, S::Error>
where
    T: Copy + Into<&'static str>,
    S: serde::Serializer,
{
    serializer.serialize_str((*value).into())
}

/// A clap parser for a finite number in `[min, max]` (`min_open`: excluding `min`).
pub fn number_in(min: f64, min_open: bool, max: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |text: &str| match text.trim().parse::<f64>() {
        Ok(value) if value.is_finite() && value <= max && (value > min || (!min_open && value == min)) => Ok(value),
        Ok(_) => {
            let low = if min_open { "(" } else { "[" };
            Err(format!("`{text}` is not a finite number in {low}{min}, {max}]"))
        }
        Err(e) => Err(format!("`{text}`: {e}")),
    }
}

/// A clap parser for a whole number of at least 1.
pub fn at_least_one<T: std::str::FromStr + PartialOrd + From<u8>>(text: &str) -> Result<T, String> {
    match text.trim().parse::<T>() {
        Ok(value) if value >= T::from(1) => Ok(value),
        _ => Err(format!("`{text}` is not a whole number of at least 1")),
    }
}

/// The progress bar of a long command: `prefix [====>   ] done/total (elapsed, eta …) message`,
/// on standard error. Where standard error is no terminal (a log file, CI), the same text is
/// written as a plain line at most every [`PROGRESS_LINE_EVERY`] ([`ProgressLines`]), where
/// indicatif would hide the bar and a run of hours under `nohup` would say nothing until its end.
pub fn progress_bar(prefix: String, total: usize) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    let bar = if std::io::stderr().is_terminal() {
        indicatif::ProgressBar::new(total as u64)
    } else {
        let target = indicatif::ProgressDrawTarget::term_like(Box::new(ProgressLines::new(PROGRESS_LINE_EVERY)));
        indicatif::ProgressBar::with_draw_target(Some(total as u64), target)
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} ({elapsed}, eta {eta}) {wide_msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix(prefix);
    bar
}

/// How often a progress bar writes a line where standard error is no terminal.
pub const PROGRESS_LINE_EVERY: std::time::Duration = std::time::Duration::from_secs(60);

/// A progress bar's drawings as plain lines, for a standard error that is no terminal: indicatif
/// draws through this (cursor moves and clears do nothing), and each drawing becomes one line on
/// standard error when `every` has passed since the bar began or since the last line; so a
/// command shorter than `every` writes nothing, as before, and a long one a line a minute at most.
/// Written here because indicatif has no line mode (its hidden target draws nothing).
pub struct ProgressLines {
    every: std::time::Duration,
    /// The drawing under way, and when the last line was written (at first: when the bar began).
    state: std::sync::Mutex<(String, std::time::Instant)>,
    /// Where the lines go (standard error; a buffer in tests).
    sink: std::sync::Mutex<Box<dyn std::io::Write + Send>>,
}

impl ProgressLines {
    /// Lines to standard error, at most one per `every`.
    pub fn new(every: std::time::Duration) -> ProgressLines {
        ProgressLines::to(every, Box::new(std::io::stderr()))
    }

    /// Lines to `sink`, at most one per `every`.
    pub fn to(every: std::time::Duration, sink: Box<dyn std::io::Write + Send>) -> ProgressLines {
        ProgressLines { every, state: std::sync::Mutex::new((String::new(), std::time::Instant::now())), sink: std::sync::Mutex::new(sink) }
    }
}

impl std::fmt::Debug for ProgressLines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProgressLines").field("every", &self.every).finish_non_exhaustive()
    }
}

impl indicatif::TermLike for ProgressLines {
    fn width(&self) -> u16 {
        // Wide enough for the bar and the longest task id (ALFWorld's game and trial), as a log
        // line need not fit a screen.
        240
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, text: &str) -> std::io::Result<()> {
        self.write_str(text)
    }
    fn write_str(&self, text: &str) -> std::io::Result<()> {
        let mut state = self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        state.0.push_str(text.trim_start_matches('\r'));
        Ok(())
    }
    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }
    fn flush(&self) -> std::io::Result<()> {
        use std::io::Write as _;
        let mut state = self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let line = std::mem::take(&mut state.0);
        let line = line.trim_end();
        if line.is_empty() || state.1.elapsed() < self.every {
            return Ok(());
        }
        state.1 = std::time::Instant::now();
        let mut sink = self.sink.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        writeln!(sink, "{line}")?;
        sink.flush()
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};
    use std::time::Duration;

    use super::ProgressLines;

    #[test]
    fn timed_plan_lines_lose_their_stamp_and_duration() {
        for (line, step) in [
            ("0: (pick b1 left)", "(pick b1 left)"),
            ("0.001: (pick b1 left) [1]", "(pick b1 left)"),
            ("  12 :  (drop b1)  [0.5] ", "(drop b1)"),
            ("(pick b1 left)", "(pick b1 left)"),
            ("pick: b1", "pick: b1"),
            ("(x) [a]", "(x) [a]"),
        ] {
            assert_eq!(super::untimed(line), step, "{line}");
        }
    }

    /// A sink the test reads back.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl std::io::Write for Shared {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(bytes);
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn bar_into(sink: &Shared, every: Duration) -> indicatif::ProgressBar {
        let lines = ProgressLines::to(every, Box::new(sink.clone()));
        let target = indicatif::ProgressDrawTarget::term_like(Box::new(lines));
        let bar = indicatif::ProgressBar::with_draw_target(Some(3), target);
        bar.set_style(indicatif::ProgressStyle::with_template("{prefix} {pos}/{len} {wide_msg}").unwrap());
        bar.set_prefix("alfworld-seen ours");
        bar
    }

    #[test]
    fn a_bar_off_a_terminal_writes_whole_lines_once_its_interval_has_passed() {
        let sink = Shared::default();
        let bar = bar_into(&sink, Duration::ZERO);
        bar.set_message("task-a");
        bar.inc(1);
        // indicatif draws at most at its refresh rate; `tick` forces a drawing.
        bar.tick();
        let text = String::from_utf8(sink.0.lock().unwrap().clone()).unwrap();
        let last = text.lines().last().expect("a line");
        assert_eq!(last, "alfworld-seen ours 1/3 task-a", "{text:?}");
        assert!(text.ends_with('\n') && !text.contains('\r') && !text.contains('\x1b'), "{text:?}");
    }

    #[test]
    fn a_command_shorter_than_the_interval_writes_nothing() {
        let sink = Shared::default();
        let bar = bar_into(&sink, Duration::from_secs(3600));
        for _ in 0..3 {
            bar.inc(1);
            bar.tick();
        }
        bar.finish_and_clear();
        assert!(sink.0.lock().unwrap().is_empty());
    }
}
