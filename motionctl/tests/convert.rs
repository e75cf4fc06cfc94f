//! mm -> steps: absolute rounding without drift, feeds in step space, rapids, limits.

use motion::dda::Command;
use motion::protocol::{ProgramOutputs, SpindleDir};
use motion::Rate;
use motionctl::convert::{self, feed_hz, rapid_feed_hz, ProgramItem};
use motionctl::job::{
    self, Feed, FeedAction, FeedCommand, Item, Job, Machine, MoveCmd, Source, Target,
};

/// M3 alone.
const CW: ProgramOutputs = ProgramOutputs { spindle: SpindleDir::Cw, mist: false, flood: false };

fn machine() -> Machine {
    job::parse_machine_toml(include_str!("../examples/machine.toml")).unwrap()
}

fn relative(index: usize, by_mm: [f64; 3], feed: Feed) -> Item {
    Item::Move(MoveCmd {
        target: Target::Relative(by_mm.to_vec()),
        feed,
        source: Source::Toml { index },
    })
}

fn job(items: Vec<Item>) -> Job {
    Job { machine: machine(), items, feed_commands: vec![] }
}

#[test]
fn absolute_rounding_does_not_drift_over_10_000_small_moves() {
    // 0.0123 mm = 0.984 steps on X, 0.0037 mm = 0.296 steps on Y, -0.0011 mm = -0.44 steps on Z:
    // rounding each move alone would give 10 000, 0 and 0 steps.
    let n = 10_000;
    let items =
        (0..n).map(|i| relative(i, [0.0123, 0.0037, -0.0011], Feed::MmPerMin(600.0))).collect();
    let p = convert::convert(&job(items)).unwrap();
    let expected = [
        (123.0f64 * 80.0).round() as i64,
        (37.0f64 * 80.0).round() as i64,
        (-11.0f64 * 400.0).round() as i64,
    ];
    assert_eq!(expected, [9_840, 2_960, -4_400]);
    assert_eq!(p.final_steps[..3], expected);
    // The moves themselves add up to it, and none is lost to rounding to zero.
    let mut sum = [0i64; 3];
    for mv in p.moves() {
        for (s, &d) in sum.iter_mut().zip(&mv.steps) {
            *s += d as i64;
        }
        assert!(mv.steps[0] == 0 || mv.steps[0] == 1);
    }
    assert_eq!(sum, expected);
    assert_eq!(p.moves().count() + p.skipped_moves, n);
}

#[test]
fn same_no_drift_through_gcode_relative_mode() {
    let src: String = std::iter::once("G91 G1 F300\n")
        .chain(std::iter::repeat_n("X0.0123 Z-0.0011\n", 10_000))
        .collect();
    let m = machine();
    let items = motionctl::gcode::parse(&src, &m).unwrap();
    let p = convert::convert(&job(items)).unwrap();
    assert_eq!(p.final_steps[..3], [9_840, 0, -4_400]);
}

#[test]
fn feed_is_step_space_path_speed() {
    // X 30 mm at 80 steps/mm, Y 40 mm at 100 steps/mm: 50 mm at 600 mm/min takes 5 s, and the
    // step vector is |(2400, 4000)| = 4664.76 steps long: 932.95 steps/s.
    let spm = [80.0, 100.0, 400.0];
    assert_eq!(feed_hz(&[2_400, 4_000, 0, 0, 0, 0], &spm, 600.0), 933);
    // One axis: feed / 60 * steps_per_mm.
    assert_eq!(feed_hz(&[-800, 0, 0, 0, 0, 0], &spm, 1_200.0), 1_600);
    assert_eq!(feed_hz(&[0, 0, 5, 0, 0, 0], &spm, 30.0), 200);
    // Never zero.
    assert_eq!(feed_hz(&[1, 0, 0, 0, 0, 0], &spm, 0.01), 1);
}

