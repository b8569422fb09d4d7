//! Validation of the 3D finite-strain hexahedron
//! (`haptex_fem::solid3d::finite_hex8`): consistent tangent, energy,
//! small-strain limit, objectivity and a homogeneous deformation against
//! the analytic neo-Hookean stress. Each test names its source and
//! tolerance. (The 2D element's checks, tests/finite_strain_element.rs,
//! one dimension up.)

// Numeric checks index several arrays with one loop variable (as the library).
#![allow(clippy::needless_range_loop)]

use haptex_fem::element::Formulation;
use haptex_fem::material::Material;
use haptex_fem::solid3d::finite_hex8::{
    NeoHookean3, Volumetric, cauchy_stress, deformation_gradient, det3, energy, internal_force, isochoric_stresses,
    mean_dilatation,
};
use haptex_fem::solid3d::hex8::{CORNERS, Hex8};

/// A hexahedron of about 2 x 1.5 x 1 mm with its corners moved off a box.
fn nodes() -> [[f64; 3]; 8] {
    let moves = [
        [0.1, -0.05, 0.0],
        [0.2, 0.1, -0.1],
        [-0.1, 0.15, 0.05],
        [0.05, -0.1, 0.1],
        [-0.05, 0.05, -0.05],
        [0.15, 0.0, 0.1],
        [0.0, -0.1, -0.05],
        [0.1, 0.1, 0.0],
    ];
    std::array::from_fn(|a| {
        let c = CORNERS[a];
        [1.0 + c[0] + moves[a][0], 0.75 * (1.0 + c[1]) + moves[a][1], 0.5 * (1.0 + c[2]) + moves[a][2]]
    })
}

fn law() -> NeoHookean3 {
    NeoHookean3::from_material(&Material::elastic(0.1, 0.45))
}

/// A small deterministic pseudo-random sequence (no dependency).
fn lcg(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn times(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|k| (0..3).map(|l| a[i][l] * b[l][k]).sum()))
}

fn apply(a: &[[f64; 3]; 3], p: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| a[i][k] * p[k]).sum())
}

/// The displacements that move the nodes `x` to `f x`.
fn affine(f: &[[f64; 3]; 3], x: &[[f64; 3]; 8]) -> [f64; 24] {
    std::array::from_fn(|i| apply(f, x[i / 3])[i % 3] - x[i / 3][i % 3])
}

/// A rotation by `deg` degrees about the axis (1, 2, 3)/|.| (Rodrigues).
fn rotation(deg: f64) -> [[f64; 3]; 3] {
    let n = 14f64.sqrt();
    let k = [1.0 / n, 2.0 / n, 3.0 / n];
    let (s, c) = deg.to_radians().sin_cos();
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let cross = match (i, j) {
                (0, 1) => -k[2],
                (0, 2) => k[1],
                (1, 0) => k[2],
                (1, 2) => -k[0],
                (2, 0) => -k[1],
                (2, 1) => k[0],
                _ => 0.0,
            };
            let delta = if i == j { 1.0 } else { 0.0 };
            c * delta + s * cross + (1.0 - c) * k[i] * k[j]
        })
    })
}

