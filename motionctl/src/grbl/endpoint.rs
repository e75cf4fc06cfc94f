//! Where the sender connects: a pseudo-terminal (a symlink names it, as a serial port), or a raw
//! TCP socket (grblHAL's telnet/socket stream). One sender at a time.

use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::pty::openpty;
use nix::sys::inotify::{AddWatchFlags, InitFlags, Inotify};
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};
use std::fs::File;
use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::os::fd::AsFd;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// What waiting on the endpoint brought.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Input {
    /// A sender connected (the welcome goes out).
    pub opened: bool,
    /// The sender went away.
    pub closed: bool,
    /// The sender went away and one connected again since the last poll (a sender that closes
    /// the port and opens it at once): both of the above, in that order.
    pub reopened: bool,
    pub data: Vec<u8>,
}

pub trait Endpoint {
    /// Waits at most `timeout` for the sender.
    fn poll(&mut self, timeout: Duration) -> io::Result<Input>;
    /// Sends to the sender if one is connected (dropped otherwise, or when it does not read).
    fn write(&mut self, bytes: &[u8]);
    fn describe(&self) -> String;
}

/// A pseudo-terminal; `link` points at its slave side.
///
/// Whether a sender has the port open is read from the opens and closes of the slave device
/// (inotify): the master's hang-up only shows while no one has it open, and a sender that closes
/// the port and opens it again between two polls would never show one, and get no welcome. The
/// hang-up stays as the fallback should the event queue overflow.
pub struct Pty {
    master: File,
    slave_name: PathBuf,
    link: PathBuf,
    opens: Inotify,
    /// File descriptors open on the slave, counted from the events: a sender is connected
    /// while any is.
    slave_fds: u32,
}

impl Pty {
    pub fn open(link: &Path) -> io::Result<Pty> {
        let pty = openpty(None, None).map_err(io::Error::from)?;
        let slave_name = nix::unistd::ttyname(pty.slave.as_fd()).map_err(io::Error::from)?;
        // Raw from the start, so nothing is echoed or translated before the sender sets it up.
        let mut t = tcgetattr(pty.slave.as_fd()).map_err(io::Error::from)?;
        cfmakeraw(&mut t);
        tcsetattr(pty.slave.as_fd(), SetArg::TCSANOW, &t).map_err(io::Error::from)?;
        let flags = fcntl(pty.master.as_fd(), FcntlArg::F_GETFL).map_err(io::Error::from)?;
        let flags = OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK;
        fcntl(pty.master.as_fd(), FcntlArg::F_SETFL(flags)).map_err(io::Error::from)?;
        // Our slave fd closes here: the master then sees a hang-up until a sender opens it.
        drop(pty.slave);
        // Watched from here on, with no fd open on it and before the symlink names it: every
        // open and close is a sender's.
        let opens = Inotify::init(InitFlags::IN_NONBLOCK | InitFlags::IN_CLOEXEC)
            .map_err(io::Error::from)?;
        let events = AddWatchFlags::IN_OPEN
            | AddWatchFlags::IN_CLOSE_WRITE
            | AddWatchFlags::IN_CLOSE_NOWRITE;
        opens.add_watch(&slave_name, events).map_err(io::Error::from)?;
        match std::fs::symlink_metadata(link) {
            Ok(m) if m.file_type().is_symlink() => std::fs::remove_file(link)?,
            Ok(_) => {
                return Err(io::Error::new(
                    io::ErrorKind::AlreadyExists,
                    format!("{} exists and is not a symlink: not replacing it", link.display()),
                ))
            }
            Err(_) => {}
        }
        std::os::unix::fs::symlink(&slave_name, link).map_err(|e| {
            io::Error::new(e.kind(), format!("cannot create the symlink {}: {e}", link.display()))
        })?;
        Ok(Pty {
            master: File::from(pty.master),
            slave_name,
            link: link.to_path_buf(),
            opens,
            slave_fds: 0,
        })
    }

    pub fn slave_name(&self) -> &Path {
        &self.slave_name
    }
}

impl Drop for Pty {
    fn drop(&mut self) {
        if std::fs::read_link(&self.link).is_ok_and(|t| t == self.slave_name) {
            let _ = std::fs::remove_file(&self.link);
        }
    }
}

fn ms(d: Duration) -> PollTimeout {
    PollTimeout::try_from(d.as_millis().min(10_000) as u64).unwrap_or(PollTimeout::ZERO)
}

impl Pty {
    /// The slave's opens and closes since the last call, in order, as connection changes.
    fn follow_opens(&mut self, input: &mut Input, hung_up: bool) {
        // EAGAIN: nothing yet. Any other failure leaves the hang-up to decide.
        for e in self.opens.read_events().unwrap_or_default() {
            let was = self.connected();
            if e.mask.contains(AddWatchFlags::IN_Q_OVERFLOW) {
                // Events were lost: the hang-up says whether anyone has it open now.
                self.slave_fds = u32::from(!hung_up);
            } else if e.mask.contains(AddWatchFlags::IN_OPEN) {
                self.slave_fds += 1;
            } else if self.slave_fds > 0 {
                self.slave_fds -= 1;
            }
            self.settle(was, input);
        }
    }

    fn connected(&self) -> bool {
        self.slave_fds > 0
    }

    /// A connection change since `was`, into `input`.
    fn settle(&self, was: bool, input: &mut Input) {
        match (was, self.connected()) {
            (false, true) => {
                input.reopened |= input.closed;
                input.opened = true;
            }
            (true, false) => input.closed = true,
            _ => {}
        }
    }
}

