//! The thesis capabilities as named `$` commands (grblHAL names its own `$` commands too):
//! `$MILL=JOB.toml` (a force-controlled milling job), `$POLAR=STREAM.bin [SPEED [M:K]]` (polar
//! playback of a step-event stream), `$TURN=TABLE [RPM [X0:X1 [FEED]]]` (a Z-slide turning job,
//! mm and mm/s; `TABLE` a `turning table` file or `builtin`) and `$WIRE=JOB.toml [FROM..TO]` (a
//! 4-axis wire job, only segments FROM..TO if given). Each runs its runner on the bridge's link
//! while a [`SenderHook`] keeps answering the sender's real-time bytes: `?` (`Run` or `Hold`,
//! the job's position), `!`, `~`, Ctrl-X (abort); line bytes wait in the receive buffer until
//! the job ends.

use super::endpoint::Endpoint;
use super::protocol::{realtime, Realtime, RxBuffer, PLANNER_BLOCKS};
use super::report::{Report, State};
use crate::runner::{JobControl, JobHook};
use motion::machine::MachineState;
use motion::polar::playback::SizeScale;
use motion::protocol::{LinkState, ProgramOutputs, Status};
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
    /// `$TURN=TABLE [RPM [X0:X1 [FEED]]]`, as `turning run`'s flags (`--table` an absolute
    /// path; lengths in mm).
    Turn { name: String, flags: Vec<String> },
    /// `$WIRE=JOB.toml [FROM..TO]`.
    Wire { file: PathBuf, segments: Option<std::ops::Range<usize>> },
}

/// The word `$TURN=` takes for `turning run`'s built-in table (the thesis's Douglass table).
pub const BUILTIN_TABLE: &str = "builtin";

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
        "$TURN" => {
            let Some(table) = arg.split_whitespace().next() else {
                return Some(Err(need_file("Z-slide table (`turning table --out`, or builtin)")));
            };
            turn_flags(table, jobs, words).map(|flags| JobCmd::Turn { name: table.into(), flags })
        }
        "$WIRE" => {
            let Some(file) = file else {
                return Some(Err(need_file("wire job (TOML, version 1)")));
            };
            let segments = match words.next().map(crate::wire::cli::parse_range) {
                None => Ok(None),
                Some(Ok(r)) => Ok(Some(r)),
                Some(Err(e)) => Err(format!("$WIRE= segments FROM..TO: {e}")),
            };
            match (segments, words.next()) {
                (Ok(segments), None) => Ok(JobCmd::Wire { file, segments }),
                (Err(e), _) => Err(e),
                (_, Some(w)) => Err(format!("$WIRE= takes FILE [FROM..TO], found {w:?}")),
            }
        }
        _ => return None,
    })
}

/// `$TURN=`'s words after the table as `turning run` flags in mm: RPM, X0:X1, FEED (mm/s).
fn turn_flags<'a>(
    table: &str,
    jobs: &Path,
    mut words: impl Iterator<Item = &'a str>,
) -> Result<Vec<String>, String> {
    let mut flags = vec!["--units".to_string(), "mm".to_string()];
    if !table.eq_ignore_ascii_case(BUILTIN_TABLE) {
        flags.extend(["--table".to_string(), jobs.join(table).display().to_string()]);
    }
    let number = |what: &str, w: &str| match w.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v.to_string()),
        _ => Err(format!("$TURN= {what} must be a number, found {w:?}")),
    };
    if let Some(w) = words.next() {
        flags.extend(["--rpm".to_string(), number("RPM", w)?]);
    }
    if let Some(w) = words.next() {
        let (a, b) =
            w.split_once(':').ok_or(format!("$TURN= X range must be X0:X1 mm, found {w:?}"))?;
        flags.extend(["--x-start".into(), number("X0", a)?, "--x-end".into(), number("X1", b)?]);
    }
    if let Some(w) = words.next() {
        flags.extend(["--feed".to_string(), number("FEED", w)?]);
    }
    match words.next() {
        Some(w) => Err(format!("$TURN= takes TABLE [RPM [X0:X1 [FEED]]], found {w:?}")),
        None => Ok(flags),
    }
}

/// Position of a capability's job as the report's axes, mm (degrees for a rotary axis).
pub type PositionsMm = Box<dyn Fn(&Status) -> Vec<f64>>;

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