/// The consistent tangent is the derivative of the internal force: central
/// differences (h = 1e-6) at random deformations of up to 30%, random
/// frozen visco-elastic stresses and shear ratios, both volumetric
/// functions; 1e-6 relative to the tangent's largest entry (Wriggers,
/// Nonlinear FEM, 2008, sec. 4.2: the check of a linearization; the
/// differences' truncation error is about h^2 times the third derivative,
/// 1e-10 here).
#[test]
fn tangent_matches_finite_differences() {
    let h8 = Hex8::new(&nodes()).unwrap();
    let mut seed = 11;
    for case in 0..12 {
        let law = law().with_volumetric(if case % 2 == 0 { Volumetric::SimoTaylor } else { Volumetric::Quadratic });
        let u: [f64; 24] = std::array::from_fn(|_| 0.3 * lcg(&mut seed));
        let frozen: [[f64; 6]; 8] = std::array::from_fn(|_| std::array::from_fn(|_| 0.01 * lcg(&mut seed)));
        let ratio = 0.4 + 0.6 * lcg(&mut seed).abs();
        let mut k = [[0.0; 24]; 24];
        internal_force(&h8, &u, &law, ratio, &frozen, Some(&mut k)).unwrap();
        let scale = k.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let h = 1e-6;
        for j in 0..24 {
            let (mut up, mut um) = (u, u);
            up[j] += h;
            um[j] -= h;
            let fp = internal_force(&h8, &up, &law, ratio, &frozen, None).unwrap();
            let fm = internal_force(&h8, &um, &law, ratio, &frozen, None).unwrap();
            for i in 0..24 {
                let fd = (fp[i] - fm[i]) / (2.0 * h);
                assert!((fd - k[i][j]).abs() < 1e-6 * scale, "case {case}, K[{i}][{j}] = {} vs {fd}", k[i][j]);
            }
        }
        for i in 0..24 {
            for j in 0..i {
                assert!((k[i][j] - k[j][i]).abs() < 1e-12 * scale, "case {case}: not symmetric at {i}, {j}");
            }
        }
    }
}

/// The internal force is the gradient of the element's energy (no history,
/// shear ratio 1): central differences of the energy (h = 1e-6), 1e-7
/// relative to the largest force, both volumetric functions.
#[test]
fn internal_force_is_the_energy_gradient() {
    let h8 = Hex8::new(&nodes()).unwrap();
    let mut seed = 5;
    for case in 0..6 {
        let law = law().with_volumetric(if case % 2 == 0 { Volumetric::SimoTaylor } else { Volumetric::Quadratic });
        let u: [f64; 24] = std::array::from_fn(|_| 0.25 * lcg(&mut seed));
        let f = internal_force(&h8, &u, &law, 1.0, &[[0.0; 6]; 8], None).unwrap();
        let scale = f.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let h = 1e-6;
        for j in 0..24 {
            let (mut up, mut um) = (u, u);
            up[j] += h;
            um[j] -= h;
            let fd = (energy(&h8, &up, &law) - energy(&h8, &um, &law)) / (2.0 * h);
            assert!((fd - f[j]).abs() < 1e-7 * scale, "case {case}, f[{j}] = {} vs {fd}", f[j]);
        }
    }
}

/// At zero displacement the tangent is the small-strain B-bar stiffness
/// (super::hex8, with G = shear ratio x mu and the bulk modulus K), to
/// 1e-12 of its largest entry, and the forces of a displacement of 1e-7 mm
/// are K u to 1e-6 relative (the next term is quadratic in u): the element
/// is the small-strain one in the limit (de Souza Neto et al. 2008,
/// sec. 15.3).
#[test]
fn small_displacement_limit_is_the_bbar_element() {
    let h8 = Hex8::new(&nodes()).unwrap();
    let m = Material::elastic(0.1, 0.45);
    for volumetric in [Volumetric::SimoTaylor, Volumetric::Quadratic] {
        let law = NeoHookean3::from_material(&m).with_volumetric(volumetric);
        let ratio = 0.6;
        let linear = h8.stiffness(Formulation::BBar, ratio * m.shear_mpa(), m.bulk_mpa());
        let mut k = [[0.0; 24]; 24];
        internal_force(&h8, &[0.0; 24], &law, ratio, &[[0.0; 6]; 8], Some(&mut k)).unwrap();
        let scale = linear.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..24 {
            for j in 0..24 {
                assert!((k[i][j] - linear[i][j]).abs() < 1e-12 * scale, "{i}, {j}: {} vs {}", k[i][j], linear[i][j]);
            }
        }
        let mut seed = 3;
        let u: [f64; 24] = std::array::from_fn(|_| 1e-7 * lcg(&mut seed));
        let f = internal_force(&h8, &u, &law, ratio, &[[0.0; 6]; 8], None).unwrap();
        let ku: Vec<f64> = (0..24).map(|i| (0..24).map(|j| linear[i][j] * u[j]).sum()).collect();
        let scale = ku.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..24 {
            assert!((f[i] - ku[i]).abs() < 1e-6 * scale, "{i}: {} vs {}", f[i], ku[i]);
        }
    }
}

