//! The guard: a tiny process that outlives the supervisor only to kill the process groups
//! it leaves behind.
//!
//! `PR_SET_PDEATHSIG` kills a supervisor's direct children when it dies, even by SIGKILL,
//! but not their children: a service that runs a helper (a shell script starting a
//! daemon, a driver forking a reader) would leave it orphaned. Every child runs in its own
//! process group, and the guard kills those groups once nobody can.
//!
//! The supervisor forks the guard when it is made. The guard puts itself in a process group
//! of its own (a Ctrl-C at the terminal does not reach it), ignores the usual stop signals,
//! keeps only the read end of a pipe and reads lines from it: `+PGID` when a child starts,
//! `-PGID` before its leader is reaped (while the zombie still holds the id, so it cannot
//! have been reused). When the pipe reaches end of file (the supervisor was dropped, or its
//! process died however it died) the guard sends SIGKILL to every group it still knows and
//! exits. After a clean stop it knows none.
//!
//! The forked guard runs no Rust runtime code: only raw system calls on fixed-size buffers
//! (after `fork` in a threaded process, only async-signal-safe calls are allowed).
//!
//! Not covered: a grandchild that leaves its group (`setsid`, `setpgid`) is not found.

use std::io;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::time::Duration;

use nix::libc;
use rustix::event::{PollFd, PollFlags};
use rustix::process::{PidfdFlags, pidfd_open};

/// The most process groups the guard keeps at once; further ones are not guarded.
const MAX_GROUPS: usize = 4096;

/// How long dropping a guard waits for it to exit.
const EXIT_WAIT: Duration = Duration::from_secs(2);

/// The supervisor's end of the guard (see the module documentation).
#[derive(Debug)]
pub(crate) struct Guard {
    write: Option<OwnedFd>,
    pid: libc::pid_t,
}

impl Guard {
    /// Forks the guard.
    pub(crate) fn spawn() -> io::Result<Self> {
        let mut fds = [0 as libc::c_int; 2];
        // SAFETY: `fds` has room for the two descriptors pipe2 writes.
        if unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) } != 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: pipe2 succeeded, so both are open descriptors that nothing else owns.
        let (read, write) = unsafe { (OwnedFd::from_raw_fd(fds[0]), OwnedFd::from_raw_fd(fds[1])) };
        // Writes never block the supervisor: a guard that stopped reading only loses lines.
        // SAFETY: fcntl on a descriptor we own.
        unsafe {
            let flags = libc::fcntl(write.as_raw_fd(), libc::F_GETFL);
            libc::fcntl(write.as_raw_fd(), libc::F_SETFL, flags | libc::O_NONBLOCK);
        }
        // SAFETY: the child runs only `guard_main`, which makes raw, async-signal-safe system
        // calls on stack buffers and never returns.
        match unsafe { libc::fork() } {
            -1 => Err(io::Error::last_os_error()),
            0 => unsafe { guard_main(read.as_raw_fd()) },
            pid => Ok(Self {
                write: Some(write),
                pid,
            }),
        }
    }

    /// The group `pgid` (a child's pid) is to be killed if the supervisor dies.
    pub(crate) fn watch(&self, pgid: u32) {
        self.say(b'+', pgid);
    }

    /// The group `pgid` is gone (its leader is about to be reaped).
    pub(crate) fn forget(&self, pgid: u32) {
        self.say(b'-', pgid);
    }

    fn say(&self, op: u8, pgid: u32) {
        let Some(write) = &self.write else {
            return;
        };
        let mut line = [0u8; 16];
        line[0] = op;
        let mut len = 1 + write_decimal(&mut line[1..15], pgid);
        line[len] = b'\n';
        len += 1;
        // One write of at most 16 bytes: atomic on a pipe (under PIPE_BUF), so lines never
        // interleave even if several threads share the supervisor's guard.
        // SAFETY: writes `len` initialised bytes from `line` to a descriptor we own.
        let written = unsafe { libc::write(write.as_raw_fd(), line.as_ptr().cast(), len) };
        if usize::try_from(written).ok() != Some(len) {
            tracing::warn!(
                pgid,
                "the process guard did not take a line: {}",
                io::Error::last_os_error()
            );
        }
    }
}

impl Drop for Guard {
    fn drop(&mut self) {
        // End of file for the guard: it kills what it still knows (nothing after a clean
        // stop) and exits.
        self.write = None;
        let Some(pid) = rustix::process::Pid::from_raw(self.pid) else {
            return;
        };
        if let Ok(pidfd) = pidfd_open(pid, PidfdFlags::empty()) {
            let timeout = super::process::timespec(EXIT_WAIT);
            let mut fds = [PollFd::new(&pidfd, PollFlags::IN)];
            if !matches!(rustix::event::poll(&mut fds, Some(&timeout)), Ok(n) if n > 0) {
                tracing::warn!(pid = self.pid, "the process guard did not exit");
                return;
            }
        }
        let mut status = 0;
        // SAFETY: waits for our own child, which has exited (or the pidfd failed and it is
        // about to).
        unsafe { libc::waitpid(self.pid, &raw mut status, 0) };
    }
}

