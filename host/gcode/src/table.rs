//! The table of supported words, for the README (a test checks the README against
//! [`markdown`], and runs every example below through the interpreter).

/// Whether a word is implemented.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    Yes,
    /// Valid rs274 that this front end refuses, and why.
    No(&'static str),
}

/// One row: the word, what it does, and a short program that uses it.
#[derive(Clone, Copy, Debug)]
pub struct Word {
    pub word: &'static str,
    pub meaning: &'static str,
    pub support: Support,
    /// A complete program using the word (checked by the tests).
    pub example: &'static str,
}

const fn yes(word: &'static str, meaning: &'static str, example: &'static str) -> Word {
    Word { word, meaning, support: Support::Yes, example }
}

const fn no(
    word: &'static str,
    meaning: &'static str,
    why: &'static str,
    example: &'static str,
) -> Word {
    Word { word, meaning, support: Support::No(why), example }
}

pub const WORDS: &[Word] = &[
    yes("G0", "rapid move", "G0 X1 Y2 Z3\nM2"),
    yes("G1", "feed move", "G1 X1 F100\nM2"),
    yes(
        "G2, G3",
        "arc clockwise / counterclockwise: centre (IJK) or R form, P turns, helical, full circles",
        "G1 X1 F100\nG2 X1 Y0 I-1 J0 P2 Z-1\nG3 X0 Y1 R1\nM2",
    ),
    yes("G4", "dwell P seconds", "G4 P0.5\nM2"),
    yes("G5", "cubic spline (NURBS_FEED)", "G1 F100\nG5 I1 J0 P-1 Q0 X2 Y0\nM2"),
    yes("G5.1", "quadratic spline (NURBS_FEED)", "G1 F100\nG5.1 I1 J1 X2 Y0\nM2"),
    yes(
        "G5.2, G5.3",
        "NURBS control points, end of NURBS",
        "G1 F100\nG5.2 X0 Y1 P1 L3\nX1 Y1 P1\nX1 Y0 P1\nG5.3\nM2",
    ),
    yes("G7, G8", "lathe diameter / radius mode", "G7 G0 X2\nG8\nM2"),
    yes("G10 L1, L10, L11", "tool table entry", "G10 L1 P2 Z1 R0.5\nM2"),
    yes(
        "G10 L2, L20",
        "coordinate system origin (L2 with R rotation)",
        "G10 L2 P1 X1 R30\nG10 L20 P2 X0\nM2",
    ),
    yes("G10 L0", "reload the tool table", "G10 L0\nM2"),
    yes("G17, G18, G19", "arc plane XY, XZ, YZ", "G18\nG19\nG17\nM2"),
    yes("G17.1, G18.1, G19.1", "UV, UW, VW planes (no arcs or cycles there)", "G17.1\nG17\nM2"),
    yes("G20, G21", "inches / millimetres", "G20\nG21\nM2"),
    yes("G28, G28.1", "go to / store the G28 position (#5161..#5166)", "G28.1\nG28 Z1\nM2"),
    yes("G30, G30.1", "go to / store the G30 position (#5181..#5186)", "G30.1\nG30\nM2"),
    yes("G33", "spindle-synchronised motion", "M3 S100\nG33 Z-1 K0.1\nM2"),
    yes("G33.1", "rigid tapping (RIGID_TAP)", "M3 S100\nG33.1 Z-1 K0.1\nM2"),
    yes(
        "G38.2..G38.5",
        "straight probe (STRAIGHT_PROBE); `run` drives each alone, the result in #5061..#5066, #5070",
        "G1 F10\nG38.2 Z-1\nM2",
    ),
    yes("G40", "cutter radius compensation off", "G40\nM2"),
    no(
        "G41, G42, G41.1, G42.1",
        "cutter radius compensation",
        "with a zero radius as rs274 does; a non-zero radius is refused: compensate in CAM",
        "G41.1 D1\nM2",
    ),
    yes(
        "G43, G43.1, G43.2, G49",
        "tool length offset (table, explicit, added, off)",
        "T1 M6\nG43 H1\nG43.1 Z1\nG49\nM2",
    ),
    yes("G52", "local coordinate offset", "G52 X1\nM2"),
    yes("G53", "move in machine coordinates", "G53 G0 X0\nM2"),
    yes("G54..G59.3", "coordinate systems 1..9", "G55\nG59.3\nG54\nM2"),
    yes(
        "G61, G61.1, G64",
        "exact path, exact stop, blending (P Q tolerances)",
        "G61\nG61.1\nG64 P0.01\nM2",
    ),
    no(
        "G70..G72.2",
        "lathe roughing cycles",
        "lathe profile cycles are not implemented",
        "G70\nM2",
    ),
    yes(
        "G73, G81..G89",
        "canned cycles: chip break, drill, dwell, peck, tap, bore, back bore, with L repeats",
        "G1 F100\nG81 X1 Z-1 R1 L2\nG83 X2 Z-1 R1 Q0.3\nG80\nM2",
    ),
    yes("G74", "left-hand tapping cycle", "M4 S100 G1 F10\nG74 X1 Z-1 R1\nM2"),
    no(
        "G76",
        "threading cycle",
        "the threading cycle is not implemented",
        "M3 S100\nG76 P0.1 Z-1 I-0.1 J0.01 K0.05\nM2",
    ),
    yes("G80", "cancel the motion mode", "G80\nM2"),
    yes("G90, G91", "absolute / incremental distances", "G91 G0 X1\nG90\nM2"),
    yes("G90.1, G91.1", "absolute / incremental arc centres", "G90.1\nG91.1\nM2"),
    yes(
        "G92, G92.1, G92.2, G92.3",
        "axis offsets (#5210..#5216)",
        "G92 X1\nG92.2\nG92.3\nG92.1\nM2",
    ),
    yes(
        "G93, G94, G95",
        "inverse time, units per minute, units per revolution feed",
        "G93 G1 X1 F2\nG94\nG95\nM2",
    ),
    yes("G96, G97", "constant surface speed / RPM", "G96 S100 D2000\nG97\nM2"),
    yes("G98, G99", "canned cycle retract to the start level / R plane", "G98\nG99\nM2"),
    yes("M0, M1", "program stop, optional stop", "M0\nM1\nM2"),
    yes("M2, M30", "program end (M30 with pallet shuttle)", "M30"),
    yes("M3, M4, M5", "spindle clockwise, counterclockwise, stop; S speed", "M3 S1000\nM4\nM5\nM2"),
    yes("M6, T", "tool change to the prepared tool", "T2 M6\nM2"),
    yes("M7, M8, M9", "mist, flood, coolant off", "M7\nM8\nM9\nM2"),
    yes("M19", "spindle orient (R angle, P direction, Q timeout)", "M19 R90 Q1\nM2"),
    yes(
        "M48..M53",
        "override switches (feed, speed, adaptive feed, feed hold)",
        "M49\nM48\nM50 P0\nM51 P1\nM52 P1\nM53 P0\nM2",
    ),
    yes("M60", "pallet shuttle and stop", "M60\nM2"),
    yes("M61", "set the current tool number (Q)", "M61 Q3\nM2"),
    yes(
        "M62..M65, M66, M67, M68",
        "digital and analog outputs, wait for an input",
        "M62 P1\nM63 P1\nM64 P2\nM65 P2\nM66 P0 L0\nM67 E0 Q1\nM68 E1 Q2\nM2",
    ),
    no(
        "M70..M73",
        "save / restore modal state",
        "modal state save and restore is not implemented",
        "M70\nM2",
    ),
    no("M98, M99", "Fanuc-style subprograms", "use O-word sub/call", "M98 P100\nM2"),
    yes("M100..M199", "user M-codes (refused as rs274 does without user programs)", "M2"),
    yes("F, S, T, N", "feed, spindle speed, tool, line number", "N10 G1 X1 F100 S200 T1\nM2"),
    yes(
        "#n, #<name>, #<_global>",
        "numbered and named parameters; all of a line's values read before its assignments",
        "#1=2 #<d>=[#1*2] #<_g>=#<d>\nG0 X#<_g>\nM2",
    ),
    yes(
        "[ ]",
        "expressions: + - * / MOD ** AND OR XOR EQ NE GT GE LT LE",
        "G0 X[1+2*3 MOD 4 ** 2] Y[1 GT 0 AND 2 LE 3]\nM2",
    ),
    yes(
        "functions",
        "ABS ACOS ASIN ATAN[a]/[b] COS EXP FIX FUP LN ROUND SIN SQRT TAN EXISTS (degrees)",
        "G0 X[ATAN[1]/[1]+SIN[30]+ROUND[1.5]+EXISTS[#<_x>]]\nM2",
    ),
    yes("@, ^", "polar coordinates (radius, angle) in G17", "G0 @1 ^45\nM2"),
    yes(
        "O sub/endsub/call/return",
        "subroutines with [arguments] in #1..#30, return values in #<_value>",
        "O100 sub\nG0 X#1\nO100 endsub [2]\nO100 call [3]\nM2",
    ),
    yes(
        "O if/elseif/else/endif",
        "conditionals",
        "O1 if [1]\nG0 X1\nO1 elseif [0]\nO1 else\nO1 endif\nM2",
    ),
    yes(
        "O while/endwhile, do/while, repeat/endrepeat, break, continue",
        "loops (each at most 10 000 000 times)",
        "#1=0\nO2 while [#1 LT 3]\n#1=[#1+1]\nO2 endwhile\nO3 repeat [2]\nO3 endrepeat\nM2",
    ),
    yes(
        "( ), ;, (msg,), (debug,), (log,)",
        "comments, operator messages, parameter printing",
        "(msg,hello)\n(debug,#<_x>)\n; note\nM2",
    ),
    yes("/, %", "block delete (off by default, as rs274), program delimiters", "%\n/G0 X1\nM2\n%"),
];

