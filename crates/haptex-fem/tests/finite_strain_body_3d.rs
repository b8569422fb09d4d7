//! Validation of the 3D finite-strain body (`haptex_fem::solid3d::finite_body`)
//! against closed forms: the finite-strain patch test, uniaxial
//! compression to 40% and Prony relaxation of a held shear. Each test
//! names its source and tolerance.

// Numeric checks index several arrays with one loop variable (as the library).
#![allow(clippy::needless_range_loop)]

use haptex_fem::material::{Material, PronyTerm};
use haptex_fem::solid3d::finite_body::{FiniteBody3, StaticSettings};
use haptex_fem::solid3d::finite_hex8::{NeoHookean3, Volumetric, det3};
use haptex_fem::solid3d::mesh::{Mesh3, Side};

const L: f64 = 2.0;

/// A 3 x 3 x 3 block of side L whose interior nodes are moved off the grid
/// (by up to 0.12 mm), so that no element is a box.
fn distorted_block() -> Mesh3 {
    let c = [0.0, 0.6, 1.3, L];
    let mut mesh = Mesh3::block(&c, &c, &c).unwrap();
    mesh.map(|[x, y, z]| {
        let interior = [x, y, z].iter().all(|&v| v > 1e-9 && v < L - 1e-9);
        if interior {
            [x + 0.12 * (y - 1.0).signum() * 0.5, y - 0.1 * (z - 1.0), z + 0.08 * (x - 1.0)]
        } else {
            [x, y, z]
        }
    });
    mesh
}

/// Every DOF of the block's boundary nodes.
fn boundary_dofs(mesh: &Mesh3) -> Vec<usize> {
    (0..mesh.n_nodes())
        .filter(|&a| mesh.nodes[a].iter().any(|&v| v.abs() < 1e-9 || (v - L).abs() < 1e-9))
        .flat_map(|a| [3 * a, 3 * a + 1, 3 * a + 2])
        .collect()
}

/// The displacements (3 per node) of the homogeneous deformation `f`.
fn affine_field(f: &[[f64; 3]; 3], nodes: &[[f64; 3]]) -> Vec<f64> {
    (0..3 * nodes.len())
        .map(|d| (0..3).map(|k| f[d % 3][k] * nodes[d / 3][k]).sum::<f64>() - nodes[d / 3][d % 3])
        .collect()
}

fn times(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|k| (0..3).map(|l| a[i][l] * b[l][k]).sum()))
}

fn cofactor(f: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| {
        std::array::from_fn(|k| {
            let (i1, i2, k1, k2) = ((i + 1) % 3, (i + 2) % 3, (k + 1) % 3, (k + 2) % 3);
            f[i1][k1] * f[i2][k2] - f[i1][k2] * f[i2][k1]
        })
    })
}

fn sym(s: &[f64; 6]) -> [[f64; 3]; 3] {
    [[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]]
}

/// The virial of the internal forces, sum_a f_a (x) X_a over all nodes: V P
/// for a homogeneous state (the forces of free nodes vanish, and the
/// prescribed nodes' are the reactions).
fn virial(mesh: &Mesh3, f: &[f64]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|k| (0..mesh.n_nodes()).map(|a| f[3 * a + i] * mesh.nodes[a][k]).sum()))
}

/// Patch test at finite strain (Zienkiewicz & Taylor 2005, sec. 9.3): the
/// boundary nodes of the distorted block follow F (shear, stretch and a
/// volume change of -10%); Newton's method on the interior nodes from the
/// undeformed state, in 3 sub-steps, reproduces the affine field (1e-10
/// mm), and the reactions' virial is V P with the analytic first
/// Piola-Kirchhoff stress P = J sigma F^-T (1e-10 relative), for both
/// volumetric functions.
#[test]
fn patch_test_homogeneous_finite_deformation() {
    let f = [[0.93, 0.15, 0.0], [-0.05, 0.96, 0.08], [0.04, 0.0, 1.02]];
    for volumetric in [Volumetric::SimoTaylor, Volumetric::Quadratic] {
        let mesh = distorted_block();
        let material = Material::elastic(0.1, 0.45);
        let prescribed = boundary_dofs(&mesh);
        let affine = affine_field(&f, &mesh.nodes);
        let n = 3 * mesh.n_nodes();
        let n_elements = mesh.elements.len();
        let mut body =
            FiniteBody3::new(mesh, vec![material.clone()], vec![0; n_elements], volumetric, &prescribed).unwrap();
        let mut u = vec![0.0; n];
        let settings = StaticSettings { increments: 3, ..StaticSettings::default() };
        let report = body.step(0.0, &mut u, &affine, &vec![0.0; n], &settings).unwrap();
        assert_eq!(report.halvings, 0);
        for d in 0..n {
            assert!((u[d] - affine[d]).abs() < 1e-10, "{volumetric:?} DOF {d}: {} vs {}", u[d], affine[d]);
        }
        let law = NeoHookean3::from_material(&material).with_volumetric(volumetric);
        let p = times(&sym(&law.cauchy_stress(&f)), &cofactor(&f));
        let v = virial(&body.mesh, &body.committed_forces(&u).unwrap());
        let scale = p.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        let volume = L * L * L;
        for i in 0..3 {
            for k in 0..3 {
                assert!(
                    (v[i][k] - volume * p[i][k]).abs() < 1e-10 * volume * scale,
                    "{i}{k}: {} vs {}",
                    v[i][k] / volume,
                    p[i][k]
                );
            }
        }
    }
}

