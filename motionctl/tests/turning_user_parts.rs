//! `motionctl turning table` for parts other than the thesis's, checked against values computed
//! here by independent methods: the paraboloid's surface from its definition (frame transforms
//! and a root solve, not eq 2-9), the tool-nose envelope by direct maximisation, the Fourier
//! coefficients by Gauss-Legendre quadrature; the ellipse by bisection along the ray.

use motionctl::turning::table_file::{Form, ZTable};
use std::f64::consts::PI;
use std::process::Command;

fn motionctl(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl")).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn temp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("turning-user-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The table `turning table ARGS --out FILE` writes, parsed back.
fn table(args: &[&str], file: &str) -> ZTable {
    let path = temp(file);
    let mut all = vec!["turning", "table"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--out", path.to_str().unwrap()]);
    let (ok, _, err) = motionctl(&all);
    assert!(ok, "{err}");
    ZTable::parse(file, &std::fs::read_to_string(&path).unwrap()).unwrap()
}

/// Maximum of a unimodal `f` on `[a, b]` by golden-section search.
fn golden_max(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..200 {
        if fc > fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
        if b - a < 1e-13 {
            break;
        }
    }
    f(0.5 * (a + b))
}

/// The paraboloid z1 = (x1^2 + y1^2) / c with its sector centre at y1 = Sy, seen from the
/// machine frame (subscript 3: tilted by theta, tan theta = 2 Sy / c, about the x axis through
/// the sector centre): the axial height z3 of the surface over (x3, y3), by bisection on the
/// implicit equation.
struct Surface {
    c: f64,
    sy: f64,
    sz: f64,
    sin: f64,
    cos: f64,
}

impl Surface {
    fn new(focal_in: f64, sy: f64) -> Self {
        let c = 4.0 * focal_in;
        let th = (2.0 * sy / c).atan();
        Surface { c, sy, sz: sy * sy / c, sin: th.sin(), cos: th.cos() }
    }

    fn z3(&self, x3: f64, y3: f64) -> f64 {
        let f = |z3: f64| {
            let y1 = y3 * self.cos - z3 * self.sin + self.sy;
            let z1 = y3 * self.sin + z3 * self.cos + self.sz;
            z1 - (x3 * x3 + y1 * y1) / self.c
        };
        // f increases with z3 near the sector; bracket and bisect.
        let (mut lo, mut hi) = (-1.0, 1.0);
        assert!(f(lo) < 0.0 && f(hi) > 0.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) < 0.0 {
                lo = mid
            } else {
                hi = mid
            }
        }
        0.5 * (lo + hi)
    }

    /// Y_t(X, phi): the height at radius X (any sign) and spindle angle phi.
    fn yt(&self, x: f64, phi: f64) -> f64 {
        self.z3(x * phi.cos(), x * phi.sin())
    }
}

/// 8-point Gauss-Legendre nodes and weights on [-1, 1].
const GL8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
];

/// `integral_0^2pi f(phi) dphi` by 8-point Gauss-Legendre on `panels` panels.
fn quad(f: impl Fn(f64) -> f64, panels: usize) -> f64 {
    let h = 2.0 * PI / panels as f64;
    (0..panels)
        .map(|k| {
            let mid = (k as f64 + 0.5) * h;
            GL8.iter().map(|&(x, w)| w * (f(mid - 0.5 * h * x) + f(mid + 0.5 * h * x))).sum::<f64>()
                * 0.5
                * h
        })
        .sum()
}

