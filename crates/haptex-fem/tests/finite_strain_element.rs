//! Validation of the finite-strain element and material
//! (`haptex_fem::finite_element`, `haptex_fem::hyperelastic`): consistent
//! tangent, patch test, objectivity, small-strain limit, plane-strain
//! uniaxial compression and Prony relaxation against the analytic
//! neo-Hookean solutions. Each test names its source and tolerance.

// Numeric checks index several arrays with one loop variable (as the library).
#![allow(clippy::needless_range_loop)]

mod common;

use haptex_fem::body::{Body, SubdomainModel};
use haptex_fem::element::{Formulation, Q4};
use haptex_fem::finite_element::{cauchy_stress, deformation_gradient, internal_force, isochoric_stresses};
use haptex_fem::finite_solver::FiniteBody;
use haptex_fem::hyperelastic::NeoHookean;
use haptex_fem::material::{Material, PronyTerm};

const X: [[f64; 2]; 4] = [[0.0, 0.0], [2.0, 0.3], [2.4, 1.7], [-0.2, 1.2]];

fn law() -> NeoHookean {
    NeoHookean::from_material(&Material::elastic(0.1, 0.45))
}

/// A small deterministic pseudo-random sequence (no dependency).
fn lcg(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn affine(f: [[f64; 2]; 2], x: &[[f64; 2]]) -> Vec<f64> {
    x.iter().flat_map(|p| [(f[0][0] - 1.0) * p[0] + f[0][1] * p[1], f[1][0] * p[0] + (f[1][1] - 1.0) * p[1]]).collect()
}

/// The consistent tangent is the derivative of the internal force:
/// central differences (h = 1e-6) at random deformations of up to 30% and
/// a random frozen visco-elastic stress, 1e-6 relative to the tangent's
/// largest entry (Wriggers, Nonlinear FEM, 2008, sec. 4.2: the check of a
/// linearization).
#[test]
fn tangent_matches_finite_differences() {
    let q = Q4::new(&X).unwrap();
    let law = law();
    let mut seed = 7;
    for case in 0..20 {
        let u: [f64; 8] = std::array::from_fn(|_| 0.3 * lcg(&mut seed));
        let frozen: [[f64; 4]; 4] = std::array::from_fn(|_| std::array::from_fn(|_| 0.01 * lcg(&mut seed)));
        let ratio = 0.4 + 0.6 * lcg(&mut seed).abs();
        let mut k = [[0.0; 8]; 8];
        internal_force(&q, &u, &law, ratio, &frozen, Some(&mut k)).unwrap();
        let scale = k.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let h = 1e-6;
        for j in 0..8 {
            let (mut up, mut um) = (u, u);
            up[j] += h;
            um[j] -= h;
            let fp = internal_force(&q, &up, &law, ratio, &frozen, None).unwrap();
            let fm = internal_force(&q, &um, &law, ratio, &frozen, None).unwrap();
            for i in 0..8 {
                let fd = (fp[i] - fm[i]) / (2.0 * h);
                assert!((fd - k[i][j]).abs() < 1e-6 * scale, "case {case}: K[{i}][{j}] = {} vs fd {fd}", k[i][j]);
            }
        }
        for i in 0..8 {
            for j in 0..8 {
                assert!((k[i][j] - k[j][i]).abs() < 1e-12 * scale, "symmetric");
            }
        }
    }
}

/// At 1e-6 strain the finite-strain element force equals the small-strain
/// B-bar element's K u (Hughes 1980) to 1e-5 relative.
#[test]
fn small_displacement_limit_is_the_bbar_element() {
    let q = Q4::new(&X).unwrap();
    let m = Material::elastic(0.1, 0.45);
    let law = NeoHookean::from_material(&m);
    let k = q.stiffness(Formulation::BBar, m.shear_mpa(), m.bulk_mpa());
    let mut seed = 3;
    for _ in 0..10 {
        let u: [f64; 8] = std::array::from_fn(|_| 1e-6 * lcg(&mut seed));
        let f = internal_force(&q, &u, &law, 1.0, &[[0.0; 4]; 4], None).unwrap();
        let linear: Vec<f64> = (0..8).map(|i| (0..8).map(|j| k[i][j] * u[j]).sum()).collect();
        let scale = linear.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..8 {
            assert!((f[i] - linear[i]).abs() < 1e-5 * scale, "{i}: {} vs {}", f[i], linear[i]);
        }
    }
}

/// Objectivity (Holzapfel 2000, sec. 5.4): a rigid rotation by 30 degrees
/// of the undeformed element gives zero internal force (1e-12 of mu times
/// its size); a rotated stretched state gives the rotated nodal forces and
/// the rotated Cauchy stress (1e-12 relative).
#[test]
fn objectivity_under_rigid_rotation() {
    let q = Q4::new(&X).unwrap();
    let law = law();
    let t = 30f64.to_radians();
    let r = [[t.cos(), -t.sin()], [t.sin(), t.cos()]];
    let u: [f64; 8] = affine(r, &X).try_into().unwrap();
    let f = internal_force(&q, &u, &law, 1.0, &[[0.0; 4]; 4], None).unwrap();
    assert!(f.iter().all(|v| v.abs() < 1e-12 * law.mu * 2.0), "{f:?}");
    let stretch = [[1.1, 0.2], [0.05, 0.93]];
    let rotated = [
        [r[0][0] * stretch[0][0] + r[0][1] * stretch[1][0], r[0][0] * stretch[0][1] + r[0][1] * stretch[1][1]],
        [r[1][0] * stretch[0][0] + r[1][1] * stretch[1][0], r[1][0] * stretch[0][1] + r[1][1] * stretch[1][1]],
    ];
    // A non-affine perturbation on top, rotated with the rest.
    let bump = [0.03, -0.02, 0.01, 0.04, -0.02, 0.01, 0.02, -0.03];
    let x1: Vec<[f64; 2]> = (0..4)
        .map(|a| {
            let p = [X[a][0] + bump[2 * a], X[a][1] + bump[2 * a + 1]];
            [stretch[0][0] * p[0] + stretch[0][1] * p[1], stretch[1][0] * p[0] + stretch[1][1] * p[1]]
        })
        .collect();
    let u1: [f64; 8] = std::array::from_fn(|i| x1[i / 2][i % 2] - X[i / 2][i % 2]);
    let u2: [f64; 8] = std::array::from_fn(|i| {
        let p = x1[i / 2];
        let rp = [r[0][0] * p[0] + r[0][1] * p[1], r[1][0] * p[0] + r[1][1] * p[1]];
        rp[i % 2] - X[i / 2][i % 2]
    });
    let frozen = [[0.002, -0.001, 0.0005, 0.003]; 4];
    let f1 = internal_force(&q, &u1, &law, 0.7, &frozen, None).unwrap();
    let f2 = internal_force(&q, &u2, &law, 0.7, &frozen, None).unwrap();
    let scale = f1.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for a in 0..4 {
        let rf = [r[0][0] * f1[2 * a] + r[0][1] * f1[2 * a + 1], r[1][0] * f1[2 * a] + r[1][1] * f1[2 * a + 1]];
        assert!((rf[0] - f2[2 * a]).abs() < 1e-12 * scale && (rf[1] - f2[2 * a + 1]).abs() < 1e-12 * scale);
    }
    let s1 = law.cauchy_stress(&stretch);
    let s2 = law.cauchy_stress(&rotated);
    let m1 = [[s1[0], s1[3]], [s1[3], s1[1]]];
    let mut rsr = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            for k in 0..2 {
                for l in 0..2 {
                    rsr[i][j] += r[i][k] * m1[k][l] * r[j][l];
                }
            }
        }
    }
    let scale = s1.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (a, b) in [(rsr[0][0], s2[0]), (rsr[1][1], s2[1]), (s1[2], s2[2]), (rsr[0][1], s2[3])] {
        assert!((a - b).abs() < 1e-12 * scale, "{a} vs {b}");
    }
    // The element's own stress output agrees.
    let u: [f64; 8] = affine(rotated, &X).try_into().unwrap();
    let s_iso = isochoric_stresses(&q, &u, &law);
    for gp in 0..4 {
        let sigma = cauchy_stress(&q, gp, &u, &law, &s_iso[gp]);
        for k in 0..4 {
            assert!((sigma[k] - s2[k]).abs() < 1e-12 * scale);
        }
    }
}

