//! Program lines one block at a time through `motion-gcode`, set up as `motionctl`'s G-code
//! front end sets it up (default options, grbl habits accepted), its calls turned into job items
//! by the same [`Converter`]. The interpreter reads from a queue the bridge fills one line at a
//! time; a marker comment after each line tells where that line's calls end.

use crate::gcode::{Converter, Loaded};
use crate::job::{Item, Machine};
use motion_gcode::canon::{Canon, Units};
use motion_gcode::source::{LineInfo, LineSource, SourcePos};
use motion_gcode::{Event, Interpreter, ModalState, Options};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::io;
use std::rc::Rc;

const MARKER: &str = "motionctl-grbl-end-of-block";

/// Lines handed to the interpreter; past the last one, the marker comment.
struct Feed {
    queue: Rc<RefCell<VecDeque<String>>>,
    markers: Rc<RefCell<u32>>,
    pos: SourcePos,
}

impl LineSource for Feed {
    fn next_line(&mut self, buf: &mut Vec<u8>) -> io::Result<Option<LineInfo>> {
        let line = match self.queue.borrow_mut().pop_front() {
            Some(l) => l,
            None => {
                *self.markers.borrow_mut() += 1;
                format!("({MARKER})")
            }
        };
        buf.clear();
        buf.extend_from_slice(line.as_bytes());
        let info = LineInfo { line: self.pos.line, len_with_newline: buf.len() + 1, cut: false };
        self.pos.offset += buf.len() as u64 + 1;
        self.pos.line += 1;
        Ok(Some(info))
    }

    fn tell(&self) -> SourcePos {
        self.pos
    }

    fn seek(&mut self, _pos: SourcePos) -> io::Result<()> {
        Err(io::Error::new(
            io::ErrorKind::Unsupported,
            "a sender's stream cannot go back (no O-word loops or calls over grbl)",
        ))
    }
}

/// What one block made.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Block {
    pub steps: Vec<Step>,
    /// `(msg,...)` texts.
    pub messages: Vec<String>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// A move, a spindle event, a pause or a dwell (G4), as `motionctl run` reads them.
    Item(Item),
}

/// Why a block was refused: grbl's error number and the interpreter's words.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BlockError {
    pub code: u8,
    pub message: String,
}

pub struct Program {
    machine: &'static Machine,
    interp: Interpreter<Feed>,
    conv: Converter<'static>,
    queue: Rc<RefCell<VecDeque<String>>>,
    markers: Rc<RefCell<u32>>,
    /// The last block was a probe move whose result the interpreter has not been told
    /// ([`Program::probed`]); it reads it with the next line.
    probe_pending: bool,
}

impl Program {
    /// A fresh interpreter (rs274's power-on state) whose idea of the position is `at` (machine
    /// mm per machine axis), in G0 as grbl starts.
    /// `machine` lives as long as the bridge (the converter borrows it).
    pub fn new(machine: &'static Machine, at: &[f64]) -> Self {
        Program::with_parameters(machine, at, Vec::new())
    }

    /// As [`Program::new`], with numbered parameters carried over (see [`Program::persistent`]).
    pub fn with_parameters(
        machine: &'static Machine,
        at: &[f64],
        parameters: Vec<(usize, f64)>,
    ) -> Self {
        let queue = Rc::new(RefCell::new(VecDeque::new()));
        let markers = Rc::new(RefCell::new(0));
        let feed = Feed {
            queue: queue.clone(),
            markers: markers.clone(),
            pos: SourcePos { offset: 0, line: 1 },
        };
        let mut p = Program {
            machine,
            interp: {
                let mut opts = Options::default();
                opts.parameters.extend(parameters);
                Interpreter::new(feed, "grbl", opts).keep_going(true)
            },
            conv: Converter::new(machine),
            queue,
            markers,
            probe_pending: false,
        };
        p.sync(at);
        p
    }

    pub fn modal(&self) -> ModalState {
        self.interp.modal_state()
    }

    /// The program ended (M2, M30): a new `Program` takes the next lines.
    pub fn ended(&self) -> bool {
        self.interp.ended()
    }

