//! The second pass of `run` over a G-code file ([`outputs`]): the file read again and planned as
//! the board takes the segments, and the probe moves' results taken back into it.

use super::{Checked, Items, Stop};
use crate::plan::Stream;
use motion::MAX_AXES;
use motion_gcode::source::LineSource;

/// The second pass: `items` (the file read again) planned as the board takes the segments, each
/// with its G-code line, for [`crate::runner::run_outputs`]. The file must give what the first
/// pass checked: an error, or another number of segments than `segments`, ends the run (the file
/// changed in between). After a probe move the rest is planned from where the board stopped, so
/// its segments are no longer those counted, and an error found then (a soft limit the probed
/// position makes the program cross) ends the run as it is found.
pub fn outputs<'a, S: LineSource + 'a>(
    items: Items<'a, S>,
    checked: &Checked,
    label: &str,
    segments: u32,
) -> crate::runner::Outputs<'a> {
    let source = Second {
        stream: Stream::over(&checked.program.config, items),
        given: 0,
        segments,
        label: label.to_string(),
        probed: false,
    };
    crate::runner::Outputs::from_source(
        source,
        segments,
        checked.totals.nominal_ticks,
        checked.report.ticks,
    )
    .named(label)
}

/// The second pass's source.
struct Second<'a, S> {
    stream: Stream<Items<'a, S>, Stop>,
    given: u32,
    segments: u32,
    label: String,
    /// A probe move has replanned the rest: the count checked no longer holds.
    probed: bool,
}

impl<S: LineSource> crate::runner::OutputSource for Second<'_, S> {
    fn next_output(&mut self) -> Option<Result<crate::runner::Tagged, String>> {
        let changed = format!("{} changed since it was checked", self.label);
        let (given, segments) = (self.given, self.segments);
        let Some(out) = self.stream.next() else {
            return (!self.probed && given != segments)
                .then(|| Err(format!("{changed}: {given} segments instead of {segments}")));
        };
        let line = match self.stream.source() {
            Some(crate::job::Source::Gcode { line }) => Some(line),
            _ => None,
        };
        Some(match out {
            Ok(crate::plan::Output::Segment(_)) if !self.probed && given >= segments => {
                Err(format!("{changed}: more than {segments} segments"))
            }
            Ok(o) => {
                self.given += matches!(o, crate::plan::Output::Segment(_)) as u32;
                Ok((o, line))
            }
            Err(Stop::Plan(p)) => Err(format!("{}: {p}", self.label)),
            Err(Stop::Refused) => {
                let why = match self.stream.items().verdict() {
                    Err(r) => r.to_string(),
                    Ok(()) => String::new(),
                };
                Err(if self.probed {
                    format!("after a probe move: {why}")
                } else if why.is_empty() {
                    changed
                } else {
                    format!("{changed}: {why}")
                })
            }
        })
    }

    fn probed(&mut self, o: &crate::runner::ProbeOutcome) -> Result<(), String> {
        self.probed = true;
        self.stream.items_mut().probed(o.tripped, &o.trip_steps, &o.rest_steps);
        Ok(())
    }

    fn final_steps(&self) -> Option<[i64; MAX_AXES]> {
        Some(self.stream.items().final_steps())
    }
}
