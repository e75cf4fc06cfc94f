//! G-code through motion-gcode (the rs274ngc-grade front end): modes, units, events, comments,
//! and every error with file:line:column in rs274's words.

use motion::protocol::{ProgramOutputs, SpindleDir};
use motionctl::convert;
use motionctl::gcode;
use motionctl::job::{self, Feed, Item, Job, Machine, Source, Target};

/// M3 alone, and everything off.
const CW: ProgramOutputs = ProgramOutputs { spindle: SpindleDir::Cw, mist: false, flood: false };
const OFF: ProgramOutputs = ProgramOutputs::OFF;

fn machine() -> Machine {
    job::parse_machine_toml(include_str!("../examples/machine.toml")).unwrap()
}

fn items(src: &str) -> Vec<Item> {
    gcode::parse(src, &machine()).unwrap_or_else(|e| panic!("{src:?}: {e}"))
}

fn err(src: &str) -> String {
    match gcode::parse(src, &machine()) {
        Err(e) => e.to_string(),
        Ok(i) => panic!("{src:?} was accepted: {i:?}"),
    }
}

/// Final position in steps after running `src` through the converter.
fn final_steps(src: &str) -> [i64; 3] {
    let job = Job { machine: machine(), items: items(src), feed_commands: vec![] };
    let p = convert::convert(&job).unwrap_or_else(|e| panic!("{src:?}: {e}"));
    [p.final_steps[0], p.final_steps[1], p.final_steps[2]]
}

fn only_move(src: &str) -> (Target, Feed, Source) {
    match items(src).as_slice() {
        [Item::Move(m)] => (m.target.clone(), m.feed, m.source),
        other => panic!("{src:?}: {other:?}"),
    }
}

#[test]
fn part_example_parses_and_ends_where_written() {
    let src = include_str!("../examples/part.gcode");
    let items = items(src);
    let moves = items.iter().filter(|i| matches!(i, Item::Move(_))).count();
    assert_eq!(moves, 12);
    let events: Vec<&Item> = items.iter().filter(|i| !matches!(i, Item::Move(_))).collect();
    // M5, then M30's own spindle stop (rs274 stops the spindle at the program end).
    let stops = [&Item::Outputs(OFF), &Item::Outputs(OFF)];
    assert_eq!(events, [[&Item::Outputs(CW), &Item::Pause].as_slice(), &stops].concat());
    // N160 in inches: X1.5 Y1 at F40 in/min; Z stays where N130 put it.
    let Some(Item::Move(inch)) = items.iter().rev().nth(3) else { panic!("N160 is a move") };
    assert_eq!(inch.source, Source::Gcode { line: 18 });
    assert_eq!(inch.target, Target::Absolute(vec![Some(1.5 * 25.4), Some(25.4), Some(0.0)]));
    assert_eq!(inch.feed, Feed::MmPerMin(40.0 * 25.4));
    assert_eq!(final_steps(src), [800, 800, 0]);
}

#[test]
fn absolute_and_relative_modes() {
    assert_eq!(final_steps("G0 X10 Y20\nG91\nG1 X1 F100\nX1 Y-5"), [960, 1200, 0]);
    assert_eq!(final_steps("G91 G0 X10\nG90 G0 X2"), [160, 0, 0]);
    // Absolute is the default; the interpreter knows every axis, so a move names them all
    // (unnamed ones where they are), and incremental moves arrive resolved.
    let y3 = Target::Absolute(vec![Some(0.0), Some(3.0), Some(0.0)]);
    assert_eq!(only_move("G0 Y3").0, y3);
    assert_eq!(only_move("G91 G0 Y3").0, y3);
    // Motion mode is modal, and G0 is rapid whatever F says.
    let it = items("G1 X1 F300\nX2\nG0 X3\nX4");
    let feeds: Vec<Feed> = it
        .iter()
        .map(|i| match i {
            Item::Move(m) => m.feed,
            _ => panic!(),
        })
        .collect();
    assert_eq!(feeds, [Feed::MmPerMin(300.0), Feed::MmPerMin(300.0), Feed::Rapid, Feed::Rapid]);
}

#[test]
fn inches_convert_to_steps_exactly_within_rounding() {
    assert_eq!(final_steps("G20 G0 X1 Y0.5 Z-0.01"), [2_032, 1_016, -102]);
    // Every 0.0001 in step from 0 to 0.2 in: 0.0001 in = 0.2032 steps at 80 steps/mm, never a tie.
    for k in 0..2_000i64 {
        let x_in = format!("{}.{:04}", k / 10_000, k % 10_000);
        let exact = (k * 2_032 + 5_000).div_euclid(10_000);
        assert_eq!(final_steps(&format!("G20 G0 X{x_in}"))[0], exact, "X{x_in} in");
    }
    // Units switch back and forth; F follows the units of its block.
    assert_eq!(final_steps("G20 G0 X1\nG21 G91 G0 X1\nG20 X1"), [2032 + 80 + 2032, 0, 0]);
    assert_eq!(only_move("G20 G1 X1 F10").1, Feed::MmPerMin(254.0));
    assert_eq!(only_move("G1 F10 G20 X1").1, Feed::MmPerMin(254.0));
    // An inch feed becomes the exact step rate: 40 in/min on X = 1016 mm/min = 1354.67 steps/s.
    let p = convert::convert(&Job {
        machine: machine(),
        items: items("G20 G1 X1 F40"),
        feed_commands: vec![],
    })
    .unwrap();
    assert_eq!(p.moves().next().unwrap().feed_hz, 1_355);
}

