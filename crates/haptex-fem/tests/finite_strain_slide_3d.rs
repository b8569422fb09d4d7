//! The 3D fingertip at finite strain (`--model 3d --kinematics finite`,
//! issue 39): the total-Lagrangian body of tests/finite_strain_body_3d.rs
//! in the slide, balanced against the contact by the outer iteration of
//! `solid3d::finite_contact`. Each test names its source and tolerance.

mod common;

use haptex_fem::finger::{FingerModel, Resolution};
use haptex_fem::scenario::{Kinematics, Loading, Scenario};
use haptex_fem::solid3d::finite_hex8::Volumetric;
use haptex_fem::solid3d::slide::{Simulation3, run, run_with_volumetric};
use haptex_fem::surface::SurfaceShape;

/// The half-disc finger of the CalculiX comparisons (validation/calculix3d):
/// homogeneous E = 0.1 MPa, nu = 0.45, elastic, pressed 0.5 mm, slid 3 mm.
fn half_disc(surface: SurfaceShape, mu_skin: Option<f64>, kinematics: Kinematics) -> Scenario {
    let mut scenario = Scenario::paper(surface);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/finger/half-disc.toml");
    scenario.model = FingerModel::read(std::path::Path::new(path)).unwrap();
    scenario.viscoelastic = false;
    scenario.resolution = Resolution::Coarse;
    scenario.loading = Loading::Indent(0.5);
    scenario.slide_mm = 3.0;
    scenario.step_mm = 0.1;
    scenario.mu_skin = mu_skin;
    scenario.kinematics = kinematics;
    scenario
}

/// The normal force at the end of the press (N).
fn press_force(result: &Simulation3) -> f64 {
    result.history.iter().rev().find(|h| h.slide_mm == 0.0).expect("the press's rows").fn_n
}

/// An elastic body in frictionless contact is conservative at finite
/// strain too: over a path symmetric about the bump's top (from 1.5 mm
/// ahead to 1.5 mm past it, the mesh symmetric about x = 0) Ft/Fn(x) =
/// -Ft/Fn(3 - x). Small strain holds it to 1e-8
/// (tests/calculix_reference_3d.rs); at finite strain the outer iteration
/// stops within its tolerance, and 1e-6 of the largest |Ft/Fn| is asserted
/// as in small strain (measured: 6e-10 of it).
#[test]
fn frictionless_bump_is_antisymmetric_at_finite_strain() {
    let scenario = half_disc(SurfaceShape::Bump { x0: 1.5, width: 1.5, height: 0.2 }, Some(0.0), Kinematics::Finite);
    let result = run(&scenario, 0.0, &mut |_| {}).unwrap();
    let (largest, worst) = common::antisymmetry_over_3_mm(&result);
    assert!(largest > 0.05, "the bump tilts the contact: |Ft/Fn| up to {largest}");
    eprintln!("largest |Ft/Fn| {largest:.5}, largest asymmetry {worst:.3e}");
    assert!(worst <= 1e-6 * largest, "asymmetry {worst} of {largest}");
}

/// Finite against small strain at a small indentation: the kinematics
/// differ by terms of the order of the strain, so at 0.05 mm (a tenth of
/// the runs' indentation) the press forces agree within 0.5% (measured:
/// -0.03%; CalculiX's C3D20R NLGEOM over its linear run: -0.38%, the
/// tolerance covers both), while at 0.5 mm finite strain carries 1.9% more
/// (asserted above 1%): the finite-strain finger is the small-strain one
/// where strains are small.
#[test]
fn finite_strain_press_tends_to_small_strain() {
    let flat = SurfaceShape::Flat;
    let mut small = half_disc(flat.clone(), Some(0.0), Kinematics::Small);
    small.slide_mm = 0.2;
    let mut finite = half_disc(flat, Some(0.0), Kinematics::Finite);
    finite.slide_mm = 0.2;
    let deep =
        (press_force(&run(&small, 0.0, &mut |_| {}).unwrap()), press_force(&run(&finite, 0.0, &mut |_| {}).unwrap()));
    small.loading = Loading::Indent(0.05);
    finite.loading = Loading::Indent(0.05);
    let shallow =
        (press_force(&run(&small, 0.0, &mut |_| {}).unwrap()), press_force(&run(&finite, 0.0, &mut |_| {}).unwrap()));
    let ratio = |(s, f): (f64, f64)| f / s - 1.0;
    eprintln!("finite over small: {:+.4}% at 0.05 mm, {:+.4}% at 0.5 mm", 100.0 * ratio(shallow), 100.0 * ratio(deep));
    assert!(ratio(shallow).abs() < 0.005);
    assert!(ratio(deep) > 0.01);
}

