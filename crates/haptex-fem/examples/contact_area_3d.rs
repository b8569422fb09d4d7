//! The layered 3D fingertip (solid3d::fingertip, the index finger's
//! default shape) pressed onto a rigid flat, frictionless, with the four
//! soft layers' instantaneous moduli (small strain, no visco-elasticity):
//! contact area against normal force, and k = A / F of eq. (8). A probe of
//! the 3D model while it is built (issue 39), not yet its physiology
//! check: the finger is driven at the bone and at the cap's sides.
//!
//!   cargo run --release -p haptex-fem --example contact_area_3d [DIVISIONS]

use haptex_fem::solid3d::contact::ContactSurface;
use haptex_fem::solid3d::fingertip::{FingertipSpec, mesh};
use haptex_fem::solid3d::hex8::Formulation;
use haptex_fem::solid3d::solver::ElasticBody;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let divisions = match std::env::args().nth(1) {
        Some(text) => text.parse().map_err(|e| format!("DIVISIONS '{text}': {e}"))?,
        None => 24,
    };
    let spec = FingertipSpec { surface_divisions: divisions, ..FingertipSpec::index_finger() };
    let f = mesh(&spec)?;
    let contact = ContactSurface::new(&f.mesh, &f.skin_faces);
    let prescribed: Vec<(usize, f64)> =
        f.driven_nodes.iter().flat_map(|&n| (0..3).map(move |d| (3 * n + d, 0.0))).collect();
    // Stratum corneum, viable epidermis, dermis, hypodermis: E (MPa), nu
    // (data/finger/finger-2d.toml).
    let materials = [(1.0, 0.48), (0.75, 0.48), (0.15, 0.48), (0.03, 0.48)];
    let started = std::time::Instant::now();
    let mut body =
        ElasticBody::new(f.mesh, Formulation::BBar, &materials, &f.element_layer, &prescribed, contact, 200.0)?;
    println!(
        "{} unknowns, Cholesky factor {} non-zeros, set up in {:.2} s",
        body.n_free(),
        body.factor_nnz(),
        started.elapsed().as_secs_f64()
    );
    println!("indent_mm,force_n,area_mm2,k_mm2_per_n,iterations,seconds");
    let mut previous: Option<(f64, Vec<f64>)> = None;
    for indent in [0.3, 0.5, 0.8, 1.1, 1.4] {
        let started = std::time::Instant::now();
        let guess = previous.as_ref().map(|(d, u)| u.iter().map(|v| v * indent / d).collect::<Vec<f64>>());
        let s = body.solve(indent, guess.as_deref())?;
        let area: f64 =
            s.pressure.iter().zip(&body.contact.points).filter(|(p, _)| **p > 0.0).map(|(_, c)| c.weight).sum();
        println!(
            "{indent},{:.4},{area:.2},{:.1},{},{:.2}",
            s.force_n,
            area / s.force_n,
            s.iterations,
            started.elapsed().as_secs_f64()
        );
        previous = Some((indent, s.u));
    }
    Ok(())
}