/// The Z-slide machine's X (the radial feed) and Z (the slide), mm, as grbl's X, Y, Z.
pub fn turning_mm(st: &Status) -> Vec<f64> {
    use crate::turning::run::{X_AXIS, X_STEPS_PER_IN, Z_AXIS, Z_STEPS_PER_IN};
    use crate::units::MM_PER_IN;
    vec![
        st.positions[X_AXIS as usize] as f64 * MM_PER_IN / X_STEPS_PER_IN as f64,
        0.0,
        st.positions[Z_AXIS as usize] as f64 * MM_PER_IN / Z_STEPS_PER_IN as f64,
    ]
}

/// The wire manipulator's X, Y (mm) as grbl's X, Y, then Z 0, and alpha, beta (deg) as A, B:
/// `spu` the steps per unit of X, Y, beta, alpha.
pub fn wire_mm(st: &Status, spu: [f64; 4]) -> Vec<f64> {
    let p = |i: usize| st.positions[i] as f64 / spu[i];
    vec![p(0), p(1), 0.0, p(3), p(2)]
}

/// The sender's side while a capability job owns the link.
pub struct SenderHook<'a> {
    pub ep: &'a mut dyn Endpoint,
    pub rx: &'a mut RxBuffer,
    pub interrupt: Arc<AtomicBool>,
    /// Axes the report shows at least (the job's own, if more).
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
        let axes = self.axes.max(mpos.len());
        mpos.resize(axes, 0.0);
        let stopping = st.machine == MachineState::Running
            || (st.machine == MachineState::Holding && st.state != LinkState::Held);
        Report {
            state: if self.hold { State::Hold { stopping } } else { State::Run },
            mpos,
            wco: vec![0.0; axes],
            planner_free: PLANNER_BLOCKS,
            rx_free: self.rx.free(),
            feed: 0.0,
            // The spindle speed the board senses (a Z-slide job's; 0 for the others).
            speed: st.z_spindle_rpm_milli as f64 / 1e3,
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
        let turn = |flags: &[&str]| JobCmd::Turn {
            name: flags[0].into(),
            flags: flags[1..].iter().map(|f| f.to_string()).collect(),
        };
        assert_eq!(
            parse("$TURN=t.txt 360 0:12.7 25.4", d),
            Some(Ok(turn(&[
                "t.txt",
                "--units",
                "mm",
                "--table",
                "/jobs/t.txt",
                "--rpm",
                "360",
                "--x-start",
                "0",
                "--x-end",
                "12.7",
                "--feed",
                "25.4"
            ])))
        );
        assert_eq!(parse("$turn=BUILTIN", d), Some(Ok(turn(&["BUILTIN", "--units", "mm"]))));
        assert_eq!(
            parse("$WIRE=w.toml 1..3", d),
            Some(Ok(JobCmd::Wire { file: "/jobs/w.toml".into(), segments: Some(1..3) }))
        );
        assert_eq!(
            parse("$WIRE=w.toml", d),
            Some(Ok(JobCmd::Wire { file: "/jobs/w.toml".into(), segments: None }))
        );
        for bad in [
            "$TURN=",
            "$TURN=t x",
            "$TURN=t 360 5",
            "$TURN=t 1 0:1 2 3",
            "$WIRE=",
            "$WIRE=w 3..1",
            "$WIRE=w 1..2 x",
        ] {
            assert!(matches!(parse(bad, d), Some(Err(_))), "{bad}");
        }
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
        // Turning: axis 0 the slide (Z, 10 uin steps), axis 1 the radial feed (X, 1 mil).
        let mut st = Status::default();
        st.positions[0] = -100_000;
        st.positions[1] = 500;
        let v = turning_mm(&st);
        assert!((v[0] - 12.7).abs() < 1e-9 && v[1] == 0.0 && (v[2] + 25.4).abs() < 1e-9, "{v:?}");
        // Wire: X, Y, beta, alpha steps -> X, Y, Z 0, A alpha, B beta.
        st.positions[..4].copy_from_slice(&[200, -100, 30, 40]);
        assert_eq!(wire_mm(&st, [100.0, 100.0, 10.0, 20.0]), vec![2.0, -1.0, 0.0, 2.0, 3.0]);
    }
}
