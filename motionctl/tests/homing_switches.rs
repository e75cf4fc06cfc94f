//! The machine file's homing switches reach the board before it homes, the same switches sent
//! again keep the board homed, and a machine without switches is homed where it stands only when
//! the operator vouches for it (`runner::ZeroHere`).

use motionctl::convert;
use motionctl::job::{self, Job};
use motionctl::plan::{self, Output};
use motionctl::runner::{self, RunOptions, ZeroHere};
use motionctl::sim_board::{SimBoard, SIM_CAPACITY};

const SQUARE: &str = include_str!("../examples/square.toml");

/// The bench machine's square job, its Z homed first on its max switch at 0 mm, then X on its
/// min switch at 0 mm.
fn with_switches() -> String {
    let x = "max_mm = 300.0\n";
    let z = "max_mm = 0.0\n";
    assert!(SQUARE.contains(x) && SQUARE.contains(z));
    SQUARE
        .replace(
            x,
            "max_mm = 300.0\nhome = { switch = \"min\", at_mm = 0.0, search_mm_s = 20.0, \
             latch_mm_s = 2.0 }\n",
        )
        .replace(
            z,
            "max_mm = 0.0\nhome = { switch = \"max\", at_mm = 0.0, search_mm_s = 10.0, \
             latch_mm_s = 1.0, backoff_mm = 1.0 }\n",
        )
        .replace("[machine]\n", "[machine]\nhome_order = [\"Z\", \"X\"]\n")
}

fn run(src: &str, board: &mut SimBoard, o: RunOptions) -> Result<(), String> {
    let job: Job = job::parse_toml(src).map_err(|e| e.to_string())?;
    let program = convert::convert(&job).unwrap();
    let outputs: Vec<Output> = plan::Stream::new(&program).collect::<Result<_, _>>().unwrap();
    let expected = program.final_steps;
    let r =
        runner::run(board, &job, &program, &outputs, &expected, o).map_err(|e| e.to_string())?;
    assert!(r.ok(), "{:?}", r.problems);
    Ok(())
}

fn opts(zero_here: ZeroHere) -> RunOptions {
    RunOptions { home: true, zero_here, ..RunOptions::default() }
}

#[test]
fn the_machine_files_switches_reach_the_board_and_the_same_again_keeps_it_homed() {
    let src = with_switches();
    let job = job::parse_toml(&src).unwrap();
    let homing = job.machine.homing();
    assert_eq!((homing.count, &homing.order[..2]), (2, &[2u8, 0][..]));
    let z = homing.axes[2];
    assert!(z.toward_max);
    assert_eq!((z.search_hz, z.latch_hz, z.backoff_steps), (4_000, 400, 400));
    // The Z search defaults to 1.5 travels of its 50 mm.
    assert_eq!(z.max_travel_steps, 30_000);

    let mut board = SimBoard::new(SIM_CAPACITY, 100.0);
    // A machine with switches homes on them: nobody is asked about the zero.
    run(&src, &mut board, opts(ZeroHere::Refuse)).unwrap();
    assert_eq!(board.target.homing, homing);
    assert!(board.target.homed);
    // The same switches again: the board stays homed, so a run that may not home goes on.
    run(&src, &mut board, RunOptions { home: false, ..opts(ZeroHere::Refuse) }).unwrap();
    assert!(board.target.homed);
}

#[test]
fn a_machine_without_switches_homes_where_it_stands_only_when_the_operator_says_so() {
    let mut board = SimBoard::new(SIM_CAPACITY, 100.0);
    let e = run(SQUARE, &mut board, opts(ZeroHere::Refuse)).unwrap_err();
    assert!(e.contains("no homing switches") && e.contains("--yes"), "{e}");
    assert!(!board.target.homed, "not homed without the operator's word");
    assert_eq!(board.target.segments_done, 0, "nothing ran");
    run(SQUARE, &mut board, opts(ZeroHere::Confirmed)).unwrap();
    assert!(board.target.homed);
}

#[test]
fn switches_given_to_a_board_homed_without_them_make_it_home_again() {
    let mut board = SimBoard::new(SIM_CAPACITY, 100.0);
    run(SQUARE, &mut board, opts(ZeroHere::Confirmed)).unwrap();
    let e = run(&with_switches(), &mut board, RunOptions { home: false, ..opts(ZeroHere::Refuse) })
        .unwrap_err();
    assert!(e.contains("not homed"), "{e}");
}

#[test]
fn bad_homing_entries_are_refused_naming_the_field() {
    let cases = [
        (
            "at_mm = 0.0, search_mm_s = 20.0",
            "at_mm = 400.0, search_mm_s = 20.0",
            "axes[0].home.at_mm",
        ),
        ("search_mm_s = 20.0", "search_mm_s = 900.0", "axes[0].home.search_mm_s"),
        ("switch = \"min\"", "switch = \"left\"", "axes[0].home.switch"),
        ("home_order = [\"Z\", \"X\"]", "home_order = [\"Z\", \"Y\"]", "machine.home_order"),
        ("home_order = [\"Z\", \"X\"]", "home_order = [\"Z\"]", "machine.home_order"),
    ];
    let src = with_switches();
    for (from, to, field) in cases {
        assert!(src.contains(from), "{from}");
        let e = job::parse_toml(&src.replacen(from, to, 1)).unwrap_err().to_string();
        assert!(e.contains(field), "{to}: {e}");
    }
}
