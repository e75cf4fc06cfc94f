//! The G-code subset motionctl reads, to the same [`Item`]s as a TOML job.
//!
//! Supported: `G0`/`G1` with axis words and `F`, `G90`/`G91`, `G20`/`G21`, `M3`/`M5` (spindle
//! on/off), `M0` (pause), `M2`/`M30` (end of program), `S` (accepted, ignored), `N` line numbers,
//! `( ... )` and `; ...` comments, `%` delimiter lines. Case-insensitive; spaces may appear between
//! a letter and its number. Axis words are the machine's axis names of one letter (X Y Z, also
//! A B C when the machine has such axes).
//!
//! Written here rather than on the `gcode` crate (0.7): that crate stores numbers as `f32`, which
//! at 1000 mm is 6e-5 mm apart — enough to flip the rounding of a step at fine resolutions — and
//! a comment in the middle of a block detaches the words after it from their G-code.

use crate::job::{Feed, Item, LineCol, Machine, MoveCmd, Source, Target, MAX_FEED_MM_MIN};
use std::fmt;

const MM_PER_INCH: f64 = 25.4;

/// A rejected G-code program: where, and what was expected.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GcodeError {
    pub at: LineCol,
    pub message: String,
}

impl fmt::Display for GcodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}, column {}: {}", self.at.line, self.at.column, self.message)
    }
}

impl std::error::Error for GcodeError {}

/// One word: a letter and its number, with where the letter stood.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Word {
    letter: char,
    value: f64,
    column: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Motion {
    Rapid,
    Linear,
}

/// Modal state carried from block to block.
struct State {
    motion: Option<Motion>,
    relative: bool,
    inches: bool,
    feed_mm_min: Option<f64>,
}

/// Parses `src` for `machine` (which names the axes). Lengths come out in mm.
pub fn parse(src: &str, machine: &Machine) -> Result<Vec<Item>, GcodeError> {
    let mut state = State { motion: None, relative: false, inches: false, feed_mm_min: None };
    let mut items = Vec::new();
    for (i, text) in src.lines().enumerate() {
        let line = i + 1;
        let words = lex_line(text, line)?;
        if !block(&words, line, machine, &mut state, &mut items)? {
            break;
        }
    }
    Ok(items)
}

/// Splits one line into words, dropping comments and the line number.
fn lex_line(text: &str, line: usize) -> Result<Vec<Word>, GcodeError> {
    let chars: Vec<char> = text.chars().collect();
    let err =
        |col: usize, message: String| GcodeError { at: LineCol { line, column: col }, message };
    let mut words = Vec::new();
    let mut k = 0;
    while k < chars.len() {
        let c = chars[k];
        let column = k + 1;
        if c.is_whitespace() {
            k += 1;
        } else if c == ';' {
            break;
        } else if c == '(' {
            match chars[k..].iter().position(|&c| c == ')') {
                Some(len) => k += len + 1,
                None => {
                    return Err(err(
                        column,
                        "comment not closed: expected ')' before the end of the line".into(),
                    ))
                }
            }
        } else if c == '%' && words.is_empty() && text.trim() == "%" {
            break;
        } else if c.is_ascii_alphabetic() {
            let letter = c.to_ascii_uppercase();
            k += 1;
            while k < chars.len() && (chars[k] == ' ' || chars[k] == '\t') {
                k += 1;
            }
            let start = k;
            if k < chars.len() && (chars[k] == '+' || chars[k] == '-') {
                k += 1;
            }
            let digits_start = k;
            while k < chars.len() && (chars[k].is_ascii_digit() || chars[k] == '.') {
                k += 1;
            }
            let number: String = chars[start..k].iter().collect();
            let digits = &chars[digits_start..k];
            let dots = digits.iter().filter(|&&c| c == '.').count();
            let valid = digits.iter().any(|c| c.is_ascii_digit()) && dots <= 1;
            let value = number.parse::<f64>().ok().filter(|_| valid);
            let Some(value) = value else {
                let found = match chars.get(start) {
                    Some(c) if k == start => format!("'{c}'"),
                    Some(_) => format!("{number:?}"),
                    None => "the end of the line".into(),
                };
                return Err(err(
                    start + 1,
                    format!("expected a number after '{letter}', found {found}"),
                ));
            };
            if letter != 'N' {
                words.push(Word { letter, value, column });
            } else if !words.is_empty() {
                return Err(err(column, "a line number N must start the block".into()));
            }
        } else {
            return Err(err(
                column,
                format!("expected a word (letter and number) or a comment, found '{c}'"),
            ));
        }
    }
    Ok(words)
}