impl Endpoint for Pty {
    fn poll(&mut self, timeout: Duration) -> io::Result<Input> {
        let mut input = Input::default();
        let (master, opens) = {
            let mut fds = [
                PollFd::new(self.master.as_fd(), PollFlags::POLLIN),
                PollFd::new(self.opens.as_fd(), PollFlags::POLLIN),
            ];
            match poll(&mut fds, ms(timeout)) {
                Ok(_) => (
                    fds[0].revents().unwrap_or(PollFlags::empty()),
                    fds[1].revents().unwrap_or(PollFlags::empty()),
                ),
                Err(nix::errno::Errno::EINTR) => (PollFlags::empty(), PollFlags::empty()),
                Err(e) => return Err(e.into()),
            }
        };
        let hup = master.contains(PollFlags::POLLHUP);
        if master.contains(PollFlags::POLLIN) {
            let mut buf = [0u8; 4096];
            match self.master.read(&mut buf) {
                Ok(n) => input.data.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                // EIO: no sender has the slave open.
                Err(e) if e.raw_os_error() == Some(nix::libc::EIO) => {}
                Err(e) => return Err(e),
            }
        }
        if opens.contains(PollFlags::POLLIN) {
            self.follow_opens(&mut input, hup);
        }
        if hup && input.data.is_empty() {
            // Closed though no close was counted (the events overflowed): the hang-up decides.
            if self.connected() && !input.opened {
                self.slave_fds = 0;
                self.settle(true, &mut input);
            } else if !self.connected() {
                std::thread::sleep(timeout.min(Duration::from_millis(20)));
            }
        }
        Ok(input)
    }

    fn write(&mut self, bytes: &[u8]) {
        if !self.connected() {
            return;
        }
        let mut rest = bytes;
        let mut tries = 0;
        while !rest.is_empty() && tries < 200 {
            match self.master.write(rest) {
                Ok(n) => rest = &rest[n..],
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    // The sender is not reading: wait a little, then drop the rest.
                    tries += 1;
                    std::thread::sleep(Duration::from_millis(5));
                }
                Err(_) => return,
            }
        }
    }

    fn describe(&self) -> String {
        format!("{} ({})", self.link.display(), self.slave_name.display())
    }
}

/// A TCP listener serving one sender at a time; others are told so and closed.
pub struct Tcp {
    listener: TcpListener,
    client: Option<TcpStream>,
    addr: String,
}

impl Tcp {
    pub fn listen(addr: &str) -> io::Result<Tcp> {
        let listener = TcpListener::bind(addr)
            .map_err(|e| io::Error::new(e.kind(), format!("cannot listen on {addr}: {e}")))?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr().map(|a| a.to_string()).unwrap_or_else(|_| addr.into());
        Ok(Tcp { listener, client: None, addr })
    }

    pub fn local_addr(&self) -> &str {
        &self.addr
    }
}

impl Endpoint for Tcp {
    fn poll(&mut self, timeout: Duration) -> io::Result<Input> {
        let mut input = Input::default();
        loop {
            match self.listener.accept() {
                Ok((mut s, _)) => {
                    if self.client.is_some() {
                        let _ = s.write_all(b"[MSG:busy: another sender is connected]\r\n");
                        continue;
                    }
                    s.set_nonblocking(false)?;
                    s.set_nodelay(true)?;
                    self.client = Some(s);
                    input.opened = true;
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(_) => break,
            }
        }
        let Some(client) = self.client.as_mut() else {
            std::thread::sleep(timeout.min(Duration::from_millis(20)));
            return Ok(input);
        };
        client.set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        let mut buf = [0u8; 4096];
        match client.read(&mut buf) {
            Ok(0) => {
                self.client = None;
                input.closed = true;
            }
            Ok(n) => input.data.extend_from_slice(&buf[..n]),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) => {}
            Err(_) => {
                self.client = None;
                input.closed = true;
            }
        }
        Ok(input)
    }

    fn write(&mut self, bytes: &[u8]) {
        if let Some(c) = self.client.as_mut() {
            let _ = c.set_write_timeout(Some(Duration::from_secs(1)));
            if c.write_all(bytes).is_err() {
                self.client = None;
            }
        }
    }

    fn describe(&self) -> String {
        format!("TCP {}", self.addr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs::OpenOptions;
    use std::os::unix::fs::OpenOptionsExt;

    fn sender(link: &Path) -> File {
        OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(nix::libc::O_NOCTTY)
            .open(link)
            .unwrap()
    }

    fn poll(pty: &mut Pty) -> Input {
        pty.poll(Duration::from_millis(50)).unwrap()
    }

    #[test]
    fn a_sender_that_closes_and_opens_again_between_two_polls_is_seen_reconnecting() {
        let link = std::env::temp_dir().join(format!("motionctl-pty-test-{}", std::process::id()));
        let mut pty = Pty::open(&link).unwrap();
        assert_eq!(poll(&mut pty), Input::default());
        let mut a = sender(&link);
        let i = poll(&mut pty);
        assert!(i.opened && !i.closed && !i.reopened, "{i:?}");
        a.write_all(b"?").unwrap();
        assert_eq!(poll(&mut pty).data, b"?");
        // Closed and opened again before the bridge looks: no hang-up in between to see.
        drop(a);
        let b = sender(&link);
        let i = poll(&mut pty);
        assert!(i.opened && i.closed && i.reopened, "{i:?}");
        drop(b);
        let i = poll(&mut pty);
        assert!(i.closed && !i.opened && !i.reopened, "{i:?}");
        assert_eq!(poll(&mut pty), Input::default());
    }
}
