//! The byte link to the board: a serial port, a TCP socket (the QEMU board's UART, see
//! [`crate::qemu`]), the in-process simulated board (`crate::sim_board`) or an in-memory
//! [`Loopback`] for tests. Everything above (the CLI's link commands, the job runner) talks to a
//! `dyn Transport` only.

use std::fmt;
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::time::Duration;

/// Default serial speed, baud.
pub const DEFAULT_BAUD: u32 = 460_800;
/// Longest a TCP connect may take before it is reported.
pub const TCP_CONNECT_TIMEOUT: Duration = Duration::from_secs(3);

/// Counts of what a noise proxy (`crate::noise`) did, per direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoiseStats {
    pub bytes: u64,
    pub corrupted: u64,
    pub dropped: u64,
}

/// A bidirectional byte stream to the board.
pub trait Transport {
    /// Writes all of `bytes`.
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Bytes received within `timeout` (returns as soon as some arrived); empty when nothing
    /// arrived in time. An error means the link is broken.
    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>>;
    /// Opens the link again after an error (serial: reopen the port; TCP: reconnect).
    fn reconnect(&mut self) -> io::Result<()> {
        Err(io::Error::new(io::ErrorKind::Unsupported, "this link cannot reconnect"))
    }
    /// "serial port /dev/ttyACM0 at 460800 baud", for messages.
    fn describe(&self) -> String;
    /// What a noise proxy did (to the board, from the board), if there is one.
    fn noise_stats(&self) -> Option<(NoiseStats, NoiseStats)> {
        None
    }
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).send(bytes)
    }
    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        (**self).recv(timeout)
    }
    fn reconnect(&mut self) -> io::Result<()> {
        (**self).reconnect()
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
    fn noise_stats(&self) -> Option<(NoiseStats, NoiseStats)> {
        (**self).noise_stats()
    }
}

/// Where the link goes, from the command line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LinkTarget {
    Serial {
        port: String,
        baud: u32,
    },
    /// A TCP socket carrying the board's UART bytes (e.g. a QEMU started by hand).
    Tcp {
        addr: String,
    },
    /// Start QEMU with the link firmware (`firmware`, or the default build) and talk to it.
    Qemu {
        firmware: Option<PathBuf>,
    },
    /// The in-process simulated board (`BoardLink` + `SimTarget`).
    Sim,
}

impl fmt::Display for LinkTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkTarget::Serial { port, baud } => write!(f, "serial port {port} at {baud} baud"),
            LinkTarget::Tcp { addr } => write!(f, "TCP {addr}"),
            LinkTarget::Qemu { .. } => write!(f, "the QEMU board"),
            LinkTarget::Sim => write!(f, "the simulated board"),
        }
    }
}

/// A serial port, 8N1, no flow control.
pub struct Serial {
    port: Box<dyn serialport::SerialPort>,
    path: String,
    baud: u32,
}

fn serial_error(path: &str, e: serialport::Error) -> io::Error {
    use serialport::ErrorKind as K;
    let kind = match e.kind() {
        K::Io(k) => k,
        K::NoDevice => io::ErrorKind::NotFound,
        K::InvalidInput => io::ErrorKind::InvalidInput,
        K::Unknown => io::ErrorKind::Other,
    };
    let msg = match kind {
        io::ErrorKind::NotFound => format!("port {path} not found: {e}"),
        io::ErrorKind::PermissionDenied => format!(
            "permission denied opening port {path}: {e} (add yourself to the port's group, \
             e.g. `sudo usermod -aG dialout $USER`, and log in again)"
        ),
        _ => format!("cannot open port {path}: {e}"),
    };
    io::Error::new(kind, msg)
}

impl Serial {
    pub fn open(path: &str, baud: u32) -> io::Result<Serial> {
        let port = serialport::new(path, baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(Duration::from_millis(10))
            .open()
            .map_err(|e| serial_error(path, e))?;
        Ok(Serial { port, path: path.to_string(), baud })
    }
}

impl Transport for Serial {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        self.port.set_timeout(timeout.max(Duration::from_millis(1)))?;
        let mut buf = [0u8; 4096];
        match self.port.read(&mut buf) {
            Ok(n) => Ok(buf[..n].to_vec()),
            Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => {
                Ok(Vec::new())
            }
            Err(e) => Err(e),
        }
    }

    fn reconnect(&mut self) -> io::Result<()> {
        *self = Serial::open(&self.path, self.baud)?;
        Ok(())
    }

