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
/// Who has the slave open is read from inotify's open and close events on the slave's device
/// node, not from the master's hang-up: a sender that closes and reopens the port at once
/// leaves no hang-up to see, yet a real grbl resets (and greets) on every open.
pub struct Pty {
    master: File,
    slave_name: PathBuf,
    link: PathBuf,
    watch: Inotify,
    /// Open file descriptions of the slave (senders may open it more than once).
    opens: u32,
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
        // Our slave fd closes before the watch starts: every open and close it sees is a sender's.
        drop(pty.slave);
        let watch_err = |e: nix::errno::Errno| {
            io::Error::new(
                io::Error::from(e).kind(),
                format!("cannot watch {} for senders opening it: {e}", slave_name.display()),
            )
        };
        let watch =
            Inotify::init(InitFlags::IN_NONBLOCK | InitFlags::IN_CLOEXEC).map_err(watch_err)?;
        watch
            .add_watch(&slave_name, AddWatchFlags::IN_OPEN | AddWatchFlags::IN_CLOSE)
            .map_err(watch_err)?;
        Ok(Pty {
            master: File::from(pty.master),
            slave_name,
            link: link.to_path_buf(),
            watch,
            opens: 0,
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
    /// Opens and closes since the last look, in order: `closed` when the last sender's
    /// description went, `opened` when one came while none was open (both, for a reopen: the
    /// session handles `closed` first).
    fn note_opens(&mut self, input: &mut Input) -> io::Result<()> {
        let events = match self.watch.read_events() {
            Ok(events) => events,
            Err(nix::errno::Errno::EAGAIN) => return Ok(()),
            Err(e) => return Err(e.into()),
        };
        for e in events {
            if e.mask.contains(AddWatchFlags::IN_OPEN) {
                input.opened |= self.opens == 0;
                self.opens += 1;
            } else if e.mask.intersects(AddWatchFlags::IN_CLOSE) && self.opens > 0 {
                self.opens -= 1;
                input.closed |= self.opens == 0;
            }
        }
        Ok(())
    }
}

impl Endpoint for Pty {
    fn poll(&mut self, timeout: Duration) -> io::Result<Input> {
        let mut input = Input::default();
        // The master is watched only while a sender has the slave open: without one it reports
        // a hang-up at once, for ever.
        let connected = self.opens > 0;
        let (watch_ready, master_ready) = {
            let mut fds = [
                PollFd::new(self.watch.as_fd(), PollFlags::POLLIN),
                PollFd::new(self.master.as_fd(), PollFlags::POLLIN),
            ];
            let n = if connected { 2 } else { 1 };
            match poll(&mut fds[..n], ms(timeout)) {
                Ok(_) => {
                    let ready =
                        |f: &PollFd| f.revents().is_some_and(|r| r.contains(PollFlags::POLLIN));
                    (ready(&fds[0]), connected && ready(&fds[1]))
                }
                Err(nix::errno::Errno::EINTR) => (false, false),
                Err(e) => return Err(e.into()),
            }
        };
        if master_ready {
            let mut buf = [0u8; 4096];
            match self.master.read(&mut buf) {
                Ok(n) => input.data.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                // EIO: the sender closed the slave; its close event says so.
                Err(e) if e.raw_os_error() == Some(nix::libc::EIO) => {}
                Err(e) => return Err(e),
            }
        }
        if watch_ready {
            self.note_opens(&mut input)?;
        }
        Ok(input)
    }

    fn write(&mut self, bytes: &[u8]) {
        if self.opens == 0 {
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

    /// Polls until something happens (at most 2 s).
    fn next(pty: &mut Pty) -> Input {
        for _ in 0..100 {
            let input = pty.poll(Duration::from_millis(20)).unwrap();
            if input != Input::default() {
                return input;
            }
        }
        Input::default()
    }

    fn port(pty: &Pty) -> File {
        OpenOptions::new().read(true).write(true).open(pty.slave_name()).unwrap()
    }

    #[test]
    fn a_sender_that_closes_and_reopens_at_once_is_seen_leaving_and_coming() {
        let link = std::env::temp_dir().join(format!("motionctl-pty-{}", std::process::id()));
        let mut pty = Pty::open(&link).unwrap();
        assert_eq!(pty.poll(Duration::from_millis(10)).unwrap(), Input::default());
        let mut sender = port(&pty);
        assert_eq!(next(&mut pty), Input { opened: true, ..Input::default() });
        sender.write_all(b"?").unwrap();
        assert_eq!(next(&mut pty), Input { data: b"?".to_vec(), ..Input::default() });
        // Closed and opened again before the bridge looks: no hang-up is left to see.
        drop(sender);
        let mut sender = port(&pty);
        assert_eq!(next(&mut pty), Input { opened: true, closed: true, data: Vec::new() });
        // A second description of the same port (a sender's helper) is not a new sender.
        let helper = port(&pty);
        drop(helper);
        assert_eq!(next(&mut pty), Input::default());
        pty.write(b"ok\r\n");
        let mut got = [0u8; 4];
        sender.read_exact(&mut got).unwrap();
        assert_eq!(&got, b"ok\r\n");
        drop(sender);
        assert_eq!(next(&mut pty), Input { closed: true, ..Input::default() });
        drop(pty);
        assert!(std::fs::symlink_metadata(&link).is_err(), "the symlink outlived the bridge");
    }
}
