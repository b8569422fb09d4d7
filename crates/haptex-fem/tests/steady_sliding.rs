//! Steady sliding on a flat (physics.md section 3): once the whole contact
//! slips, the field is stationary in the finger's frame and the apparent
//! friction Ft/Fn equals the Coulomb coefficient. Tolerance 1% (issue 3),
//! for the elastic and the visco-elastic finger. Also checks global
//! equilibrium at every step: the contact force on the skin balances the
//! reaction of bone and nail computed element by element from the tissue's
//! stresses (relative 1e-6, issue 3).

use haptex_fem::finger::Resolution;
use haptex_fem::scenario::{Scenario, run};
use haptex_fem::surface::SurfaceShape;

fn flat(viscoelastic: bool, mu: f64) -> haptex_fem::scenario::SimulationResult {
    let mut scenario = Scenario::paper(SurfaceShape::Flat);
    scenario.viscoelastic = viscoelastic;
    scenario.resolution = Resolution::Coarse;
    scenario.slide_mm = 3.0;
    scenario.step_mm = 0.05;
    scenario.mu_skin = Some(mu);
    run(&scenario, &mut |_| {}).unwrap()
}

#[test]
fn steady_sliding_flat_equals_coulomb_mu() {
    for viscoelastic in [false, true] {
        for mu in [0.3, 0.5, 0.8] {
            let result = flat(viscoelastic, mu);
            let profile = result.profile.as_ref().unwrap().mu();
            let x = result.profile.as_ref().unwrap().x_mm();
            // Fully sliding after the first millimetre.
            for (x, m) in x.iter().zip(profile).filter(|(x, _)| **x >= 1.0) {
                assert!((m / mu - 1.0).abs() < 0.01, "viscoelastic {viscoelastic}, mu {mu}: Ft/Fn = {m} at x = {x}");
            }
        }
    }
}

#[test]
fn global_equilibrium_contact_equals_reaction() {
    for viscoelastic in [false, true] {
        let result = flat(viscoelastic, 0.5);
        for row in &result.history {
            let contact = [-row.ft_n, row.fn_n];
            for k in 0..2 {
                let scale = row.fn_n.abs();
                assert!(
                    (contact[k] + row.reaction_n[k]).abs() <= 1e-6 * scale,
                    "t = {}: contact {contact:?} vs reaction {:?}",
                    row.t_s,
                    row.reaction_n
                );
            }
        }
    }
}
