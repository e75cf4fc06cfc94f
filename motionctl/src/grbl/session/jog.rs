//! Jogging: `$J=` lines parsed and cut into short pieces (a jog cancel stops within one).

use super::Bridge;
use crate::grbl::protocol::error;
use crate::job::{Feed, Machine};
use anyhow::Result;
use motion_gcode::canon::Units;

/// Longest piece of a jog, seconds.
const JOG_PIECE_S: f64 = 0.1;

impl Bridge<'_> {
    /// `$J=`: G20/G21, G90/G91, G53, axis words and F; one move that ends at rest.
    pub(super) fn jog_line(&mut self, body: &str) {
        if self.alarm.is_some() {
            return self.error(error::SYSTEM_GC_LOCK);
        }
        if self.check || self.hold || self.door || (self.moving() && !self.jog) {
            return self.error(error::IDLE_ERROR);
        }
        let jog = match parse_jog(body, self.machine) {
            Ok(j) => j,
            Err(n) => return self.error(n),
        };
        if self.prog.ended() {
            self.new_program();
        }
        let modal = self.prog.modal();
        let inches = jog.inches.unwrap_or(modal.units == Units::Inches);
        let k = if inches { 25.4 } else { 1.0 };
        let incremental = jog.incremental.unwrap_or(!modal.absolute) && !jog.machine_coords;
        let wco = self.wco();
        let from = self.motion.pos_mm.clone();
        let mut target: Vec<Option<f64>> = vec![None; from.len()];
        for (i, v) in jog.axes.iter().enumerate() {
            let Some(v) = v else { continue };
            let mm = v * k;
            target[i] = Some(if incremental {
                from[i] + mm
            } else if jog.machine_coords {
                mm
            } else {
                mm + wco[i]
            });
        }
        let to: Vec<f64> = target.iter().zip(&from).map(|(t, p)| t.unwrap_or(*p)).collect();
        if self.motion.check(&from, &to).is_err() {
            return self.error(error::TRAVEL_EXCEEDED);
        }
        let feed = jog.feed * k;
        self.feed_now = feed;
        // Pieces of at most JOG_PIECE_S each, so a cancel stops within one piece even on a
        // board that cannot stop inside a segment.
        let len = from.iter().zip(&to).map(|(a, b)| (b - a) * (b - a)).sum::<f64>().sqrt();
        let pieces = (len / (feed / 60.0) / JOG_PIECE_S).ceil().clamp(1.0, 2000.0) as usize;
        for p in 1..=pieces {
            let f = p as f64 / pieces as f64;
            let t: Vec<Option<f64>> = from
                .iter()
                .zip(&to)
                .zip(&target)
                .map(|((a, b), t)| t.map(|_| if p == pieces { *b } else { a + (b - a) * f }))
                .collect();
            if self.motion.push_move(&t, Feed::MmPerMin(feed), false).is_err() {
                self.motion.flush();
                return self.error(error::INVALID_JOG_COMMAND);
            }
        }
        self.motion.flush();
        self.jog = true;
        self.ok();
    }
}

/// A parsed `$J=` line.
#[derive(Clone, Debug, PartialEq)]
pub struct Jog {
    pub axes: Vec<Option<f64>>,
    pub feed: f64,
    pub inches: Option<bool>,
    pub incremental: Option<bool>,
    pub machine_coords: bool,
}

/// Parses a jog's words (what follows `$J=`); errors are grbl's numbers.
pub fn parse_jog(body: &str, machine: &Machine) -> Result<Jog, u8> {
    let mut jog = Jog {
        axes: vec![None; machine.axes.len()],
        feed: 0.0,
        inches: None,
        incremental: None,
        machine_coords: false,
    };
    let mut feed = None;
    let chars: Vec<char> = body.chars().filter(|c| !c.is_whitespace()).collect();
    let mut i = 0;
    while i < chars.len() {
        let letter = chars[i].to_ascii_uppercase();
        if !letter.is_ascii_alphabetic() {
            return Err(error::EXPECTED_COMMAND_LETTER);
        }
        i += 1;
        let start = i;
        while i < chars.len() && (chars[i].is_ascii_digit() || matches!(chars[i], '.' | '-' | '+'))
        {
            i += 1;
        }
        let text: String = chars[start..i].iter().collect();
        let v: f64 = text.parse().map_err(|_| error::BAD_NUMBER_FORMAT)?;
        if !v.is_finite() {
            return Err(error::BAD_NUMBER_FORMAT);
        }
        match letter {
            'G' => match text.as_str() {
                "20" => jog.inches = Some(true),
                "21" => jog.inches = Some(false),
                "90" => jog.incremental = Some(false),
                "91" => jog.incremental = Some(true),
                "53" => jog.machine_coords = true,
                _ => return Err(error::INVALID_JOG_COMMAND),
            },
            'F' => {
                if feed.replace(v).is_some() {
                    return Err(error::WORD_REPEATED);
                }
            }
            _ => {
                let Some(a) = machine.axis_index(&letter.to_string()) else {
                    return Err(error::INVALID_JOG_COMMAND);
                };
                if jog.axes[a].replace(v).is_some() {
                    return Err(error::WORD_REPEATED);
                }
            }
        }
    }
    match feed {
        Some(f) if f > 0.0 => jog.feed = f,
        _ => return Err(error::UNDEFINED_FEED_RATE),
    }
    if jog.axes.iter().all(Option::is_none) {
        return Err(error::NO_AXIS_WORDS);
    }
    Ok(jog)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine() -> Machine {
        crate::grbl::test_machine()
    }

    #[test]
    fn jog_lines_parse_as_grbl_reads_them() {
        let m = machine();
        let j = parse_jog("G91X10.5Y-2F500", &m).unwrap();
        assert_eq!(j.axes, vec![Some(10.5), Some(-2.0), None]);
        assert_eq!((j.feed, j.incremental), (500.0, Some(true)));
        assert_eq!(parse_jog("G91 X1", &m), Err(error::UNDEFINED_FEED_RATE));
        assert_eq!(parse_jog("G91 F100", &m), Err(error::NO_AXIS_WORDS));
        assert_eq!(parse_jog("G1 X1 F100", &m), Err(error::INVALID_JOG_COMMAND));
        assert_eq!(parse_jog("X1..2 F100", &m), Err(error::BAD_NUMBER_FORMAT));
        assert_eq!(parse_jog("X1 X2 F100", &m), Err(error::WORD_REPEATED));
        assert_eq!(parse_jog("A1 F100", &m), Err(error::INVALID_JOG_COMMAND));
        assert_eq!(parse_jog("#1 F100", &m), Err(error::EXPECTED_COMMAND_LETTER));
    }
}