    /// Tells the interpreter the machine is at `at` (after a jog, homing or a stop), without
    /// motion: a G53 move there whose item is dropped; the motion mode is kept when it is G0,
    /// or G1 with a feed.
    pub fn sync(&mut self, at: &[f64]) {
        let m = self.modal();
        let k = if m.units == Units::Inches { 1.0 / 25.4 } else { 1.0 };
        let mut words = String::new();
        for (a, v) in self.machine.axes.iter().zip(at) {
            words.push_str(&format!(" {}{:.6}", a.name, v * k));
        }
        let keep = m.motion == 0 || (m.motion == 10 && m.feed_rate > 0.0);
        let line = if keep { format!("G53{words}") } else { format!("G53 G0{words}") };
        let _ = self.run(&line);
    }

    /// Sets the coolant of the modal state (what `$G` shows and later M-codes switch from)
    /// without queueing anything: M9, then M7 and M8 as asked, their items dropped (a real-time
    /// toggle switched the board itself).
    pub fn set_coolant(&mut self, mist: bool, flood: bool) {
        let words = [("M9", true), ("M7", mist), ("M8", flood)];
        for (word, on) in words {
            if on {
                let _ = self.run(word);
            }
        }
    }

    /// Values of numbered length parameters (`#5221` ...), mm. rs274 keeps them in its machine
    /// units, inches, whatever G20/G21 says.
    pub fn parameters(&mut self, numbers: &[u32]) -> Vec<f64> {
        let list: Vec<String> = numbers.iter().map(|n| format!("#{n}")).collect();
        let line = format!("(debug,{})", list.join(" "));
        let msgs = self.run(&line).map(|b| b.messages).unwrap_or_default();
        let vals: Vec<f64> = msgs
            .first()
            .map(|m| m.split_whitespace().filter_map(|v| v.parse().ok()).collect())
            .unwrap_or_default();
        if vals.len() == numbers.len() {
            vals.iter().map(|v| v * 25.4).collect()
        } else {
            vec![0.0; numbers.len()]
        }
    }

    /// The parameters grbl keeps across a reset (its EEPROM): G28 and G30 positions and the
    /// G54..G59.3 origins, as rs274 stores them.
    pub fn persistent(&mut self) -> Vec<(usize, f64)> {
        let mut numbers: Vec<u32> = (5161..=5166).chain(5181..=5186).collect();
        for system in 0..9 {
            numbers.extend((0..6).map(|a| 5221 + 20 * system + a));
        }
        let mut out = Vec::with_capacity(numbers.len());
        for chunk in numbers.chunks(12) {
            let list: Vec<String> = chunk.iter().map(|n| format!("#{n}")).collect();
            let line = format!("(debug,{})", list.join(" "));
            let msgs = self.run(&line).map(|b| b.messages).unwrap_or_default();
            let vals: Vec<f64> = msgs
                .first()
                .map(|m| m.split_whitespace().filter_map(|v| v.parse().ok()).collect())
                .unwrap_or_default();
            if vals.len() == chunk.len() {
                out.extend(chunk.iter().zip(vals).map(|(&n, v)| (n as usize, v)));
            }
        }
        out
    }

    /// The probe move of the last block ended on the board: whether it tripped, where the
    /// machine axes latched (`trip_mm`) and came to rest (`rest_mm`), machine mm per machine
    /// axis. The interpreter takes it in with the next line (#5061..#5070, and the rest of the
    /// program continues from the rest position), as `motionctl run` tells it.
    pub fn probed(&mut self, tripped: bool, trip_mm: &[f64], rest_mm: &[f64]) {
        let result = self.conv.probe_result(tripped, trip_mm, rest_mm);
        self.interp.world_mut().set_probe_result(result);
        self.probe_pending = false;
    }

    /// A probe move whose result never came (refused, check mode, the machine stopped): no trip,
    /// the machine where the converter follows it, so the next line reads a result of the
    /// board's rather than the interpreter's own model of one.
    fn settle_probe(&mut self) {
        if !self.probe_pending {
            return;
        }
        let frame = self.conv.frame.position;
        let at: Vec<f64> =
            self.conv.axis_map().iter().map(|g| g.map_or(0.0, |g| frame[g])).collect();
        self.probed(false, &at, &at);
    }