/// Patch test (Zienkiewicz & Taylor 2005, sec. 9.3, at finite strain): the
/// boundary nodes of the distorted 3x3 patch follow the homogeneous
/// deformation F = [[1.1, 0.2], [0.05, 0.93]]; Newton on the interior nodes
/// from the undeformed state reproduces the affine field, and every Gauss
/// point the analytic neo-Hookean Cauchy stress (1e-10 relative).
#[test]
fn patch_test_homogeneous_finite_deformation() {
    let (mesh, boundary) = common::distorted_patch();
    let law = law();
    let f_hom = [[1.1, 0.2], [0.05, 0.93]];
    let exact = affine(f_hom, &mesh.nodes);
    let n = mesh.nodes.len();
    let geometry: Vec<Q4> = mesh.elements.iter().map(|e| Q4::new(&e.map(|a| mesh.nodes[a])).unwrap()).collect();
    let free: Vec<usize> = (0..2 * n).filter(|d| !boundary.contains(&(d / 2))).collect();
    let mut u: Vec<f64> = (0..2 * n).map(|d| if boundary.contains(&(d / 2)) { exact[d] } else { 0.0 }).collect();
    for _ in 0..20 {
        let mut f = vec![0.0; 2 * n];
        let mut k = vec![vec![0.0; 2 * n]; 2 * n];
        for (e, nodes) in mesh.elements.iter().enumerate() {
            let dofs: [usize; 8] = std::array::from_fn(|i| 2 * nodes[i / 2] + i % 2);
            let ue = dofs.map(|d| u[d]);
            let mut ke = [[0.0; 8]; 8];
            let fe = internal_force(&geometry[e], &ue, &law, 1.0, &[[0.0; 4]; 4], Some(&mut ke)).unwrap();
            for i in 0..8 {
                f[dofs[i]] += fe[i];
                for j in 0..8 {
                    k[dofs[i]][dofs[j]] += ke[i][j];
                }
            }
        }
        let r: Vec<f64> = free.iter().map(|&d| f[d]).collect();
        if r.iter().all(|v| v.abs() < 1e-14) {
            break;
        }
        // Dense Gaussian elimination on the free DOFs.
        let m = free.len();
        let mut a: Vec<Vec<f64>> = free.iter().map(|&i| free.iter().map(|&j| k[i][j]).collect()).collect();
        let mut b: Vec<f64> = r.iter().map(|v| -v).collect();
        for p in 0..m {
            for row in p + 1..m {
                let factor = a[row][p] / a[p][p];
                for c in p..m {
                    a[row][c] -= factor * a[p][c];
                }
                b[row] -= factor * b[p];
            }
        }
        for p in (0..m).rev() {
            let mut v = b[p];
            for c in p + 1..m {
                v -= a[p][c] * b[c];
            }
            b[p] = v / a[p][p];
        }
        for (i, &d) in free.iter().enumerate() {
            u[d] += b[i];
        }
    }
    for d in 0..2 * n {
        assert!((u[d] - exact[d]).abs() < 1e-10, "dof {d}: {} vs {}", u[d], exact[d]);
    }
    let sigma = law.cauchy_stress(&f_hom);
    let scale = sigma.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (e, nodes) in mesh.elements.iter().enumerate() {
        let ue: [f64; 8] = std::array::from_fn(|i| u[2 * nodes[i / 2] + i % 2]);
        let s_iso = isochoric_stresses(&geometry[e], &ue, &law);
        for gp in 0..4 {
            let f = deformation_gradient(&geometry[e], gp, &ue);
            for i in 0..2 {
                for j in 0..2 {
                    assert!((f[i][j] - f_hom[i][j]).abs() < 1e-10);
                }
            }
            let s = cauchy_stress(&geometry[e], gp, &ue, &law, &s_iso[gp]);
            for k in 0..4 {
                assert!((s[k] - sigma[k]).abs() < 1e-10 * scale, "element {e} gp {gp}: {s:?} vs {sigma:?}");
            }
        }
    }
}

