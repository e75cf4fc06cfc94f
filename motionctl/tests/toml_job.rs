//! TOML job files: the shipped example in full, and every error path naming its field.

use motion::protocol::{ProgramOutputs, SpindleDir};
use motionctl::convert::{self, ProgramItem};
use motionctl::job::{self, Feed, FeedAction, Item, Source, Target};

/// M3 alone, and everything off.
const CW: ProgramOutputs = ProgramOutputs { spindle: SpindleDir::Cw, mist: false, flood: false };
const OFF: ProgramOutputs = ProgramOutputs::OFF;

const SQUARE: &str = include_str!("../examples/square.toml");

#[test]
fn square_example_parses_in_full() {
    let job = job::parse_toml(SQUARE).unwrap();
    let m = &job.machine;
    assert_eq!(m.tick_hz, 100_000);
    assert_eq!(
        (m.timing.pulse_ns, m.timing.dir_setup_ns, m.timing.dir_hold_ns),
        (2_500, 5_000, 5_000)
    );
    assert_eq!(m.axis_names(), "X, Y, Z");
    let z = &m.axes[2];
    assert_eq!(
        (z.steps_per_mm, z.max_rate_mm_s, z.accel_mm_s2, z.junction_jerk_mm_s),
        (400.0, 25.0, 500.0, 2.0)
    );
    assert_eq!((z.min_mm, z.max_mm), (-50.0, 0.0));

    assert_eq!(job.items.len(), 12);
    let Item::Move(first) = &job.items[0] else { panic!("first item is a move") };
    assert_eq!(first.target, Target::Absolute(vec![Some(10.0), Some(10.0), None]));
    assert_eq!(first.feed, Feed::Rapid);
    assert_eq!(first.source, Source::Toml { index: 0 });
    assert_eq!(job.items[1], Item::Outputs(CW));
    // feed_mm_min is modal: moves[4] has none and keeps 1200.
    let Item::Move(side) = &job.items[4] else { panic!("moves[4] is a move") };
    assert_eq!(side.target, Target::Relative(vec![0.0, 40.0, 0.0]));
    assert_eq!(side.feed, Feed::MmPerMin(1_200.0));
    assert_eq!(job.items[8], Item::Pause);
    assert_eq!(job.items[10], Item::Outputs(OFF));
    assert_eq!(job.feed_commands.len(), 2);
    assert_eq!(job.feed_commands[0].at_s, 1.0);
    assert_eq!(job.feed_commands[0].action, FeedAction::Override(1.5));

    let p = convert::convert(&job).unwrap();
    assert_eq!(p.config.axis_count, 3);
    assert_eq!(p.config.axes[0].max_rate_hz, 20_000);
    assert_eq!(p.config.axes[2].accel_steps_per_s2, 200_000);
    assert_eq!(p.config.axes[0].junction_jerk_hz, 800);
    let moves: Vec<_> = p.moves().copied().collect();
    assert_eq!(moves.len(), 9);
    assert_eq!(moves[0].steps[..3], [800, 800, 0]);
    assert_eq!(moves[1].steps[..3], [0, 0, -800]);
    // 300 mm/min on Z at 400 steps/mm: 2000 steps/s.
    assert_eq!(moves[1].feed_hz, 2_000);
    assert_eq!(moves[2].steps[..3], [3_200, 0, 0]);
    // 1200 mm/min on X at 80 steps/mm: 1600 steps/s.
    assert_eq!(moves[2].feed_hz, 1_600);
    assert_eq!(p.final_steps[..3], [400, 400, 0]);
    assert_eq!(p.commands.len(), 2);
    assert_eq!(p.commands[0].0, 100_000);
    assert!(matches!(p.items[1], ProgramItem::Outputs(CW)));
}

/// Replaces `from` (which must occur) in the example and returns the error text.
fn error_after(from: &str, to: &str) -> String {
    assert!(SQUARE.contains(from), "{from:?} not in the example");
    let src = SQUARE.replacen(from, to, 1);
    match job::parse_toml(&src) {
        Err(e) => e.to_string(),
        Ok(j) => match convert::convert(&j) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{from:?} -> {to:?} was accepted"),
        },
    }
}