    /// One program line: its steps, or the first error (nothing of the block is kept). After a
    /// probe move the interpreter stops at the end of its block, before the next line, until
    /// [`Program::probed`] (or the next line, which takes it as no trip).
    pub fn run(&mut self, line: &str) -> Result<Block, BlockError> {
        self.settle_probe();
        if self.ended() {
            return Err(BlockError { code: 20, message: "program ended".into() });
        }
        if starts_with_o_word(line) {
            return Err(BlockError {
                code: super::protocol::error::UNSUPPORTED_COMMAND,
                message: "O-word subroutines and loops need the whole program (run it with \
                          `motionctl run`)"
                    .into(),
            });
        }
        self.queue.borrow_mut().push_back(line.to_string());
        *self.markers.borrow_mut() = 0;
        let mut calls = Vec::new();
        let mut error: Option<BlockError> = None;
        loop {
            if *self.markers.borrow() > 2 {
                // The interpreter is skipping lines: it will never get past this block.
                error.get_or_insert(BlockError { code: 20, message: "block never ends".into() });
                break;
            }
            let Some(ev) = self.interp.next_event() else { break };
            match ev {
                Event::Call(c) => {
                    if matches!(&c.canon, Canon::Comment(m) if m == MARKER) {
                        break;
                    }
                    self.probe_pending |= matches!(c.canon, Canon::StraightProbe { .. });
                    calls.push(c);
                }
                Event::Diagnostic(d) if d.is_error() => {
                    error.get_or_insert(BlockError {
                        code: super::protocol::error_for_message(&d.message),
                        message: d.message.clone(),
                    });
                }
                Event::Diagnostic(_) => {}
            }
            // The rest of a probe move's block, without reading on: the next line must wait
            // for the board's result.
            if self.probe_pending && !self.interp.has_queued_events() {
                break;
            }
        }
        self.queue.borrow_mut().clear();
        if let Some(e) = error {
            return Err(e);
        }
        let mut block = Block::default();
        for c in calls {
            let mut loaded = Loaded::default();
            self.conv.call(c.line, &c.canon, &mut loaded).map_err(|m| BlockError {
                code: super::protocol::error::UNSUPPORTED_COMMAND,
                message: m,
            })?;
            if let Canon::Message(m) = &c.canon {
                block.messages.push(m.clone());
            }
            block.steps.extend(loaded.items.into_iter().map(Step::Item));
        }
        self.conv.notes.clear();
        Ok(block)
    }
}