/// Applies one block to the modal state, appending its items. False at end of program (M2/M30).
fn block(
    words: &[Word],
    line: usize,
    machine: &Machine,
    state: &mut State,
    items: &mut Vec<Item>,
) -> Result<bool, GcodeError> {
    let err =
        |w: &Word, message: String| GcodeError { at: LineCol { line, column: w.column }, message };
    let mut motion: Option<(Motion, &Word)> = None;
    let mut units: Option<&Word> = None;
    let mut distance: Option<&Word> = None;
    let mut spindle: Option<(bool, &Word)> = None;
    let mut pause = false;
    let mut end = false;
    let mut feed: Option<&Word> = None;
    let mut axes: Vec<Option<(f64, &Word)>> = vec![None; machine.axes.len()];
    for w in words {
        let code = w.value;
        let whole = code.fract() == 0.0 && code >= 0.0;
        match w.letter {
            'G' => {
                let slot = match (whole, code as u32) {
                    (true, 0) => motion.replace((Motion::Rapid, w)).map(|m| m.1),
                    (true, 1) => motion.replace((Motion::Linear, w)).map(|m| m.1),
                    (true, 20 | 21) => units.replace(w),
                    (true, 90 | 91) => distance.replace(w),
                    _ => {
                        return Err(err(
                            w,
                            format!(
                                "unsupported G-code G{code}: expected G0, G1, G20, G21, G90 or G91"
                            ),
                        ))
                    }
                };
                if let Some(prev) = slot {
                    return Err(err(
                        w,
                        format!("G{code} conflicts with G{} in the same block", prev.value),
                    ));
                }
            }
            'M' => match (whole, code as u32) {
                (true, 3 | 5) => {
                    if spindle.replace((code == 3.0, w)).is_some() {
                        return Err(err(w, "two spindle M-codes in one block".into()));
                    }
                }
                (true, 0) => pause = true,
                (true, 2 | 30) => end = true,
                _ => {
                    return Err(err(
                        w,
                        format!("unsupported M-code M{code}: expected M0, M2, M3, M5 or M30"),
                    ))
                }
            },
            'F' => {
                if feed.replace(w).is_some() {
                    return Err(err(w, "F given twice in one block".into()));
                }
                if !(w.value > 0.0 && w.value * MM_PER_INCH <= MAX_FEED_MM_MIN) {
                    return Err(err(
                        w,
                        format!(
                            "expected a feed > 0 and below {MAX_FEED_MM_MIN} mm/min, found F{}",
                            w.value
                        ),
                    ));
                }
            }
            'S' => {
                if w.value < 0.0 {
                    return Err(err(w, format!("spindle speed must be >= 0, found S{}", w.value)));
                }
            }
            letter => {
                let axis = machine.axis_index(letter.encode_utf8(&mut [0; 4]));
                let Some(i) = axis else {
                    return Err(err(
                        w,
                        format!(
                            "unsupported word '{letter}': expected G, M, F, S, N or an axis ({})",
                            machine.axis_names()
                        ),
                    ));
                };
                if axes[i].replace((w.value, w)).is_some() {
                    return Err(err(w, format!("{letter} given twice in one block")));
                }
            }
        }
    }
    // Execution order within a block, as RS274: units, feed, spindle, distance mode, motion,
    // then pause / end.
    if let Some(u) = units {
        state.inches = u.value == 20.0;
    }
    let scale = if state.inches { MM_PER_INCH } else { 1.0 };
    if let Some(f) = feed {
        state.feed_mm_min = Some(f.value * scale);
    }
    if let Some((on, _)) = spindle {
        items.push(Item::Spindle(on));
    }
    if let Some(d) = distance {
        state.relative = d.value == 91.0;
    }
    if let Some((m, _)) = motion {
        state.motion = Some(m);
    }
    if let Some(first) = axes.iter().flatten().map(|a| a.1).min_by_key(|w| w.column) {
        let feed = match state.motion {
            None => {
                return Err(err(
                    first,
                    "axis words without a motion mode: expected G0 or G1 first".into(),
                ))
            }
            Some(Motion::Rapid) => Feed::Rapid,
            Some(Motion::Linear) => match state.feed_mm_min {
                Some(f) => Feed::MmPerMin(f),
                None => {
                    let at = motion.map_or(first, |m| m.1);
                    return Err(err(at, "G1 needs a feed: expected an F word".into()));
                }
            },
        };
        let mm = |a: &Option<(f64, &Word)>| a.map(|(v, _)| v * scale);
        let target = if state.relative {
            Target::Relative(axes.iter().map(|a| mm(a).unwrap_or(0.0)).collect())
        } else {
            Target::Absolute(axes.iter().map(mm).collect())
        };
        items.push(Item::Move(MoveCmd { target, feed, source: Source::Gcode { line } }));
    }
    if pause {
        items.push(Item::Pause);
    }
    Ok(!end)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn letters(text: &str) -> Vec<(char, f64, usize)> {
        lex_line(text, 1).unwrap().iter().map(|w| (w.letter, w.value, w.column)).collect()
    }

    #[test]
    fn lexer_splits_words_and_drops_comments_and_line_numbers() {
        assert_eq!(
            letters("N7 g1(c)x-1.5 Y 2. ;x9"),
            [('G', 1.0, 4), ('X', -1.5, 9), ('Y', 2.0, 15)]
        );
        assert_eq!(letters("%"), []);
        assert_eq!(letters("(only a comment)"), []);
        assert_eq!(letters("G0X+.25"), [('G', 0.0, 1), ('X', 0.25, 3)]);
    }

    #[test]
    fn lexer_errors_point_at_the_number() {
        let e = lex_line("G1 X 1..2", 4).unwrap_err();
        assert_eq!(e.at, LineCol { line: 4, column: 6 });
        assert_eq!(e.to_string(), "line 4, column 6: expected a number after 'X', found \"1..2\"");
    }
}
