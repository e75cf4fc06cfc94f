//! The program's events between segments, each once the motion before it is done: the spindle
//! and coolant switched on the board, program pauses (M0), dwells (G4), probe moves (G38.x,
//! `probe`).

use super::report::{err, link_err, RunError};
use super::stream::Stream;
use crate::plan::Output;
use motion::protocol::ProgramOutputs;
use std::sync::mpsc;
use std::time::{Duration, Instant};

impl Stream<'_, '_> {
    /// Events (spindle and coolant, pause, dwell) once the motion before them is done; stops at
    /// the next segment or at an event still under way.
    pub(super) fn handle_events(&mut self) -> Result<(), RunError> {
        while let Some((out, line)) = self.peek()? {
            if matches!(out, Output::Segment(_)) {
                break;
            }
            // The probe move's own segments end it: some are dropped at a trip.
            if out == Output::ProbeEnd {
                if self.probe_ended()? {
                    continue;
                }
                break;
            }
            let before_done = self.report.acked == self.sent_segs
                && self.job_done(&self.latest) >= self.sent_segs;
            if !before_done {
                break;
            }
            let went_on = match out {
                Output::Outputs(first) => {
                    self.switch_outputs(first)?;
                    true
                }
                Output::Pause => self.pause(),
                Output::Dwell(seconds) => self.dwell(seconds),
                Output::Probe(kind) => self.arm_probe(kind, line)?,
                // Both taken above.
                Output::Segment(_) | Output::ProbeEnd => false,
            };
            if !went_on {
                break;
            }
        }
        Ok(())
    }

    /// Switches the spindle and coolant to `first` and any switches right after it, and checks
    /// the board's status shows them.
    fn switch_outputs(&mut self, first: ProgramOutputs) -> Result<(), RunError> {
        let mut to = first;
        self.outputs.advance();
        // Switches with no motion between them (M9 is two calls, a program end three) are one
        // request.
        while let Some((Output::Outputs(next), _)) = self.peek()? {
            to = next;
            self.outputs.advance();
        }
        if to == self.switched {
            return Ok(());
        }
        let words = crate::outputs::describe_change(self.switched, to);
        self.say(&words);
        let st = crate::outputs::switch(&mut self.s, to).map_err(link_err)?.map_err(|e| {
            err(format!(
                "{e}; {} of {} segments were done",
                self.job_done(&self.latest),
                self.total
            ))
        })?;
        let shown = st.outputs;
        if shown != to.bits() {
            self.report.problems.push(format!(
                "{words}: the board's status shows {} instead",
                crate::outputs::describe(ProgramOutputs::from_bits(shown))
            ));
        }
        self.report.output_switches.push(crate::outputs::Switched {
            to,
            shown,
            segments_done: self.job_done(&st),
        });
        self.switched = to;
        Ok(())
    }

    /// A program pause (M0): held until the operator presses Enter when interactive. True once
    /// it is over.
    fn pause(&mut self) -> bool {
        if !self.opts.interactive {
            self.say("program pause (M0): not interactive, continuing at once");
            self.outputs.advance();
            return true;
        }
        match &self.pause_wait {
            None => {
                self.say("program pause (M0): the machine is stopped; press Enter to continue");
                let (tx, rx) = mpsc::channel();
                std::thread::spawn(move || {
                    let mut line = String::new();
                    let _ = std::io::stdin().read_line(&mut line);
                    let _ = tx.send(());
                });
                self.pause_wait = Some(rx);
                false
            }
            Some(rx) => {
                if rx.try_recv().is_err() {
                    return false;
                }
                self.pause_wait = None;
                self.say("continuing");
                self.outputs.advance();
                true
            }
        }
    }

    /// A dwell (G4) at rest. True once it is over.
    fn dwell(&mut self, seconds: f64) -> bool {
        let until = match self.dwell_until {
            Some(until) => until,
            None => {
                self.say(&format!("dwell (G4) {seconds:.3} s at rest"));
                let until = Instant::now() + Duration::from_millis(crate::plan::dwell_ms(seconds));
                self.dwell_until = Some(until);
                until
            }
        };
        if Instant::now() < until {
            return false;
        }
        self.dwell_until = None;
        self.outputs.advance();
        true
    }
}
