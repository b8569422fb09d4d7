//! The 3D chain against the 2D model: the 2D finger's cross-section
//! extruded into a slice one hexahedron deep, held in y (plane strain
//! exactly, solid3d::extrude), pressed and slid over a bump by the 3D
//! solver (solid3d::slide), must give the 2D model's forces per mm of
//! width (crate::scenario, validated against CalculiX in
//! tests/calculix_reference.rs).
//!
//! What differs is only how each integrates the contact: the 2D model has
//! four Gauss points per skin segment and measures depth to the closest
//! point of the surface's curve, the 3D one 4 x 4 points per face and
//! depth to the surface's tangent plane. Measured at the coarse mesh
//! (this test): 0.003% of the largest force and 0.00004 in Ft/Fn. (Before
//! the 3D first touch was found from the contact's own points: 0.11% and
//! 0.00037; with 2 x 2 points as well, 0.20% and 0.0021.) Tolerance: 0.05%
//! and 0.0005.

use haptex_fem::finger::Resolution;
use haptex_fem::scenario::{self, Scenario};
use haptex_fem::solid3d::extrude::plane_strain_slice;
use haptex_fem::solid3d::slide;
use haptex_fem::surface::SurfaceShape;

#[test]
fn plane_strain_slice_slides_as_the_2d_finger() {
    let mut s = Scenario::paper(SurfaceShape::Bump { x0: 1.5, width: 1.5, height: 0.2 });
    s.resolution = Resolution::Coarse;
    s.slide_mm = 3.0;
    let two = scenario::run(&s, &mut |_| {}).unwrap();
    let width = 1.0;
    let slice = plane_strain_slice(&s.model, s.resolution, width).unwrap();
    let three = slide::run_finger(slice, &s, 0.0, &mut |_| {}).unwrap();
    assert_eq!(two.history.len(), three.history.len());
    let largest = two.history.iter().map(|r| r.fn_n).fold(0.0, f64::max);
    let (mut force, mut mu) = (0.0f64, 0.0f64);
    for (a, b) in two.history.iter().zip(&three.history) {
        assert!((a.slide_mm - b.slide_mm).abs() < 1e-12);
        let (fn3, ft3) = (b.fn_n / width, b.ft_n / width);
        force = force.max((fn3 - a.fn_n).abs()).max((ft3 - a.ft_n).abs());
        if a.slide_mm > 0.0 {
            mu = mu.max((ft3 / fn3 - a.ft_n / a.fn_n).abs());
        }
        assert!(b.ft_lateral_n.abs() < 1e-9, "{b:?}");
    }
    eprintln!(
        "largest difference: {:.3}% of the largest Fn ({largest:.4} N/mm), {mu:.5} in Ft/Fn",
        100.0 * force / largest
    );
    assert!(force < 0.0005 * largest, "forces differ by {force} N/mm");
    assert!(mu < 0.0005, "Ft/Fn differs by {mu}");
}

/// The same slice on an electrovibration display under a voltage that
/// ramps from 0 to 150 V, then steps to 60 V (crate::display), pressed by
/// a constant load as `haptex check` presses: the 3D chain's attraction
/// (eq. (3) over the gap, on the contact region's 4 x 4 points per face)
/// must give the 2D model's forces. The 2D model attracts its whole lower
/// skin, the 3D one the skin up to 1.05 mm above the display (the rest
/// feels less than 3e-5 of the contact's traction).
///
/// Measured at the coarse mesh (this test): 0.0014% of the largest
/// contact force, 0.00002 in Ft/Fn, 0.008% of the largest attraction (the
/// attraction is a third of the contact force at 150 V). Tolerance: 0.05%
/// of the largest force, 0.0005 in Ft/Fn, and 0.5% of the largest
/// attraction.
#[test]
fn plane_strain_slice_feels_a_display_as_the_2d_finger() {
    use haptex_core::electrovibration::LayerStack;
    use haptex_core::signal::{Extend, VoltageCurve};
    use haptex_fem::display::Display;
    use haptex_fem::scenario::Loading;

    let mut s = Scenario::paper(SurfaceShape::Flat);
    s.resolution = Resolution::Coarse;
    s.slide_mm = 3.0;
    s.loading = Loading::Load(0.0133);
    s.display = Some(Display {
        voltage: VoltageCurve::new(vec![0.0, 2.0, 2.05, 3.0], vec![0.0, 150.0, 60.0, 60.0]).unwrap(),
        extend: Extend::Hold,
        stack: LayerStack::PAPER,
        vibration: None,
        air_gap_um: 0.0,
    });
    let two = scenario::run(&s, &mut |_| {}).unwrap();
    let width = 1.0;
    let slice = plane_strain_slice(&s.model, s.resolution, width).unwrap();
    let three = slide::run_finger(slice, &s, 0.0, &mut |_| {}).unwrap();
    assert_eq!(two.history.len(), three.history.len());
    let largest = two.history.iter().map(|r| r.fn_n + r.fe_n).fold(0.0, f64::max);
    let attraction = two.history.iter().map(|r| r.fe_n).fold(0.0, f64::max);
    assert!(attraction > 0.2 * largest, "the voltage must matter: Fe {attraction}, Fn {largest}");
    let (mut force, mut mu, mut fe) = (0.0f64, 0.0f64, 0.0f64);
    for (a, b) in two.history.iter().zip(&three.history) {
        assert!((a.slide_mm - b.slide_mm).abs() < 1e-12);
        let (fn3, ft3, fe3) = (b.fn_n / width, b.ft_n / width, b.fe_n / width);
        force = force.max((fn3 - a.fn_n).abs()).max((ft3 - a.ft_n).abs());
        fe = fe.max((fe3 - a.fe_n).abs());
        if a.slide_mm > 0.0 {
            mu = mu.max((ft3 / fn3 - a.ft_n / a.fn_n).abs());
        }
    }
    eprintln!(
        "largest difference: {:.4}% of the largest contact force ({largest:.4} N/mm), {mu:.6} in Ft/Fn, {:.4}% of \
         the largest attraction ({attraction:.4} N/mm)",
        100.0 * force / largest,
        100.0 * fe / attraction
    );
    assert!(force < 0.0005 * largest, "forces differ by {force} N/mm");
    assert!(mu < 0.0005, "Ft/Fn differs by {mu}");
    assert!(fe < 0.005 * attraction, "attractions differ by {fe} N/mm");
}
