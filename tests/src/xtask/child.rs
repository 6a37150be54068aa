//! Children that cannot outlive the xtask: every command the xtask starts (`cmd`) asks the
//! kernel, between fork and exec, for SIGKILL when the xtask dies (`PR_SET_PDEATHSIG`,
//! Linux), whatever kills it, and exits at once if the xtask already died in that window.
//! So a killed `cargo xtask test` or `pil-record` leaves no QEMU or `ssmctl pil` (and, through
//! ssmctl's own tie, no QEMU behind it) running. [`Tied`] also kills and reaps a child on
//! every return path of the code that waits for it (timeouts, errors).
//!
//! `PR_SET_PDEATHSIG` fires when the thread that spawned the child ends: the xtask waits for
//! each child on the thread that started it (`pil-record` runs one scoped thread per run).

use std::process::{Child, Command};

/// Arms `c` so that its child dies with this process (no-op off Linux).
pub fn tie(c: &mut Command) {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: getpid has no preconditions.
        let parent = unsafe { libc::getpid() };
        // SAFETY: the closure runs in the forked child and only makes async-signal-safe
        // system calls (prctl, getppid, _exit), allocating nothing.
        unsafe {
            c.pre_exec(move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL as libc::c_ulong, 0, 0, 0) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                if libc::getppid() != parent {
                    libc::_exit(1);
                }
                Ok(())
            });
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = c;
}

/// A running child, killed and reaped when dropped.
pub struct Tied(pub Child);

impl Drop for Tied {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let _ = self.0.kill();
        }
        let _ = self.0.wait();
    }
}
