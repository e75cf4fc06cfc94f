//! The Z table file (`turning table --out`, `turning run --table`): every line read, errors at
//! file:line:column, both units, both forms.

use motionctl::turning::run::LinkTableBytes;
use motionctl::turning::table_file::{Form, ZTable, MAX_ROWS};
use std::process::Command;

fn parse(src: &str) -> Result<ZTable, String> {
    ZTable::parse("t.txt", src).map_err(|e| e.to_string())
}

/// A table whose last row has a bad column is refused at that line and column; the parser
/// before this one skipped the line and ran the table one row short.
#[test]
fn a_bad_last_row_is_an_error_not_a_shorter_table() {
    let src = "x_in c00_in c01_in c02_in c03_in\n0 0 0 0 0\n0.1 0 0 0 0\n0.2 0 0 0,x1\n";
    assert_eq!(parse(src).unwrap_err(), "t.txt:4:11: `x1` is not a finite number");
    // A short last row and a NaN are errors too.
    let short = "0 0 0 0 0\n0.1 0 0 0 0\n0.2 0 0 0\n";
    assert!(parse(short).unwrap_err().starts_with("t.txt:3: 4 values"), "{:?}", parse(short));
    let nan = "0 0 0 0 0\n0.1 0 NaN 0 0\n";
    assert_eq!(parse(nan).unwrap_err(), "t.txt:2:7: `NaN` is not a finite number");
}

/// Through the command line: `turning run --table` names the file, line and column before it
/// talks to any board (the old parser dropped the row and went on to the link).
#[test]
fn turning_run_names_the_bad_row() {
    let dir = std::env::temp_dir().join(format!("ztable-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.txt");
    std::fs::write(&path, "0 0 0 0 0\n0.1 0 0 0 0\n0.2 0 0 0 0\n0.3 0 0.001x 0 0\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_motionctl"))
        .args(["turning", "run", "--sim", "--table", path.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains(&format!("{}:4:7: `0.001x`", path.display())), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn headers_units_and_forms() {
    let inch = parse("# c\nx_in c00_in c01_in c02_in c03_in\n0 1 2 3 4\n0.1 1 2 3 4\n").unwrap();
    assert_eq!((inch.form, inch.len()), (Form::Power, 2));
    let mm =
        parse("x_mm,c00_mm,c01_mm,c02_mm,c03_mm\n0,25.4,50.8,76.2,101.6\n2.54,0,0,0,0\n").unwrap();
    assert!((mm.dx_in - 0.1).abs() < 1e-15 && (mm.rows[0][3] - 4.0).abs() < 1e-14, "{mm:?}");
    // The thesis's FOR30 print (`|` separated, no header) is inches, power form.
    let for30 = parse(" 0.0| 0.0000000| 0.0000000| 0.0000000| 0.0000000\n 0.1|-0.0000000|-0.0000000|-0.0000009| 0.0000000\n").unwrap();
    assert_eq!(for30.rows[1][2], -0.0000009);
    let h = parse("x_in a0_in a1_in b1_in a2_in b2_in\n0 1 0 0 0.5 0\n1 1 0 0 0.5 0\n").unwrap();
    assert_eq!(h.form, Form::Harmonic(2));
    assert!((h.z_in(0.5, 0.0).unwrap() - 1.5).abs() < 1e-15);
    for (src, want) in [
        ("x_in c00_mm c01_in c02_in c03_in\n", "t.txt:1:6: `c00_mm`: every column"),
        ("x_in c00_in c01_in cXX_in c03_in\n", "t.txt:1:20: header: unexpected `cxx`"),
        ("x_in a0_in a1_in b1_in a2_in\n", "t.txt:1:24: header: unexpected `a2`"),
        ("0 0 0 0 0\n", "t.txt: a table needs at least two rows"),
        ("0 0 0 0 0\n0.1 0 0 0 0\n0.3 0 0 0 0\n", "t.txt:3:1: X = 0.3 is off the uniform grid"),
        ("0.1 0 0 0 0\n0 0 0 0 0\n", "t.txt:2:1: X must increase"),
    ] {
        let e = parse(src).unwrap_err();
        assert!(e.starts_with(want), "{src:?}: {e}");
    }
    let big: String = (0..=MAX_ROWS).map(|i| format!("{} 0 0 0 0\n", i as f64 * 0.1)).collect();
    let e = parse(&big).unwrap_err();
    assert!(e.starts_with(&format!("t.txt:{}: more than {MAX_ROWS} rows", MAX_ROWS + 1)), "{e}");
}

/// The same table written in inches and in mm gives the board the same bytes.
#[test]
fn inch_and_mm_files_give_the_board_the_same_table() {
    let rows: Vec<Vec<f64>> = (0..21)
        .map(|i| {
            let x = i as f64 * 0.1;
            vec![-1e-5 * x.powi(4), -2e-4 * x.powi(3), -1.5e-3 * x * x, 6e-6 * x.powi(3)]
        })
        .collect();
    let t = ZTable { form: Form::Power, x0_in: 0.0, dx_in: 0.1, rows };
    let fmt = |v: f64| format!("{v:.12}");
    let inch = t.render(motionctl::turning::units::Units::In, &[], &fmt);
    let mm = t.render(motionctl::turning::units::Units::Mm, &["mm".into()], &fmt);
    let a = LinkTableBytes::parse("in", &inch).unwrap();
    let b = LinkTableBytes::parse("mm", &mm).unwrap();
    assert_eq!((a.header, &a.bytes), (b.header, &b.bytes));
    let csv =
        LinkTableBytes::parse("csv", &t.render_csv(motionctl::turning::units::Units::Mm)).unwrap();
    assert_eq!(a.bytes, csv.bytes);
}
