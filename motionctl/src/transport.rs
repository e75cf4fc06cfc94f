//! The byte link to the board: a serial port, or the UART socket of a QEMU run.
//!
//! The transports themselves are not written yet; [`connect`] reports that. They plug in by
//! implementing [`Transport`] and adding an arm to [`connect`]; everything above (the CLI's link
//! commands, the job runner) talks to a `Box<dyn Transport>` only.

use std::fmt;
use std::time::Duration;

/// A bidirectional byte stream to the board.
pub trait Transport {
    /// Writes all of `bytes`.
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()>;
    /// Bytes received within `timeout`; empty when nothing arrived in time.
    fn recv(&mut self, timeout: Duration) -> std::io::Result<Vec<u8>>;
}

/// Where the link goes, from the command line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LinkTarget {
    Serial {
        port: String,
        baud: u32,
    },
    /// The QEMU board's UART, exposed as a socket (path given, or the default one).
    Qemu {
        socket: Option<String>,
    },
}

impl fmt::Display for LinkTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkTarget::Serial { port, baud } => write!(f, "serial port {port} at {baud} baud"),
            LinkTarget::Qemu { socket: None } => write!(f, "the QEMU board's UART"),
            LinkTarget::Qemu { socket: Some(s) } => write!(f, "the QEMU board's UART at {s}"),
        }
    }
}

/// The link could not be opened.
#[derive(Debug)]
pub enum LinkError {
    /// No transport for this target is built in yet.
    NotAvailable(LinkTarget),
    Io(std::io::Error),
}

impl fmt::Display for LinkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkError::NotAvailable(t) => {
                write!(f, "link transport not available yet (wanted {t})")
            }
            LinkError::Io(e) => write!(f, "link I/O error: {e}"),
        }
    }
}

impl std::error::Error for LinkError {}

/// Opens the link to `target`.
pub fn connect(target: &LinkTarget) -> Result<Box<dyn Transport>, LinkError> {
    Err(LinkError::NotAvailable(target.clone()))
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
}

impl Transport for Loopback {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.sent.extend_from_slice(bytes);
        Ok(())
    }

    fn recv(&mut self, _timeout: Duration) -> std::io::Result<Vec<u8>> {
        Ok(self.incoming.pop_front().unwrap_or_default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn connect_says_the_transport_is_missing() {
        let t = LinkTarget::Serial { port: "/dev/ttyACM0".into(), baud: 115_200 };
        let Err(e) = connect(&t) else { panic!("no transport exists yet") };
        assert_eq!(
            e.to_string(),
            "link transport not available yet (wanted serial port /dev/ttyACM0 at 115200 baud)"
        );
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