/// Plane-strain uniaxial compression of a block (rollers on the left and
/// bottom, the right face moved by -20%, the top free) against the
/// analytic neo-Hookean solution: lateral stretch from sigma_yy = 0 and
/// the end force sigma_xx times the current height (1e-9 relative).
#[test]
fn plane_strain_uniaxial_compression_matches_analytic() {
    let law = law();
    let lambda = 0.8;
    // Analytic: find lambda_y with sigma_yy(diag(lambda, lambda_y)) = 0.
    let mut ly = 1.0;
    for _ in 0..100 {
        let s = law.cauchy_stress(&[[lambda, 0.0], [0.0, ly]])[1];
        let h = 1e-7;
        let ds = (law.cauchy_stress(&[[lambda, 0.0], [0.0, ly + h]])[1] - s) / h;
        ly -= s / ds;
    }
    let sigma_xx = law.cauchy_stress(&[[lambda, 0.0], [0.0, ly]])[0];
    // 3x2 block of 2 x 1 mm, elements of different widths.
    let xs = [0.0, 0.5, 1.3, 2.0];
    let ys = [0.0, 0.4, 1.0];
    let nodes: Vec<[f64; 2]> = ys.iter().flat_map(|&y| xs.iter().map(move |&x| [x, y])).collect();
    let mut elements = Vec::new();
    for j in 0..2 {
        for i in 0..3 {
            let n = 4 * j + i;
            elements.push([n, n + 1, n + 5, n + 4]);
        }
    }
    let geometry: Vec<Q4> = elements.iter().map(|e: &[usize; 4]| Q4::new(&e.map(|a| nodes[a])).unwrap()).collect();
    let nn = nodes.len();
    let mut fixed = vec![None; 2 * nn];
    for (a, p) in nodes.iter().enumerate() {
        if p[0] == 0.0 {
            fixed[2 * a] = Some(0.0);
        }
        if p[0] == 2.0 {
            fixed[2 * a] = Some((lambda - 1.0) * 2.0);
        }
        if p[1] == 0.0 {
            fixed[2 * a + 1] = Some(0.0);
        }
    }
    let free: Vec<usize> = (0..2 * nn).filter(|&d| fixed[d].is_none()).collect();
    let mut u: Vec<f64> = (0..2 * nn).map(|d| fixed[d].unwrap_or(0.0)).collect();
    let mut f = vec![0.0; 2 * nn];
    for _ in 0..30 {
        f = vec![0.0; 2 * nn];
        let mut k = vec![vec![0.0; 2 * nn]; 2 * nn];
        for (e, el) in elements.iter().enumerate() {
            let dofs: [usize; 8] = std::array::from_fn(|i| 2 * el[i / 2] + i % 2);
            let ue = dofs.map(|d| u[d]);
            let mut ke = [[0.0; 8]; 8];
            let fe = internal_force(&geometry[e], &ue, &law, 1.0, &[[0.0; 4]; 4], Some(&mut ke)).unwrap();
            for i in 0..8 {
                f[dofs[i]] += fe[i];
                for j in 0..8 {
                    k[dofs[i]][dofs[j]] += ke[i][j];
                }
            }
        }
        let m = free.len();
        let mut a: Vec<Vec<f64>> = free.iter().map(|&i| free.iter().map(|&j| k[i][j]).collect()).collect();
        let mut b: Vec<f64> = free.iter().map(|&d| -f[d]).collect();
        if b.iter().all(|v| v.abs() < 1e-15) {
            break;
        }
        for p in 0..m {
            for row in p + 1..m {
                let factor = a[row][p] / a[p][p];
                for c in p..m {
                    a[row][c] -= factor * a[p][c];
                }
                b[row] -= factor * b[p];
            }
        }
        for p in (0..m).rev() {
            let mut v = b[p];
            for c in p + 1..m {
                v -= a[p][c] * b[c];
            }
            b[p] = v / a[p][p];
        }
        for (i, &d) in free.iter().enumerate() {
            u[d] += b[i];
        }
    }
    let top = nodes.iter().position(|p| p[1] == 1.0).unwrap();
    assert!((1.0 + u[2 * top + 1] - ly).abs() < 1e-9, "lateral stretch {} vs {ly}", 1.0 + u[2 * top + 1]);
    let end_force: f64 = (0..nn).filter(|&a| nodes[a][0] == 2.0).map(|a| f[2 * a]).sum();
    let expected = sigma_xx * ly * 1.0;
    assert!((end_force / expected - 1.0).abs() < 1e-9, "end force {end_force} vs {expected}");
    eprintln!("plane-strain compression to 0.8: lateral stretch {ly:.6}, sigma_xx {sigma_xx:.6} MPa");
}

