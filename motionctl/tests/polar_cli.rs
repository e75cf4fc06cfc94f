//! `motionctl polar` subcommands: digitize to a file and read it back, dump it, a CSV contour,
//! the pole search, and errors for bad specs.

use clap::Parser;
use motion::polar::stream::decode_all;
use motionctl::polar::cli::{parse_contour, run, PolarCmd};
use motionctl::polar::contour::{Limacon, Polar};
use motionctl::polar::digitize::{digitize, FeedAt, Setup};
use motionctl::polar::work_area::WorkArea;
use motionctl::polar::Resolution;

#[derive(Parser)]
struct Cli {
    #[command(subcommand)]
    cmd: PolarCmd,
}

fn parse(args: &[&str]) -> PolarCmd {
    Cli::try_parse_from(std::iter::once("polar").chain(args.iter().copied())).unwrap().cmd
}

#[test]
fn digitize_writes_a_stream_that_decodes_to_the_digitizer_events() {
    let dir = std::env::temp_dir().join(format!("polar_cli_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("limacon.bin");
    let f = file.to_str().unwrap();
    // Table 4.1 convention: machine pole at C = 6.5 in, beta = 70 deg + pi in the contour frame.
    let beta = (70f64.to_radians() + std::f64::consts::PI).to_string();
    run(parse(&[
        "digitize",
        "limacon:3,2",
        "--pole-c",
        "6.5",
        "--pole-beta",
        &beta,
        "--tool-radius",
        "0.125",
        "--vt",
        "0.5",
        "--out",
        f,
    ]))
    .unwrap();
    let bytes = std::fs::read(&file).unwrap();
    let mut got = Vec::new();
    decode_all(&bytes, |e| got.push(e)).unwrap();
    let setup = Setup {
        pole_r_in: 6.5,
        pole_angle_rad: 70f64.to_radians(),
        tool_radius_in: 0.125,
        vt_in_per_s: 0.5,
        res: Resolution::THESIS,
        tick_hz: motion::polar::scenario::TICK_HZ,
        cap_speed: true,
        area: WorkArea::FAHIM_1983,
        // The CLI's default: Vt at the contact point.
        feed_at: FeedAt::Contact,
    };
    let want = digitize(&Polar::closed(Limacon { b: 3.0, a: 2.0 }), &setup).unwrap();
    assert_eq!(got, want.events);
    run(parse(&["dump", f])).unwrap();
    // A corrupted file: dump reports the error.
    let mut bad = bytes.clone();
    bad[10] ^= 1;
    std::fs::write(&file, &bad).unwrap();
    assert!(run(parse(&["dump", f])).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn csv_contour_and_pole_search() {
    let dir = std::env::temp_dir().join(format!("polar_cli_csv_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("arc.csv");
    // An arc of radius 2 in about the contour pole, as points, with a header line.
    let mut text = String::from("x,y\n");
    for i in 0..=40 {
        let t = 0.2 + 1.2 * i as f64 / 40.0;
        text += &format!("{},{}\n", 2.0 * t.cos(), 2.0 * t.sin());
    }
    std::fs::write(&file, text).unwrap();
    let c = parse_contour(file.to_str().unwrap()).unwrap();
    let [p, ..] = c.jet(c.range().1 / 2.0);
    assert!((p[0].hypot(p[1]) - 2.0).abs() < 1e-4, "{p:?}");
    run(parse(&["pole", file.to_str().unwrap()])).unwrap();
    run(parse(&["pole", "serpentine:0.5,3,-4,4", "--box-only", "13"])).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(parse_contour("limacon:3").is_err());
    assert!(parse_contour("witch:1,2,nan").is_err());
    assert!(parse_contour("/no/such/file.csv").is_err());
    // Pole inside the closed contour: a clear error, not a panic.
    assert!(run(parse(&[
        "digitize",
        "circle:5",
        "--pole-c",
        "1",
        "--pole-beta",
        "0",
        "--vt",
        "1"
    ]))
    .is_err());
}

/// `digitize --json` says where the machine starts (r, theta of the tool centre about the
/// machine pole), the path, the events and the cut time; the start is the contour's first point
/// seen from the pole, computed here from the pole's position in the contour frame.
#[test]
fn digitize_reports_the_start_point_path_and_time_as_json() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["polar", "digitize", "circle:2", "--pole-c", "8", "--pole-beta=-1.5707963267949"])
        .args(["--vt", "0.5", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let f = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k} in {v}"));
    // The circle r = 2 starts at (2, 0) in its own frame; the machine pole is 8 in away at
    // beta = -90 deg, (0, -8): the start is hypot(2, 8) in from it (to the dR grid).
    assert!((f("start_r_in") - 2f64.hypot(8.0)).abs() <= 0.001, "{v}");
    assert!(f("start_theta_deg") > 0.0 && f("start_theta_deg") < 160.0, "{v}");
    let length = 2.0 * std::f64::consts::PI * 2.0;
    assert!((f("path_in") - length).abs() < 1e-3, "{v}");
    assert!((f("duration_s") - length / 0.5).abs() / (length / 0.5) < 1e-3, "{v}");
    assert_eq!(f("events") as u64, f("radial_events") as u64 + f("angular_events") as u64);
}
