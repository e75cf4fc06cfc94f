//! Probe moves through the bridge on the simulated board, a scripted sender's raw session
//! checked line for line: `[PRB:]` before the block's `ok`, the program going on from where the
//! probe stopped, `$#`, `ALARM:4` and `ALARM:5` as grbl raises them and `$X` after them.

use super::{Bridge, Persist};
use crate::grbl::endpoint::{Endpoint, Input};
use crate::grbl::settings::Settings;
use crate::job::Machine;
use crate::link::Session;
use crate::polar::sim::EventSim;
use crate::runner::{self, SimProbe};
use crate::sim_board::SIM_CAPACITY;
use crate::transport::Transport;
use motion::protocol::{HostConfig, RequestBody};
use std::cell::{Cell, RefCell};
use std::rc::Rc;
use std::time::{Duration, Instant};

/// Machine time per wall time: the longest probe move here (10 mm at 100 mm/min) takes 0.12 s.
const SIM_SPEED: f64 = 50.0;
/// Longest wait for a line from the bridge.
const LINE_WAIT: Duration = Duration::from_secs(20);

/// The sender's side of the endpoint.
#[derive(Clone, Default)]
struct SenderPort {
    to_bridge: Rc<RefCell<Vec<u8>>>,
    from_bridge: Rc<RefCell<Vec<u8>>>,
    opened: Rc<Cell<bool>>,
}

impl Endpoint for SenderPort {
    fn poll(&mut self, timeout: Duration) -> std::io::Result<Input> {
        let data = std::mem::take(&mut *self.to_bridge.borrow_mut());
        let opened = !self.opened.replace(true);
        if data.is_empty() && !opened {
            std::thread::sleep(timeout);
        }
        Ok(Input { opened, data, ..Input::default() })
    }

    fn write(&mut self, bytes: &[u8]) {
        self.from_bridge.borrow_mut().extend_from_slice(bytes);
    }

    fn describe(&self) -> String {
        "a scripted sender".into()
    }
}

/// A raw session: lines to the bridge, its answers read back one line at a time.
struct Sender<'b, 'a> {
    bridge: &'b mut Bridge<'a>,
    port: SenderPort,
}

impl Sender<'_, '_> {
    fn send(&mut self, text: &str) {
        self.port.to_bridge.borrow_mut().extend_from_slice(text.as_bytes());
    }

    /// The next line from the bridge, running it until one comes.
    fn line(&mut self) -> String {
        let start = Instant::now();
        loop {
            let mut out = self.port.from_bridge.borrow_mut();
            if let Some(i) = out.windows(2).position(|w| w == b"\r\n") {
                let l = String::from_utf8_lossy(&out[..i]).into_owned();
                out.drain(..i + 2);
                return l;
            }
            drop(out);
            assert!(start.elapsed() < LINE_WAIT, "no line from the bridge");
            assert!(!self.bridge.step().unwrap(), "the bridge stopped");
        }
    }

    fn expect(&mut self, want: &str) {
        assert_eq!(self.line(), want);
    }

    /// Sends `?` until the machine is idle: that report.
    fn until_idle(&mut self) -> String {
        let start = Instant::now();
        loop {
            self.send("?");
            let st = self.line();
            if st.starts_with("<Idle|") {
                return st;
            }
            assert!(start.elapsed() < LINE_WAIT, "never idle: {st}");
        }
    }
}

/// The corpus machine on a fresh simulated board, its probe surface at `surface` (machine
/// coordinates), behind a bridge a scripted sender has just connected to.
fn session(surface: Option<SimProbe>, script: impl FnOnce(&mut Sender)) {
    let machine: &'static Machine = Box::leak(Box::new(crate::grbl::test_machine()));
    let (cfg, link_cfg) = crate::grbl::board_config(machine).unwrap();
    let mut t: Box<dyn Transport> = Box::new(EventSim::scaled(SIM_CAPACITY, SIM_SPEED));
    let mut s = Session::new(&mut *t, HostConfig { rto_ms: 50, window: 8 });
    s.connect().unwrap();
    runner::ready_board(&mut s, link_cfg, runner::Home::AsConfigured, "machine file", &|_| {})
        .unwrap();
    if let Some(sim) = surface {
        let spm: Vec<f64> = machine.axes.iter().map(|a| a.steps_per_mm).collect();
        runner::set_sim_probe(&mut s, sim, &[0; motion::MAX_AXES], &spm).unwrap();
    }
    let period = RequestBody::SetStatusPeriod { ms: crate::grbl::STATUS_MS };
    runner::ask(&mut s, period, "SetStatusPeriod").unwrap();
    s.streaming = true;
    let latest = runner::ask_status(&mut s).unwrap();
    let machine_path = std::path::PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/corpus-machine.toml"
    ));
    let persist = Persist {
        machine_src: std::fs::read_to_string(&machine_path).unwrap(),
        // Never written: no test here changes a setting.
        overlay: std::env::temp_dir().join("motionctl-grbl-probe-test.grbl.toml"),
        machine_path,
        settings: Settings::from_machine(machine),
        startup: Default::default(),
    };
    let port = SenderPort::default();
    let mut ep = port.clone();
    let mut bridge = Bridge::new(s, &mut ep, machine, cfg, latest, None, persist);
    let mut sender = Sender { bridge: &mut bridge, port };
    sender.expect("");
    sender.expect("Grbl 1.1h ['$' for help]");
    script(&mut sender);
}

