//! Wall and CPU time of the report's inner tasks, for finding the critical path of
//! `ssmctl reproduce` (docs/decisions/0003). Off unless the environment variable
//! [`TASK_TIMES_ENV`] is set: then every [`task`] prints one line to stderr when it ends,
//! `task NAME: start S s, wall W s, thread cpu T s, process cpu P s`, where `start` is the
//! offset from the first task of the process, `thread cpu` the CPU time of the thread that
//! ran the closure (`RUSAGE_THREAD`; work the closure handed to other pool threads is not
//! in it) and `process cpu` the whole process's CPU time over the task's wall time (every
//! thread's, so it includes tasks running beside it). A task whose thread CPU is close to
//! its wall time while the process CPU is about twice that ran serially beside other work.
//! Only timings are printed; no result depends on it.

use std::sync::OnceLock;
use std::time::Instant;

/// Set (to anything) to print the task lines.
pub const TASK_TIMES_ENV: &str = "SSMCTL_TASK_TIMES";

/// Whether the lines are printed (read once).
fn enabled() -> bool {
    static ON: OnceLock<bool> = OnceLock::new();
    *ON.get_or_init(|| std::env::var_os(TASK_TIMES_ENV).is_some())
}

/// The time of the first task (the origin of `start`).
fn origin() -> Instant {
    static T0: OnceLock<Instant> = OnceLock::new();
    *T0.get_or_init(Instant::now)
}

/// CPU seconds (user + system) of the calling thread (`thread`, `RUSAGE_THREAD`) or of the
/// process (`RUSAGE_SELF`); NaN off Linux or when `getrusage` fails.
fn cpu_seconds(thread: bool) -> f64 {
    #[cfg(target_os = "linux")]
    {
        let who = if thread { libc::RUSAGE_THREAD } else { libc::RUSAGE_SELF };
        // SAFETY: getrusage writes one rusage into the zeroed struct we own; `who` is one of
        // the two values Linux accepts here.
        let mut u: libc::rusage = unsafe { std::mem::zeroed() };
        if unsafe { libc::getrusage(who, &mut u) } != 0 {
            return f64::NAN;
        }
        let tv = |t: libc::timeval| t.tv_sec as f64 + 1e-6 * t.tv_usec as f64;
        tv(u.ru_utime) + tv(u.ru_stime)
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = thread;
        f64::NAN
    }
}

/// Runs `f`, and when [`TASK_TIMES_ENV`] is set prints its timing line (see the module doc).
pub fn task<T>(name: &str, f: impl FnOnce() -> T) -> T {
    if !enabled() {
        return f();
    }
    let t0 = Instant::now();
    let start = t0.duration_since(origin()).as_secs_f64();
    let (th0, pr0) = (cpu_seconds(true), cpu_seconds(false));
    let r = f();
    let (th1, pr1) = (cpu_seconds(true), cpu_seconds(false));
    eprintln!(
        "task {name}: start {start:.1} s, wall {:.1} s, thread cpu {:.1} s, process cpu {:.1} s",
        t0.elapsed().as_secs_f64(),
        th1 - th0,
        pr1 - pr0
    );
    r
}