#[test]
fn rapid_runs_at_the_limiting_axis_max_rate() {
    let cfg = convert::machine_config(&machine()).unwrap();
    assert_eq!(rapid_feed_hz(&[500, 0, 0, 0, 0, 0], &cfg), 20_000);
    // Z (10 000 steps/s) limits a diagonal X/Z move of 1000 / 1000 steps: 10 000 * sqrt(2).
    assert_eq!(rapid_feed_hz(&[1_000, 0, -1_000, 0, 0, 0], &cfg), 14_142);
    // X and Y equal: both at max.
    assert_eq!(rapid_feed_hz(&[300, 300, 0, 0, 0, 0], &cfg), 28_284);
    let p = convert::convert(&job(vec![relative(0, [1.0, 0.0, 0.0], Feed::Rapid)])).unwrap();
    assert_eq!(p.moves().next().unwrap().feed_hz, 20_000);
}

#[test]
fn machine_config_rounds_limits_down() {
    let mut m = machine();
    m.axes[0].steps_per_mm = 78.7402;
    m.axes[0].max_rate_mm_s = 100.0;
    m.axes[0].accel_mm_s2 = 1_000.0;
    m.axes[0].junction_jerk_mm_s = 0.0;
    let cfg = convert::machine_config(&m).unwrap();
    assert_eq!(cfg.axes[0].max_rate_hz, 7_874);
    assert_eq!(cfg.axes[0].accel_steps_per_s2, 78_740);
    assert_eq!(cfg.axes[0].junction_jerk_hz, 0);
    assert_eq!(cfg.axis_count, 3);
    assert_eq!(cfg.axes[3], motion::AxisLimits::UNUSED);
}

#[test]
fn zero_step_moves_are_skipped_and_events_kept_in_order() {
    let items = vec![
        relative(0, [0.001, 0.0, 0.0], Feed::MmPerMin(100.0)),
        Item::Outputs(CW),
        relative(2, [0.01, 0.0, 0.0], Feed::MmPerMin(100.0)),
        Item::Pause,
        relative(4, [0.0, 0.0, 0.0], Feed::Rapid),
    ];
    let p = convert::convert(&job(items)).unwrap();
    assert_eq!(p.skipped_moves, 2);
    assert!(matches!(
        p.items.as_slice(),
        [
            ProgramItem::Outputs(CW),
            ProgramItem::Move { source: Source::Toml { index: 2 }, .. },
            ProgramItem::Pause
        ]
    ));
    // 0.011 mm in all: round(0.88) = 1 step.
    assert_eq!(p.final_steps[0], 1);
}

#[test]
fn a_move_longer_than_an_i32_of_steps_is_refused() {
    let mut m = machine();
    m.axes[0].steps_per_mm = 1.0e6;
    m.axes[0].max_rate_mm_s = 0.01;
    m.axes[0].accel_mm_s2 = 1.0;
    m.axes[0].max_mm = 5_000.0;
    let mut j = job(vec![relative(7, [3_000.0, 0.0, 0.0], Feed::Rapid)]);
    j.machine = m;
    let e = convert::convert(&j).unwrap_err().to_string();
    assert!(
        e.starts_with("moves[7]: axis X moves 3000000000 steps, more than one move can hold"),
        "{e}"
    );
}

#[test]
fn feed_commands_become_tick_stamped_dda_commands() {
    let mut j = job(vec![]);
    j.feed_commands = vec![
        FeedCommand { at_s: 0.25, action: FeedAction::Override(0.5) },
        FeedCommand { at_s: 1.0, action: FeedAction::Hold },
        FeedCommand { at_s: 1.5, action: FeedAction::Resume },
    ];
    let p = convert::convert(&j).unwrap();
    assert_eq!(
        p.commands,
        [
            (25_000, Command::SetOverride(Rate::lit("0.5"))),
            (100_000, Command::Hold),
            (150_000, Command::Resume)
        ]
    );
}
