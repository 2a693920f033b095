//! The clock a search's time limit is read on.
//!
//! The paper bounds Phase II by wall-clock time (250 s a task), so a search that runs beside
//! other work gets less done in its limit and can lose where it would win alone: its verdict
//! depends on the machine's load. [`Clock::Cpu`] reads the processor time the process itself
//! has used instead, which other processes do not spend: the same limit, on an idle machine
//! about the same work, and the same work whatever else runs (`nice 19` in the background
//! included). Counts (expansions, simulations, model calls) remain the bounds that do not
//! depend on the machine at all.

use std::cell::Cell;
use std::time::{Duration, Instant};

/// [`Stopwatch::past`] reads the processor-time clock again only after this much real time:
/// the read is a system call (0.8-2 µs here, against 25 ns for the wall clock's), which on a
/// search of cheap expansions (blind A*) doubled the time; the limit is then overshot by at
/// most this much real time (times the process's busy threads).
const CPU_READ_INTERVAL: Duration = Duration::from_millis(1);

/// What a time limit is measured on (command-line names `wall`, `cpu`).
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    Default,
    serde::Serialize,
    serde::Deserialize,
    strum::EnumString,
    strum::IntoStaticStr,
    strum::VariantNames,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case", parse_err_ty = crate::UnknownName, parse_err_fn = Clock::unknown)]
pub enum Clock {
    /// Elapsed real time, what a user waits (the paper's).
    #[default]
    Wall,
    /// Processor time used by this process, all its threads together (`CLOCK_PROCESS_CPUTIME_ID`):
    /// one busy thread counts one second a second, two count two, a thread waiting for the
    /// processor or a server counts nothing.
    Cpu,
}

impl Clock {
    fn unknown(given: &str) -> crate::UnknownName {
        crate::UnknownName::of::<Clock>("clock", given)
    }

    /// Whether this is the wall clock (for `serde(skip_serializing_if)`: configurations
    /// written before the clock was a setting name the wall clock by leaving it out).
    pub fn is_wall(&self) -> bool {
        *self == Clock::Wall
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        self.into()
    }

    /// Whether this platform can read the clock (the processor-time clock is read with
    /// `clock_gettime`, which Windows and a few Unix systems do not offer for a process).
    pub fn available(self) -> bool {
        match self {
            Clock::Wall => true,
            Clock::Cpu => cpu::now().is_some(),
        }
    }
}

/// A clock started at one moment: how much of a limit has been used since.
#[derive(Debug, Clone)]
pub struct Stopwatch {
    clock: Clock,
    wall: Instant,
    /// The process's processor time at the start (zero on the wall clock).
    cpu: Duration,
    /// The processor clock's last reading by [`Stopwatch::past`]: (real time, processor time
    /// used) since the start.
    last: Cell<(Duration, Duration)>,
}

impl Stopwatch {
    /// Starts now on `clock`. On a platform without the processor-time clock
    /// ([`Clock::available`]) it reads the wall clock: callers that offer the choice check
    /// availability when they parse it.
    pub fn start(clock: Clock) -> Stopwatch {
        let (clock, cpu) = match clock {
            Clock::Wall => (Clock::Wall, Duration::ZERO),
            Clock::Cpu => cpu::now().map_or((Clock::Wall, Duration::ZERO), |now| (Clock::Cpu, now)),
        };
        Stopwatch { clock, wall: Instant::now(), cpu, last: Cell::new((Duration::ZERO, Duration::ZERO)) }
    }

    /// The clock it reads.
    pub fn clock(&self) -> Clock {
        self.clock
    }

    /// Time used since the start, on its clock.
    pub fn elapsed(&self) -> Duration {
        match self.clock {
            Clock::Wall => self.wall.elapsed(),
            Clock::Cpu => cpu::now().map_or_else(|| self.wall.elapsed(), |now| now.saturating_sub(self.cpu)),
        }
    }

    /// Real time since the start, whatever the clock (what a report shows as duration).
    pub fn wall_elapsed(&self) -> Duration {
        self.wall.elapsed()
    }

    /// Whether `limit` (if any) has been used up. Cheap enough to ask before every expansion:
    /// on the processor clock it reads that clock at most once a millisecond of real time
    /// (`CPU_READ_INTERVAL`), answering from the last reading in between.
    pub fn past(&self, limit: Option<Duration>) -> bool {
        let Some(limit) = limit else { return false };
        if self.clock == Clock::Wall {
            return self.wall.elapsed() >= limit;
        }
        let now = self.wall.elapsed();
        let (at, used) = self.last.get();
        if now.saturating_sub(at) < CPU_READ_INTERVAL {
            return used >= limit;
        }
        let used = self.elapsed();
        self.last.set((now, used));
        used >= limit
    }
}

#[cfg(any(
    target_os = "linux",
    target_os = "android",
    target_vendor = "apple",
    target_os = "freebsd",
    target_os = "openbsd",
    target_os = "dragonfly"
))]
mod cpu {
    use std::time::Duration;

    /// The process's processor time (a system call, 0.8-2 µs here: [`super::Stopwatch::past`]
    /// reads it at most once a millisecond).
    pub fn now() -> Option<Duration> {
        let t = rustix::time::clock_gettime(rustix::time::ClockId::ProcessCPUTime);
        Some(Duration::new(u64::try_from(t.tv_sec).ok()?, u32::try_from(t.tv_nsec).ok()?))
    }
}

#[cfg(not(any(
    target_os = "linux",
    target_os = "android",
    target_vendor = "apple",
    target_os = "freebsd",
    target_os = "openbsd",
    target_os = "dragonfly"
)))]
mod cpu {
    use std::time::Duration;

    pub fn now() -> Option<Duration> {
        None
    }
}
