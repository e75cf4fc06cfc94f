//! What a run sends ([`Outputs`], pulled as the link takes it) and where the run is in it
//! ([`Whereabouts`], for the operator).

use super::report::{err, ProbeOutcome, RunError};
use crate::link::Session;
use crate::plan::Output;
use motion::protocol::{RequestBody, Status};
use motion::segment::Segment;
use motion::MAX_AXES;
use std::collections::VecDeque;

/// One output and the G-code line it came from, if any.
pub type Tagged = (Output, Option<usize>);

/// What a run sends, pulled one output at a time.
pub trait OutputSource {
    /// The next output; `Some(Err)` ends the run with that message.
    fn next_output(&mut self) -> Option<Result<Tagged, String>>;

    /// A probe move ([`Output::ProbeEnd`]) ended: what follows is to be planned from there.
    fn probed(&mut self, _outcome: &ProbeOutcome) -> Result<(), String> {
        Err("this job cannot take a probe move's result".into())
    }

    /// Once every output was given: where the job as run leaves the axes, steps from its start
    /// (after a probe move this is the source's to say, not the host model's).
    fn final_steps(&self) -> Option<[i64; MAX_AXES]> {
        None
    }
}

/// A source from a closure.
struct FromFn<F>(F);

impl<F: FnMut() -> Option<Result<Tagged, String>>> OutputSource for FromFn<F> {
    fn next_output(&mut self) -> Option<Result<Tagged, String>> {
        (self.0)()
    }
}

/// What a run sends, in order, pulled only as the link takes it: a planned slice, or a stream
/// planned while it runs (a G-code file read a second time).
pub struct Outputs<'a> {
    pull: Box<dyn OutputSource + 'a>,
    peeked: Option<Tagged>,
    ended: bool,
    /// Segments in all, and the sum of their nominal durations (ticks at override 1.0).
    pub(super) segments: u32,
    pub(super) planned_ticks: u64,
    /// The host model's length of the job, ticks (ramps make it longer than the nominal sum).
    pub(super) model_ticks: u64,
    /// The job's file, for messages naming a line of it.
    pub(super) label: Option<String>,
}

impl<'a> Outputs<'a> {
    /// Everything already planned.
    pub fn planned(outputs: &'a [Output]) -> Self {
        let mut segments = 0u32;
        let mut planned_ticks = 0u64;
        for o in outputs {
            if let Output::Segment(s) = o {
                segments += 1;
                planned_ticks += s.duration_ticks as u64;
            }
        }
        let mut it = outputs.iter();
        Outputs::from_source(
            FromFn(move || it.next().map(|o| Ok((*o, None)))),
            segments,
            planned_ticks,
            planned_ticks,
        )
    }

    /// A stream planned as it is pulled; `segments`, `planned_ticks` and `model_ticks` from a
    /// pass that planned the same job before. Each output's line from `next` (G-code's).
    pub fn streamed(
        next: impl FnMut() -> Option<Result<Tagged, String>> + 'a,
        segments: u32,
        planned_ticks: u64,
        model_ticks: u64,
    ) -> Self {
        Outputs::from_source(FromFn(next), segments, planned_ticks, model_ticks)
    }

    /// [`Outputs::streamed`] from a source that can also take probe results.
    pub fn from_source(
        source: impl OutputSource + 'a,
        segments: u32,
        planned_ticks: u64,
        model_ticks: u64,
    ) -> Self {
        Outputs {
            pull: Box::new(source),
            peeked: None,
            ended: false,
            segments,
            planned_ticks,
            model_ticks,
            label: None,
        }
    }

    /// Messages about a line name it `label:LINE`.
    pub fn named(mut self, label: &str) -> Self {
        self.label = Some(label.to_string());
        self
    }

    /// `label:LINE` (or `line LINE`) for a message, empty without a line.
    pub(super) fn at(&self, line: Option<usize>) -> String {
        match (line, &self.label) {
            (Some(l), Some(f)) => format!("{f}:{l}: "),
            (Some(l), None) => format!("line {l}: "),
            (None, Some(f)) => format!("{f}: "),
            (None, None) => String::new(),
        }
    }

    pub(super) fn probed(&mut self, outcome: &ProbeOutcome) -> Result<(), String> {
        self.pull.probed(outcome)
    }

    pub(super) fn final_steps(&self) -> Option<[i64; MAX_AXES]> {
        self.pull.final_steps()
    }

    pub fn segments(&self) -> u32 {
        self.segments
    }