/// The table C = 3.1 in, S_y = 0.7 in, RT = 0.05 in against the tool-centre command computed
/// here: at each sample X and phi the nose circle's centre height on the meridian section
/// (the highest centre over the contact points, by golden section), less the same envelope of
/// the gross path (the surface's highest point per radius, by golden section over phi); its
/// C0, S1, C2, S3 by quadrature, in the power form.
#[test]
fn a_non_thesis_paraboloid_matches_quadrature_of_the_exact_surface() {
    let (focal, sy, rt) = (3.1, 0.7, 0.05);
    let t = table(
        &[
            "--focal-length",
            "3.1",
            "--offset",
            "0.7",
            "--nose-radius",
            "0.05",
            "--x-max",
            "2",
            "--x-step",
            "0.05",
        ],
        "p31.txt",
    );
    assert_eq!((t.form, t.len()), (Form::Power, 41));
    let s = Surface::new(focal, sy);
    let circle = |u: f64, xc: f64| (rt * rt - (u - xc) * (u - xc)).max(0.0).sqrt();
    let centre =
        |xc: f64, y: &dyn Fn(f64) -> f64| golden_max(|u| y(u) + circle(u, xc), xc - rt, xc + rt);
    let gross = |x: f64| {
        // The surface's highest point at radius x: near phi = -asin(small) and pi + it; scan,
        // then refine the best bracket.
        let n = 720;
        let (k, _) = (0..n)
            .map(|k| (k, s.yt(x, 2.0 * PI * k as f64 / n as f64)))
            .fold((0, f64::NEG_INFINITY), |m, p| if p.1 > m.1 { p } else { m });
        let d = 2.0 * PI / n as f64;
        golden_max(|phi| s.yt(x, phi), k as f64 * d - d, k as f64 * d + d)
    };
    for &xc in &[0.5, 1.25, 2.0] {
        let g = centre(xc, &gross);
        let z = |phi: f64| centre(xc, &|u| s.yt(u, phi)) - g;
        let c0 = quad(z, 48) / (2.0 * PI);
        let s1 = quad(|p| z(p) * p.sin(), 48) / PI;
        let c2 = quad(|p| z(p) * (2.0 * p).cos(), 48) / PI;
        let s3 = quad(|p| z(p) * (3.0 * p).sin(), 48) / PI;
        let want = [c0 + c2, s1 + 3.0 * s3, -2.0 * c2, -4.0 * s3];
        let row = &t.rows[(xc / 0.05_f64).round() as usize];
        for k in 0..4 {
            assert!(
                (row[k] - want[k]).abs() < 1e-11,
                "X = {xc}: C0{k} table {} vs quadrature {} in",
                row[k],
                want[k]
            );
        }
    }
}

/// The same part in mm is the same table, converted (and the board gets the same bytes).
#[test]
fn millimetre_tables_are_the_inch_tables_converted() {
    let args_in = [
        "--focal-length",
        "3.1",
        "--offset",
        "0.7",
        "--nose-radius",
        "0.05",
        "--x-max",
        "2",
        "--x-step",
        "0.1",
    ];
    let args_mm = [
        "--units",
        "mm",
        "--focal-length",
        "78.74",
        "--offset",
        "17.78",
        "--nose-radius",
        "1.27",
        "--x-max",
        "50.8",
        "--x-step",
        "2.54",
    ];
    let a = table(&args_in, "a_in.txt");
    let b = table(&args_mm, "b_mm.txt");
    assert_eq!(a.len(), b.len());
    for (ra, rb) in a.rows.iter().zip(&b.rows) {
        for (x, y) in ra.iter().zip(rb) {
            assert!((x - y).abs() < 1e-11, "{x} vs {y} in");
        }
    }
    let text = std::fs::read_to_string(temp("b_mm.txt")).unwrap();
    assert!(text.contains("\nx_mm c00_mm c01_mm c02_mm c03_mm\n"), "{text}");
}

/// Thesis mode keeps FOREX4's method for other constants: close to the accurate table in the
/// spindle-angle terms, not equal (three nose passes, FORIF's pi, the gross arc's nose model).
/// Its C00 is measured from the gross arc, which this part's surface leaves at X = 1.4 in
/// (where the two maxima of eq 2-11 meet): there the accurate C00, measured from the highest
/// point, is the larger.
#[test]
fn thesis_mode_takes_other_constants() {
    let args = [
        "--focal-length",
        "3.1",
        "--offset",
        "0.7",
        "--nose-radius",
        "0.05",
        "--x-max",
        "2",
        "--x-step",
        "0.1",
    ];
    let mut thesis_args = args.to_vec();
    thesis_args.extend(["--mode", "thesis"]);
    let th = table(&thesis_args, "th.txt");
    let acc = table(&args, "acc.txt");
    let diff = th
        .rows
        .iter()
        .zip(&acc.rows)
        .flat_map(|(a, b)| a[1..].iter().zip(&b[1..]).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max);
    assert!(diff > 0.0 && diff < 2e-5, "thesis vs accurate: {diff} in");
    for (i, (a, b)) in th.rows.iter().zip(&acc.rows).enumerate() {
        let x = i as f64 * 0.1;
        if x <= 1.3 {
            assert!((a[0] - b[0]).abs() < 2e-5, "X = {x}: C00 {} vs {}", a[0], b[0]);
        } else if x >= 1.6 {
            assert!(b[0] > a[0] + 1e-5, "X = {x}: C00 {} vs {}", a[0], b[0]);
        }
    }
}