/// Finite-strain Prony relaxation (Simo 1987): a homogeneous stretch
/// F = [[1.3, 0.1], [0, 0.85]] applied in 1e-9 s and held. The isochoric
/// second Piola-Kirchhoff stress relaxes as G(t)/G0 = g_inf + sum g_i
/// exp(-t/tau_i) exactly; the Cauchy stress is then
/// F (ratio S0_iso) F^T / J + U'(J) I. Checked through the body's history
/// (FiniteBody::commit, element_stress) at physics.md's times, 1e-6
/// relative (the ramp of the first step).
#[test]
fn prony_relaxation_of_a_stretched_block() {
    let (mesh, _) = common::distorted_patch();
    let material = Material {
        e_mpa: 1.0,
        nu: 0.3,
        prony: vec![PronyTerm { g: 0.3, tau_s: 0.01 }, PronyTerm { g: 0.3, tau_s: 1.0 }],
    };
    let law = NeoHookean::from_material(&material);
    let f_hom = [[1.3, 0.1], [0.0, 0.85]];
    let u = affine(f_hom, &mesh.nodes);
    let body = Body::new(mesh, vec![SubdomainModel::Deformable(material.clone())], Formulation::BBar).unwrap();
    let mut state = FiniteBody::new(&body);
    state.commit(&body, &body.step_coefficients(1e-9), &u);
    let mut t = 1e-9;
    let j = f_hom[0][0] * f_hom[1][1] - f_hom[0][1] * f_hom[1][0];
    let s0 = law.isochoric(&f_hom).stress;
    for target in [0.01, 0.1, 1.0, 10.0] {
        state.commit(&body, &body.step_coefficients(target - t), &u);
        t = target;
        let ratio = material.relaxation_ratio(t);
        let s = s0.map(|v| ratio * v);
        let iso = haptex_fem::hyperelastic::push_forward(&f_hom, &s);
        let (p, _) = law.volumetric(j);
        let expected = [iso[0] + p, iso[1] + p, iso[2] + p, iso[3]];
        let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for e in 0..body.mesh.n_elements() {
            let sigma = state.element_stress(&body, e, &u);
            for k in 0..4 {
                assert!((sigma[k] - expected[k]).abs() < 1e-6 * scale, "t = {t}: {sigma:?} vs {expected:?}");
            }
        }
    }
}