    /// The next output, not taken.
    pub(super) fn peek(&mut self) -> Result<Option<Tagged>, String> {
        if self.peeked.is_none() && !self.ended {
            match self.pull.next_output() {
                Some(Ok(t)) => self.peeked = Some(t),
                Some(Err(e)) => {
                    self.ended = true;
                    return Err(e);
                }
                None => self.ended = true,
            }
        }
        Ok(self.peeked)
    }

    pub(super) fn advance(&mut self) {
        self.peeked = None;
    }
}

/// Where a run is, for the operator: the line of the segment executing and the planned time
/// left.
pub(super) struct Whereabouts {
    /// Sent and not yet done, oldest first: (line, nominal ticks).
    in_flight: VecDeque<(Option<usize>, u64)>,
    done: u32,
    done_ticks: u64,
    planned_ticks: u64,
    /// Machine ticks per nominal tick (the host model's length over the nominal sum).
    stretch: f64,
    tick_hz: f64,
}

impl Whereabouts {
    /// Nothing sent yet of a job of `planned_ticks` nominal ticks that the host model says
    /// takes `model_ticks`, on a board ticking at `tick_hz`.
    pub(super) fn new(planned_ticks: u64, model_ticks: u64, tick_hz: f64) -> Self {
        Whereabouts {
            in_flight: VecDeque::new(),
            done: 0,
            done_ticks: 0,
            planned_ticks,
            stretch: if planned_ticks > 0 {
                model_ticks as f64 / planned_ticks as f64
            } else {
                1.0
            },
            tick_hz,
        }
    }

    pub(super) fn sent(&mut self, line: Option<usize>, seg: &Segment) {
        self.in_flight.push_back((line, seg.duration_ticks as u64));
    }

    pub(super) fn update(&mut self, done: u32) {
        while self.done < done {
            let Some((_, ticks)) = self.in_flight.pop_front() else { break };
            self.done += 1;
            self.done_ticks += ticks;
        }
    }

    /// The line being executed (or next) and seconds left at `override_factor`.
    pub(super) fn at(&self, override_factor: f64) -> (Option<usize>, Option<f64>) {
        let line = self.in_flight.front().and_then(|f| f.0);
        let left = self.planned_ticks.saturating_sub(self.done_ticks) as f64 * self.stretch;
        let eta = (override_factor > 0.0).then(|| left / self.tick_hz / override_factor);
        (line, eta)
    }
}

/// The next output; a stream that cannot go on (its file changed since it was checked) aborts
/// the board and ends the run.
pub(super) fn peek(
    outputs: &mut Outputs<'_>,
    s: &mut Session,
    latest: &Status,
    base: &Status,
) -> Result<Option<Tagged>, RunError> {
    outputs.peek().map_err(|e| {
        let aborted = matches!(s.request(RequestBody::Abort), Ok(Ok(_)));
        err(format!(
            "{e}; {} sent to the board; {} of {} segments were done",
            if aborted { "Abort" } else { "Abort could not be" },
            latest.segments_done.wrapping_sub(base.segments_done),
            outputs.segments
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::Whereabouts;
    use motion::segment::{Rate, Segment};
    use std::collections::VecDeque;

    #[test]
    fn whereabouts_give_the_executing_line_and_the_planned_time_left() {
        let seg = |ticks: u32| Segment {
            steps: [1, 0, 0, 0, 0, 0],
            duration_ticks: ticks,
            entry_rate: Rate::ONE,
            exit_rate: Rate::ONE,
            accel_per_tick: Rate::ONE,
            id: 0,
        };
        let mut w = Whereabouts {
            in_flight: VecDeque::new(),
            done: 0,
            done_ticks: 0,
            planned_ticks: 6_000,
            stretch: 1.5,
            tick_hz: 1_000.0,
        };
        assert_eq!(w.at(1.0), (None, Some(9.0)));
        w.sent(Some(7), &seg(1_000));
        w.sent(Some(7), &seg(1_000));
        w.sent(Some(9), &seg(2_000));
        assert_eq!(w.at(1.0), (Some(7), Some(9.0)));
        w.update(2);
        // 4000 nominal ticks left, 1.5 machine ticks each, at 1 kHz.
        assert_eq!(w.at(1.0), (Some(9), Some(6.0)));
        assert_eq!(w.at(0.5), (Some(9), Some(12.0)));
        assert_eq!(w.at(0.0), (Some(9), None));
        w.update(3);
        assert_eq!(w.at(1.0), (None, Some(3.0)));
    }
}
