//! The byte level of grbl 1.1's serial protocol: real-time command bytes (acted on the moment
//! they arrive, never stored as line text), the 128-byte receive buffer senders count characters
//! against, and grbl's error and alarm numbers.

use motion::protocol::ProgramOutputs;
use std::collections::VecDeque;

/// The receive buffer a character-counting sender assumes (grbl's `RX_BUFFER_SIZE`).
pub const RX_BUFFER_SIZE: usize = 128;
/// Longest line accepted (grblHAL's line buffer); a longer one is answered `error:11`.
pub const LINE_MAX: usize = 256;
/// Bytes held at most before more are dropped (a sender that ignores the protocol).
pub const RX_HOLD_MAX: usize = 64 * 1024;
/// Planner blocks a sender is told about (`Bf:` first field, grbl's `BLOCK_BUFFER_SIZE - 1`).
pub const PLANNER_BLOCKS: usize = 15;

pub const WELCOME: &str = "Grbl 1.1h ['$' for help]";

/// Real-time commands.
pub mod rt {
    pub const STATUS: u8 = b'?';
    pub const FEED_HOLD: u8 = b'!';
    pub const CYCLE_START: u8 = b'~';
    pub const RESET: u8 = 0x18;
    pub const SAFETY_DOOR: u8 = 0x84;
    pub const JOG_CANCEL: u8 = 0x85;
    pub const FEED_100: u8 = 0x90;
    pub const FEED_PLUS_10: u8 = 0x91;
    pub const FEED_MINUS_10: u8 = 0x92;
    pub const FEED_PLUS_1: u8 = 0x93;
    pub const FEED_MINUS_1: u8 = 0x94;
    pub const RAPID_100: u8 = 0x95;
    pub const RAPID_50: u8 = 0x96;
    pub const RAPID_25: u8 = 0x97;
    pub const SPINDLE_100: u8 = 0x99;
    pub const SPINDLE_PLUS_10: u8 = 0x9A;
    pub const SPINDLE_MINUS_10: u8 = 0x9B;
    pub const SPINDLE_PLUS_1: u8 = 0x9C;
    pub const SPINDLE_MINUS_1: u8 = 0x9D;
    pub const SPINDLE_STOP: u8 = 0x9E;
    pub const FLOOD_TOGGLE: u8 = 0xA0;
    pub const MIST_TOGGLE: u8 = 0xA1;
}

/// A real-time command, decoded from its byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Realtime {
    Status,
    FeedHold,
    CycleStart,
    Reset,
    SafetyDoor,
    JogCancel,
    /// Feed override: set to 100 %, or change by this many percent.
    Feed(OverrideChange),
    Rapid(u8),
    Spindle(OverrideChange),
    /// Spindle stop (0x9E): toggles the spindle off and on during a feed hold.
    SpindleStop,
    /// Flood (0xA0) or mist (0xA1) toggled at once.
    Coolant(Coolant),
    /// Any other byte of 0x80..=0xFF: ignored, as grbl does.
    Ignored,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OverrideChange {
    Reset,
    By(i8),
}

impl OverrideChange {
    /// The new override percentage from `now`, within grbl's 10..=200.
    pub fn apply(self, now: u8) -> u8 {
        match self {
            OverrideChange::Reset => 100,
            OverrideChange::By(d) => (now as i16 + d as i16).clamp(10, 200) as u8,
        }
    }
}

/// Which coolant a toggle byte switches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coolant {
    Flood,
    Mist,
}

impl Coolant {
    /// The outputs after toggling this coolant in `now` (the spindle and the other coolant
    /// stay).
    pub fn toggle(self, now: ProgramOutputs) -> ProgramOutputs {
        match self {
            Coolant::Flood => ProgramOutputs { flood: !now.flood, ..now },
            Coolant::Mist => ProgramOutputs { mist: !now.mist, ..now },
        }
    }
}

