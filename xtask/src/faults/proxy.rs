//! A TCP proxy between `motionctl --tcp` and QEMU's UART socket that injects link trouble on
//! command: silence both ways (the cable pulled) and bursts of bytes lost on the way to the
//! board (what a USART receiver overrun does: the bytes that arrive while the data register is
//! still full are lost). Every byte it drops is counted. A reconnect from motionctl opens a new
//! connection to QEMU.

use anyhow::{Context, Result};
use std::io::{Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How long a new connection waits for QEMU's UART socket.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(10);

/// What the proxy is told to do, and what it did.
#[derive(Debug, Default)]
pub struct Trouble {
    /// Drop every byte, both ways, until then.
    pub silent_until: Option<Instant>,
    /// Of every `period` bytes to the board, lose the first `burst` (one overrun burst).
    pub overrun: Option<(u64, u64)>,
    /// Bytes seen to the board (counted while an overrun is on).
    pub to_board: u64,
    pub bursts: u64,
    pub dropped: u64,
}

pub struct Proxy {
    pub port: u16,
    pub trouble: Arc<Mutex<Trouble>>,
}

impl Proxy {
    /// Listens on a free loopback port; each connection is forwarded to 127.0.0.1:`board_port`.
    pub fn start(board_port: u16) -> Result<Proxy> {
        let listener = TcpListener::bind("127.0.0.1:0").context("proxy: bind")?;
        let port = listener.local_addr()?.port();
        let trouble = Arc::new(Mutex::new(Trouble::default()));
        let t = Arc::clone(&trouble);
        std::thread::spawn(move || {
            for host in listener.incoming().map_while(Result::ok) {
                let Some(board) = connect(board_port) else { continue };
                for (from, to, to_board) in [
                    (host.try_clone(), board.try_clone(), true),
                    (board.try_clone(), host.try_clone(), false),
                ] {
                    let (Ok(from), Ok(to)) = (from, to) else { continue };
                    let t = Arc::clone(&t);
                    std::thread::spawn(move || forward(from, to, to_board, &t));
                }
            }
        });
        Ok(Proxy { port, trouble })
    }

    pub fn addr(&self) -> String {
        format!("127.0.0.1:{}", self.port)
    }

    pub fn silence_for(&self, d: Duration) {
        lock(&self.trouble).silent_until = Some(Instant::now() + d);
    }

    pub fn overrun(&self, period_bytes: u64, burst_bytes: u64) {
        lock(&self.trouble).overrun = Some((period_bytes, burst_bytes));
    }

    /// Stops the overrun bursts; returns (bursts, bytes dropped) so far.
    pub fn calm(&self) -> (u64, u64) {
        let mut t = lock(&self.trouble);
        t.overrun = None;
        t.silent_until = None;
        (t.bursts, t.dropped)
    }
}

/// QEMU's UART socket, waiting up to [`CONNECT_TIMEOUT`] for it to open (a QEMU just started);
/// `None` when it does not (a QEMU killed: the host's connection is then dropped).
fn connect(port: u16) -> Option<TcpStream> {
    let start = Instant::now();
    loop {
        match TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) => return Some(s),
            Err(_) if start.elapsed() > CONNECT_TIMEOUT => return None,
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

fn lock(t: &Mutex<Trouble>) -> std::sync::MutexGuard<'_, Trouble> {
    t.lock().unwrap_or_else(|p| p.into_inner())
}

fn forward(mut from: TcpStream, mut to: TcpStream, to_board: bool, t: &Mutex<Trouble>) {
    let mut buf = [0u8; 4096];
    loop {
        let n = match from.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        let mut keep = Vec::with_capacity(n);
        {
            let mut t = lock(t);
            let silent = t.silent_until.is_some_and(|u| Instant::now() < u);
            for &b in &buf[..n] {
                let lost = if silent {
                    true
                } else if let (true, Some((period, burst))) = (to_board, t.overrun) {
                    let at = t.to_board % period;
                    t.to_board += 1;
                    if at == 0 {
                        t.bursts += 1;
                    }
                    at < burst
                } else {
                    false
                };
                if lost {
                    t.dropped += 1;
                } else {
                    keep.push(b);
                }
            }
        }
        if to.write_all(&keep).is_err() {
            break;
        }
    }
    let _ = to.shutdown(Shutdown::Both);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A board that collects what reaches it.
    fn sink() -> (u16, std::sync::mpsc::Receiver<Vec<u8>>) {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = l.local_addr().unwrap().port();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let (mut s, _) = l.accept().unwrap();
            let mut all = Vec::new();
            let _ = s.read_to_end(&mut all);
            let _ = tx.send(all);
        });
        (port, rx)
    }

    #[test]
    fn overrun_bursts_lose_the_first_bytes_of_each_period_and_silence_loses_all() {
        let (port, got) = sink();
        let p = Proxy::start(port).unwrap();
        let mut host = TcpStream::connect(p.addr()).unwrap();
        p.overrun(10, 3);
        let sent: Vec<u8> = (0..30).collect();
        host.write_all(&sent).unwrap();
        std::thread::sleep(Duration::from_millis(200));
        assert_eq!(p.calm(), (3, 9));
        p.silence_for(Duration::from_secs(5));
        host.write_all(&[99; 7]).unwrap();
        std::thread::sleep(Duration::from_millis(200));
        drop(host);
        let want: Vec<u8> = sent.iter().copied().filter(|b| b % 10 >= 3).collect();
        assert_eq!(got.recv_timeout(Duration::from_secs(5)).unwrap(), want);
        assert_eq!(lock(&p.trouble).dropped, 9 + 7);
    }
}
