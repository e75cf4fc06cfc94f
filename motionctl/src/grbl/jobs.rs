//! The thesis capabilities as named `$` commands (grblHAL names its own `$` commands too):
//! `$MILL=JOB.toml` (a force-controlled milling job), `$POLAR=STREAM.bin [SPEED [M:K]]` (polar
//! playback of a step-event stream), and `$TURN=`, `$WIRE=` (refused for now, naming the
//! subcommand that runs them). Each runs its runner on the bridge's link while a [`SenderHook`]
//! keeps answering the sender's real-time bytes: `?` (`Run` or `Hold`, the job's position), `!`,
//! `~`, Ctrl-X (abort); line bytes wait in the receive buffer until the job ends.

use super::endpoint::Endpoint;
use super::protocol::{realtime, Realtime, RxBuffer, PLANNER_BLOCKS};
use super::report::{Report, State};
use crate::milling::run::MillingRunReport;
use crate::polar::run::PolarReport;
use crate::runner::{fault_names, JobControl, JobHook};
use motion::machine::MachineState;
use motion::polar::playback::SizeScale;
use motion::protocol::{ProgramOutputs, Status, WireState};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// What a capability command asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum JobCmd {
    /// `$MILL=JOB.toml`.
    Mill(PathBuf),
    /// `$POLAR=STREAM.bin [SPEED [M:K]]`.
    Polar { file: PathBuf, speed: f64, scale: SizeScale },
}

/// The `$` names, with what each runs (the `$` help lists them).
pub const NAMES: [&str; 4] = ["$MILL=", "$POLAR=", "$TURN=", "$WIRE="];

/// Reads a capability command: `None` when `line` is none; else the command or why it is
/// refused (a bad argument, or a capability the bridge does not run). `jobs` is the directory
/// relative paths are read from.
pub fn parse(line: &str, jobs: &Path) -> Option<Result<JobCmd, String>> {
    let (name, arg) = line.trim().split_once('=')?;
    let name = name.trim().to_ascii_uppercase();
    let mut words = arg.split_whitespace();
    let file = words.next().map(|f| jobs.join(f));
    let need_file = |what: &str| format!("{name}= needs a {what} file");
    Some(match name.as_str() {
        "$MILL" => match (file, words.next()) {
            (Some(f), None) => Ok(JobCmd::Mill(f)),
            (None, _) => Err(need_file("milling job (TOML, version 2)")),
            (Some(_), Some(w)) => Err(format!("$MILL= takes one job file, found {w:?} after it")),
        },
        "$POLAR" => {
            let Some(file) = file else { return Some(Err(need_file("step-event stream"))) };
            let speed = match words.next().map(str::parse::<f64>) {
                None => Ok(1.0),
                Some(Ok(v)) if (0.25..=2.0).contains(&v) => Ok(v),
                Some(_) => Err("$POLAR= speed must be a number within 0.25..=2".to_string()),
            };
            let scale = match words.next() {
                None => Ok(SizeScale::ONE),
                Some(w) => {
                    crate::polar::cli::parse_size(w).map_err(|e| format!("$POLAR= size: {e}"))
                }
            };
            match (speed, scale, words.next()) {
                (Ok(speed), Ok(scale), None) => Ok(JobCmd::Polar { file, speed, scale }),
                (Err(e), _, _) | (_, Err(e), _) => Err(e),
                (_, _, Some(w)) => Err(format!("$POLAR= takes FILE [SPEED [M:K]], found {w:?}")),
            }
        }
        "$TURN" => Err("Z-slide turning is not run behind the bridge yet: `motionctl fourier \
                        run` runs it"
            .into()),
        "$WIRE" => Err("wire jobs are not run behind the bridge yet: `motionctl wire run` runs \
                        them"
            .into()),
        _ => return None,
    })
}

/// Position of a capability's job as the report's axes, mm (degrees for a rotary axis).
pub type PositionsMm = fn(&Status) -> Vec<f64>;

/// The milling machine's X (1 um a step).
pub fn milling_mm(st: &Status) -> Vec<f64> {
    vec![st.positions[0] as f64 / 1e3]
}

/// The polar machine's theta (degrees) and r (mm).
pub fn polar_mm(st: &Status) -> Vec<f64> {
    use motion::polar::job::{R_STEPS_PER_IN, THETA_STEPS_PER_REV};
    vec![
        st.positions[0] as f64 * 360.0 / THETA_STEPS_PER_REV as f64,
        st.positions[1] as f64 * 25.4 / R_STEPS_PER_IN as f64,
    ]
}

/// The sender's side while a capability job owns the link.
pub struct SenderHook<'a> {
    pub ep: &'a mut dyn Endpoint,
    pub rx: &'a mut RxBuffer,
    pub interrupt: Arc<AtomicBool>,
    /// Axes the report shows.
    pub axes: usize,
    pub positions: PositionsMm,
    pub overrides: [u8; 3],
    pub mask: u16,
    pub inches: bool,
    /// `!` asked for a hold (`~` lets go).
    pub hold: bool,
    /// Ctrl-X, the sender leaving, or Ctrl-C: the job stops.
    pub abort: bool,
}

impl SenderHook<'_> {
    /// The status report of a running job: `Run`, or `Hold` while held; its position in
    /// machine mm, no work offset.
    pub fn report(&self, st: &Status) -> String {
        let mut mpos = (self.positions)(st);
        mpos.resize(self.axes, 0.0);
        let stopping = st.machine == MachineState::Running
            || (st.machine == MachineState::Holding && st.state != WireState::Held);
        Report {
            state: if self.hold { State::Hold { stopping } } else { State::Run },
            mpos,
            wco: vec![0.0; self.axes],
            planner_free: PLANNER_BLOCKS,
            rx_free: self.rx.free(),
            feed: 0.0,
            speed: 0.0,
            overrides: self.overrides,
            accessories: ProgramOutputs::from_bits(st.outputs),
            mask: self.mask,
            inches: self.inches,
        }
        .line()
    }

    fn say(&mut self, line: &str) {
        self.ep.write(format!("{line}\r\n").as_bytes());
    }
}