/// The defaults in thesis mode print Table 2-2 of the thesis, every row digit for digit.
#[test]
fn thesis_defaults_print_table_2_2() {
    let (ok, out, err) = motionctl(&["turning", "table", "--mode", "thesis"]);
    assert!(ok, "{err}");
    let printed: Vec<Vec<String>> = out
        .lines()
        .filter(|l| l.as_bytes().first().is_some_and(u8::is_ascii_digit))
        .map(|l| l.split_whitespace().map(String::from).collect())
        .collect();
    let thesis: Vec<Vec<String>> = include_str!("data/turning/table_2_2.txt")
        .lines()
        .filter(|l| l.as_bytes().first().is_some_and(u8::is_ascii_digit))
        .map(|l| l.split('\t').map(String::from).collect())
        .collect();
    assert_eq!(printed.len(), 81);
    for (p, t) in printed.iter().zip(&thesis) {
        let x: f64 = p[0].parse().unwrap();
        assert!((x - t[0].parse::<f64>().unwrap()).abs() < 1e-9);
        for k in 1..5 {
            // The thesis prints X = 0's zeros with a sign IEEE arithmetic does not give.
            let want = if x == 0.0 { t[k].trim_start_matches('-') } else { &t[k] };
            assert_eq!(p[k], want, "X = {x}, column {k}");
        }
    }
}

/// Flags out of range are refused with the flag's name and the range, before any work.
#[test]
fn bad_parameters_name_the_flag_and_the_range() {
    for (args, want) in [
        (&["--focal-length", "0"][..], "--focal-length must be a finite length within (0, "),
        (&["--focal-length", "-2"][..], "--focal-length must be"),
        (&["--nose-radius", "-0.1"][..], "--nose-radius must be a finite length within [0, 10] in"),
        (&["--x-step", "0"][..], "--x-step must be a finite length within (0, 8] in"),
        (&["--x-step", "1e-9"][..], "the board's table holds at most 96 rows"),
        (&["--x-max", "NaN"][..], "--x-max must be a finite length"),
        (&["--offset", "inf"][..], "--offset must be a finite length"),
        (
            &["--units", "mm", "--x-max", "3000"][..],
            "--x-max must be a finite length within (0, 2540] mm",
        ),
        (&["--x-step", "0.3"][..], "--x-max must be a whole number of --x-step"),
        (&["--harmonics", "0"][..], "--harmonics must be within 1..=8"),
        (&["--mode", "thesis", "--harmonics", "3"][..], "--harmonics needs --mode accurate"),
        (&["--focal-length", "1", "--offset", "0.5", "--x-max", "5"][..], "outside the paraboloid"),
    ] {
        let mut all = vec!["turning", "table"];
        all.extend_from_slice(args);
        let (ok, out, err) = motionctl(&all);
        assert!(!ok, "{args:?} was accepted: {out}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
    let (ok, _, err) = motionctl(&["turning", "table", "--x-step", "1e-9"]);
    assert!(!ok && err.contains("--x-step"), "{err}");
}

/// The summary as JSON: one object with the units in the key names.
#[test]
fn json_summary() {
    let (ok, out, err) = motionctl(&["turning", "table", "--units", "mm", "--json"]);
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["rows"], 81);
    assert!((j["x_max_mm"].as_f64().unwrap() - 203.2).abs() < 1e-9);
    assert!(j["part_error_max_mm"].as_f64().unwrap() < 1e-6);
    assert_eq!(j["board_ok"], true);
}

/// Distance from the spindle axis to the ellipse along the ray at phi, by bisection.
fn ellipse_ray(a: f64, b: f64, cx: f64, cy: f64, phi: f64) -> f64 {
    let inside =
        |s: f64| ((s * phi.cos() - cx) / a).powi(2) + ((s * phi.sin() - cy) / b).powi(2) < 1.0;
    let (mut lo, mut hi) = (0.0, 10.0 * a.max(b));
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if inside(m) {
            lo = m
        } else {
            hi = m
        }
    }
    0.5 * (lo + hi)
}