/// The packed element loops (`FiniteBody::add_trial_internal_forces` and
/// `visit_trial_tangents`, four elements side by side in SIMD lanes) are
/// the element-by-element loop of `internal_force` to the bit, forces and
/// tangents: on the distorted patch (9 elements: two full blocks and one of
/// a single element) with a visco-elastic history, at random deformations
/// of up to 30%. An inverted element is reported as the element loop
/// reports it.
#[test]
fn packed_internal_forces_are_the_element_loop_to_the_bit() {
    let (mesh, _) = common::distorted_patch();
    let material = Material {
        e_mpa: 1.0,
        nu: 0.45,
        prony: vec![PronyTerm { g: 0.3, tau_s: 0.01 }, PronyTerm { g: 0.3, tau_s: 1.0 }],
    };
    let n = 2 * mesh.nodes.len();
    let law = NeoHookean::from_material(&material);
    let body = Body::new(mesh, vec![SubdomainModel::Deformable(material)], Formulation::BBar).unwrap();
    let mut state = FiniteBody::new(&body);
    let mut seed = 11;
    let mut random_u = |size: f64| -> Vec<f64> { (0..n).map(|_| size * lcg(&mut seed)).collect() };
    let history = random_u(0.1);
    state.commit(&body, &body.step_coefficients(0.003), &history);
    let c = body.step_coefficients(0.005);
    state.set_trial(&body, &c);
    let all = body.deformable_elements().to_vec();
    let mut compared = 0;
    for _ in 0..10 {
        let u = random_u(0.3);
        let (mut packed, mut looped) = (vec![0.0; n], vec![0.0; n]);
        let a = state.add_trial_internal_forces(&body, &u, &mut packed);
        let b = state.add_internal_forces(&body, Some(&c), &all, &u, &mut looped);
        assert_eq!(a, b);
        if a.is_err() {
            continue;
        }
        for d in 0..n {
            assert_eq!(packed[d].to_bits(), looped[d].to_bits(), "DOF {d}: {} vs {}", packed[d], looped[d]);
        }
        let mut visited = Vec::new();
        state.visit_trial_tangents(&body, &u, &mut |e, k| visited.push((e, *k))).unwrap();
        assert_eq!(visited.iter().map(|(e, _)| *e).collect::<Vec<_>>(), all);
        for (e, k) in visited {
            let nodes = body.mesh.elements[e];
            let ue: [f64; 8] = std::array::from_fn(|i| u[2 * nodes[i / 2] + i % 2]);
            let (ratio, frozen) = state.stress_parts(&body, e, Some(&c));
            let mut expected = [[0.0; 8]; 8];
            internal_force(&body.geometry[e], &ue, &law, ratio, &frozen, Some(&mut expected)).unwrap();
            for i in 0..8 {
                for j in 0..8 {
                    assert_eq!(k[i][j].to_bits(), expected[i][j].to_bits(), "element {e}: K[{i}][{j}]");
                }
            }
        }
        compared += 1;
    }
    assert!(compared >= 5, "{compared} of 10 deformations without an inverted element");
    // Element 4 (the middle one, in the second block) turned inside out.
    let mut u = vec![0.0; n];
    for (i, &node) in body.mesh.elements[4].iter().enumerate() {
        let p = body.mesh.nodes[node];
        let centre = [1.5, 1.5];
        if i < 2 {
            u[2 * node] = 2.0 * (centre[0] - p[0]);
            u[2 * node + 1] = 2.0 * (centre[1] - p[1]);
        }
    }
    let (mut packed, mut looped) = (vec![0.0; n], vec![0.0; n]);
    let a = state.add_trial_internal_forces(&body, &u, &mut packed);
    let b = state.add_internal_forces(&body, Some(&c), &all, &u, &mut looped);
    assert!(b.is_err(), "the element loop sees no inverted element");
    assert_eq!(a, b);
}
