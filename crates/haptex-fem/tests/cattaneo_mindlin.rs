//! Cattaneo-Mindlin partial slip in 2D (Johnson, Contact Mechanics, 1985,
//! sec. 7.2): a cylinder pressed on a rigid flat and then loaded
//! tangentially by Q < mu P sticks over a central zone of half-width
//! c = a sqrt(1 - Q/(mu P)) and slips outside it. The classical result
//! assumes normal and tangential responses uncouple, which holds exactly
//! for an incompressible body on a rigid flat (Dundurs' beta = 0), so the
//! cylinder here has nu = 0.4999 (B-bar elements). R = 8 mm, rigid core
//! r = 2 mm pressed by 0.08 mm then moved sideways; mu = 0.5. The stick
//! zone is read from the contact points' stick/slip state and compared for
//! three tangential loads. Tolerance 5% of a (the zone's edge is located
//! to within one contact-point spacing, 6 um, 1% of a).

mod common;

use haptex_fem::analytic::cattaneo_stick_ratio;
use haptex_fem::contact::ContactLaw;
use haptex_fem::material::Material;
use haptex_fem::solver::{Drive, Solver, SolverSettings};

#[test]
fn cattaneo_mindlin_stick_zone() {
    let mu = 0.5;
    let law = ContactLaw {
        penalty_normal: 2000.0,
        penalty_tangential: 2000.0,
        mu,
        smoothing_mm: 0.0,
        geometric_tangent: false,
        electrostatic: None,
    };
    let problem = common::cylinder_on_flat(8.0, 2.0, 0.025, 2.0, Material::elastic(1.0, 0.4999), law);
    let mut solver = Solver::new(problem, SolverSettings::default(), 0.0).unwrap();
    let delta = 0.08;
    for k in 1..=8 {
        solver.advance(1.0, 0.0, Drive::Displacement([0.0, -delta * k as f64 / 8.0])).unwrap();
    }
    let weights = solver.problem.contact.point_weights();
    let mut checked = 0;
    // Move the core sideways in small steps; check at several loads.
    for k in 1..=60 {
        let dx = 0.002 * k as f64;
        let report = solver.advance(1.0, 0.0, Drive::Displacement([dx, -delta])).unwrap();
        let (q, p) = (report.totals.force[0].abs(), report.totals.force[1]);
        let ratio = q / (mu * p);
        if !(0.2..0.85).contains(&ratio) || k % 3 != 0 {
            continue;
        }
        let u_s: Vec<f64> =
            solver.problem.contact.nodes.iter().flat_map(|&n| [solver.u[2 * n], solver.u[2 * n + 1]]).collect();
        let positions = solver.problem.contact.point_positions(&u_s);
        let states = &solver.problem.contact.committed;
        // Contact half-width from the pressure's second moment (as in the
        // Hertz test), stick zone from the extreme sticking points.
        let (mut total, mut second, mut centre) = (0.0, 0.0, 0.0);
        for ((x, s), w) in positions.iter().zip(states).zip(&weights) {
            total += s.pressure * w;
            centre += x[0] * s.pressure * w;
        }
        centre /= total;
        for ((x, s), w) in positions.iter().zip(states).zip(&weights) {
            second += (x[0] - centre).powi(2) * s.pressure * w;
        }
        let a = 2.0 * (second / total).sqrt();
        let stick: Vec<f64> =
            positions.iter().zip(states).filter(|(_, s)| s.active && !s.slipping).map(|(x, _)| x[0]).collect();
        let c = 0.5
            * (stick.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - stick.iter().cloned().fold(f64::INFINITY, f64::min));
        let expected = cattaneo_stick_ratio(q, mu, p);
        eprintln!("Q/(mu P) = {ratio:.3}: c/a = {:.3}, Cattaneo-Mindlin {expected:.3}", c / a);
        assert!((c / a - expected).abs() < 0.05, "c/a = {} vs {expected}", c / a);
        checked += 1;
    }
    assert!(checked >= 3, "only {checked} loads in range");
}