/// An oval (0.2 mm ovality, 0.02 mm eccentric, tapered) as a harmonic table in mm: the table's
/// command plus the gross radius is the ellipse's radius along the ray, at rows and between.
#[test]
fn an_ellipse_profile_is_its_radius_along_the_ray() {
    let path = temp("oval.toml");
    std::fs::write(
        &path,
        "[ellipse]\nunits = \"mm\"\nsemi_axis_x = 40\nsemi_axis_y = 39.9\nsemi_axis_y_end = 39.85\ncentre_x = 0.02\n",
    )
    .unwrap();
    let t = table(
        &["--profile", path.to_str().unwrap(), "--units", "mm", "--x-max", "60", "--x-step", "5"],
        "oval.txt",
    );
    assert_eq!(t.form, Form::Harmonic(8));
    let mm = 25.4;
    for &(x_mm, frac) in &[(0.0, 0.0), (27.5, 27.5 / 60.0), (60.0, 1.0)] {
        let b = 39.9 + (39.85 - 39.9) * frac;
        let r = |phi: f64| ellipse_ray(40.0, b, 0.02, 0.0, phi);
        let gross = (0..3600).map(|k| r(2.0 * PI * k as f64 / 3600.0)).fold(0.0, f64::max);
        for k in 0..36 {
            let phi = 2.0 * PI * k as f64 / 36.0;
            let z = t.z_in(x_mm / mm, phi).unwrap() * mm;
            // Between rows the taper is linear in X: the cubic interpolation is exact for it.
            assert!(
                (z - (r(phi) - gross)).abs() < 2e-7,
                "X {x_mm} mm, phi {phi}: {z} vs {}",
                r(phi) - gross
            );
        }
    }
}

/// A cam given by points of a trigonometric polynomial: the harmonic table recovers its
/// coefficients (the spline through 120 points is exact to well below a micron).
#[test]
fn a_cam_profile_recovers_its_harmonics() {
    let path = temp("cam.csv");
    let f = |t: f64| 20.0 + 0.5 * t.cos() + 0.3 * (2.0 * t).sin() - 0.1 * (3.0 * t).cos();
    let mut src = String::from("# a test cam\ntheta_deg,r_mm\n");
    for i in 0..120 {
        let deg = 3.0 * i as f64;
        src += &format!("{deg},{:.9}\n", f(deg.to_radians()));
    }
    std::fs::write(&path, src).unwrap();
    let t = table(
        &[
            "--profile",
            path.to_str().unwrap(),
            "--units",
            "mm",
            "--x-max",
            "10",
            "--x-step",
            "5",
            "--harmonics",
            "4",
        ],
        "cam.txt",
    );
    let row: Vec<f64> = t.rows[1].iter().map(|v| v * 25.4).collect();
    let want = [0.5, 0.0, 0.0, 0.3, -0.1, 0.0, 0.0, 0.0];
    for (k, w) in want.iter().enumerate() {
        assert!((row[k + 1] - w).abs() < 2e-6, "coefficient {}: {} vs {w}", k + 1, row[k + 1]);
    }
    // Bad cam files name the line and column.
    std::fs::write(&path, "0,20\n90,20\n90,21\n270,20\n").unwrap();
    let (ok, _, err) = motionctl(&["turning", "table", "--profile", path.to_str().unwrap()]);
    assert!(!ok && err.contains("cam.csv:3:1: theta = 90 deg"), "{err}");
    std::fs::write(&path, "0,20\n90,20\n180,-1\n270,20\n").unwrap();
    let (ok, _, err) = motionctl(&["turning", "table", "--profile", path.to_str().unwrap()]);
    assert!(!ok && err.contains("cam.csv:3:5: r = -1"), "{err}");
}

#[test]
fn turning_firmware_table_needs_the_accurate_mode() {
    let (ok, _, err) = motionctl(&["turning", "table", "--mode", "thesis", "--firmware-rust", "x"]);
    assert!(!ok);
    assert!(err.contains("--mode accurate"), "{err}");
}

#[test]
fn turning_accurate_table_writes_the_firmware_table() {
    let dir = std::env::temp_dir().join(format!("motionctl-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("table.rs");
    let (ok, out, err) =
        motionctl(&["turning", "table", "--firmware-rust", path.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(out.contains("81 rows"), "{out}");
    // The same source as the checked-in firmware table.
    let written = std::fs::read_to_string(&path).unwrap();
    let checked_in = include_str!("../../src/turning/douglass_table.rs");
    assert_eq!(written.trim(), checked_in.trim());
}
