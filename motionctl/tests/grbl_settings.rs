//! `motionctl grbl`'s stored state:
//! - `$N=V` on the machine's values reconfigures the board (steps/mm change the step count of a
//!   move, a travel change moves the board's own soft limit), survives a restart of the bridge
//!   through the overlay beside the machine file, and `$RST=$` restores the machine file's.
//! - `$N0`/`$N1` startup lines run after a soft reset and on connect (`>LINE:ok`), survive a
//!   restart, and an alarm from one is answered in its place.

mod grbl_support;

use grbl_support::{bridge, manifest, tmp_dir, Raw};

#[test]
fn settings_reconfigure_the_board_and_outlive_the_bridge() {
    let dir = tmp_dir("settings");
    let machine = dir.0.join("machine.toml");
    let overlay = dir.0.join("machine.grbl.toml");
    let new_machine = "[MSG:the board has the new config and must be homed: '$H' to home]";
    {
        let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
        let mut r = Raw::connect(&mut b);
        // Values the machine file refuses are refused with its words, and change nothing.
        r.send(b"$100=0\n");
        r.expect("[MSG:$100=0: machine.axes[0].steps_per_mm: must be > 0 and <= 1000000, got 0]");
        r.expect("error:52");
        r.send(b"$26=100\n");
        let m = r.line();
        assert!(m.starts_with("[MSG:$26=100: machine.switch_debounce_ms: must be"), "{m}");
        r.expect("error:52");
        assert!(!overlay.exists());

        // Steps per mm: a new config on the board (which loses its homing).
        r.send(b"$100=7.77\n");
        r.expect(new_machine);
        r.expect("ok");
        assert!(r.status().starts_with("<Alarm|"));
        r.send(b"G0 X10\n");
        r.expect("error:9");
        r.send(b"$H\n");
        r.expect("ok");
        // 10 mm at 7.77 steps/mm is 78 steps: 10.039 mm.
        r.send(b"G0 X10\n");
        r.expect("ok");
        let st = r.until_idle();
        assert!(st.starts_with("<Idle|MPos:10.039,0.000,0.000|"), "{st}");

        // Travel and max rate; with the bridge's soft limits off ($20=0), the board's own
        // limits (from the new travel: X -500..20 mm) refuse a move they allowed before.
        r.send(b"$20=0\n$130=520\n");
        r.expect("ok");
        r.expect(new_machine);
        r.expect("ok");
        r.send(b"$110=600\n$H\n");
        for want in [new_machine, "ok", "ok"] {
            r.expect(want);
        }
        r.send(b"G0 X30\n");
        r.expect("ok");
        r.expect("ALARM:3");
        r.expect("[MSG:the board refused queued motion]");
        r.send(b"$X\n");
        r.expect("[MSG:Caution: Unlocked]");
        r.expect("ok");
        let s = r.settings();
        for want in ["$20=0", "$100=7.770", "$110=600.000", "$130=520.000", "$101=80.000"] {
            assert!(s.iter().any(|l| l == want), "{want} missing: {s:?}");
        }
    }
    // The machine file is untouched; the overlay beside it has the settings.
    assert_eq!(
        std::fs::read_to_string(&machine).unwrap(),
        std::fs::read_to_string(manifest().join("examples/corpus-machine.toml")).unwrap()
    );
    let text = std::fs::read_to_string(&overlay).unwrap();
    assert!(text.contains("100 = 7.77"), "{text}");

    // A new bridge reads them back and configures the board with them.
    let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
    let mut r = Raw::connect(&mut b);
    let s = r.settings();
    for want in ["$20=0", "$100=7.770", "$110=600.000", "$130=520.000"] {
        assert!(s.iter().any(|l| l == want), "{want} missing after a restart: {s:?}");
    }
    r.send(b"G0 X10\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:10.039,0.000,0.000|"), "{st}");
    r.send(b"G0 X30\n");
    r.expect("ok");
    r.expect("ALARM:3");
    r.expect("[MSG:the board refused queued motion]");
    r.send(b"$X\n");
    r.expect("[MSG:Caution: Unlocked]");
    r.expect("ok");

    // $RST=$: the machine file's values, on the board too; the overlay goes.
    r.send(b"$RST=$\n");
    r.expect(new_machine);
    r.expect("ok");
    r.send(b"$H\n");
    r.expect("ok");
    let s = r.settings();
    for want in ["$20=1", "$100=80.000", "$110=15000.000", "$130=1000.000"] {
        assert!(s.iter().any(|l| l == want), "{want} missing after $RST=$: {s:?}");
    }
    assert!(!overlay.exists(), "{}", std::fs::read_to_string(&overlay).unwrap_or_default());
    r.send(b"G0 X30\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:30.000,0.000,0.000|"), "{st}");
}

#[test]
fn startup_lines_run_after_a_reset_and_a_restart() {
    let dir = tmp_dir("startup");
    {
        let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
        let mut r = Raw::connect(&mut b);
        // A bad line is refused when stored, with the interpreter's words.
        r.send(b"$N1=G1 X1..2\n");
        let m = r.line();
        assert!(m.starts_with("[MSG:$N1: "), "{m}");
        r.expect("error:2");
        r.send(b"$N0=G20\n$N1=G0 X2\n$N\n");
        for want in ["ok", "ok", "$N0=G20", "$N1=G0 X2", "ok"] {
            r.expect(want);
        }
        assert_eq!(r.status().split('|').nth(1), Some("MPos:0.000,0.000,0.000"), "stored only");
        // A soft reset runs them, in order, each answered as grbl answers it.
        r.send(b"\x18");
        for want in ["", "Grbl 1.1h ['$' for help]", ">G20:ok", ">G0 X2:ok"] {
            r.expect(want);
        }
        let st = r.until_idle();
        assert!(st.starts_with("<Idle|MPos:50.800,0.000,0.000|"), "2 inches: {st}");
        r.send(b"$G\n");
        let gc = r.line();
        assert!(gc.contains(" G20 "), "{gc}");
        r.expect("ok");
    }
    // Kept across a restart: the connect's welcome runs them.
    let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
    let mut r = Raw::connect(&mut b);
    r.expect(">G20:ok");
    r.expect(">G0 X2:ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:50.800,0.000,0.000|"), "{st}");
    // An error is answered in its place, and the next line still runs.
    r.send(b"$N0=G0 X600\n");
    r.expect("ok");
    r.send(b"\x18");
    for want in ["", "Grbl 1.1h ['$' for help]", "ALARM:2"] {
        r.expect(want);
    }
    let m = r.line();
    assert!(m.starts_with("[MSG:axis X target 600.000 mm is outside its travel"), "{m}");
    r.expect(">G0 X600:error:9");
    assert!(r.status().starts_with("<Alarm|MPos:50.800,"), "the alarm stops the rest");
    // $RST=* forgets them.
    r.send(b"$X\n$RST=*\n$N\n");
    for want in ["[MSG:Caution: Unlocked]", "ok", "ok", "$N0=", "$N1=", "ok"] {
        r.expect(want);
    }
    assert!(!dir.0.join("machine.grbl.toml").exists());
}