/// Polls until idle: the machine must stand at `mpos` (mm, as the report prints it).
fn idle_at(r: &mut Sender, mpos: &str) {
    let st = r.until_idle();
    assert!(st.starts_with(&format!("<Idle|MPos:{mpos}|")), "{st}");
}

/// `ALARM:n` and the `[MSG:]` naming the board's `fault`.
fn alarm(r: &mut Sender, n: u8, fault: &str) {
    r.expect(&format!("ALARM:{n}"));
    let msg = r.line();
    assert!(msg.starts_with(&format!("[MSG:board fault {fault}")), "{msg}");
}

fn unlock(r: &mut Sender) {
    r.send("$X\n");
    r.expect("[MSG:Caution: Unlocked]");
    r.expect("ok");
}

/// `$#`: its lines up to `ok`.
fn parameters(r: &mut Sender) -> Vec<String> {
    r.send("$#\n");
    let mut lines = Vec::new();
    loop {
        let l = r.line();
        if l == "ok" {
            return lines;
        }
        lines.push(l);
    }
}

#[test]
fn probe_moves_report_their_contact_and_the_program_goes_on_from_there() {
    let surface = SimProbe { axis: 2, at_mm: -3.0, below: true };
    session(Some(surface), |r| {
        assert_eq!(parameters(r).last().unwrap(), "[PRB:0.000,0.000,0.000:0]");
        // G38.2 toward the surface: the trip position before the block's `ok`.
        r.send("G38.2 Z-10 F100\n");
        r.expect("[PRB:0.000,0.000,-3.000:1]");
        r.expect("ok");
        idle_at(r, "0.000,0.000,-3.000");
        // The parser stands where the probe stopped: an incremental move goes from there.
        r.send("G91 G0 Z1\nG90\n");
        r.expect("ok");
        r.expect("ok");
        idle_at(r, "0.000,0.000,-2.000");
        let p = parameters(r);
        assert_eq!(p.len(), 11, "{p:?}");
        assert_eq!(p.last().unwrap(), "[PRB:0.000,0.000,-3.000:1]", "{p:?}");

        // G38.3 away from the surface: no contact, no alarm, the end of the move.
        r.send("G38.3 Z5 F300\n");
        r.expect("[PRB:0.000,0.000,5.000:0]");
        r.expect("ok");
        idle_at(r, "0.000,0.000,5.000");

        // G38.2 along X, over the surface: no contact is ALARM:5, locked until $X.
        r.send("G38.2 X5 F600\n");
        alarm(r, 5, "ProbeFail");
        r.expect("[PRB:0.000,0.000,5.000:0]");
        r.expect("ok");
        r.send("G0 X0\n");
        r.expect("error:9");
        unlock(r);
        idle_at(r, "5.000,0.000,5.000");

        // Already in contact: ALARM:4, nothing moves, no probe result.
        r.send("G0 Z-3.5\nG38.2 Z-5 F100\n");
        r.expect("ok");
        alarm(r, 4, "ProbeInitial");
        r.expect("ok");
        unlock(r);
        idle_at(r, "5.000,0.000,-3.500");
        assert_eq!(parameters(r).last().unwrap(), "[PRB:0.000,0.000,5.000:0]");

        // A soft reset forgets the probe position, as grbl's does.
        r.send("\x18");
        r.expect("");
        r.expect("Grbl 1.1h ['$' for help]");
        assert_eq!(parameters(r).last().unwrap(), "[PRB:0.000,0.000,0.000:0]");
    });
}

#[test]
fn without_a_surface_g38_2_alarms_and_unlocks_with_dollar_x() {
    session(None, |r| {
        r.send("G38.2 Z-10 F100\n");
        alarm(r, 5, "ProbeFail");
        r.expect("[PRB:0.000,0.000,0.000:0]");
        r.expect("ok");
        unlock(r);
        // The rest goes on from where the move ended.
        r.send("G91 G0 Z2\n");
        r.expect("ok");
        idle_at(r, "0.000,0.000,-8.000");

        // Check mode: the probe block is checked and answered, nothing moves, no result.
        r.send("$C\nG90 G38.2 Z-20 F100\n");
        for want in ["[MSG:Enabled]", "ok", "ok"] {
            r.expect(want);
        }
        r.send("$C\n");
        for want in ["[MSG:Disabled]", "ok", "", "Grbl 1.1h ['$' for help]"] {
            r.expect(want);
        }
        idle_at(r, "0.000,0.000,-8.000");
    });
}