/// The real-time command `b` stands for, or `None` for a byte of line text.
pub fn realtime(b: u8) -> Option<Realtime> {
    use OverrideChange::{By, Reset};
    Some(match b {
        rt::STATUS => Realtime::Status,
        rt::FEED_HOLD => Realtime::FeedHold,
        rt::CYCLE_START => Realtime::CycleStart,
        rt::RESET => Realtime::Reset,
        rt::SAFETY_DOOR => Realtime::SafetyDoor,
        rt::JOG_CANCEL => Realtime::JogCancel,
        rt::FEED_100 => Realtime::Feed(Reset),
        rt::FEED_PLUS_10 => Realtime::Feed(By(10)),
        rt::FEED_MINUS_10 => Realtime::Feed(By(-10)),
        rt::FEED_PLUS_1 => Realtime::Feed(By(1)),
        rt::FEED_MINUS_1 => Realtime::Feed(By(-1)),
        rt::RAPID_100 => Realtime::Rapid(100),
        rt::RAPID_50 => Realtime::Rapid(50),
        rt::RAPID_25 => Realtime::Rapid(25),
        rt::SPINDLE_100 => Realtime::Spindle(Reset),
        rt::SPINDLE_PLUS_10 => Realtime::Spindle(By(10)),
        rt::SPINDLE_MINUS_10 => Realtime::Spindle(By(-10)),
        rt::SPINDLE_PLUS_1 => Realtime::Spindle(By(1)),
        rt::SPINDLE_MINUS_1 => Realtime::Spindle(By(-1)),
        rt::SPINDLE_STOP => Realtime::SpindleStop,
        rt::FLOOD_TOGGLE => Realtime::Coolant(Coolant::Flood),
        rt::MIST_TOGGLE => Realtime::Coolant(Coolant::Mist),
        0x80..=0xFF => Realtime::Ignored,
        _ => return None,
    })
}

/// grbl 1.1's error numbers (`error:N`).
pub mod error {
    pub const EXPECTED_COMMAND_LETTER: u8 = 1;
    pub const BAD_NUMBER_FORMAT: u8 = 2;
    pub const INVALID_STATEMENT: u8 = 3;
    pub const NEGATIVE_VALUE: u8 = 4;
    pub const SETTING_DISABLED: u8 = 5;
    /// Settings could not be applied (grbl: the EEPROM read failed).
    pub const SETTING_READ_FAIL: u8 = 7;
    pub const IDLE_ERROR: u8 = 8;
    pub const SYSTEM_GC_LOCK: u8 = 9;
    pub const SOFT_LIMIT_ERROR: u8 = 10;
    pub const OVERFLOW: u8 = 11;
    pub const TRAVEL_EXCEEDED: u8 = 15;
    pub const INVALID_JOG_COMMAND: u8 = 16;
    pub const UNSUPPORTED_COMMAND: u8 = 20;
    pub const MODAL_GROUP_VIOLATION: u8 = 21;
    pub const UNDEFINED_FEED_RATE: u8 = 22;
    pub const COMMAND_VALUE_NOT_INTEGER: u8 = 23;
    pub const AXIS_COMMAND_CONFLICT: u8 = 24;
    pub const WORD_REPEATED: u8 = 25;
    pub const NO_AXIS_WORDS: u8 = 26;
    pub const AXIS_WORDS_EXIST: u8 = 31;
    pub const NO_AXIS_WORDS_IN_PLANE: u8 = 32;
    pub const INVALID_TARGET: u8 = 33;
    pub const ARC_RADIUS_ERROR: u8 = 34;
    pub const NO_OFFSETS_IN_PLANE: u8 = 35;
    /// A job file could not be read (grblHAL's "file open/read failed").
    pub const FILE_READ: u8 = 61;
}

