//! Prony step relaxation through the 3D body's time stepping (the 2D
//! test's case, tests/prony_relaxation.rs, in 3D): a distorted block of
//! B-bar hexahedra held in simple shear gamma from t = 0 relaxes as
//! tau_xy / (G0 gamma) = G(t)/G0 = g_inf + sum g_i exp(-t/tau_i).
//! Material of physics.md's "Prony bar": E0 = 1, nu = 0.3, g = (0.3, 0.3),
//! tau = (0.01, 1) s: 1, 0.807, 0.672, 0.510, 0.400 at t = 0, 0.01, 0.1,
//! 1, 10 s (physics.md section 3). Tolerance: 0.5% of the table, and 1e-6
//! of the exact formula (the ramp of the first 1e-9 s step). A uniform
//! dilatation does not relax (the bulk modulus is elastic): its mean
//! stress stays K theta to 1e-12.

use haptex_fem::material::{Material, PronyTerm};
use haptex_fem::solid3d::body::ViscoelasticBody;
use haptex_fem::solid3d::hex8::Formulation;
use haptex_fem::solid3d::mesh::Mesh3;

fn prony_bar() -> Material {
    Material { e_mpa: 1.0, nu: 0.3, prony: vec![PronyTerm { g: 0.3, tau_s: 0.01 }, PronyTerm { g: 0.3, tau_s: 1.0 }] }
}

/// A 3 x 3 x 3 block of the unit cube with its interior nodes moved, and
/// its boundary nodes.
fn distorted_block() -> (Mesh3, Vec<usize>) {
    let c = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0];
    let mut mesh = Mesh3::block(&c, &c, &c).unwrap();
    let on_boundary = |p: [f64; 3]| p.iter().any(|&v| v == 0.0 || v == 1.0);
    let boundary: Vec<usize> = (0..mesh.n_nodes()).filter(|&n| on_boundary(mesh.nodes[n])).collect();
    let interior: Vec<usize> = (0..mesh.n_nodes()).filter(|&n| !on_boundary(mesh.nodes[n])).collect();
    for (k, n) in interior.into_iter().enumerate() {
        let s = [0.07, -0.05, 0.04, -0.06, 0.03, 0.05, -0.04, 0.06][k % 8];
        let p = &mut mesh.nodes[n];
        *p = [p[0] + s, p[1] - 0.5 * s, p[2] + 0.8 * s];
    }
    (mesh, boundary)
}

fn body(prescribed_nodes: &[usize], mesh: Mesh3) -> ViscoelasticBody {
    let prescribed: Vec<usize> = prescribed_nodes.iter().flat_map(|&n| [3 * n, 3 * n + 1, 3 * n + 2]).collect();
    let n_elements = mesh.elements.len();
    ViscoelasticBody::new(mesh, Formulation::BBar, vec![prony_bar()], vec![0; n_elements], &prescribed).unwrap()
}

#[test]
fn prony_step_relaxation_3d() {
    let material = prony_bar();
    let (mesh, boundary) = distorted_block();
    let mut b = body(&boundary, mesh);
    let n = b.mesh.n_nodes();
    let gamma = 0.01;
    let mut u = vec![0.0; 3 * n];
    for &node in &boundary {
        u[3 * node] = gamma * b.mesh.nodes[node][1];
    }
    let f = vec![0.0; 3 * n];
    let g0 = material.shear_mpa();
    let mut t = 0.0;
    for (target, table) in [(1e-9, 1.0), (0.01, 0.807), (0.1, 0.672), (1.0, 0.510), (10.0, 0.400)] {
        let steps = 4;
        let dt = (target - t) / steps as f64;
        for _ in 0..steps {
            b.step(dt, &mut u, &f).unwrap();
        }
        t = target;
        for e in 0..b.mesh.elements.len() {
            for gp in 0..8 {
                let s = b.stress(e, gp, &u);
                // tau_xy = 2 G eps_xy with eps_xy = gamma / 2.
                let ratio = s[3] / (g0 * gamma);
                assert!((ratio / table - 1.0).abs() < 0.005, "t = {t}: {ratio} vs table {table}");
                assert!((ratio - material.relaxation_ratio(t)).abs() < 1e-6, "t = {t}: {ratio}");
                for k in [0, 1, 2, 4, 5] {
                    assert!(s[k].abs() < 1e-12, "t = {t}: component {k} of {s:?}");
                }
            }
        }
    }
}

#[test]
fn a_dilatation_does_not_relax_3d() {
    let material = prony_bar();
    let (mesh, boundary) = distorted_block();
    let mut b = body(&boundary, mesh);
    let n = b.mesh.n_nodes();
    let strain = 0.001;
    let mut u = vec![0.0; 3 * n];
    for &node in &boundary {
        for k in 0..3 {
            u[3 * node + k] = strain * b.mesh.nodes[node][k];
        }
    }
    let f = vec![0.0; 3 * n];
    for dt in [1e-9, 0.01, 1.0, 10.0] {
        b.step(dt, &mut u, &f).unwrap();
        for e in 0..b.mesh.elements.len() {
            for gp in 0..8 {
                let s = b.stress(e, gp, &u);
                let p = material.bulk_mpa() * 3.0 * strain;
                for k in 0..3 {
                    assert!((s[k] - p).abs() < 1e-12, "dt {dt}: {s:?} vs mean stress {p}");
                }
                assert!(s[3].abs() < 1e-12 && s[4].abs() < 1e-12 && s[5].abs() < 1e-12);
            }
        }
    }
}
