//! `motionctl grbl`'s capability commands (`$POLAR=`, `$TURN=`, `$WIRE=`; `$MILL=` refused on
//! a board without milling jobs): refusals name why, a job runs with `?` reporting its position,
//! `!` holds it in place and `~` resumes it, its summary matches the host model, Ctrl-X aborts
//! it, and the bridge's machine runs G-code again afterwards.

mod grbl_support;

use grbl_support::{bridge, tmp_dir, Bridge, Raw};
use std::path::Path;
use std::time::Duration;

/// Lines up to the answer of a line (`ok`, `error:N`), status reports skipped: those lines,
/// then the answer.
fn until_answer(r: &mut Raw) -> (Vec<String>, String) {
    let mut lines = Vec::new();
    loop {
        let l = r.line();
        if l == "ok" || l.starts_with("error:") {
            return (lines, l);
        }
        if !l.starts_with('<') {
            lines.push(l);
        }
    }
}

/// A bridge reading capability jobs from `dir`, and a raw session on it.
fn bridge_with_jobs(dir: &Path) -> (Bridge, Raw) {
    let jobs = dir.to_str().unwrap().to_string();
    let mut b = bridge(dir, &["--listen", "127.0.0.1:0", "--jobs", &jobs]);
    let r = Raw::connect(&mut b);
    (b, r)
}

/// `!` holds a running job where it is (the report's position unchanged for `wait`), `~`
/// resumes it.
fn hold_in_place(r: &mut Raw, wait: Duration) {
    r.send(b"!");
    let held = r.until_status(|st| st.starts_with("<Hold:0|"));
    std::thread::sleep(wait);
    let still = r.status();
    assert_eq!(held.split('|').nth(1), still.split('|').nth(1), "held in place: {still}");
    r.send(b"~");
}

#[test]
fn capability_jobs_run_from_dollar_commands_and_answer_real_time_bytes() {
    use motion::polar::playback::SizeScale;
    let dir = tmp_dir("caps");
    // An open arc of the built-in limacon stream (its first 40 blocks): about 4.6 s of board
    // time at speed 1, so a hold lands inside it.
    let arc =
        motionctl::polar::run::first_blocks(motion::polar::limacon_stream::BYTES, 40).unwrap();
    std::fs::write(dir.0.join("arc.bin"), &arc).unwrap();
    let scale = SizeScale::new(3, 2).unwrap();
    let model = motionctl::polar::run::model(&arc, motion::Rate::ONE, scale).unwrap();
    let (_b, mut r) = bridge_with_jobs(&dir.0);

    r.send(b"$\n");
    let help = r.line();
    assert!(help.contains(" $MILL=job $POLAR=stream $TURN=table $WIRE=job]"), "{help}");
    r.expect("ok");
    // Refusals name why: a capability the board lacks, a missing file, a bad argument.
    r.send(b"$MILL=case_a_milling.toml\n");
    r.expect("[MSG:the board runs no milling jobs (CAP_MILLING_JOB)]");
    r.expect("error:20");
    r.send(b"$POLAR=missing.bin\n");
    let m = r.line();
    assert!(m.starts_with("[MSG:reading ") && m.contains("missing.bin"), "{m}");
    r.expect("error:61");
    r.send(b"$POLAR=arc.bin 7\n");
    let m = r.line();
    assert!(m.contains("0.25..=2"), "{m}");
    r.expect("error:3");

    // The job runs; `?` reports Run with its position, `!` holds it where it is, `~` resumes.
    r.send(b"$POLAR=arc.bin 1 3:2\n");
    let st = r.until_status(|st| st.starts_with("<Run|") && !st.contains("MPos:0.000,0.000,"));
    assert!(st.contains("|Bf:15,"), "{st}");
    hold_in_place(&mut r, Duration::from_millis(300));
    let (msgs, answer) = until_answer(&mut r);
    assert_eq!(answer, "ok", "{msgs:?}");
    let events =
        format!("[MSG:POLAR arc.bin: {} of {} events in 40 blocks,", model.events, model.events);
    assert!(msgs.iter().any(|m| m.starts_with(&events)), "{msgs:?}");
    let end = msgs.iter().find(|m| m.starts_with("[MSG:POLAR end: ")).expect("an end line");
    let (board, host) = end.trim_end_matches(']').split_once("; host model ").unwrap();
    assert_eq!(board.trim_start_matches("[MSG:POLAR end: "), host, "{end}");
    assert!(msgs
        .iter()
        .any(|m| m == "[MSG:POLAR checks: ok (every event once, the host model's end)]"));

    // The bridge's machine is back: G-code runs on it.
    r.until_idle();
    r.send(b"G0 X5 Y2\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:5.000,2.000,0.000|"), "{st}");

    // Ctrl-X aborts a job: ALARM:3, then the welcome, as a reset during a cycle in grbl.
    r.send(b"$POLAR=arc.bin\n");
    r.until_status(|st| st.starts_with("<Run|"));
    r.send(b"\x18");
    let (mut lines, mut next) = (Vec::new(), r.line());
    while next.starts_with('<') {
        next = r.line();
    }
    lines.push(next);
    for _ in 0..4 {
        lines.push(r.line());
    }
    assert_eq!(
        lines,
        [
            "ALARM:3",
            "[MSG:arc.bin: aborted by the sender]",
            "",
            "Grbl 1.1h ['$' for help]",
            "[MSG:'$H'|'$X' to unlock]"
        ],
    );
    assert!(r.status().starts_with("<Alarm|"));
}