/// An O-word starts the block (after a block-delete slash and a line number).
fn starts_with_o_word(line: &str) -> bool {
    let t = line.trim_start().trim_start_matches('/').trim_start();
    let t = if t.starts_with(['n', 'N']) {
        t[1..].trim_start_matches(|c: char| c.is_ascii_digit() || c == ' ' || c == '.')
    } else {
        t
    };
    t.starts_with(['o', 'O'])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::{Feed as JobFeed, MoveCmd, Target};

    fn machine() -> &'static Machine {
        let src = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/corpus-machine.toml"
        ))
        .unwrap();
        Box::leak(Box::new(crate::job::parse_machine_toml(&src).unwrap()))
    }

    fn target(s: &Step) -> Vec<Option<f64>> {
        match s {
            Step::Item(Item::Move(MoveCmd { target: Target::Absolute(t), .. })) => t.clone(),
            other => panic!("not a move: {other:?}"),
        }
    }

    #[test]
    fn blocks_run_one_at_a_time_with_modal_state_kept() {
        let m = machine();
        let mut p = Program::new(m, &[0.0, 0.0, 0.0]);
        assert!(p.run("G21 G90").unwrap().steps.is_empty());
        let b = p.run("G1 X10 Y5 F600").unwrap();
        assert_eq!(target(&b.steps[0]), vec![Some(10.0), Some(5.0), Some(0.0)]);
        assert!(matches!(
            &b.steps[0],
            Step::Item(Item::Move(MoveCmd { feed: JobFeed::MmPerMin(f), .. })) if *f == 600.0
        ));
        let b = p.run("G91 X1").unwrap();
        assert_eq!(target(&b.steps[0]), vec![Some(11.0), Some(5.0), Some(0.0)]);
        assert_eq!(p.run("G1 X1 Y1 Y2").unwrap_err().code, 25);
        assert_eq!(p.run("G1 X1..2").unwrap_err().code, 2);
        assert_eq!(p.run("o100 sub").unwrap_err().code, 20);
        let b = p.run("G4 P0.5").unwrap();
        assert_eq!(b.steps, vec![Step::Item(Item::Dwell(0.5))]);
        // Still usable after errors.
        let b = p.run("X1").unwrap();
        assert_eq!(target(&b.steps[0]), vec![Some(12.0), Some(5.0), Some(0.0)]);
    }

    fn debug(p: &mut Program, words: &str) -> Vec<f64> {
        let b = p.run(&format!("(debug,{words})")).unwrap();
        b.messages[0].split_whitespace().map(|v| v.parse().unwrap()).collect()
    }

    #[test]
    fn a_probe_block_waits_for_the_boards_result_and_the_program_goes_on_from_it() {
        let m = machine();
        let mut p = Program::new(m, &[0.0; 3]);
        p.run("G10 L2 P1 Z1").unwrap();
        let b = p.run("G38.2 Z-10 F100").unwrap();
        match &b.steps[..] {
            [Step::Item(Item::Probe { kind, mv })] => {
                assert_eq!(*kind, motion::machine::ProbeKind::TowardError);
                assert_eq!(mv.target, Target::Absolute(vec![Some(0.0), Some(0.0), Some(-9.0)]));
            }
            other => panic!("not one probe move: {other:?}"),
        }
        // Latched at machine Z -3, stopped 0.1 mm further on.
        p.probed(true, &[0.0, 0.0, -3.0], &[0.0, 0.0, -3.1]);
        let v = debug(&mut p, "#5063 #5070 #5422");
        assert!((v[0] + 4.0).abs() < 1e-9 && v[1] == 1.0 && (v[2] + 4.1).abs() < 1e-9, "{v:?}");
        let b = p.run("G91 G0 Z2").unwrap();
        let z = target(&b.steps[0])[2].unwrap();
        assert!((z + 1.1).abs() < 1e-9, "from the rest position: {z}");

        // No result told (the move refused, or check mode): no trip, the programmed end.
        p.run("G90 G38.3 X5 F100").unwrap();
        let v = debug(&mut p, "#5061 #5070 #5420");
        assert_eq!(v, vec![5.0, 0.0, 5.0]);
    }

    #[test]
    fn sync_moves_the_interpreter_without_motion() {
        let m = machine();
        let mut p = Program::new(m, &[3.0, 4.0, -1.0]);
        let b = p.run("G1 X5 F100").unwrap();
        assert_eq!(target(&b.steps[0]), vec![Some(5.0), Some(4.0), Some(-1.0)]);
        p.sync(&[7.0, 8.0, 9.0]);
        assert_eq!(p.modal().motion, 10);
        let b = p.run("G91 G1 X1").unwrap();
        assert_eq!(target(&b.steps[0]), vec![Some(8.0), Some(8.0), Some(9.0)]);
        assert!(p.run("G90 M30").is_ok());
        assert!(p.ended());
    }

    #[test]
    fn coolant_set_without_items_shows_in_the_modal_state() {
        let m = machine();
        let mut p = Program::new(m, &[0.0; 3]);
        p.set_coolant(false, true);
        assert!(p.modal().codes().contains(&"M8".to_string()));
        p.set_coolant(true, false);
        let codes = p.modal().codes();
        assert!(codes.contains(&"M7".to_string()) && !codes.contains(&"M8".to_string()));
        // The next M-code switches from the toggled state: M3 keeps the mist.
        let b = p.run("M3").unwrap();
        let want = motion::protocol::ProgramOutputs {
            spindle: motion::protocol::SpindleDir::Cw,
            mist: true,
            flood: false,
        };
        assert_eq!(b.steps, vec![Step::Item(Item::Outputs(want))]);
        p.set_coolant(false, false);
        assert!(p.modal().codes().contains(&"M9".to_string()));
    }

    #[test]
    fn parameters_read_back_offsets() {
        let m = machine();
        let mut p = Program::new(m, &[0.0; 3]);
        p.run("G10 L2 P1 X5 Y6 Z-1").unwrap();
        let v = p.parameters(&[5221, 5222, 5223]);
        assert!(v.iter().zip([5.0, 6.0, -1.0]).all(|(a, b)| (a - b).abs() < 1e-4), "{v:?}");
        p.run("G20 G10 L2 P2 X1").unwrap();
        let v = p.parameters(&[5241]);
        assert!((v[0] - 25.4).abs() < 1e-4, "{v:?}");
        let kept = p.persistent();
        let mut q = Program::with_parameters(m, &[0.0; 3], kept);
        let v = q.parameters(&[5221, 5241]);
        assert!((v[0] - 5.0).abs() < 1e-4 && (v[1] - 25.4).abs() < 1e-4, "{v:?}");
    }
}