/// Objectivity (Holzapfel 2000, sec. 5.4): a rigid rotation by 40 degrees
/// gives zero internal force (1e-12 of mu times the element's area); a
/// rotated, non-affinely deformed state with a history gives the rotated
/// nodal forces (1e-12 relative), its tangent the rotated tangent, and the
/// Cauchy stress the rotated stress.
#[test]
fn objectivity_under_rigid_rotation() {
    let x = nodes();
    let h8 = Hex8::new(&x).unwrap();
    let law = law();
    let r = rotation(40.0);
    let f = internal_force(&h8, &affine(&r, &x), &law, 1.0, &[[0.0; 6]; 8], None).unwrap();
    assert!(f.iter().all(|v| v.abs() < 1e-12 * law.mu * 4.0), "{f:?}");
    let stretch = [[1.1, 0.2, -0.05], [0.05, 0.93, 0.1], [0.0, -0.08, 1.05]];
    let bump: [f64; 24] = std::array::from_fn(|i| 0.03 * ((i * 7 % 11) as f64 / 5.0 - 1.0));
    let x1: [[f64; 3]; 8] =
        std::array::from_fn(|a| apply(&stretch, std::array::from_fn(|i| x[a][i] + bump[3 * a + i])));
    let u1: [f64; 24] = std::array::from_fn(|i| x1[i / 3][i % 3] - x[i / 3][i % 3]);
    let u2: [f64; 24] = std::array::from_fn(|i| apply(&r, x1[i / 3])[i % 3] - x[i / 3][i % 3]);
    let frozen = [[0.002, -0.001, 0.0005, 0.003, -0.001, 0.0015]; 8];
    let (mut k1, mut k2) = ([[0.0; 24]; 24], [[0.0; 24]; 24]);
    let f1 = internal_force(&h8, &u1, &law, 0.7, &frozen, Some(&mut k1)).unwrap();
    let f2 = internal_force(&h8, &u2, &law, 0.7, &frozen, Some(&mut k2)).unwrap();
    let scale = f1.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for a in 0..8 {
        let rf = apply(&r, [f1[3 * a], f1[3 * a + 1], f1[3 * a + 2]]);
        for i in 0..3 {
            assert!((rf[i] - f2[3 * a + i]).abs() < 1e-12 * scale, "node {a}: {rf:?} vs {:?}", &f2[3 * a..3 * a + 3]);
        }
    }
    // K2 = R K1 R^T blockwise.
    let k_scale = k1.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for a in 0..8 {
        for b in 0..8 {
            let block: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| k1[3 * a + i][3 * b + j]));
            let rt: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| r[j][i]));
            let rotated = times(&times(&r, &block), &rt);
            for i in 0..3 {
                for j in 0..3 {
                    assert!((rotated[i][j] - k2[3 * a + i][3 * b + j]).abs() < 1e-11 * k_scale);
                }
            }
        }
    }
    let s1 = law.cauchy_stress(&stretch);
    let s2 = law.cauchy_stress(&times(&r, &stretch));
    let m1 = [[s1[0], s1[3], s1[5]], [s1[3], s1[1], s1[4]], [s1[5], s1[4], s1[2]]];
    let rt: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| r[j][i]));
    let rsr = times(&times(&r, &m1), &rt);
    let scale = s1.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (v, (i, j)) in [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)].into_iter().enumerate() {
        assert!((rsr[i][j] - s2[v]).abs() < 1e-12 * scale, "{v}: {} vs {}", rsr[i][j], s2[v]);
    }
}