/// Uniaxial compression to 40% of the height (Holzapfel 2000, sec. 6.5:
/// the homogeneous solution F = diag(lt, lt, 0.6), lt from sigma_xx = 0):
/// the distorted block on rollers (x = 0, y = 0 and z = 0 held normal),
/// its top pushed down by 0.8 mm and its sides free. The lateral stretch at
/// the free sides (1e-9 mm) and the force on the top, sigma_zz times the
/// current area (1e-9 relative), against the closed form solved for lt by
/// bisection to round-off; both volumetric functions. A small-strain
/// body would carry E eps A0 = 0.04 N here; the neo-Hookean one carries
/// about twice that, which the test also states.
#[test]
fn uniaxial_compression_matches_analytic() {
    let material = Material::elastic(0.1, 0.45);
    let stretch = 0.6;
    for volumetric in [Volumetric::SimoTaylor, Volumetric::Quadratic] {
        let law = NeoHookean3::from_material(&material).with_volumetric(volumetric);
        // sigma_xx(lt) = 0 by bisection: it rises with lt.
        let sxx = |lt: f64| law.cauchy_stress(&[[lt, 0.0, 0.0], [0.0, lt, 0.0], [0.0, 0.0, stretch]])[0];
        let (mut lo, mut hi) = (1.0, 2.0);
        assert!(sxx(lo) < 0.0 && sxx(hi) > 0.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if sxx(mid) < 0.0 { lo = mid } else { hi = mid }
        }
        let lt = 0.5 * (lo + hi);
        let f_analytic = [[lt, 0.0, 0.0], [0.0, lt, 0.0], [0.0, 0.0, stretch]];
        let top_force = law.cauchy_stress(&f_analytic)[2] * (lt * L) * (lt * L);

        let mesh = distorted_block();
        let mut prescribed = Vec::new();
        for (side, dir) in [(Side::XMin, 0), (Side::YMin, 1), (Side::ZMin, 2), (Side::ZMax, 2)] {
            prescribed.extend(mesh.side_nodes(side).into_iter().map(|a| 3 * a + dir));
        }
        let top = mesh.side_nodes(Side::ZMax);
        let n = 3 * mesh.n_nodes();
        let mut target = vec![0.0; n];
        for &a in &top {
            target[3 * a + 2] = (stretch - 1.0) * L;
        }
        let n_elements = mesh.elements.len();
        let mut body =
            FiniteBody3::new(mesh, vec![material.clone()], vec![0; n_elements], volumetric, &prescribed).unwrap();
        let mut u = vec![0.0; n];
        let settings = StaticSettings { increments: 4, ..StaticSettings::default() };
        body.step(0.0, &mut u, &target, &vec![0.0; n], &settings).unwrap();
        for &a in &body.mesh.side_nodes(Side::XMax) {
            assert!(
                (u[3 * a] - (lt - 1.0) * L).abs() < 1e-9,
                "{volumetric:?} node {a}: {} vs {}",
                u[3 * a],
                (lt - 1.0) * L
            );
        }
        let f = body.committed_forces(&u).unwrap();
        let force: f64 = top.iter().map(|&a| f[3 * a + 2]).sum();
        assert!((force - top_force).abs() < 1e-9 * top_force.abs(), "{volumetric:?}: {force} vs {top_force} N");
        let linear = material.e_mpa * (1.0 - stretch) * L * L;
        assert!(-force > 1.5 * linear && -force < 3.0 * linear, "{force} N against {linear} N in small strain");
    }
}