/// As [`until_answer`], asking `?` every 200 ms meanwhile (a job may run longer than a line's
/// wait): the lines that are neither reports nor the answer, and the answer (the report asked
/// for last read too).
fn until_answer_polling(r: &mut Raw) -> (Vec<String>, String) {
    let mut lines = Vec::new();
    loop {
        r.send(b"?");
        loop {
            let l = r.line();
            if l == "ok" || l.starts_with("error:") {
                let report = r.line();
                assert!(report.starts_with('<'), "{report}");
                return (lines, l);
            }
            if l.starts_with('<') {
                break;
            }
            lines.push(l);
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
fn turning_and_wire_jobs_run_from_dollar_commands() {
    let dir = tmp_dir("turn-wire");
    std::fs::write(dir.0.join("wire.toml"), "version = 1\nfr_mm2_per_min = 800\n").unwrap();
    let (_b, mut r) = bridge_with_jobs(&dir.0);

    // Bad arguments, a missing file, a board without Z-slide jobs: refused, nothing moves.
    r.send(b"$TURN=builtin 360 5\n");
    let m = r.line();
    assert!(m.starts_with("[MSG:$TURN= X range must be X0:X1"), "{m}");
    r.expect("error:3");
    r.send(b"$WIRE=wire.toml 3..1\n");
    let m = r.line();
    assert!(m.contains("FROM must be below TO"), "{m}");
    r.expect("error:3");
    r.send(b"$WIRE=missing.toml\n");
    let m = r.line();
    assert!(m.starts_with("[MSG:reading ") && m.contains("missing.toml"), "{m}");
    r.expect("error:61");
    r.send(b"$TURN=builtin 360 0:12.7 25.4\n");
    r.expect("[MSG:the board runs no turning jobs (CAP_TURNING_JOB)]");
    r.expect("error:20");

    // Two segments of the circle -> complex die as a wire job: `?` reports Run with X, Y, Z,
    // A (alpha), B (beta); `!` holds it where it is, `~` resumes; the summary against the
    // host model, then ok.
    let job = motionctl::wire::cli::wire_board_job(&dir.0.join("wire.toml"), Some(1..3)).unwrap();
    r.send(b"$WIRE=wire.toml 1..3\n");
    let st = r.until_status(|st| st.starts_with("<Run|"));
    assert_eq!(st.split('|').nth(1).unwrap().split(',').count(), 5, "{st}");
    hold_in_place(&mut r, Duration::from_millis(600));
    let (msgs, answer) = until_answer_polling(&mut r);
    assert_eq!(answer, "ok", "{msgs:?}");
    let head = format!(
        "[MSG:WIRE wire.toml: {} die, 2 of its {} segments at FR 800 mm^2/min (13.33 mm^2/s);",
        job.label, job.job_segments
    );
    assert!(msgs.iter().any(|m| m.starts_with(&head)), "{head} in {msgs:?}");
    let end = msgs.iter().find(|m| m.starts_with("[MSG:WIRE end: ")).expect("an end line");
    let (board, host) = end.trim_end_matches(']').split_once("; host model ").unwrap();
    assert_eq!(board.trim_start_matches("[MSG:WIRE end: "), host, "{end}");
    assert!(msgs.iter().any(|m| m.starts_with("[MSG:WIRE checks: ok")), "{msgs:?}");
    // The bridge's machine is back (where the job left its axes' steps).
    r.until_idle();
    r.send(b"G0 X1\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:1.000,"), "{st}");
}