impl JobHook for SenderHook<'_> {
    fn poll(&mut self, st: &Status) -> JobControl {
        match self.ep.poll(Duration::ZERO) {
            Ok(input) => {
                for b in input.data {
                    match realtime(b) {
                        None => self.rx.push(b),
                        Some(Realtime::Status) => {
                            let line = self.report(st);
                            self.say(&line);
                        }
                        Some(Realtime::FeedHold | Realtime::SafetyDoor) => self.hold = true,
                        Some(Realtime::CycleStart) => self.hold = false,
                        Some(Realtime::Reset) => self.abort = true,
                        // Overrides and toggles belong to the job while it runs.
                        Some(_) => {}
                    }
                }
                if input.closed {
                    self.abort = true;
                }
            }
            Err(e) => {
                eprintln!("motionctl: the sender's endpoint failed: {e}");
                self.abort = true;
            }
        }
        if self.interrupt.load(Ordering::SeqCst) {
            self.abort = true;
        }
        match (self.abort, self.hold) {
            (true, _) => JobControl::Abort,
            (false, true) => JobControl::Hold,
            (false, false) => JobControl::Go,
        }
    }
}

/// `[MSG:...]` texts summing up a milling job in the job's units.
pub fn milling_summary(name: &str, r: &MillingRunReport, fnom_n: f64) -> Vec<String> {
    let tick_hz = motion::force::scenario::TICK_HZ as f64;
    let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.0} ms", v * 1e3));
    let forces: Vec<f64> = r.trace.iter().map(|p| p.force_n).collect();
    let mean =
        if forces.is_empty() { 0.0 } else { forces.iter().sum::<f64>() / forces.len() as f64 };
    let mut out = vec![
        format!(
            "MILL {name}: X {:.3} mm of {:.3} mm in {:.3} s of board time ({:.1} s wall)",
            r.x_steps as f64 / 1e3,
            r.expected_x_steps as f64 / 1e3,
            r.board_ticks as f64 / tick_hz,
            r.seconds
        ),
        format!(
            "MILL force: mean {mean:.0} N, peak {:.0} N, Fnom {fnom_n:.0} N, back within +-10 % \
             {} after the depth step (host model {}); {} control updates",
            r.peak_n,
            ms(r.settle_s),
            ms(r.model_settle_s),
            r.updates
        ),
    ];
    if r.faults != 0 {
        out.push(format!("MILL faults: {}", fault_names(r.faults)));
    }
    out.extend(r.problems.iter().map(|p| format!("MILL check failed: {p}")));
    if r.ok() {
        out.push("MILL checks: ok (position and force as the host model)".into());
    }
    out
}

/// `[MSG:...]` texts summing up a polar playback.
pub fn polar_summary(name: &str, r: &PolarReport) -> Vec<String> {
    let tick_hz = motion::polar::job::wire_config().machine.tick_hz as f64;
    let at = |p: [i64; 2]| {
        let st = Status { positions: [p[0], p[1], 0, 0, 0, 0], ..Status::default() };
        let v = polar_mm(&st);
        format!("theta {:.3} deg, r {:.3} mm", v[0], v[1])
    };
    let mut out = vec![
        format!(
            "POLAR {name}: {} of {} events in {} blocks, {:.3} s of board time ({:.1} s wall)",
            r.events_fired,
            r.events,
            r.blocks,
            r.board_ticks as f64 / tick_hz,
            r.seconds
        ),
        format!("POLAR end: {}; host model {}", at(r.positions), at(r.expected_positions)),
    ];
    out.extend(r.problems.iter().map(|p| format!("POLAR check failed: {p}")));
    if r.ok() {
        out.push("POLAR checks: ok (every event once, the host model's end)".into());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capability_commands_parse_with_their_arguments() {
        let d = Path::new("/jobs");
        assert_eq!(parse("$MILL=a.toml", d), Some(Ok(JobCmd::Mill("/jobs/a.toml".into()))));
        assert_eq!(
            parse("$polar= s.bin 2 3:2", d),
            Some(Ok(JobCmd::Polar {
                file: "/jobs/s.bin".into(),
                speed: 2.0,
                scale: SizeScale::new(3, 2).unwrap()
            }))
        );
        for bad in ["$MILL=", "$MILL=a b", "$POLAR=s 9", "$POLAR=s 1 5:1", "$POLAR=s 1 1:1 x"] {
            assert!(matches!(parse(bad, d), Some(Err(_))), "{bad}");
        }
        let e = parse("$TURN=t.toml", d).unwrap().unwrap_err();
        assert!(e.contains("motionctl fourier run"), "{e}");
        assert!(parse("$WIRE=w.toml", d).unwrap().is_err());
        assert_eq!(parse("$100=80", d), None);
        assert_eq!(parse("$J=X1", d), None);
    }

    #[test]
    fn positions_read_in_the_capability_units() {
        let mut st = Status::default();
        st.positions[0] = 12_345;
        assert_eq!(milling_mm(&st), vec![12.345]);
        st.positions[0] = motion::polar::job::THETA_STEPS_PER_REV as i64 / 4;
        st.positions[1] = motion::polar::job::R_STEPS_PER_IN as i64;
        let v = polar_mm(&st);
        assert!((v[0] - 90.0).abs() < 1e-9 && (v[1] - 25.4).abs() < 1e-9, "{v:?}");
    }
}