/// Prony relaxation at finite strain (Simo 1987; Holzapfel 2000, sec.
/// 6.10): an isochoric simple shear of 40% applied over t0 = 1e-9 s (one
/// step) and held for 3 s in steps of 0.05 s. Under a held deformation the
/// isochoric second Piola-Kirchhoff stress is g(t) S0_iso with the
/// convolution of the relaxation function with a ramp of S0 over [0, t0],
/// g(t) = g_inf + sum g_i (tau_i/t0) (1 - exp(-t0/tau_i)) exp(-(t -
/// t0)/tau_i), for which the recursion is exact (it assumes S0 linear in
/// time over a step); the pressure is elastic. The reactions' virial
/// against V (F g(t) S0_iso + J p F^-T) at every step, 1e-9 relative.
#[test]
fn prony_relaxation_of_a_held_shear() {
    let material = Material {
        e_mpa: 0.1,
        nu: 0.45,
        prony: vec![PronyTerm { g: 0.3, tau_s: 0.1 }, PronyTerm { g: 0.4, tau_s: 1.0 }],
    };
    let f = [[1.0, 0.4, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert!((det3(&f) - 1.0).abs() < 1e-15);
    let mesh = distorted_block();
    let prescribed = boundary_dofs(&mesh);
    let target = affine_field(&f, &mesh.nodes);
    let n = 3 * mesh.n_nodes();
    let n_elements = mesh.elements.len();
    let mut body =
        FiniteBody3::new(mesh, vec![material.clone()], vec![0; n_elements], Volumetric::SimoTaylor, &prescribed)
            .unwrap();
    let mut u = vec![0.0; n];
    let zero = vec![0.0; n];
    let settings = StaticSettings { increments: 2, ..StaticSettings::default() };
    let t0 = 1e-9;
    body.step(t0, &mut u, &target, &zero, &settings).unwrap();
    let law = NeoHookean3::from_material(&material);
    let s0 = sym(&law.isochoric_stress(&f));
    let (p, _) = Volumetric::SimoTaylor.derivatives(law.kappa, 1.0);
    let volume = L * L * L;
    let mut t = t0;
    let mut checked = 0;
    while t < 3.0 {
        let g = material.g_inf()
            + material
                .prony
                .iter()
                .map(|term| {
                    let x = t0 / term.tau_s;
                    term.g * (-(-x).exp_m1() / x) * (-(t - t0) / term.tau_s).exp()
                })
                .sum::<f64>();
        let s: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|k| g * s0[i][k]));
        let piola = times(&f, &s);
        let cof = cofactor(&f);
        let expected: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|k| piola[i][k] + p * cof[i][k]));
        let v = virial(&body.mesh, &body.committed_forces(&u).unwrap());
        let scale = expected.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        for i in 0..3 {
            for k in 0..3 {
                assert!(
                    (v[i][k] - volume * expected[i][k]).abs() < 1e-9 * volume * scale,
                    "t = {t} s, P{i}{k}: {} vs {}",
                    v[i][k] / volume,
                    expected[i][k]
                );
            }
        }
        checked += 1;
        body.step(0.05, &mut u, &target, &zero, &settings).unwrap();
        t += 0.05;
    }
    assert!(checked >= 60);
}

/// Inputs of the wrong size are refused with the size named, not a panic.
#[test]
fn wrong_lengths_are_refused() {
    let mesh = distorted_block();
    let n = 3 * mesh.n_nodes();
    let err =
        FiniteBody3::new(mesh.clone(), vec![Material::elastic(0.1, 0.45)], vec![0; 3], Volumetric::SimoTaylor, &[])
            .err()
            .unwrap();
    assert!(err.to_string().contains("element materials has 3 values"), "{err}");
    let err =
        FiniteBody3::new(mesh.clone(), vec![Material::elastic(0.1, 0.45)], vec![1; 27], Volumetric::SimoTaylor, &[])
            .err()
            .unwrap();
    assert!(err.to_string().contains("material 1"), "{err}");
    let mut body =
        FiniteBody3::new(mesh, vec![Material::elastic(0.1, 0.45)], vec![0; 27], Volumetric::SimoTaylor, &[0, 1, 2])
            .unwrap();
    let err = body.step(0.0, &mut vec![0.0; n], &[0.0; 5], &vec![0.0; n], &StaticSettings::default()).unwrap_err();
    assert!(err.to_string().contains("the targets has 5 values"), "{err}");
    let err =
        body.step(f64::NAN, &mut vec![0.0; n], &vec![0.0; n], &vec![0.0; n], &StaticSettings::default()).unwrap_err();
    assert!(err.to_string().contains("step size"), "{err}");
}