/// grbl's alarm numbers (`ALARM:N`), and the board's own faults past them (README).
pub mod alarm {
    pub const HARD_LIMIT: u8 = 1;
    pub const SOFT_LIMIT: u8 = 2;
    pub const ABORT_CYCLE: u8 = 3;
    /// Probe fail: not in the expected initial state before the cycle (the board's
    /// `ProbeInitial`).
    pub const PROBE_FAIL_INITIAL: u8 = 4;
    /// Probe fail: no contact within the travel (G38.2, G38.4; the board's `ProbeFail`).
    pub const PROBE_FAIL_CONTACT: u8 = 5;
    pub const HOMING_FAIL_RESET: u8 = 6;
    /// grblHAL's e-stop alarm.
    pub const ESTOP: u8 = 10;
    /// Homing required before motion (grblHAL's 11).
    pub const HOMING_REQUIRED: u8 = 11;
    /// Any other board fault: this plus its fault code (e.g. WireStall, code 16: ALARM:46).
    pub const BOARD_FAULT_BASE: u8 = 30;
}

/// The grbl error number for an interpreter diagnostic (rs274's wording).
pub fn error_for_message(m: &str) -> u8 {
    let l = m.to_ascii_lowercase();
    let has = |s: &str| l.contains(s);
    if has("bad number format") || has("no characters found in reading real value") {
        error::BAD_NUMBER_FORMAT
    } else if has("bad character") || has("unknown word") {
        error::EXPECTED_COMMAND_LETTER
    } else if has("negative") {
        error::NEGATIVE_VALUE
    } else if has("same modal group") || has("two m codes") {
        error::MODAL_GROUP_VIOLATION
    } else if has("zero feed rate") || has("f word missing") {
        error::UNDEFINED_FEED_RATE
    } else if has("non integer value") {
        error::COMMAND_VALUE_NOT_INTEGER
    } else if has("two g codes that both use axis values") {
        error::AXIS_COMMAND_CONFLICT
    } else if has("multiple") && has("words on one line") {
        error::WORD_REPEATED
    } else if has("all axes missing") {
        error::NO_AXIS_WORDS
    } else if has("axis values without a g code") || has("with no g code that uses it") {
        error::AXIS_WORDS_EXIST
    } else if has("words missing for arc") {
        error::NO_AXIS_WORDS_IN_PLANE
    } else if has("r i j k words all missing") {
        error::NO_OFFSETS_IN_PLANE
    } else if has("radius") && has("arc") {
        error::ARC_RADIUS_ERROR
    } else if has("arc") || has("end point") {
        error::INVALID_TARGET
    } else {
        error::UNSUPPORTED_COMMAND
    }
}

/// What the receive side holds: line text (real-time bytes taken out) split into lines, with
/// the byte count a character-counting sender sees.
#[derive(Debug, Default)]
pub struct RxBuffer {
    /// Complete lines, each with the bytes it took in the buffer (newline included), and
    /// whether it overflowed [`LINE_MAX`] (its text is then cut).
    lines: VecDeque<(Vec<u8>, usize, bool)>,
    partial: Vec<u8>,
    partial_bytes: usize,
    partial_overflow: bool,
    held: usize,
    last_cr: bool,
    /// Bytes dropped because more than [`RX_HOLD_MAX`] were waiting.
    pub dropped: u64,
}

/// A line taken from the buffer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Line {
    Text(String),
    /// Longer than [`LINE_MAX`]: answered `error:11`, not executed.
    Overflow,
}

impl RxBuffer {
    /// One byte of line text (not a real-time byte). `\r`, `\n` and `\r\n` end a line; other
    /// control characters are dropped as grbl drops them.
    pub fn push(&mut self, b: u8) {
        let cr_lf = self.last_cr && b == b'\n';
        self.last_cr = b == b'\r';
        if cr_lf {
            // The `\n` of `\r\n`: the line already ended; count the byte with it.
            if let Some(last) = self.lines.back_mut() {
                last.1 += 1;
                self.held += 1;
            }
            return;
        }
        if self.held >= RX_HOLD_MAX {
            self.dropped += 1;
            return;
        }
        self.held += 1;
        self.partial_bytes += 1;
        match b {
            b'\n' | b'\r' => {
                let text = std::mem::take(&mut self.partial);
                self.lines.push_back((text, self.partial_bytes, self.partial_overflow));
                self.partial_bytes = 0;
                self.partial_overflow = false;
            }
            0..=0x1F | 0x7F.. => {}
            _ if self.partial.len() >= LINE_MAX => self.partial_overflow = true,
            _ => self.partial.push(b),
        }
    }