/// Writes `n` in decimal into `out` (at least 10 bytes); returns the length.
fn write_decimal(out: &mut [u8], mut n: u32) -> usize {
    let mut digits = [0u8; 10];
    let mut count = 0;
    loop {
        digits[count] = b'0' + (n % 10) as u8;
        count += 1;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    for (i, digit) in digits[..count].iter().rev().enumerate() {
        out[i] = *digit;
    }
    count
}

/// The set of process groups the guard knows, parsed from its pipe byte by byte.
struct Groups {
    ids: [libc::pid_t; MAX_GROUPS],
    len: usize,
    op: u8,
    number: libc::pid_t,
}

impl Groups {
    fn feed(&mut self, byte: u8) {
        match byte {
            b'+' | b'-' => {
                self.op = byte;
                self.number = 0;
            }
            b'0'..=b'9' => {
                self.number = self
                    .number
                    .saturating_mul(10)
                    .saturating_add(libc::pid_t::from(byte - b'0'));
            }
            b'\n' => {
                let id = self.number;
                let found = self.ids[..self.len].iter().position(|g| *g == id);
                match (self.op, found) {
                    (b'+', None) if self.len < MAX_GROUPS && id > 1 => {
                        self.ids[self.len] = id;
                        self.len += 1;
                    }
                    (b'-', Some(i)) => {
                        self.len -= 1;
                        self.ids[i] = self.ids[self.len];
                    }
                    _ => {}
                }
                self.op = 0;
                self.number = 0;
            }
            _ => {}
        }
    }
}

/// The guard process (see the module documentation). Never returns.
///
/// # Safety
/// Only in the child of `fork`, with `read` the read end of the guard's pipe.
unsafe fn guard_main(read: libc::c_int) -> ! {
    const FD: libc::c_int = 3;
    // SAFETY: raw system calls on descriptors and constants; async-signal-safe.
    unsafe {
        libc::setpgid(0, 0);
        for signal in [
            libc::SIGINT,
            libc::SIGTERM,
            libc::SIGHUP,
            libc::SIGQUIT,
            libc::SIGPIPE,
        ] {
            libc::signal(signal, libc::SIG_IGN);
        }
        if read != FD {
            libc::dup2(read, FD);
        }
        // Everything else inherited goes: the write end of our own pipe (or end of file
        // would never come), other pipes, sockets, shared memory.
        if libc::syscall(libc::SYS_close_range, FD + 1, libc::c_uint::MAX, 0) != 0 {
            for fd in FD + 1..65536 {
                libc::close(fd);
            }
        }
        // Standard streams to /dev/null: holding the supervisor's stderr open would keep
        // whoever reads it waiting.
        let null = libc::open(c"/dev/null".as_ptr(), libc::O_RDWR);
        if null >= 0 {
            for fd in 0..FD {
                libc::dup2(null, fd);
            }
            libc::close(null);
        }
        let mut groups = Groups {
            ids: [0; MAX_GROUPS],
            len: 0,
            op: 0,
            number: 0,
        };
        let mut buf = [0u8; 512];
        loop {
            let n = libc::read(FD, buf.as_mut_ptr().cast(), buf.len());
            if n > 0 {
                for byte in &buf[..n.unsigned_abs()] {
                    groups.feed(*byte);
                }
            } else if n == 0 || *libc::__errno_location() != libc::EINTR {
                break;
            }
        }
        for id in &groups.ids[..groups.len] {
            libc::kill(-*id, libc::SIGKILL);
        }
        libc::_exit(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_add_and_remove_groups_even_when_split_across_reads() {
        fn check(input: &[u8], expected: &[libc::pid_t]) {
            let mut groups = Groups {
                ids: [0; MAX_GROUPS],
                len: 0,
                op: 0,
                number: 0,
            };
            for byte in input {
                groups.feed(*byte);
            }
            let mut got = groups.ids[..groups.len].to_vec();
            got.sort_unstable();
            assert_eq!(got, expected, "{}", String::from_utf8_lossy(input));
        }
        check(b"+12\n+34\n", &[12, 34]);
        check(b"+12\n+34\n-12\n", &[34]);
        check(b"+12\n+12\n", &[12]);
        check(b"-5\n+1\n+0\n", &[]);
        check(b"+4294967295\n", &[libc::pid_t::MAX]);
    }

    #[test]
    fn numbers_are_written_in_decimal() {
        fn check(n: u32, expected: &str) {
            let mut out = [0u8; 10];
            let len = write_decimal(&mut out, n);
            assert_eq!(&out[..len], expected.as_bytes());
        }
        check(0, "0");
        check(7, "7");
        check(4_194_304, "4194304");
        check(u32::MAX, "4294967295");
    }
}
