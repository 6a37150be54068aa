//! The steps of `cargo xtask test`: each step's start (seconds after the command began), wall
//! time and outcome, printed when it ends and as a table at the end, also written as JSON
//! ([`Steps::write_json`]); [`Gate`] lets a step started on its own thread wait for the
//! result of another (QEMU installed, the host build done); [`run_logged`] runs a command of
//! a step that runs beside others with its output in a log file, shown when it fails.

use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::{Condvar, Mutex};
use std::time::Instant;

use crate::Result;

/// One finished step.
#[derive(Debug, Clone)]
pub struct Row {
    pub name: String,
    pub start_s: f64,
    pub seconds: f64,
    /// `None` when the step passed, else its error.
    pub error: Option<String>,
}

/// The steps of one command, timed from [`Steps::new`].
pub struct Steps {
    t0: Instant,
    rows: Mutex<Vec<Row>>,
}

impl Steps {
    pub fn new() -> Self {
        Self { t0: Instant::now(), rows: Mutex::new(Vec::new()) }
    }

    /// Runs `f` as the step `name`: prints its start and end with its wall time and records it.
    pub fn run<T>(&self, name: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
        let start = self.t0.elapsed().as_secs_f64();
        println!("step: {name}: started at {start:.1} s");
        let t = Instant::now();
        let r = f();
        let seconds = t.elapsed().as_secs_f64();
        match &r {
            Ok(_) => println!("step: {name}: ok in {seconds:.1} s"),
            Err(e) => println!("step: {name}: FAILED in {seconds:.1} s: {}", first_line(e)),
        }
        let row = Row { name: name.to_string(), start_s: start, seconds, error: r.as_ref().err().cloned() };
        self.rows.lock().unwrap_or_else(|p| p.into_inner()).push(row);
        r
    }

    /// Records a part of a step (e.g. one test binary of the host tests) timed by the step
    /// itself, `start_s` seconds after the command began.
    pub fn add(&self, row: Row) {
        self.rows.lock().unwrap_or_else(|p| p.into_inner()).push(row);
    }

    /// The finished steps in the order they started.
    pub fn rows(&self) -> Vec<Row> {
        let mut rows = self.rows.lock().unwrap_or_else(|p| p.into_inner()).clone();
        rows.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
        rows
    }

    /// Seconds since the command began.
    pub fn elapsed(&self) -> f64 {
        self.t0.elapsed().as_secs_f64()
    }

    /// The table of steps: name, start, wall time, result; then the whole command's wall time.
    pub fn table(&self) -> String {
        let rows = self.rows();
        let width = rows.iter().map(|r| r.name.len()).max().unwrap_or(4).max(4);
        let mut s = format!("{:<width$}  {:>8}  {:>8}  result\n", "step", "start s", "wall s");
        for r in &rows {
            let result = if r.error.is_none() { "ok" } else { "FAILED" };
            s.push_str(&format!("{:<width$}  {:>8.1}  {:>8.1}  {result}\n", r.name, r.start_s, r.seconds));
        }
        s.push_str(&format!("{:<width$}  {:>8}  {:>8.1}\n", "whole command", "", self.elapsed()));
        s
    }

    /// The steps as JSON with `extra` keys (CPU time, load) added at the top level.
    pub fn json(&self, extra: serde_json::Value) -> serde_json::Value {
        let steps: Vec<serde_json::Value> = self
            .rows()
            .iter()
            .map(|r| {
                serde_json::json!({"name": r.name, "start_seconds": r.start_s, "seconds": r.seconds,
                    "ok": r.error.is_none(), "error": r.error})
            })
            .collect();
        let mut v = serde_json::json!({ "steps": steps, "total_seconds": self.elapsed() });
        if let (Some(o), serde_json::Value::Object(e)) = (v.as_object_mut(), extra) {
            o.extend(e);
        }
        v
    }

    /// Writes [`Steps::json`] to `path`.
    pub fn write_json(&self, path: &Path, extra: serde_json::Value) -> Result<()> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let text = serde_json::to_string_pretty(&self.json(extra)).map_err(|e| e.to_string())?;
        crate::files::write_atomic(path, text.as_bytes())
    }
}

fn first_line(s: &str) -> &str {
    s.lines().next().unwrap_or("")
}

/// A result set once by one step and awaited by others.
pub struct Gate<T> {
    value: Mutex<Option<T>>,
    ready: Condvar,
}

impl<T: Clone> Gate<T> {
    pub fn new() -> Self {
        Self { value: Mutex::new(None), ready: Condvar::new() }
    }

