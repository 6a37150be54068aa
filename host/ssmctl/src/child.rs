//! Child processes (QEMU) that cannot outlive ssmctl, however it ends.
//!
//! [`spawn_tied`] starts a child that the kernel kills (SIGKILL) when ssmctl dies, whatever
//! kills it (SIGTERM, SIGKILL, a crash): on Linux the child asks for `PR_SET_PDEATHSIG`
//! between fork and exec, and exits at once if ssmctl already died in that window. The
//! returned [`Tied`] guard kills and reaps the child when dropped, so a normal return or an
//! error return never leaves it running either. No signal handler is needed: the kernel
//! delivers the death signal even when ssmctl is killed with SIGKILL.
//!
//! `PR_SET_PDEATHSIG` fires when the *thread* that spawned the child ends: spawn from a
//! thread that lives as long as the child (the guard's owner).

use std::io;
use std::process::{Child, Command};

/// A running child that is killed and reaped when this guard is dropped.
#[derive(Debug)]
pub struct Tied(pub Child);

impl Drop for Tied {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let _ = self.0.kill();
        }
        let _ = self.0.wait();
    }
}

/// Spawns `cmd` so that the child dies with this process (see the module doc).
pub fn spawn_tied(cmd: &mut Command) -> io::Result<Tied> {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: getpid has no preconditions.
        let parent = unsafe { libc::getpid() };
        // SAFETY: the closure runs in the forked child and only makes async-signal-safe
        // system calls (prctl, getppid, _exit), allocating nothing.
        unsafe {
            cmd.pre_exec(move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL as libc::c_ulong, 0, 0, 0) != 0 {
                    return Err(io::Error::last_os_error());
                }
                // The parent died between fork and prctl: the signal will never come.
                if libc::getppid() != parent {
                    libc::_exit(1);
                }
                Ok(())
            });
        }
    }
    cmd.spawn().map(Tied)
}