#[test]
fn comments_line_numbers_case_and_spacing() {
    let (t, f, s) = only_move("n5 g1 x 10 ( a comment ) y-2.5 F 600 ; tail (not a comment)");
    assert_eq!(t, Target::Absolute(vec![Some(10.0), Some(-2.5), Some(0.0)]));
    assert_eq!(f, Feed::MmPerMin(600.0));
    assert_eq!(s, Source::Gcode { line: 1 });
    let (t, ..) = only_move("%\n(header)\n\n; note\n  \tG00X+1.5Y-.5Z-0.\r\n%\n");
    assert_eq!(t, Target::Absolute(vec![Some(1.5), Some(-0.5), Some(-0.0)]));
    assert_eq!(only_move("\n\nG0 X1").2, Source::Gcode { line: 3 });
}

#[test]
fn spindle_pause_and_end_are_items_in_order() {
    assert_eq!(
        items("M3\nG0 X1\nM0\nM5").iter().filter(|i| !matches!(i, Item::Move(_))).count(),
        3
    );
    // Within one block: spindle before motion, pause after it.
    let it = items("G1 X1 F100 M0 M3 S1000");
    assert!(matches!(it.as_slice(), [Item::Outputs(CW), Item::Move(_), Item::Pause]));
    // M30 ends the program (stopping the spindle): nothing after it is read.
    assert_eq!(items("G0 X1\nM30\nthis is not G-code").len(), 2);
    assert_eq!(items("M2\nG0 X1"), [Item::Outputs(OFF)]);
    // A tool change stops the spindle and pauses the job for the operator.
    assert_eq!(items("T1 M6"), [Item::Outputs(OFF), Item::Pause]);
    // A motion word without axes is rs274's zero-length move: it moves nothing.
    assert_eq!(final_steps("G0\nG1 F100\nG90 G21"), [0, 0, 0]);
}

#[test]
fn spindle_and_coolant_words_become_the_whole_output_state_in_order() {
    let events: Vec<ProgramOutputs> =
        items("M3 S1000\nM8\nG0 X1\nM7\nM9\nM4\nG0 X2\nM5\nM7 M3\nM2")
            .iter()
            .filter_map(|i| match i {
                Item::Outputs(o) => Some(*o),
                _ => None,
            })
            .collect();
    let o = |spindle, mist, flood| ProgramOutputs { spindle, mist, flood };
    use SpindleDir::{Ccw, Cw, Off};
    assert_eq!(
        events,
        [
            o(Cw, false, false),
            o(Cw, false, true),
            o(Cw, true, true),
            // M9 is two calls: mist off, then flood off.
            o(Cw, false, true),
            o(Cw, false, false),
            o(Ccw, false, false),
            o(Off, false, false),
            // One block: the spindle before the coolant (rs274's order), each a switch.
            o(Cw, false, false),
            o(Cw, true, false),
            // M2 stops the spindle, then the coolant that is on.
            o(Off, true, false),
            o(Off, false, false),
        ]
    );
}

