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
