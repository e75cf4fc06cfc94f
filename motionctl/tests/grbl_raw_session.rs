//! `motionctl grbl`: a raw session over TCP checks the bridge's answers byte for byte: the
//! welcome, status reports (also asked in the middle of a line), character counting, `$`
//! commands, `error:N` for bad lines, long lines, binary noise, unknown words and codes, each
//! without losing the valid line after it; overrides, soft limits, check mode, feed hold,
//! spindle and coolant (also the real-time toggles and the spindle stop) and work offsets.

mod grbl_support;

use grbl_support::{bridge, tmp_dir, wait_for_port, Raw};
use std::time::{Duration, Instant};

#[test]
fn a_raw_session_gets_grbl_answers_byte_for_byte() {
    let dir = tmp_dir("raw");
    let mut b = bridge(&dir.0, &["--listen", "127.0.0.1:0"]);
    let mut r = Raw::connect(&mut b);
    assert_eq!(
        r.status(),
        "<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000|Ov:100,100,100>"
    );

    // $ commands.
    r.send(b"$I\n");
    r.expect("[VER:1.1h.20190825:]");
    r.expect("[OPT:V,15,128]");
    r.expect("ok");
    let settings = r.settings();
    assert_eq!(settings.first().map(String::as_str), Some("$0=3"));
    for want in ["$10=3", "$100=80.000", "$102=400.000", "$112=1500.000", "$120=2000.000"] {
        assert!(settings.iter().any(|l| l == want), "{want} missing: {settings:?}");
    }
    assert_eq!(settings.last().map(String::as_str), Some("$132=200.000"));
    r.send(b"$G\n");
    r.expect("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]");
    r.expect("ok");
    r.send(b"$#\n");
    r.expect("[G54:0.000,0.000,0.000]");
    for _ in 0..8 {
        r.line();
    }
    r.expect("[TLO:0.000]");
    r.expect("[PRB:0.000,0.000,0.000:0]");
    r.expect("ok");
    r.send(b"$N\n$X\n$Z\n$110=x\n$999=1\n$24=-1\n$24=30\n");
    for want in ["$N0=", "$N1=", "ok", "ok", "error:3", "error:2", "error:3", "error:4", "ok"] {
        r.expect(want);
    }

    // Character counting: several lines in one write (under 128 bytes), one answer each, in
    // order; a bad line among them gets its error and the rest still run.
    let batch = b"G21 G90\nG1 X1..2\nQQ1\nG1 X10 Y5 F3000\nG12 X1\nG1 Y1 Y2\n\nG0 Z1\n";
    assert!(batch.len() < 128);
    r.send(batch);
    for want in ["ok", "error:2", "error:1", "ok", "error:20", "error:25", "ok", "ok"] {
        r.expect(want);
    }
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:10.000,5.000,1.000|Bf:15,128|FS:0,0|"), "{st}");

    // `?` in the middle of a line is answered at once and does not touch the line.
    r.send(b"G1 X2");
    let st = r.status();
    assert!(st.contains("|Bf:15,123|"), "5 bytes wait in the buffer: {st}");
    r.send(b"0 Y");
    r.status();
    r.send(b"7\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:20.000,7.000,1.000|"), "{st}");

    // Garbage, each followed by a valid line that must still be answered `ok` and run: a
    // 300-byte line, binary noise, a word this machine does not know (W), an unknown M code.
    let mut long = vec![b'X'; 300];
    long.push(b'\n');
    r.send(&long);
    r.expect("error:11");
    r.send(b"G0 X1\n");
    r.expect("ok");
    r.send(b"\x01\x02\x7f\xfe\xff\xc3G\x00\n");
    let l = r.line();
    assert!(l.starts_with("error:"), "{l}");
    r.send(b"G0 X2\n");
    r.expect("ok");
    r.send(b"G0 X1 W5\n");
    r.expect("error:1");
    r.send(b"G0 X3\n");
    r.expect("ok");
    r.send(b"M333\n");
    r.expect("error:20");
    r.send(b"G0 X0 Y0 Z0\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:0.000,0.000,0.000|"), "{st}");

    // Feed override bytes show in the report; 0x90 restores 100 %.
    r.send(b"\x91\x91\x94");
    let st = r.status();
    assert!(st.ends_with("|Ov:119,100,100>"), "{st}");
    r.send(b"\x90\x96");
    assert!(r.status().ends_with("|Ov:100,50,100>"));

    // Soft limits: a jog past the travel is refused; a program move past it is an alarm.
    r.send(b"$J=G91 X600 F1000\n");
    r.expect("error:15");
    r.send(b"$J=X1\n");
    r.expect("error:22");
    r.send(b"G0 X600\n");
    r.expect("ALARM:2");
    let msg = r.line();
    assert!(msg.starts_with("[MSG:"), "{msg}");
    r.expect("error:9");
    assert!(r.status().starts_with("<Alarm|"));
    r.send(b"G0 X1\n");
    r.expect("error:9");
    r.send(b"$X\n");
    r.expect("[MSG:Caution: Unlocked]");
    r.expect("ok");

    // Check mode: parsed, not run; leaving it resets.
    r.send(b"$C\n");
    r.expect("[MSG:Enabled]");
    r.expect("ok");
    r.send(b"G0 X30\n");
    r.expect("ok");
    assert!(r.status().starts_with("<Check|MPos:0.000,0.000,0.000|"));
    r.send(b"$C\n");
    r.expect("[MSG:Disabled]");
    r.expect("ok");
    r.expect("");
    r.expect("Grbl 1.1h ['$' for help]");

    // Feed hold before the motion starts, resume; soft reset.
    r.send(b"G1 X40 F6000\n!");
    r.expect("ok");
    std::thread::sleep(Duration::from_millis(200));
    let st = r.status();
    assert!(st.starts_with("<Hold:0|"), "{st}");
    r.send(b"~");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:40.000,0.000,0.000|"), "{st}");

    // Spindle and coolant: switched on the board in program order, reported in grbl 1.1's
    // accessory field (`A:` after `Ov:`; S clockwise, C counterclockwise, F flood, M mist; none
    // while all are off) and in `$G`.
    r.send(b"M3 S1000\nM8\n");
    r.expect("ok");
    r.expect("ok");
    let st = r.until_status(|st| st.contains("|A:"));
    assert!(st.ends_with("|Ov:100,100,100|A:SF>"), "{st}");
    r.send(b"G1 X41 F6000 M4 M7\n");
    r.expect("ok");
    let st = r.until_status(|st| st.contains("|A:C"));
    assert!(st.ends_with("|A:CFM>"), "{st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M4 M7 M8 ") && gc.ends_with(" S1000]"), "{gc}");
    r.expect("ok");
    r.send(b"M9\n");
    r.expect("ok");
    let st = r.until_status(|st| st.ends_with("|A:C>"));
    assert!(st.starts_with("<Idle|MPos:41.000,"), "the move before M9 is done: {st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M4 M9 "), "{gc}");
    r.expect("ok");
    r.send(b"M5\n");
    r.expect("ok");
    let st = r.until_status(|st| !st.contains("|A:"));
    assert!(st.ends_with("|Ov:100,100,100>"), "{st}");
    // The real-time toggles (0xA0 flood, 0xA1 mist) switch the board at once, with motion
    // queued and held (not after it), and the parser's coolant (`$G`) with it.
    r.send(b"G1 X60 F300\n!");
    r.expect("ok");
    r.until_status(|st| st.starts_with("<Hold:0|"));
    r.send(b"\xA0");
    let st = r.until_status(|st| st.contains("|A:"));
    assert!(st.starts_with("<Hold:0|MPos:41.000,") && st.ends_with("|A:F>"), "{st}");
    r.send(b"\xA1");
    let st = r.until_status(|st| st.ends_with("|A:FM>"));
    assert!(st.starts_with("<Hold:0|MPos:41.000,"), "{st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M5 M7 M8 "), "{gc}");
    r.expect("ok");
    r.send(b"\xA0");
    r.until_status(|st| st.ends_with("|A:M>"));
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M5 M7 T"), "{gc}");
    r.expect("ok");
    r.send(b"\xA1");
    let st = r.until_status(|st| !st.contains("|A:"));
    assert!(st.starts_with("<Hold:0|MPos:41.000,"), "mist off before the move: {st}");
    r.send(b"~");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:60.000,") && !st.contains("|A:"), "{st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M5 M9 "), "{gc}");
    r.expect("ok");
    // The spindle stop (0x9E): nothing outside a feed hold; in one, the board's spindle goes
    // off (`A:` without S) while the parser keeps M3, a second 0x9E switches it on again, and
    // cycle start switches a stopped spindle on and resumes the motion after its spin-up.
    r.send(b"M3 S1000\nG1 X70 F60\n");
    r.expect("ok");
    r.expect("ok");
    r.until_status(|st| st.starts_with("<Run|") && st.ends_with("|A:S>"));
    r.send(b"\x9E");
    std::thread::sleep(Duration::from_millis(200));
    let st = r.status();
    assert!(st.starts_with("<Run|") && st.ends_with("|A:S>"), "not outside a hold: {st}");
    r.send(b"!");
    r.until_status(|st| st.starts_with("<Hold:0|"));
    r.send(b"\x9E");
    let st = r.until_status(|st| !st.contains("|A:"));
    assert!(st.starts_with("<Hold:0|"), "{st}");
    r.send(b"$G\n");
    let gc = r.line();
    assert!(gc.contains(" M3 M9 ") && gc.ends_with(" S1000]"), "{gc}");
    r.expect("ok");
    r.send(b"\x9E");
    let st = r.until_status(|st| st.ends_with("|A:S>"));
    assert!(st.starts_with("<Hold:0|"), "{st}");
    r.send(b"\x9E");
    let st = r.until_status(|st| !st.contains("|A:"));
    let held_at = st.split('|').nth(1).unwrap().to_string();
    r.send(b"~");
    let resumed = Instant::now();
    let st = r.until_status(|st| st.ends_with("|A:S>"));
    assert!(st.starts_with("<Hold:0|") && st.contains(&held_at), "spinning up: {st}");
    let st = r.until_status(|st| !st.contains(&held_at));
    assert!(st.starts_with("<Run|") || st.starts_with("<Idle|"), "{st}");
    let spin_up = resumed.elapsed().as_secs_f64();
    assert!(spin_up >= motionctl::gcode::resume::SPIN_UP_S, "resumed after {spin_up} s");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:70.000,") && st.ends_with("|A:S>"), "{st}");
    r.send(b"M5\n");
    r.expect("ok");
    r.until_status(|st| !st.contains("|A:"));
    // Not in alarm or check mode, as grbl.
    r.send(b"$C\n");
    r.expect("[MSG:Enabled]");
    r.expect("ok");
    r.send(b"\xA0");
    assert!(!r.status().contains("|A:"));
    r.send(b"$C\n");
    r.expect("[MSG:Disabled]");
    r.expect("ok");
    r.expect("");
    r.expect("Grbl 1.1h ['$' for help]");
    // A soft reset stops them, as grbl's does.
    r.send(b"M3\nM7\n");
    r.expect("ok");
    r.expect("ok");
    r.until_status(|st| st.ends_with("|A:SM>"));
    r.send(b"\x18");
    r.expect("");
    r.expect("Grbl 1.1h ['$' for help]");
    let st = r.status();
    assert!(!st.contains("|A:"), "{st}");
    r.send(b"G0 X40\n");
    r.expect("ok");
    r.until_idle();

    // Work offsets: $# and WCO, kept across a soft reset as grbl keeps them; G92 is not.
    r.send(b"G10 L2 P1 X5 Y-2.5\nG92 Z1\n$#\n");
    r.expect("ok");
    r.expect("ok");
    r.expect("[G54:5.000,-2.500,0.000]");
    for _ in 0..7 {
        r.line();
    }
    r.expect("[G92:0.000,0.000,-1.000]");
    for want in ["[TLO:0.000]", "[PRB:0.000,0.000,0.000:0]", "ok"] {
        r.expect(want);
    }
    let st = r.status();
    assert!(st.contains("|WCO:5.000,-2.500,-1.000|"), "{st}");
    r.send(b"\x18");
    r.expect("");
    r.expect("Grbl 1.1h ['$' for help]");
    let st = r.status();
    assert!(st.contains("|WCO:5.000,-2.500,0.000|"), "{st}");
    r.send(b"$G\n");
    r.expect("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]");
    r.expect("ok");
    r.send(b"G0 X0 Y0\n");
    r.expect("ok");
    let st = r.until_idle();
    assert!(st.starts_with("<Idle|MPos:5.000,-2.500,0.000|"), "{st}");
}

/// A sender that closes the port and opens it again at once (before the bridge's next look)
/// gets the welcome again, without a Ctrl-X, and what the old session left moving is stopped.
#[test]
fn a_sender_that_reopens_the_pty_at_once_is_welcomed_again() {
    let dir = tmp_dir("reopen");
    let port = dir.0.join("ttyGRBL");
    let mut b = bridge(&dir.0, &["--pty", port.to_str().unwrap()]);
    wait_for_port(&mut b, &port);
    let x = |st: &str| -> f64 {
        let at = st.find("MPos:").unwrap() + "MPos:".len();
        st[at..].split(',').next().unwrap().parse().unwrap()
    };
    let mut r = Raw::open_pty(&port);
    for _ in 0..5 {
        let before = x(&r.until_idle());
        r.send(b"G91 G1 X20 F600\n");
        r.expect("ok");
        r.until_status(|st| st.starts_with("<Run|"));
        // Closed and opened again at once: `open_pty` waits for the welcome.
        drop(r);
        r = Raw::open_pty(&port);
        // 20 mm at 10 mm/s (half a second at the simulator's speed): stopped on the way.
        let after = x(&r.until_idle());
        assert!(after - before < 20.0 - 1e-3, "from X{before} to X{after}");
    }
}
