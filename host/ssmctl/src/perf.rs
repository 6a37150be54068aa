//! A hardware instruction counter for benches: Linux `perf_event_open` on the calling
//! thread, user-space instructions only. Virtual machines often expose no PMU; opening then
//! fails and the bench says so.

use std::io;

/// `struct perf_event_attr` up to `config1` (`PERF_ATTR_SIZE_VER0`, 64 bytes), which the
/// kernel accepts from any version.
#[repr(C)]
#[derive(Default)]
struct Attr {
    kind: u32,
    size: u32,
    config: u64,
    sample_period: u64,
    sample_type: u64,
    read_format: u64,
    /// Bit 0 `disabled`, bit 5 `exclude_kernel`, bit 6 `exclude_hv`.
    flags: u64,
    wakeup_events: u32,
    bp_type: u32,
    config1: u64,
}

const PERF_TYPE_HARDWARE: u32 = 0;
const PERF_COUNT_HW_INSTRUCTIONS: u64 = 1;
const IOC_ENABLE: libc::c_ulong = 0x2400;
const IOC_DISABLE: libc::c_ulong = 0x2401;
const IOC_RESET: libc::c_ulong = 0x2403;

/// An open instruction counter of this thread (closed on drop).
pub struct Counter {
    fd: libc::c_int,
}

impl Counter {
    /// Opens the counter, or the OS error saying why not (no PMU in a VM, or
    /// `perf_event_paranoid` forbids it).
    pub fn instructions() -> io::Result<Counter> {
        let attr = Attr {
            kind: PERF_TYPE_HARDWARE,
            size: std::mem::size_of::<Attr>() as u32,
            config: PERF_COUNT_HW_INSTRUCTIONS,
            flags: 1 | (1 << 5) | (1 << 6),
            ..Attr::default()
        };
        // SAFETY: the attr is a valid, fully initialized VER0 struct that outlives the call;
        // pid 0 / cpu -1 / group -1 / flags 0 count this thread on any CPU.
        let fd = unsafe {
            libc::syscall(libc::SYS_perf_event_open, &attr as *const Attr, 0 as libc::pid_t, -1i32, -1i32, 0u64)
        };
        if fd < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(Counter { fd: fd as libc::c_int })
    }

    /// Instructions `f` executed in user space, `None` if the counter could not be read.
    pub fn count(&self, f: impl FnOnce()) -> Option<u64> {
        // SAFETY: ioctl and read on our own open perf fd, reading 8 bytes into a u64.
        unsafe {
            libc::ioctl(self.fd, IOC_RESET, 0);
            libc::ioctl(self.fd, IOC_ENABLE, 0);
        }
        f();
        let mut n: u64 = 0;
        let got = unsafe {
            libc::ioctl(self.fd, IOC_DISABLE, 0);
            libc::read(self.fd, (&mut n as *mut u64).cast(), std::mem::size_of::<u64>())
        };
        (got == std::mem::size_of::<u64>() as isize).then_some(n)
    }
}

impl Drop for Counter {
    fn drop(&mut self) {
        // SAFETY: closing the fd this value owns, once.
        unsafe {
            libc::close(self.fd);
        }
    }
}
