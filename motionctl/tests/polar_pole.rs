//! Pole placement (Fahim Ch. 4): Table 4.1 oracles for the witch of Agnesi, the limacon and the
//! serpentine (area error at the thesis's pole vs the printed value, within an order of magnitude;
//! our optimiser's pole beside the thesis's, no worse under our F1), the limacon's pole-inside
//! violation, and the F1 / area-error theta wrap.
//!
//! Table 4.1 prints neither the x-ranges of the two open curves nor the chord count: the witch
//! runs over x in [-8, 8] in (the widest whole-inch symmetric range the thesis's pole keeps inside
//! the work area: at 8.5 in the end point is 13.1 in from the pole), the serpentine over [-4, 4] in,
//! F1 on 200 chords.

use motionctl::polar::contour::{serpentine, witch, Contour, Jet, Limacon, Polar};
use motionctl::polar::digitize::{digitize, DigitizeError, FeedAt, Setup};
use motionctl::polar::pole::{
    area_error_in2, check, chord_points, f1, f1_as_listed, optimise, Constraints, HookeJeeves,
    Optimum, Pole, Violation, F1_CHORDS, MM2_PER_IN2,
};
use motionctl::polar::work_area::WorkArea;
use motionctl::polar::Resolution;

const RES: Resolution = Resolution::THESIS;
const CM: f64 = 1.0 / 2.54;

fn area_mm2<C: Contour + ?Sized>(c: &C, pole: Pole) -> f64 {
    area_error_in2(c, pole.xy(), &RES, 4) * MM2_PER_IN2
}

fn f1_at<C: Contour + ?Sized>(c: &C, pole: Pole) -> f64 {
    f1(&chord_points(c, F1_CHORDS), pole.xy(), &RES).f1
}

/// Within an order of magnitude of the thesis's printed area error.
fn order_of_magnitude(ours: f64, thesis: f64) -> bool {
    ours > thesis / 10.0 && ours < thesis * 10.0
}

fn report<C: Contour + ?Sized>(name: &str, c: &C, thesis: Pole, thesis_mm2: f64, ours: &Optimum) {
    println!(
        "{name}: thesis pole C = {:.2} cm, beta = {:.3} rad: eps_a ours {:.3} mm^2 (thesis {thesis_mm2}), F1 {:.4}, {:?}",
        thesis.c_in / CM,
        thesis.beta_rad,
        area_mm2(c, thesis),
        f1_at(c, thesis),
        check(c, thesis.xy(), &WorkArea::FAHIM_1983)
    );
    println!(
        "{name}: our pole     C = {:.2} cm, beta = {:.3} rad: eps_a {:.3} mm^2, F1 {:.4} ({} evaluations), {:?}",
        ours.pole.c_in / CM,
        ours.pole.beta_rad,
        area_mm2(c, ours.pole),
        ours.f1.f1,
        ours.evals,
        check(c, ours.pole.xy(), &WorkArea::FAHIM_1983)
    );
}

#[test]
fn table_4_1_witch_of_agnesi() {
    let w = witch(21.59 * CM, -8.0, 8.0);
    let thesis = Pole { c_in: 15.46 * CM, beta_rad: 1.236 };
    let mirror = Pole { beta_rad: 1.905, ..thesis };
    assert_eq!(
        check(&w, thesis.xy(), &WorkArea::FAHIM_1983),
        Ok(()),
        "the thesis's pole is inside the work area"
    );
    let e = area_mm2(&w, thesis);
    assert!(order_of_magnitude(e, 2.59), "{e} mm^2");
    // The two printed betas are mirror images about the witch's axis: same F1.
    assert!((f1_at(&w, thesis) - f1_at(&w, mirror)).abs() < 0.01);
    let ours =
        optimise(&w, &RES, Constraints::WorkArea(WorkArea::FAHIM_1983), &HookeJeeves::default())
            .unwrap();
    report("witch", &w, thesis, 2.59, &ours);
    assert_eq!(check(&w, ours.pole.xy(), &WorkArea::FAHIM_1983), Ok(()));
    assert!(ours.f1.f1 <= f1_at(&w, thesis) + 1e-12);
    // And it lands on the thesis's optimum (or its mirror), to a tenth of an inch and 0.02 rad.
    let near = |p: Pole| {
        (ours.pole.c_in - p.c_in).abs() < 0.1 && (ours.pole.beta_rad - p.beta_rad).abs() < 0.02
    };
    assert!(near(thesis) || near(mirror), "{:?}", ours.pole);
}

#[test]
fn table_4_1_serpentine() {
    let s = serpentine(1.27 * CM, 7.62 * CM, -4.0, 4.0);
    let thesis = Pole { c_in: 5.37 * CM, beta_rad: 1.105 };
    // The serpentine passes through its own pole, 2.11 in from the thesis's machine pole: inside
    // the 3 in inner radius (and its left branch lies below that pole's theta = 0). HOKJEV only
    // bounds the pole's coordinates (URK/SRK), so compare under that box; our work-area optimum is
    // reported beside it.
    assert!(matches!(
        check(&s, thesis.xy(), &WorkArea::FAHIM_1983),
        Err(Violation::WorkArea { .. })
    ));
    let [px, py] = thesis.xy();
    let nearest = chord_points(&s, 2000)
        .iter()
        .map(|p| (p[0] - px).hypot(p[1] - py))
        .fold(f64::MAX, f64::min);
    assert!(nearest < 3.0, "{nearest}");
    let e = area_mm2(&s, thesis);
    assert!(order_of_magnitude(e, 4.563), "{e} mm^2");
    let boxed = optimise(
        &s,
        &RES,
        Constraints::Box { centre: [0.0, 0.0], half_in: 13.0 },
        &HookeJeeves::default(),
    )
    .unwrap();
    report("serpentine (pole box only)", &s, thesis, 4.563, &boxed);
    assert!(boxed.f1.f1 <= f1_at(&s, thesis) + 1e-12);
    let ours =
        optimise(&s, &RES, Constraints::WorkArea(WorkArea::FAHIM_1983), &HookeJeeves::default())
            .unwrap();
    report("serpentine (work area)", &s, thesis, 4.563, &ours);
    assert_eq!(check(&s, ours.pole.xy(), &WorkArea::FAHIM_1983), Ok(()));
    assert!(order_of_magnitude(area_mm2(&s, ours.pole), 4.563));
}