#[test]
fn every_error_names_its_field() {
    let cases: &[(&str, &str, &[&str])] = &[
        // Header.
        ("format = \"motion-job\"", "format = \"gcode\"", &["format: expected \"motion-job\""]),
        ("format = \"motion-job\"", "", &["format: missing"]),
        ("version = 1", "version = 2", &["version: unsupported version 2"]),
        ("version = 1", "version = \"1\"", &["version: unsupported version \"1\""]),
        // Syntax.
        ("pulse_ns = 2_500", "pulse_ns = 2_500 x", &["(line 9, column 12)"]),
        // Unknown fields anywhere.
        (
            "tick_hz = 100_000",
            "tick_hz = 100_000\nspeed = 1",
            &["machine.speed: unknown field `speed`", "(line 7, column 1)"],
        ),
        (
            "pulse_ns = 2_500",
            "pulse_ns = 2_500\npulse_us = 2",
            &["machine.timing.pulse_us: unknown field"],
        ),
        (
            "name = \"Y\"",
            "name = \"Y\"\nsteps_per_inch = 1",
            &["machine.axes[1].steps_per_inch: unknown field"],
        ),
        ("spindle = \"on\"", "spindle = \"on\"\nspeed = 100", &["moves[1].speed: unknown field"]),
        ("factor = 1.5", "factor = 1.5\nwhen = 2", &["feed_commands[0].when: unknown field"]),
        ("version = 1", "version = 1\nauthor = \"me\"", &["author: unknown field `author`"]),
        // Types and ranges, with positions.
        (
            "tick_hz = 100_000",
            "tick_hz = -1",
            &["machine.tick_hz: invalid value: integer `-1`", "(line 6, column 11)"],
        ),
        (
            "steps_per_mm = 80.0",
            "steps_per_mm = -80.0",
            &["machine.axes[0].steps_per_mm: must be > 0", "got -80", "(line 15, column 16)"],
        ),
        (
            "steps_per_mm = 80.0",
            "steps_per_mm = nan",
            &["machine.axes[0].steps_per_mm: must be a finite number"],
        ),
        (
            "max_rate_mm_s = 250.0",
            "max_rate_mm_s = inf",
            &["machine.axes[0].max_rate_mm_s: must be a finite number"],
        ),
        ("accel_mm_s2 = 500.0", "accel_mm_s2 = 0", &["machine.axes[2].accel_mm_s2: must be > 0"]),
        (
            "junction_jerk_mm_s = 2.0",
            "junction_jerk_mm_s = -2.0",
            &["machine.axes[2].junction_jerk_mm_s: must be >= 0"],
        ),
        ("max_mm = 300.0", "max_mm = 1e7", &["machine.axes[0].max_mm: must be within"]),
        ("max_mm = 300.0", "max_mm = -1.0", &["machine.axes[0].min_mm: must be below max_mm"]),
        ("name = \"Y\"", "name = \"x\"", &["machine.axes[1].name: axis name \"x\" is used twice"]),
        ("name = \"Y\"", "name = \"Y axis\"", &["machine.axes[1].name: must be letters"]),
        ("to = { Z = -2.0 }", "to = { Z = \"deep\" }", &["moves[2].to.Z: invalid type: string"]),
        (
            "to = { Z = -2.0 }",
            "to = { Q = -2.0 }",
            &["moves[2].to.Q: no such axis (axes: X, Y, Z)"],
        ),
        ("to = { Z = -2.0 }", "to = { Z = -2.0, z = 1.0 }", &["moves[2].to.z: axis given twice"]),
        (
            "to = { Z = -2.0 }",
            "to = { Z = -2.0 }\nby = { X = 1 }",
            &["moves[2]: needs exactly one of"],
        ),
        (
            "feed_mm_min = 300.0",
            "feed_mm_min = 0.0",
            &["moves[2].feed_mm_min: must be > 0", "(line 50, column 15)"],
        ),
        (
            "feed_mm_min = 300.0",
            "feed_mm_min = -inf",
            &["moves[2].feed_mm_min: must be a finite number"],
        ),
        ("feed_mm_min = 300.0", "", &["moves[2].feed_mm_min: missing"]),
        (
            "to = { Z = 0.0 }\nrapid = true",
            "to = { Z = 0.0 }\nrapid = true\nfeed_mm_min = 5",
            &["moves[9].rapid: a rapid move takes no feed_mm_min"],
        ),
        ("spindle = \"on\"", "spindle = \"fast\"", &["moves[1].spindle: unknown variant `fast`"]),
        (
            "spindle = \"on\"",
            "spindle = \"on\"\nrapid = true",
            &["moves[1]: `spindle`, `pause` and `dwell_s` entries take no"],
        ),
        ("pause = true", "pause = false", &["moves[8].pause: only `pause = true`"]),
        (
            "factor = 1.5",
            "factor = 2.5",
            &["feed_commands[0].factor: must be >= 0 and <= 2", "got 2.5"],
        ),
        ("factor = 1.5", "", &["feed_commands[0].factor: missing"]),
        ("at_s = 1.0", "at_s = -1.0", &["feed_commands[0].at_s: must be >= 0"]),
        (
            "action = \"override\"",
            "action = \"stop\"",
            &["feed_commands[0].action: unknown variant `stop`"],
        ),
        // Conversion to the firmware's config: errors name the TOML field.
        (
            "tick_hz = 100_000",
            "tick_hz = 1_000",
            &["machine.tick_hz: must be within 10 kHz..=500 kHz (is 1000)"],
        ),
        (
            "pulse_ns = 2_500",
            "pulse_ns = 250_000",
            &["machine.timing.pulse_ns: longer than 7 ticks (is 250000)"],
        ),
        (
            "max_rate_mm_s = 250.0 ",
            "max_rate_mm_s = 700.0 ",
            &["machine.axes[0].max_rate_mm_s: exceeds tick_hz", "(is 56000 steps/s)"],
        ),
        (
            "max_rate_mm_s = 25.0 ",
            "max_rate_mm_s = 0.001 ",
            &["machine.axes[2].max_rate_mm_s: 0.001 x steps_per_mm 400 = 0 steps"],
        ),
        // Soft limits name the move and the axis.
        (
            "by = { X = 40.0 }",
            "by = { X = 400.0 }",
            &["moves[3]: axis X target 410.0000 mm is above its soft limit max_mm = 300"],
        ),
        (
            "to = { Z = -2.0 }",
            "to = { Z = -60.0 }",
            &["moves[2]: axis Z target -60.0000 mm is below its soft limit min_mm = -50"],
        ),
    ];
    let mut failures = Vec::new();
    for (from, to, wants) in cases {
        let msg = error_after(from, to);
        assert!(!msg.contains('\n'), "one line: {msg}");
        for want in *wants {
            if !msg.contains(want) {
                failures.push(format!("{from:?} -> {to:?}: {msg:?} lacks {want:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn more_than_eight_feed_commands_are_refused() {
    let extra = "\n[[feed_commands]]\nat_s = 3.0\naction = \"hold\"\n".repeat(7);
    let job = job::parse_toml(&format!("{SQUARE}{extra}")).unwrap();
    let e = convert::convert(&job).unwrap_err().to_string();
    assert_eq!(e, "feed_commands: 9 given; the DDA schedules at most 8");
}

#[test]
fn machine_only_file_and_empty_program() {
    let m = include_str!("../examples/machine.toml");
    let job = job::parse_toml(m).unwrap();
    assert!(job.items.is_empty() && job.feed_commands.is_empty());
    assert_eq!(job::parse_machine_toml(m).unwrap(), job.machine);
    let e = job::parse_machine_toml(&m.replace("tick_hz = 100_000", "")).unwrap_err();
    assert!(e.to_string().starts_with("machine: missing field `tick_hz`"), "{e}");
}

#[test]
fn switch_debounce_is_the_machine_files_or_the_default() {
    let job = job::parse_toml(SQUARE).unwrap();
    assert_eq!(job.machine.switch_debounce_ms, job::DEFAULT_SWITCH_DEBOUNCE_MS);
    assert_eq!(job.machine.input_filter(), motion::InputFilterConfig::DEFAULT);
    let src =
        SQUARE.replacen("tick_hz = 100_000", "tick_hz = 100_000\nswitch_debounce_ms = 5.5", 1);
    let job = job::parse_toml(&src).unwrap();
    assert_eq!(job.machine.input_filter().switch_debounce_us, 5_500);
    // Through the config the board gets: 5.5 ms at 100 kHz.
    let program = convert::convert(&job).unwrap();
    let link_cfg = motionctl::runner::link_config(&job, &program);
    assert_eq!(link_cfg.inputs.debounce_ticks(link_cfg.machine.tick_hz), 550);
    assert!(link_cfg.validate().is_ok());
    let e = error_after("tick_hz = 100_000", "tick_hz = 100_000\nswitch_debounce_ms = 60");
    assert!(e.contains("machine.switch_debounce_ms") && e.contains("<= 50"), "{e}");
}