/// A homogeneous deformation F (stretch, shear and a volume change of
/// -8%): every Gauss point has F, Jbar = det F, the element's Cauchy stress
/// is the analytic neo-Hookean one, and the nodal forces are its
/// tractions: sum_a f_a (x) X_a = V P with P = J sigma F^-T (the virial of
/// the nodal forces, exact for an element that reproduces a constant
/// stress; Zienkiewicz & Taylor 2005, sec. 9.3). 1e-12 relative, both
/// volumetric functions; the analytic stress itself is checked against
/// a hand-computed uniaxial case in the module's own terms.
#[test]
fn homogeneous_deformation_gives_the_analytic_stress() {
    let x = nodes();
    let h8 = Hex8::new(&x).unwrap();
    let f = [[0.95, 0.12, 0.03], [-0.04, 0.97, 0.06], [0.02, -0.05, 1.01]];
    let j = det3(&f);
    assert!((j - 0.92).abs() < 0.03, "J = {j}");
    let u = affine(&f, &x);
    for volumetric in [Volumetric::SimoTaylor, Volumetric::Quadratic] {
        let law = law().with_volumetric(volumetric);
        for gp in 0..8 {
            let fg = deformation_gradient(&h8, gp, &u);
            for i in 0..3 {
                for k in 0..3 {
                    assert!((fg[i][k] - f[i][k]).abs() < 1e-13);
                }
            }
        }
        assert!((mean_dilatation(&h8, &u) - j).abs() < 1e-13);
        let sigma = law.cauchy_stress(&f);
        let scale = sigma.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let s_iso = isochoric_stresses(&h8, &u, &law);
        for gp in 0..8 {
            let s = cauchy_stress(&h8, gp, &u, &law, &s_iso[gp]);
            for v in 0..6 {
                assert!((s[v] - sigma[v]).abs() < 1e-12 * scale, "gp {gp}, {v}: {} vs {}", s[v], sigma[v]);
            }
        }
        let force = internal_force(&h8, &u, &law, 1.0, &[[0.0; 6]; 8], None).unwrap();
        // P = J sigma F^-T.
        let sm = [[sigma[0], sigma[3], sigma[5]], [sigma[3], sigma[1], sigma[4]], [sigma[5], sigma[4], sigma[2]]];
        let cof: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|k| {
                let (i1, i2, k1, k2) = ((i + 1) % 3, (i + 2) % 3, (k + 1) % 3, (k + 2) % 3);
                f[i1][k1] * f[i2][k2] - f[i1][k2] * f[i2][k1]
            })
        });
        let p = times(&sm, &cof);
        let p_scale = p.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..3 {
            for k in 0..3 {
                let virial: f64 = (0..8).map(|a| force[3 * a + i] * x[a][k]).sum();
                assert!(
                    (virial - h8.volume * p[i][k]).abs() < 1e-12 * h8.volume * p_scale,
                    "{volumetric:?} P[{i}][{k}]: {} vs {}",
                    virial / h8.volume,
                    p[i][k]
                );
            }
        }
    }
    // Uniaxial stretch lambda with lateral stretch 1: sigma_xx - sigma_yy =
    // mu J^(-5/3) (lambda^2 - 1) (Holzapfel 2000, eq. 6.139, with J = lambda),
    // and the mean stress is U'(J).
    let law = law();
    let lambda = 1.3f64;
    let s = law.cauchy_stress(&[[lambda, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let expected = law.mu * lambda.powf(-5.0 / 3.0) * (lambda * lambda - 1.0);
    assert!((s[0] - s[1] - expected).abs() < 1e-14, "{} vs {expected}", s[0] - s[1]);
    let (p, _) = Volumetric::SimoTaylor.derivatives(law.kappa, lambda);
    assert!(((s[0] + s[1] + s[2]) / 3.0 - p).abs() < 1e-14);
}

/// An element turned inside out is refused, naming the Gauss point.
#[test]
fn an_inverted_element_is_refused() {
    let x = nodes();
    let h8 = Hex8::new(&x).unwrap();
    let mirror = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
    let err = internal_force(&h8, &affine(&mirror, &x), &law(), 1.0, &[[0.0; 6]; 8], None).unwrap_err();
    assert_eq!(err.gauss_point, Some(0));
    assert!(err.to_string().contains("det F = -") && err.to_string().contains("Gauss point 0"), "{err}");
    assert!(err.det_f < 0.0);
}