/// The table as Markdown (for README.md).
pub fn markdown() -> String {
    let mut s = String::from("| word | what it does | supported |\n|---|---|---|\n");
    for w in WORDS {
        let sup = match w.support {
            Support::Yes => "yes".to_string(),
            Support::No(why) => format!("no: {why}"),
        };
        s.push_str(&format!("| {} | {} | {} |\n", w.word, w.meaning, sup));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{check_all, source::SeekSource, Kind, Options, Severity};

    #[test]
    fn every_example_does_what_the_table_says() {
        for w in WORDS {
            let src = SeekSource::new(std::io::Cursor::new(w.example.as_bytes().to_vec()));
            let diags = check_all(src, "example.ngc", Options::strict());
            let errors: Vec<_> = diags.iter().filter(|d| d.severity == Severity::Error).collect();
            match w.support {
                Support::Yes => assert!(errors.is_empty(), "{}: {errors:?}", w.word),
                Support::No(_) => assert!(
                    errors.iter().any(|d| d.kind == Kind::Unsupported) || w.word.starts_with("G41"),
                    "{}: expected a refusal, got {errors:?}",
                    w.word
                ),
            }
        }
    }

    #[test]
    fn every_rs274_g_code_is_in_the_table() {
        let table = markdown();
        for &(code, _) in crate::modal::G_CODES {
            let name = crate::modal::g_name(code);
            let listed = table.contains(&name)
                || (810..=890).contains(&code)
                || (540..=593).contains(&code)
                || (382..=385).contains(&code)
                || (700..=722).contains(&code);
            assert!(listed, "{name} missing from the table");
        }
    }
}