    fn describe(&self) -> String {
        format!("serial port {} at {} baud", self.path, self.baud)
    }
}

/// A TCP connection (the QEMU UART, or any board bridged to a socket).
pub struct Tcp {
    stream: TcpStream,
    addr: String,
}

impl Tcp {
    pub fn connect(addr: &str) -> io::Result<Tcp> {
        let resolved = addr
            .to_socket_addrs()
            .map_err(|e| io::Error::new(e.kind(), format!("bad address {addr}: {e}")))?
            .next()
            .ok_or_else(|| {
                io::Error::new(io::ErrorKind::InvalidInput, format!("bad address {addr}"))
            })?;
        let stream = TcpStream::connect_timeout(&resolved, TCP_CONNECT_TIMEOUT)
            .map_err(|e| io::Error::new(e.kind(), format!("cannot connect to {addr}: {e}")))?;
        stream.set_nodelay(true)?;
        Ok(Tcp { stream, addr: addr.to_string() })
    }
}

impl Transport for Tcp {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.stream.write_all(bytes)
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        self.stream.set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        let mut buf = [0u8; 4096];
        match self.stream.read(&mut buf) {
            Ok(0) => Err(io::Error::new(
                io::ErrorKind::ConnectionAborted,
                format!("{} closed the connection", self.addr),
            )),
            Ok(n) => Ok(buf[..n].to_vec()),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) =>
            {
                Ok(Vec::new())
            }
            Err(e) => Err(e),
        }
    }

    fn reconnect(&mut self) -> io::Result<()> {
        let _ = self.stream.shutdown(std::net::Shutdown::Both);
        *self = Tcp::connect(&self.addr)?;
        Ok(())
    }

    fn describe(&self) -> String {
        format!("TCP {}", self.addr)
    }
}

/// An in-memory transport: what is sent can be read back with [`Loopback::sent`], and `recv`
/// returns bytes queued with [`Loopback::queue`]. For tests of code above the link.
#[derive(Debug, Default)]
pub struct Loopback {
    sent: Vec<u8>,
    incoming: std::collections::VecDeque<Vec<u8>>,
}

impl Loopback {
    pub fn queue(&mut self, bytes: &[u8]) {
        self.incoming.push_back(bytes.to_vec());
    }

    pub fn sent(&self) -> &[u8] {
        &self.sent
    }

    /// Takes everything sent so far.
    pub fn take_sent(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.sent)
    }
}

impl Transport for Loopback {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.sent.extend_from_slice(bytes);
        Ok(())
    }

    fn recv(&mut self, _timeout: Duration) -> io::Result<Vec<u8>> {
        Ok(self.incoming.pop_front().unwrap_or_default())
    }

    fn describe(&self) -> String {
        "in-memory loopback".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_serial_port_is_named() {
        let Err(e) = Serial::open("/dev/ttyNOPE9", DEFAULT_BAUD) else { panic!("no such port") };
        assert!(e.to_string().starts_with("port /dev/ttyNOPE9 not found: "), "{e}");
    }

    #[test]
    fn tcp_round_trips_and_reports_a_closed_peer() {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap().to_string();
        let echo = std::thread::spawn(move || {
            let (mut s, _) = listener.accept().unwrap();
            let mut b = [0u8; 3];
            s.read_exact(&mut b).unwrap();
            s.write_all(&b).unwrap();
        });
        let mut t = Tcp::connect(&addr).unwrap();
        t.send(b"abc").unwrap();
        let mut got = Vec::new();
        while got.len() < 3 {
            got.extend(t.recv(Duration::from_millis(200)).unwrap());
        }
        assert_eq!(got, b"abc");
        echo.join().unwrap();
        let err = loop {
            match t.recv(Duration::from_millis(200)) {
                Ok(_) => continue,
                Err(e) => break e,
            }
        };
        assert!(err.to_string().contains("closed the connection"), "{err}");
    }

    #[test]
    fn loopback_round_trips() {
        let mut l = Loopback::default();
        let link: &mut dyn Transport = &mut l;
        link.send(b"abc").unwrap();
        assert_eq!(link.recv(Duration::ZERO).unwrap(), b"");
        l.queue(b"ok");
        assert_eq!(l.recv(Duration::ZERO).unwrap(), b"ok");
        assert_eq!(l.sent(), b"abc");
    }
}
