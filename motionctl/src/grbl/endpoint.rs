//! Where the sender connects: a pseudo-terminal (a symlink names it, as a serial port), or a raw
//! TCP socket (grblHAL's telnet/socket stream). One sender at a time.

use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::pty::openpty;
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
pub struct Pty {
    master: File,
    slave_name: PathBuf,
    link: PathBuf,
    connected: bool,
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
        // Our slave fd closes here: the master then sees a hang-up until a sender opens it.
        drop(pty.slave);
        Ok(Pty {
            master: File::from(pty.master),
            slave_name,
            link: link.to_path_buf(),
            connected: false,
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

impl Endpoint for Pty {
    fn poll(&mut self, timeout: Duration) -> io::Result<Input> {
        let mut input = Input::default();
        let revents = {
            let mut fds = [PollFd::new(self.master.as_fd(), PollFlags::POLLIN)];
            match poll(&mut fds, ms(timeout)) {
                Ok(_) => fds[0].revents().unwrap_or(PollFlags::empty()),
                Err(nix::errno::Errno::EINTR) => PollFlags::empty(),
                Err(e) => return Err(e.into()),
            }
        };
        let hup = revents.contains(PollFlags::POLLHUP);
        if revents.contains(PollFlags::POLLIN) {
            let mut buf = [0u8; 4096];
            match self.master.read(&mut buf) {
                Ok(n) => input.data.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                // EIO: no sender has the slave open.
                Err(e) if e.raw_os_error() == Some(nix::libc::EIO) => {}
                Err(e) => return Err(e),
            }
        }
        if hup && input.data.is_empty() {
            if self.connected {
                self.connected = false;
                input.closed = true;
            } else {
                std::thread::sleep(timeout.min(Duration::from_millis(20)));
            }
        } else if !self.connected {
            self.connected = true;
            input.opened = true;
        }
        Ok(input)
    }

    fn write(&mut self, bytes: &[u8]) {
        if !self.connected {
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
