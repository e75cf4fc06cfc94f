//! Status reports (`?`) in grbl 1.1's format:
//! `<State|MPos:x,y,z|Bf:blocks,bytes|FS:feed,speed|WCO:x,y,z|Ov:feed,rapid,spindle|A:SFM>`,
//! the accessory field `A:` (after `Ov:`, as grbl prints it) only while an accessory is on: `S`
//! spindle clockwise, `C` counterclockwise, `F` flood, `M` mist, in that order.

use motion::protocol::{ProgramOutputs, SpindleDir};
use std::fmt::Write as _;

/// grbl's machine states as a report names them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    Idle,
    Run,
    /// Hold complete (`Hold:0`) or still decelerating (`Hold:1`).
    Hold {
        stopping: bool,
    },
    Jog,
    Alarm,
    Door,
    Check,
    Home,
}

impl State {
    pub fn name(self) -> &'static str {
        match self {
            State::Idle => "Idle",
            State::Run => "Run",
            State::Hold { stopping: false } => "Hold:0",
            State::Hold { stopping: true } => "Hold:1",
            State::Jog => "Jog",
            State::Alarm => "Alarm",
            State::Door => "Door:0",
            State::Check => "Check",
            State::Home => "Home",
        }
    }
}

/// What one report says.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    pub state: State,
    /// Machine position, mm, per axis.
    pub mpos: Vec<f64>,
    /// Work coordinate offset, mm, per axis (WPos = MPos - WCO).
    pub wco: Vec<f64>,
    pub planner_free: usize,
    pub rx_free: usize,
    /// mm/min (or in/min with `$13=1`), rpm.
    pub feed: f64,
    pub speed: f64,
    pub overrides: [u8; 3],
    /// The spindle and coolant the board drives (the `A:` field).
    pub accessories: ProgramOutputs,
    /// `$10`: bit 0 MPos (else WPos), bit 1 buffer state.
    pub mask: u16,
    pub inches: bool,
}

fn axes(out: &mut String, v: &[f64], inches: bool) {
    for (i, x) in v.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        // No "-0.000".
        let x = if inches { x / 25.4 } else { *x };
        let s = if inches { format!("{x:.4}") } else { format!("{x:.3}") };
        let zero = s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.');
        out.push_str(if zero { s.trim_start_matches('-') } else { &s });
    }
}

impl Report {
    pub fn line(&self) -> String {
        let mut s = String::from("<");
        s.push_str(self.state.name());
        if self.mask & 1 != 0 {
            s.push_str("|MPos:");
            axes(&mut s, &self.mpos, self.inches);
        } else {
            s.push_str("|WPos:");
            let w: Vec<f64> = self.mpos.iter().zip(&self.wco).map(|(m, o)| m - o).collect();
            axes(&mut s, &w, self.inches);
        }
        if self.mask & 2 != 0 {
            let _ = write!(s, "|Bf:{},{}", self.planner_free, self.rx_free);
        }
        let feed = if self.inches { self.feed / 25.4 } else { self.feed };
        let _ = write!(s, "|FS:{},{}", feed.round() as i64, self.speed.round() as i64);
        s.push_str("|WCO:");
        axes(&mut s, &self.wco, self.inches);
        let [f, r, sp] = self.overrides;
        let _ = write!(s, "|Ov:{f},{r},{sp}");
        let a = self.accessories;
        if a != ProgramOutputs::OFF {
            s.push_str("|A:");
            match a.spindle {
                SpindleDir::Off => {}
                SpindleDir::Cw => s.push('S'),
                SpindleDir::Ccw => s.push('C'),
            }
            if a.flood {
                s.push('F');
            }
            if a.mist {
                s.push('M');
            }
        }
        s.push('>');
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_reads_as_grbl_1_1_prints_it() {
        let r = Report {
            state: State::Hold { stopping: false },
            mpos: vec![1.0, -0.0004, 12.3456],
            wco: vec![0.0, 0.0, 2.0],
            planner_free: 15,
            rx_free: 128,
            feed: 500.4,
            speed: 0.0,
            overrides: [100, 100, 100],
            accessories: ProgramOutputs::OFF,
            mask: 3,
            inches: false,
        };
        assert_eq!(
            r.line(),
            "<Hold:0|MPos:1.000,0.000,12.346|Bf:15,128|FS:500,0|WCO:0.000,0.000,2.000|Ov:100,100,100>"
        );
        let w = Report { mask: 0, state: State::Idle, ..r.clone() };
        assert!(w.line().starts_with("<Idle|WPos:1.000,0.000,10.346|FS:500,0|"), "{}", w.line());
        let a = |spindle, mist, flood| {
            Report { accessories: ProgramOutputs { spindle, mist, flood }, ..r.clone() }.line()
        };
        assert!(a(SpindleDir::Cw, true, true).ends_with("|Ov:100,100,100|A:SFM>"));
        assert!(a(SpindleDir::Ccw, false, false).ends_with("|Ov:100,100,100|A:C>"));
        assert!(a(SpindleDir::Off, true, false).ends_with("|Ov:100,100,100|A:M>"));
        assert!(a(SpindleDir::Off, false, true).ends_with("|A:F>"));
    }
}