    pub fn has_line(&self) -> bool {
        !self.lines.is_empty()
    }

    /// The oldest complete line; its bytes leave the buffer.
    pub fn pop_line(&mut self) -> Option<Line> {
        let (text, bytes, overflow) = self.lines.pop_front()?;
        self.held = self.held.saturating_sub(bytes);
        if overflow {
            return Some(Line::Overflow);
        }
        Some(Line::Text(String::from_utf8_lossy(&text).into_owned()))
    }

    /// Free bytes of the sender's 128-byte view (`Bf:` second field).
    pub fn free(&self) -> usize {
        RX_BUFFER_SIZE.saturating_sub(self.held)
    }

    /// Everything dropped (a soft reset empties the buffer, as grbl's does).
    pub fn clear(&mut self) {
        *self = RxBuffer { dropped: self.dropped, ..RxBuffer::default() };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(rx: &mut RxBuffer, s: &[u8]) {
        for &b in s {
            if realtime(b).is_none() {
                rx.push(b);
            }
        }
    }

    #[test]
    fn lines_split_on_cr_lf_and_crlf_and_count_bytes() {
        let mut rx = RxBuffer::default();
        feed(&mut rx, b"G1 X1\r\nG0\nM5\rX");
        assert_eq!(rx.free(), RX_BUFFER_SIZE - 14);
        assert_eq!(rx.pop_line(), Some(Line::Text("G1 X1".into())));
        assert_eq!(rx.free(), RX_BUFFER_SIZE - 7);
        assert_eq!(rx.pop_line(), Some(Line::Text("G0".into())));
        assert_eq!(rx.pop_line(), Some(Line::Text("M5".into())));
        assert_eq!(rx.pop_line(), None);
        assert_eq!(rx.free(), RX_BUFFER_SIZE - 1);
    }

    #[test]
    fn real_time_bytes_never_reach_the_line() {
        let mut rx = RxBuffer::default();
        feed(&mut rx, b"G1 X?1!~\x85\x91\n");
        assert_eq!(rx.pop_line(), Some(Line::Text("G1 X1".into())));
    }

    #[test]
    fn long_lines_overflow_and_noise_is_dropped() {
        let mut rx = RxBuffer::default();
        let long = vec![b'X'; 300];
        feed(&mut rx, &long);
        feed(&mut rx, b"\n\x01\x02G0\x7f\n");
        assert_eq!(rx.pop_line(), Some(Line::Overflow));
        assert_eq!(rx.pop_line(), Some(Line::Text("G0".into())));
        assert_eq!(rx.free(), RX_BUFFER_SIZE);
    }

    #[test]
    fn coolant_toggles_flip_one_coolant_and_keep_the_rest() {
        use motion::protocol::SpindleDir;
        assert_eq!(realtime(0xA0), Some(Realtime::Coolant(Coolant::Flood)));
        assert_eq!(realtime(0xA1), Some(Realtime::Coolant(Coolant::Mist)));
        let cw_mist = ProgramOutputs { spindle: SpindleDir::Cw, mist: true, flood: false };
        let all = Coolant::Flood.toggle(cw_mist);
        assert_eq!(all, ProgramOutputs { flood: true, ..cw_mist });
        assert_eq!(Coolant::Mist.toggle(all), ProgramOutputs { mist: false, ..all });
        assert_eq!(Coolant::Flood.toggle(all), cw_mist);
    }

    #[test]
    fn overrides_stay_within_10_and_200() {
        assert_eq!(OverrideChange::By(10).apply(195), 200);
        assert_eq!(OverrideChange::By(-10).apply(15), 10);
        assert_eq!(OverrideChange::Reset.apply(40), 100);
    }
}
