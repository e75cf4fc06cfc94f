//! A die whose points all coincide with the start cuts nothing: refused with the reason, where
//! it used to plan zero segments, print a NaN time error and exit 0.

use motionctl::wire::dies::{mdi_die, DieOverrides};

#[test]
fn a_die_the_wire_never_moves_along_is_refused() {
    let o = DieOverrides::default();
    let d = mdi_die("deg", "10\n4\n0,0,0,0\n0,0,0,0\n0,0,0,0\n0,0,0,0\n", &o).unwrap();
    let e = d.path().unwrap_err().to_string();
    assert!(e.contains("coincides with the start: the die cuts nothing"), "{e}");
    // One point away from the start is a cut (out and back), and so is one face moving.
    assert!(mdi_die("one", "10\n1\n3,4,3,4\n", &o).unwrap().path().is_ok());
    assert!(mdi_die("cone", "10\n3\n0,0,0,0\n0,0,5,0\n0,0,5,5\n", &o).unwrap().path().is_ok());
}