#[test]
fn errors_carry_line_column_and_what_was_expected() {
    let cases = [
        ("G1 X", "gcode:1:4: error: No characters found in reading real value (word X)"),
        ("G0 X1\nG1 XQ F1", "gcode:2:4: error: Unknown word where unary operation could be"),
        ("G0 X-", "gcode:1:4: error: bad number format (conversion failed) parsing '-'"),
        ("G0 X1.2.3", "gcode:1:4: error: bad number format (trailing characters) parsing '1.2.3'"),
        ("G0 X1 @", "gcode:1:7: error: No characters found in reading real value (word @)"),
        ("G0 (open X1", "gcode:1:4: error: Unclosed comment found"),
        ("G2 X1 Y1 F100", "gcode:1:1: error: R i j k words all missing for arc (word G2)"),
        ("G1.5 X1", "gcode:1:1: error: Unknown g code used (word G1.5)"),
        ("G0 G1 X1", "gcode:1:4: error: Two g codes used from same modal group (word G1)"),
        ("G20 G21", "gcode:1:5: error: Two g codes used from same modal group (word G21)"),
        ("M3 M5", "gcode:1:4: error: Two m codes used from same modal group (word M5)"),
        ("G1 X1", "gcode:1:1: error: Cannot do g1 with zero feed rate (word G1)"),
        ("G1 F100\nG0 X1\nG1 F0 X2", "gcode:3:1: error: Cannot do g1 with zero feed rate"),
        ("X5", "gcode:1:1: error: Cannot use axis values without a g code that uses them"),
        ("G0 X1 X2", "gcode:1:7: error: Multiple x words on one line (word X)"),
        ("G1 F100 X1 F200", "gcode:1:12: error: Multiple f words on one line (word F)"),
        ("G0 X1 N10", "gcode:1:7: error: Bad character 'n' used (word N)"),
        ("M3 S-1", "gcode:1:4: error: Negative spindle speed used (word S-1)"),
        ("%\n(ok)\n  G0 X1 %", "gcode:3:9: error: Bad character '%' used"),
        // What this machine or board cannot do, named with its line.
        ("G0 A1", "gcode:1:1: error: moves A to 1.0000 but the machine has no A axis"),
    ];
    let mut failures = Vec::new();
    for (src, want) in cases {
        let got = err(src);
        if !got.contains(want) {
            failures.push(format!("{src:?}: got {got:?}, want {want:?}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_probe_word_is_one_probe_item_at_the_programmed_target() {
    let items = items("G21 G90 F100\nG0 X1\nG38.3 X5 Y2");
    let Some(Item::Probe { kind, mv }) = items.last() else { panic!("{items:?}") };
    assert_eq!(*kind, motion::machine::ProbeKind::Toward);
    assert_eq!(mv.target, Target::Absolute(vec![Some(5.0), Some(2.0), Some(0.0)]));
    assert_eq!(mv.feed, Feed::MmPerMin(100.0));
    assert_eq!(mv.source, Source::Gcode { line: 3 });
}

#[test]
fn soft_limit_error_names_the_line_and_axis() {
    let job = Job {
        machine: machine(),
        items: items("G0 X10\nG91\nG1 Z-30 F100\nZ-30"),
        feed_commands: vec![],
    };
    let e = convert::convert(&job).unwrap_err().to_string();
    assert_eq!(e, "line 4: axis Z target -60.0000 mm is below its soft limit min_mm = -50");
    // The start (0, inside the limits) is not a move; X0 with min_mm 0 is fine.
    assert!(convert::convert(&Job {
        machine: machine(),
        items: items("G0 X0 Y0\nG0 X-0.001"),
        feed_commands: vec![],
    })
    .unwrap_err()
    .to_string()
    .starts_with("line 2: axis X target -0.0010 mm is below"));
}

/// The chords of a full circle of radius 10 mm (G17, centre at X10 Y0), cut with the machine's
/// `arc_tolerance_mm`: how many, and how far each chord's midpoint strays inside the circle.
fn circle_chords(tolerance_mm: Option<f64>) -> (usize, f64) {
    let mut m = machine();
    if let Some(t) = tolerance_mm {
        m.arc_tolerance_mm = t;
    }
    let src = "G21 G90 G17 G1 X0 Y0 F600\nG2 X0 Y0 I10 J0\n";
    let items = gcode::parse(src, &m).unwrap();
    let pts: Vec<(f64, f64)> = items
        .iter()
        .filter_map(|i| match i {
            Item::Move(mv) => match &mv.target {
                Target::Absolute(t) => Some((t[0]?, t[1]?)),
                _ => None,
            },
            _ => None,
        })
        .collect();
    let mut worst: f64 = 0.0;
    for w in pts.windows(2) {
        let mid = ((w[0].0 + w[1].0) / 2.0, (w[0].1 + w[1].1) / 2.0);
        worst = worst.max(10.0 - ((mid.0 - 10.0).powi(2) + mid.1.powi(2)).sqrt());
    }
    (pts.len() - 1, worst)
}

#[test]
fn arcs_are_cut_within_the_machines_arc_tolerance() {
    assert_eq!(machine().arc_tolerance_mm, job::DEFAULT_ARC_TOLERANCE_MM);
    let (fine_n, fine_err) = circle_chords(None);
    let (coarse_n, coarse_err) = circle_chords(Some(0.05));
    assert!(fine_err <= 0.002 + 1e-9 && coarse_err <= 0.05 + 1e-9, "{fine_err} {coarse_err}");
    // The sagitta of a chord grows with its square: 25 times the tolerance, 5 times fewer chords.
    let ratio = fine_n as f64 / coarse_n as f64;
    assert!((4.5..=5.5).contains(&ratio), "{fine_n} chords vs {coarse_n}");
    let e = job::parse_machine_toml(&include_str!("../examples/machine.toml").replacen(
        "tick_hz",
        "arc_tolerance_mm = 2\ntick_hz",
        1,
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("machine.arc_tolerance_mm") && e.contains("<= 1"), "{e}");
}