/// The last press force (N) of a CalculiX press curve
/// `indent_mm,fn_n,ft_n` of validation/calculix3d/results.
fn calculix_press(name: &str) -> f64 {
    let path = format!("{}/../../validation/calculix3d/results/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let last = text.lines().last().unwrap();
    last.split(',').nth(1).unwrap().parse().unwrap()
}

/// The finite-strain effect on the press against CalculiX's NLGEOM with
/// quadratic bricks (validation/calculix3d, the `press_mu0_*_C3D20R_default`
/// decks: haptex's default fingertip mesh of data/finger/half-disc.toml
/// with a node at each edge's middle, frictionless surface-to-surface
/// contact, `*HYPERELASTIC, NEO HOOKE`, whose volumetric function haptex's
/// `Volumetric::Quadratic` is). The ratio of the finite- to the
/// small-strain press force at 0.5 mm is compared, so that the elements'
/// offset on this mesh (CalculiX's linear run is 1.0% below haptex's)
/// cancels.
///
/// Measured: haptex +1.53%, CalculiX +1.57% (default mesh); on the coarse
/// mesh +1.78% and +1.46%. Tolerance 0.2 percentage points: below the
/// coarse mesh's difference (0.32), above the default mesh's (0.04), and
/// far below the effect itself and the spread of CalculiX's linear
/// elements under NLGEOM on the coarse mesh (C3D8I -4.9%, C3D8 +2.9%),
/// which is why the quadratic element is the reference. The default mesh
/// at finite strain takes about 25 s.
#[test]
fn finite_strain_press_matches_calculix_nlgeom() {
    let ccx = calculix_press("press_mu0_nlgeom_C3D20R_default_press.csv")
        / calculix_press("press_mu0_linear_C3D20R_default_press.csv")
        - 1.0;
    let mut small = half_disc(SurfaceShape::Flat, Some(0.0), Kinematics::Small);
    small.resolution = Resolution::Default;
    small.slide_mm = 0.2;
    let mut finite = small.clone();
    finite.kinematics = Kinematics::Finite;
    let s = press_force(&run(&small, 0.0, &mut |_| {}).unwrap());
    let f = press_force(&run_with_volumetric(&finite, 0.0, Volumetric::Quadratic, &mut |_| {}).unwrap());
    let haptex = f / s - 1.0;
    eprintln!(
        "finite over small strain at 0.5 mm: haptex {:+.3}%, CalculiX C3D20R {:+.3}%",
        100.0 * haptex,
        100.0 * ccx
    );
    assert!((haptex - ccx).abs() < 0.002, "haptex {haptex:+.5} vs CalculiX {ccx:+.5}");
}

/// Under a load at finite strain the drive is an unknown of each contact
/// solve, with the tangent's load per mm of it: the frictionless elastic
/// half-disc pressed by 0.3 N holds it, and an indentation to the depth
/// it found gives the same force (an elastic frictionless press does not
/// depend on its path). Measured: 0.3 N at 0.4951 mm, and the
/// indentation there 1.3e-11 from it (on the shipped finger, coarse, 5e-11);
/// asserted 1e-8 (the outer iteration stops at 1e-9 of the largest nodal
/// contact force).
#[test]
fn under_a_load_finite_strain_lands_where_the_indentation_gives_the_load() {
    let press = |loading: Loading| {
        let mut s = half_disc(SurfaceShape::Flat, Some(0.0), Kinematics::Finite);
        s.loading = loading;
        s.slide_mm = 0.0;
        run(&s, 0.0, &mut |_| {}).unwrap()
    };
    let loaded = press(Loading::Load(0.3));
    let last = loaded.history.last().unwrap();
    assert!((last.fn_n / 0.3 - 1.0).abs() < 1e-8, "load {}", last.fn_n);
    // The touch's micrometre is part of the depth the indentation takes.
    let depth = -last.drive_z_mm;
    assert!(depth > 0.1 && depth < 1.0, "depth {depth} mm");
    let indented = press(Loading::Indent(depth));
    let force = indented.history.last().unwrap().fn_n;
    eprintln!("0.3 N at {depth:.6} mm; the indentation there gives {force:.12} N");
    assert!((force / last.fn_n - 1.0).abs() < 1e-8, "{force} against {}", last.fn_n);
}

/// On a display at finite strain, as in small strain
/// (tests/sliding_3d.rs): the load is held, and in full slip the friction
/// is Coulomb's on the total contact pressure, Ft = mu (Fn + Fe), Fe the
/// attraction (measured 1 - Ft/(mu (Fn + Fe)) = 1.9e-7 after 2 mm on the
/// shipped finger, coarse: the penalty's elastic slip at the patch's
/// edge; tolerance 1e-6 as in small strain); the attraction on skin in contact
/// is eq. (3)'s pressure on the real contact area (to rounding).
#[test]
fn on_a_display_full_slip_is_coulomb_on_the_total_pressure_at_finite_strain() {
    use haptex_core::electrovibration::LayerStack;
    use haptex_fem::contact::Electrostatic;

    let u_v = 100.0;
    let mut s = Scenario::paper(SurfaceShape::Flat);
    s.resolution = Resolution::Coarse;
    s.kinematics = Kinematics::Finite;
    s.loading = Loading::Load(0.3);
    s.slide_mm = 2.0;
    s.step_mm = 0.1;
    s.mu_skin = Some(0.4);
    s.display = Some(common::constant_display(u_v));
    let r = run(&s, 0.0, &mut |_| {}).unwrap();
    for row in &r.history[s.press_steps - 1..] {
        assert!((row.fn_n / 0.3 - 1.0).abs() < 1e-7, "load not held: {row:?}");
    }
    let last = r.history.last().unwrap();
    let coulomb = last.ft_n / (0.4 * (last.fn_n + last.fe_n));
    eprintln!("Fn {:.6} N, Fe {:.6} N, Ft/(mu (Fn + Fe)) - 1 = {:.2e}", last.fn_n, last.fe_n, coulomb - 1.0);
    assert!(last.fe_n > 0.01, "the display attracts: {} N", last.fe_n);
    assert!((coulomb - 1.0).abs() < 1e-6, "Ft/(mu (Fn + Fe)) = {coulomb}");
    let p0 = Electrostatic::new(&LayerStack::PAPER, u_v).pressure_mpa;
    assert!((last.fe_contact_n / (p0 * last.contact_area_mm2) - 1.0).abs() < 1e-12);
}