#[test]
fn table_4_1_limacon_pole_inside_violation() {
    let l = Polar::closed(Limacon { b: 3.0, a: 2.0 });
    let thesis = Pole { c_in: 0.86 * CM, beta_rad: 2.0 * std::f64::consts::PI };
    let random_best = Pole { c_in: 1.27 * CM, ..thesis };
    // The thesis's optimum (and its random-search best) put the machine pole inside the closed
    // limacon, which its own constraint (b) forbids: the digitizer refuses it.
    assert_eq!(check(&l, thesis.xy(), &WorkArea::FAHIM_1983), Err(Violation::PoleInside(1)));
    assert_eq!(check(&l, random_best.xy(), &WorkArea::FAHIM_1983), Err(Violation::PoleInside(1)));
    let (ri, eps) = thesis.digitizer_pole();
    let setup = Setup {
        pole_r_in: ri,
        pole_angle_rad: eps,
        tool_radius_in: 0.0,
        vt_in_per_s: 0.5,
        res: RES,
        tick_hz: 100_000,
        cap_speed: true,
        area: WorkArea::FAHIM_1983,
        feed_at: FeedAt::Centre,
    };
    assert!(matches!(digitize(&l, &setup), Err(DigitizeError::PoleInside(1))));
    let e = area_mm2(&l, thesis);
    assert!(order_of_magnitude(e, 4.05), "{e} mm^2");
    assert!(order_of_magnitude(area_mm2(&l, random_best), 4.01));
    // Under the thesis's own (box) limits our search is no worse than its pole.
    let boxed = optimise(
        &l,
        &RES,
        Constraints::Box { centre: [0.0, 0.0], half_in: 3.0 },
        &HookeJeeves::default(),
    )
    .unwrap();
    report("limacon (pole box only)", &l, thesis, 4.05, &boxed);
    assert!(boxed.f1.f1 <= f1_at(&l, thesis) + 1e-12);
    // With both constraints: a pole outside the limacon, in the work area, that the digitizer takes.
    let ours =
        optimise(&l, &RES, Constraints::WorkArea(WorkArea::FAHIM_1983), &HookeJeeves::default())
            .unwrap();
    report("limacon (work area, pole outside)", &l, thesis, 4.05, &ours);
    assert_eq!(check(&l, ours.pole.xy(), &WorkArea::FAHIM_1983), Ok(()));
    let (ri, eps) = ours.pole.digitizer_pole();
    let d = digitize(&l, &Setup { pole_r_in: ri, pole_angle_rad: eps, ..setup }).unwrap();
    assert!(d.events.len() > 1000);
    assert!(order_of_magnitude(area_mm2(&l, ours.pole), 4.05));
}

/// A contour rotated about its own pole by `angle` (rotating the pole with it keeps the relative
/// geometry; only the machine's theta origin moves).
struct Rotated<'a, C: Contour + ?Sized> {
    inner: &'a C,
    angle: f64,
}

impl<C: Contour + ?Sized> Contour for Rotated<'_, C> {
    fn jet(&self, u: f64) -> Jet {
        let (s, c) = self.angle.sin_cos();
        self.inner.jet(u).map(|v| [c * v[0] - s * v[1], s * v[0] + c * v[1]])
    }
    fn range(&self) -> (f64, f64) {
        self.inner.range()
    }
    fn closed(&self) -> bool {
        self.inner.closed()
    }
}

#[test]
fn theta_wrap_is_handled_in_f1_and_area_error() {
    let w = witch(21.59 * CM, -8.0, 8.0);
    let pole = Pole { c_in: 15.46 * CM, beta_rad: 1.236 };
    let base_f1 = f1_at(&w, pole);
    let base_area = area_mm2(&w, pole);
    let mut listed_worst = 0.0f64;
    // Turning the setup by -1.6 rad puts the witch across the machine's theta = 0 ray.
    for angle in [-1.6, -1.2, 0.7, 2.5] {
        let r = Rotated { inner: &w, angle };
        let p = Pole { beta_rad: pole.beta_rad + angle, ..pole };
        let pts = chord_points(&r, F1_CHORDS);
        let ours = f1(&pts, p.xy(), &RES).f1;
        let listed = f1_as_listed(&pts, p.xy(), &RES).f1;
        let area = area_mm2(&r, p);
        println!(
            "rotated {angle}: F1 {ours:.6} (listing's ANGLE: {listed:.6}), eps_a {area:.4} mm^2"
        );
        assert!((ours - base_f1).abs() < 1e-9, "{angle}: {ours} vs {base_f1}");
        // The grid stays anchored to the machine's home: sub-resolution phase effects only.
        assert!((area / base_area - 1.0).abs() < 0.05, "{angle}: {area} vs {base_area}");
        listed_worst = listed_worst.max((listed - base_f1).abs());
    }
    // The listing's [0, 2 pi) angles count a chord crossing theta = 0 as nearly a full turn.
    assert!(listed_worst > 0.05, "{listed_worst}");
}
