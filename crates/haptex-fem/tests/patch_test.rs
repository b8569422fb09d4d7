//! Patch test (Zienkiewicz & Taylor, The Finite Element Method, vol. 1,
//! 6th ed., 2005, ch. 10): on a distorted mesh, prescribing a linear
//! displacement field on the boundary must reproduce it exactly inside and
//! give the exact constant stress, for the plain and the B-bar element.
//! Tolerance: 1e-12 relative (round-off).
//!
//! ```text
//!   +----+-----+---+     4x4 nodes, interior nodes moved by up to 0.24,
//!   |    |    /    |     edge nodes slid along the edges; all boundary
//!   +---+-----+----+     nodes prescribed, the 4 interior nodes free.
//!   |    \   |     |
//!   +-----+---+----+
//!   |     |    \   |
//!   +-----+-----+--+
//! ```

mod common;

use haptex_fem::body::{Body, SubdomainModel};
use haptex_fem::element::Formulation;
use haptex_fem::material::Material;
use haptex_fem::statics::LinearSystem;

fn field(p: [f64; 2]) -> [f64; 2] {
    [0.01 + 0.002 * p[0] - 0.003 * p[1], -0.02 + 0.001 * p[0] + 0.004 * p[1]]
}

#[test]
fn patch_test_linear_field_plain_and_bbar() {
    for formulation in [Formulation::Plain, Formulation::BBar] {
        for nu in [0.3, 0.4999] {
            let (mesh, boundary) = common::distorted_patch();
            let material = Material::elastic(2.0, nu);
            let mut body = Body::new(mesh, vec![SubdomainModel::Deformable(material.clone())], formulation).unwrap();
            let prescribed: Vec<usize> = boundary.iter().flat_map(|&n| [2 * n, 2 * n + 1]).collect();
            let mut system = LinearSystem::new(&body, &prescribed, 1).unwrap();
            let n = body.mesh.n_nodes();
            let mut u = vec![0.0; 2 * n];
            for &b in &boundary {
                let [ux, uy] = field(body.mesh.nodes[b]);
                u[2 * b] = ux;
                u[2 * b + 1] = uy;
            }
            system.step(&mut body, 0.0, &mut u, &vec![0.0; 2 * n]).unwrap();
            for node in 0..n {
                let exact = field(body.mesh.nodes[node]);
                for k in 0..2 {
                    let error = (u[2 * node + k] - exact[k]).abs();
                    assert!(
                        error < 1e-12 * 0.03,
                        "{formulation:?} nu {nu}: node {node}: {} vs {}",
                        u[2 * node + k],
                        exact[k]
                    );
                }
            }
            // Exact plane-strain stress of eps = (0.002, 0.004, 0, xy 0.5 * (-0.003 + 0.001)).
            let (g, lambda) = (material.shear_mpa(), material.bulk_mpa() - 2.0 / 3.0 * material.shear_mpa());
            let eps = [0.002, 0.004, 0.0, -0.001];
            let tr = eps[0] + eps[1];
            let exact = [lambda * tr + 2.0 * g * eps[0], lambda * tr + 2.0 * g * eps[1], lambda * tr, 2.0 * g * eps[3]];
            for e in 0..body.mesh.n_elements() {
                for gp in 0..4 {
                    let s = body.stress(e, gp, &u);
                    for k in 0..4 {
                        assert!(
                            (s[k] - exact[k]).abs() < 1e-11 * (1.0 + exact[k].abs()),
                            "{formulation:?} nu {nu}: {s:?} vs {exact:?}"
                        );
                    }
                }
            }
        }
    }
}
