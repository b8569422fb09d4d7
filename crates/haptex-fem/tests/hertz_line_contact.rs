//! Plane-strain Hertz contact (Johnson, Contact Mechanics, 1985, sec. 4.3):
//! a homogeneous elastic cylinder, R = 8 mm, E = 1 MPa, nu = 0.3, pressed
//! frictionlessly onto the rigid flat by its rigid core (r = 2 mm):
//! half-width a = sqrt(4 P' R / (pi E*)) and peak pressure p0 = 2 P'/(pi a),
//! E* = E/(1 - nu^2), with P' the computed load per unit length. Tolerance 5%
//! (issue 3) at a/R < 0.15. The half-width is measured from the pressure
//! distribution's second moment (a^2 = 4 int x^2 p / int p for the Hertz
//! distribution), so it is not quantized by the node spacing.
//!
//! ```text
//!        .-~~~-.        rigid core (driven down by delta)
//!      /   (o)   \      elastic cylinder, pad spacing 25 um
//!      \         /
//!   =====`-._.-'=====   rigid flat, frictionless
//! ```

mod common;

use haptex_fem::analytic::{hertz_line_contact, hertz_pressure};
use haptex_fem::contact::ContactLaw;
use haptex_fem::material::Material;
use haptex_fem::solver::{Drive, Solver, SolverSettings};

#[test]
fn hertz_line_contact_half_width_and_peak_pressure() {
    let (e, nu, radius) = (1.0, 0.3, 8.0);
    let law = ContactLaw {
        penalty_normal: 2000.0,
        penalty_tangential: 2000.0,
        mu: 0.0,
        smoothing_mm: 0.0,
        geometric_tangent: false,
        electrostatic: None,
    };
    let problem = common::cylinder_on_flat(radius, 2.0, 0.025, 2.0, Material::elastic(e, nu), law);
    let mut solver = Solver::new(problem, SolverSettings::default(), 0.0).unwrap();
    let delta = 0.08;
    let steps = 8;
    for k in 1..=steps {
        solver.advance(1.0, 0.0, Drive::Displacement([0.0, -delta * k as f64 / steps as f64])).unwrap();
    }
    let report_force = solver.forces.chunks(2).map(|f| f[1]).sum::<f64>();
    let u_s: Vec<f64> =
        solver.problem.contact.nodes.iter().flat_map(|&n| [solver.u[2 * n], solver.u[2 * n + 1]]).collect();
    let profile = solver.problem.contact.pressure_profile(&u_s);
    // Integrate with the contact points' weights: sum p w = P'.
    let (mut p_total, mut second, mut p_max) = (0.0, 0.0, 0.0f64);
    let weights = solver.problem.contact.point_weights();
    for ((x, p, _), w) in profile.iter().zip(&weights) {
        p_total += p * w;
        second += x[0] * x[0] * p * w;
        p_max = p_max.max(*p);
    }
    let a_num = 2.0 * (second / p_total).sqrt();
    let (a, p0) = hertz_line_contact(radius, report_force, e, nu);
    eprintln!(
        "P' = {report_force:.5} N/mm, a = {a_num:.4} (Hertz {a:.4}), p0 = {p_max:.5} (Hertz {p0:.5}), a/R = {:.3}",
        a / radius
    );
    assert!((p_total / report_force - 1.0).abs() < 1e-9, "pressure integral {p_total} vs force {report_force}");
    assert!(a / radius < 0.15);
    assert!((a_num / a - 1.0).abs() < 0.05, "half-width {a_num} vs Hertz {a}");
    assert!((p_max / p0 - 1.0).abs() < 0.05, "peak pressure {p_max} vs Hertz {p0}");
    // The distribution itself: RMS difference to the Hertz curve below 5% of p0.
    let rms = (profile.iter().map(|(x, p, _)| (p - hertz_pressure(a, p0, x[0])).powi(2)).sum::<f64>()
        / profile.len() as f64)
        .sqrt();
    eprintln!("pressure RMS difference: {:.4} of p0", rms / p0);
    assert!(rms / p0 < 0.05);
}