    pub fn set(&self, v: T) {
        *self.value.lock().unwrap_or_else(|p| p.into_inner()) = Some(v);
        self.ready.notify_all();
    }

    /// Blocks until [`Gate::set`] was called, then returns a copy of the value.
    pub fn wait(&self) -> T {
        let mut g = self.value.lock().unwrap_or_else(|p| p.into_inner());
        loop {
            if let Some(v) = g.as_ref() {
                return v.clone();
            }
            g = self.ready.wait(g).unwrap_or_else(|p| p.into_inner());
        }
    }
}

/// Runs `c` with stdout and stderr into `log` (a step running beside others keeps its
/// compiler output out of theirs); on failure the error carries the whole log.
pub fn run_logged(c: &mut Command, log: &Path) -> Result<()> {
    if let Some(dir) = log.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let file = std::fs::File::create(log).map_err(|e| format!("{}: {e}", log.display()))?;
    let err = file.try_clone().map_err(|e| format!("{}: {e}", log.display()))?;
    let status =
        c.stdin(Stdio::null()).stdout(file).stderr(err).status().map_err(|e| format!("cannot start {c:?}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        Err(format!("{c:?} failed with {status} (log {}):\n{text}", log.display()))
    }
}

/// Asks the kernel to run `c`'s process tree at a lower priority (nice 5: a third of a normal
/// process's CPU share when they compete): steps beside the host build take mostly the cores
/// it leaves idle, and still progress on a machine loaded by other work.
pub fn lower_priority(c: &mut Command) {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: the closure runs in the forked child and only calls setpriority, an
        // async-signal-safe system call; it allocates nothing.
        unsafe {
            c.pre_exec(|| {
                // A failure leaves the default priority: only the scheduling changes.
                let _ = libc::setpriority(libc::PRIO_PROCESS, 0, 5);
                Ok(())
            });
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = c;
}

/// User and system CPU seconds of every child process that has ended and been waited for
/// (their own children included), and the load averages of `/proc/loadavg`.
pub fn cpu_and_load() -> serde_json::Value {
    // SAFETY: getrusage writes into the zeroed struct it is given.
    let (user, sys) = unsafe {
        let mut u: libc::rusage = std::mem::zeroed();
        if libc::getrusage(libc::RUSAGE_CHILDREN, &mut u) == 0 {
            let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
            (Some(s(u.ru_utime)), Some(s(u.ru_stime)))
        } else {
            (None, None)
        }
    };
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "));
    serde_json::json!({ "children_cpu_user_seconds": user, "children_cpu_system_seconds": sys, "load_average_1_5_15_min": load })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_are_recorded_in_start_order_with_their_errors() {
        let s = Steps::new();
        std::thread::scope(|sc| {
            let late = sc.spawn(|| {
                std::thread::sleep(std::time::Duration::from_millis(30));
                s.run("second", || Err::<(), _>("broke\nmore".to_string()))
            });
            assert_eq!(s.run("first", || Ok(7)), Ok(7));
            assert!(late.join().unwrap().is_err());
        });
        let rows = s.rows();
        assert_eq!(rows.iter().map(|r| r.name.as_str()).collect::<Vec<_>>(), ["first", "second"]);
        assert_eq!(rows[1].error.as_deref(), Some("broke\nmore"));
        let t = s.table();
        assert!(t.contains("first") && t.contains("FAILED") && t.contains("whole command"), "{t}");
        let v = s.json(serde_json::json!({"x": 1}));
        assert_eq!(v["steps"][1]["ok"], false);
        assert_eq!(v["x"], 1);
    }

    #[test]
    fn a_gate_hands_its_value_to_every_waiter() {
        let g = Gate::new();
        std::thread::scope(|sc| {
            let a = sc.spawn(|| g.wait());
            let b = sc.spawn(|| g.wait());
            g.set(Ok::<u32, String>(3));
            assert_eq!(a.join().unwrap(), Ok(3));
            assert_eq!(b.join().unwrap(), Ok(3));
        });
    }

    #[test]
    fn a_failing_logged_command_reports_its_output() {
        let log = std::env::temp_dir().join(format!("xtask-steps-{}.log", std::process::id()));
        let e = run_logged(Command::new("sh").args(["-c", "echo out; echo err >&2; exit 3"]), &log).unwrap_err();
        assert!(e.contains("out") && e.contains("err") && e.contains(&log.display().to_string()), "{e}");
        assert!(run_logged(&mut Command::new("true"), &log).is_ok());
        std::fs::remove_file(&log).unwrap();
    }
}
