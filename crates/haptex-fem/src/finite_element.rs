//! The total-Lagrangian Q4 for finite strain, with the mean-dilatation
//! treatment of the volume change (the finite-strain B-bar: the Q1/P0
//! element of Simo, Taylor & Pister 1985; de Souza Neto, Peric & Owen,
//! Computational Methods for Plasticity, 2008, sec. 15.2-15.3).
//!
//! The element's energy is
//!
//! ```text
//!   Pi_e(u) = sum_gp w_gp W_iso(F_gp) + V_e U(Jbar),   Jbar = v_e / V_e,
//! ```
//!
//! with the isochoric part at each of the 2x2 Gauss points and the
//! volumetric part at the element's mean dilatation: its current area v_e
//! over its reference area V_e (J is bilinear over a Q4, so the 2x2 rule
//! gives v_e exactly). With the decoupled neo-Hookean law this is the
//! Q1/P0 element whose Fbar = (Jbar/J)^(1/3) F has the isochoric part of F
//! and the determinant Jbar; it does not lock as nu -> 0.5, and at small
//! strain it is exactly the small-strain B-bar element of
//! [`crate::element`] (pointwise deviator, element-mean dilatation).
//!
//! Internal force and consistent tangent, nodes a, b, directions i, j:
//!
//! ```text
//!   f_ai   = sum_gp w (F S)_iK N_a,K + U'(Jbar) g_ai,           g_ai = dv/du_ai = sum_gp w cof(F)_iK N_a,K
//!   K_aibj = sum_gp w [ B^T D B + delta_ij N_a,K S_KL N_b,L ]
//!          + U''(Jbar)/V g_ai g_bj + U'(Jbar) eps_ij sum_gp w (N_a,1 N_b,2 - N_a,2 N_b,1)
//! ```
//!
//! (v is quadratic in the nodal positions, hence the constant last term.)
//! S is the isochoric second Piola-Kirchhoff stress, shear_ratio S0_iso(C)
//! plus the visco-elastic history part frozen over the step
//! ([`crate::hyperelastic`]), D = shear_ratio dS0_iso/dE.

use crate::element::Q4;
use crate::hyperelastic::{
    NeoHookean, inverse_cbrt_squared, inverse_cbrt_squared_near_one, isochoric_parts, isochoric_tangent, near_one,
    push_forward, volumetric,
};
use crate::lanes::{LANES, Lanes, Real};
use pulp::Simd;

/// The deformed element is inverted or degenerate: det F at a Gauss point,
/// or the element's mean dilatation Jbar, is not positive.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("inverted ({})", match gauss_point {
    Some(gp) => format!("det F = {det_f:e} at Gauss point {gp}"),
    None => format!("mean dilatation Jbar = {det_f:e}"),
})]
pub struct Inverted {
    /// The Gauss point, or None for the element's mean dilatation.
    pub gauss_point: Option<usize>,
    pub det_f: f64,
}

/// The in-plane deformation gradient F = I + grad_X u at Gauss point `gp`
/// (`f[i][k]` = dx_i / dX_k).
pub fn deformation_gradient(q: &Q4, gp: usize, u: &[f64; 8]) -> [[f64; 2]; 2] {
    gradient_at(&q.grad[gp], u)
}

/// F = I + sum_a u_a (x) grad N_a, with the shape function gradients `n`
/// of one point.
#[inline(always)]
fn gradient_at<T: Real>(n: &[[T; 2]; 4], u: &[T; 8]) -> [[T; 2]; 2] {
    let (one, zero) = (n[0][0].constant(1.0), n[0][0].constant(0.0));
    let mut f = [[one, zero], [zero, one]];
    for a in 0..4 {
        for i in 0..2 {
            for k in 0..2 {
                f[i][k] += u[2 * a + i] * n[a][k];
            }
        }
    }
    f
}

#[inline(always)]
fn det<T: Real>(f: &[[T; 2]; 2]) -> T {
    f[0][0] * f[1][1] - f[0][1] * f[1][0]
}

/// The isochoric stress of a step's trial state, shear_ratio S0_iso +
/// frozen (11, 22, 33, 12).
#[inline(always)]
fn trial_stress<T: Real>(shear_ratio: T, s0: &[T; 4], frozen: &[T; 4]) -> [T; 4] {
    // Loops rather than closures here and in the lanes' path below: a
    // closure LLVM does not inline is compiled without the SIMD level of
    // the loop that calls it (its lane arithmetic then runs as calls).
    let mut s = *s0;
    for k in 0..4 {
        s[k] = shear_ratio * s0[k] + frozen[k];
    }
    s
}

/// Adds one Gauss point's share (weight `w`, shape function gradients `n`,
/// deformation gradient `f`, isochoric stress `s`) of the nodal forces,
/// w (F S)_iK N_a,K, and of the area derivative, w cof(F)_iK N_a,K.
#[inline(always)]
fn add_point_forces<T: Real>(w: T, n: &[[T; 2]; 4], f: &[[T; 2]; 2], s: &[T; 4], force: &mut [T; 8], g: &mut [T; 8]) {
    let sm = [[s[0], s[3]], [s[3], s[1]]];
    // P = F S (in plane).
    let mut p = *f;
    for i in 0..2 {
        for k in 0..2 {
            p[i][k] = f[i][0] * sm[0][k] + f[i][1] * sm[1][k];
        }
    }
    let cof = [[f[1][1], -f[1][0]], [-f[0][1], f[0][0]]];
    for a in 0..4 {
        for i in 0..2 {
            force[2 * a + i] += w * (p[i][0] * n[a][0] + p[i][1] * n[a][1]);
            g[2 * a + i] += w * (cof[i][0] * n[a][0] + cof[i][1] * n[a][1]);
        }
    }
}

/// The mean dilatation Jbar = v / V of the element (current over
/// reference area).
pub fn mean_dilatation(q: &Q4, u: &[f64; 8]) -> f64 {
    (0..4).map(|gp| q.weight[gp] * det(&deformation_gradient(q, gp, u))).sum::<f64>() / q.area
}

/// The instantaneous isochoric stress S0_iso (11, 22, 33, 12) at each Gauss
/// point (what the visco-elastic history records).
pub fn isochoric_stresses(q: &Q4, u: &[f64; 8], law: &NeoHookean) -> [[f64; 4]; 4] {
    std::array::from_fn(|gp| law.isochoric_stress(&deformation_gradient(q, gp, u)))
}

/// Internal nodal forces (u_a, v_a interleaved; N per mm of width) of the
/// element at displacement `u`, with the isochoric stress
/// `shear_ratio S0_iso(C) + frozen[gp]`; with `tangent`, its consistent
/// derivative (8x8, row-major, symmetric) is written there.
pub fn internal_force(
    q: &Q4,
    u: &[f64; 8],
    law: &NeoHookean,
    shear_ratio: f64,
    frozen: &[[f64; 4]; 4],
    tangent: Option<&mut [[f64; 8]; 8]>,
) -> Result<[f64; 8], Inverted> {
    let element = OneElement { q, law, shear_ratio, frozen };
    let (force, j, j_bar) = element_response(&element, u, true, tangent);
    if let Some(gp) = (0..4).find(|&gp| j[gp].is_nan() || j[gp] <= 0.0) {
        return Err(Inverted { gauss_point: Some(gp), det_f: j[gp] });
    }
    if j_bar.is_nan() || j_bar <= 0.0 {
        return Err(Inverted { gauss_point: None, det_f: j_bar });
    }
    Ok(force)
}

/// What [`element_response`] reads of an element, or of [`LANES`] of them
/// side by side: reference geometry (as [`Q4`]'s), law and the step's
/// visco-elastic stress parts (see [`internal_force`]).
trait ElementInput<T: Real> {
    fn grad(&self, gp: usize) -> [[T; 2]; 4];
    fn weight(&self, gp: usize) -> T;
    fn reference_area(&self) -> T;
    /// mu and kappa of the neo-Hookean law.
    fn law(&self) -> (T, T);
    fn shear_ratio(&self) -> T;
    fn frozen(&self, gp: usize) -> [T; 4];
}

/// One element's input to [`element_response`].
struct OneElement<'a> {
    q: &'a Q4,
    law: &'a NeoHookean,
    shear_ratio: f64,
    frozen: &'a [[f64; 4]; 4],
}

impl ElementInput<f64> for OneElement<'_> {
    fn grad(&self, gp: usize) -> [[f64; 2]; 4] {
        self.q.grad[gp]
    }
    fn weight(&self, gp: usize) -> f64 {
        self.q.weight[gp]
    }
    fn reference_area(&self) -> f64 {
        self.q.area
    }
    fn law(&self) -> (f64, f64) {
        (self.law.mu, self.law.kappa)
    }
    fn shear_ratio(&self) -> f64 {
        self.shear_ratio
    }
    fn frozen(&self, gp: usize) -> [f64; 4] {
        self.frozen[gp]
    }
}

/// The element's nodal forces and, with `tangent`, their consistent
/// derivative ([`internal_force`]), on f64 or on [`Lanes`] (one element
/// per lane); J^(-2/3) by [`inverse_cbrt_squared`] if `checked`, else by
/// [`inverse_cbrt_squared_near_one`] (the caller checks the range, which
/// is where the two agree to the bit). Also returns J at
/// the points and Jbar for the caller to check: where one is not positive
/// the element is inverted and the forces are meaningless.
#[inline(always)]
fn element_response<T: Real>(
    element: &impl ElementInput<T>,
    u: &[T; 8],
    checked: bool,
    mut tangent: Option<&mut [[T; 8]; 8]>,
) -> ([T; 8], [T; 4], T) {
    let (mu, kappa) = element.law();
    let shear_ratio = element.shear_ratio();
    let zero = shear_ratio.constant(0.0);
    let mut force = [zero; 8];
    let mut g = [zero; 8];
    let mut area = zero;
    let mut j_points = [zero; 4];
    if let Some(k) = tangent.as_deref_mut() {
        *k = [[zero; 8]; 8];
    }
    for gp in 0..4 {
        let n = &element.grad(gp);
        let f = gradient_at(n, u);
        let j = det(&f);
        j_points[gp] = j;
        let w = element.weight(gp);
        area += w * j;
        let j_23 = if checked { j.map(inverse_cbrt_squared) } else { inverse_cbrt_squared_near_one(j) };
        let (s0, ci, i1, a) = isochoric_parts(mu, &f, j_23);
        let s = trial_stress(shear_ratio, &s0, &element.frozen(gp));
        let sm = [[s[0], s[3]], [s[3], s[1]]];
        add_point_forces(w, n, &f, &s, &mut force, &mut g);
        if let Some(k) = tangent.as_deref_mut() {
            let d = isochoric_tangent(&ci, i1, a);
            // B: dE (Voigt 11, 22, 2 12) / du.
            let mut b = [[zero; 8]; 3];
            for a in 0..4 {
                for i in 0..2 {
                    b[0][2 * a + i] = f[i][0] * n[a][0];
                    b[1][2 * a + i] = f[i][1] * n[a][1];
                    b[2][2 * a + i] = f[i][0] * n[a][1] + f[i][1] * n[a][0];
                }
            }
            let mut db = [[zero; 8]; 3];
            for r in 0..3 {
                for c in 0..8 {
                    db[r][c] = shear_ratio * (d[r][0] * b[0][c] + d[r][1] * b[1][c] + d[r][2] * b[2][c]);
                }
            }
            for r in 0..8 {
                for c in 0..8 {
                    k[r][c] += w * (b[0][r] * db[0][c] + b[1][r] * db[1][c] + b[2][r] * db[2][c]);
                }
            }
            for a in 0..4 {
                for bb in 0..4 {
                    let geometric = w
                        * (n[a][0] * (sm[0][0] * n[bb][0] + sm[0][1] * n[bb][1])
                            + n[a][1] * (sm[1][0] * n[bb][0] + sm[1][1] * n[bb][1]));
                    k[2 * a][2 * bb] += geometric;
                    k[2 * a + 1][2 * bb + 1] += geometric;
                }
            }
        }
    }
    let reference_area = element.reference_area();
    let j_bar = area / reference_area;
    let (pressure, stiffness) = volumetric(kappa, j_bar);
    for r in 0..8 {
        force[r] += pressure * g[r];
    }
    if let Some(k) = tangent {
        for r in 0..8 {
            for c in 0..8 {
                k[r][c] += stiffness / reference_area * g[r] * g[c];
            }
        }
        for gp in 0..4 {
            let (w, n) = (element.weight(gp), &element.grad(gp));
            for a in 0..4 {
                for bb in 0..4 {
                    let h = pressure * w * (n[a][0] * n[bb][1] - n[a][1] * n[bb][0]);
                    k[2 * a][2 * bb + 1] += h;
                    k[2 * a + 1][2 * bb] = k[2 * a + 1][2 * bb] - h;
                }
            }
        }
    }
    (force, j_points, j_bar)
}

/// The Cauchy stress (xx, yy, zz, xy; MPa) at Gauss point `gp` for the
/// isochoric second Piola-Kirchhoff stress `s_iso` there: the push-forward
/// of s_iso plus the element's pressure U'(Jbar).
pub fn cauchy_stress(q: &Q4, gp: usize, u: &[f64; 8], law: &NeoHookean, s_iso: &[f64; 4]) -> [f64; 4] {
    let f = deformation_gradient(q, gp, u);
    let (p, _) = law.volumetric(mean_dilatation(q, u));
    let sigma = push_forward(&f, s_iso);
    [sigma[0] + p, sigma[1] + p, sigma[2] + p, sigma[3]]
}

/// [`LANES`] elements side by side (a structure of arrays): reference
/// geometry, law and the step's visco-elastic stress parts, so that the
/// internal-force loop over Gauss points runs on all of them at once, one
/// element per SIMD lane ([`Lanes`]). The arithmetic of each lane is that
/// of [`internal_force`], operation for operation (the same generic
/// helpers): the forces are the same to the bit.
#[derive(Debug, Clone)]
pub struct ElementBlock {
    /// The elements, in lane order; a last block that is not full repeats
    /// its last element in the lanes beyond `len`.
    pub elements: [usize; LANES],
    pub len: usize,
    /// Global DOFs (u_a, v_a interleaved) of each lane's element.
    dofs: [[u32; LANES]; 8],
    /// `grad[gp][a][k]`, as [`Q4::grad`].
    grad: [[[[f64; LANES]; 2]; 4]; 4],
    weight: [[f64; LANES]; 4],
    area: [f64; LANES],
    mu: [f64; LANES],
    kappa: [f64; LANES],
    /// The step's shear ratio and frozen isochoric stress `frozen[gp][k]`
    /// (see [`internal_force`]), set with [`ElementBlock::set_stress_parts`].
    shear_ratio: [f64; LANES],
    frozen: [[[f64; LANES]; 4]; 4],
}

impl ElementBlock {
    /// The block of `elements` (1 to [`LANES`]) with their geometry, global
    /// DOFs and laws.
    pub fn new(
        elements: &[usize],
        geometry: &[Q4],
        dofs: impl Fn(usize) -> [usize; 8],
        law: impl Fn(usize) -> NeoHookean,
    ) -> Self {
        assert!(!elements.is_empty() && elements.len() <= LANES, "1 to {LANES} elements in a block");
        let lane = |l: usize| elements[l.min(elements.len() - 1)];
        let element_dofs: [[usize; 8]; LANES] = std::array::from_fn(|l| dofs(lane(l)));
        let laws: [NeoHookean; LANES] = std::array::from_fn(|l| law(lane(l)));
        let lanes = |value: &dyn Fn(&Q4) -> f64| std::array::from_fn(|l| value(&geometry[lane(l)]));
        Self {
            elements: std::array::from_fn(lane),
            len: elements.len(),
            dofs: std::array::from_fn(|i| {
                std::array::from_fn(|l| u32::try_from(element_dofs[l][i]).expect("DOF index fits in 32 bits"))
            }),
            grad: std::array::from_fn(|gp| {
                std::array::from_fn(|a| std::array::from_fn(|k| lanes(&|q| q.grad[gp][a][k])))
            }),
            weight: std::array::from_fn(|gp| lanes(&|q| q.weight[gp])),
            area: lanes(&|q| q.area),
            mu: laws.map(|m| m.mu),
            kappa: laws.map(|m| m.kappa),
            shear_ratio: [0.0; LANES],
            frozen: [[[0.0; LANES]; 4]; 4],
        }
    }

    /// Sets lane `l`'s shear ratio and frozen stress of the step (see
    /// [`internal_force`]).
    pub fn set_stress_parts(&mut self, l: usize, shear_ratio: f64, frozen: &[[f64; 4]; 4]) {
        self.shear_ratio[l] = shear_ratio;
        for gp in 0..4 {
            for k in 0..4 {
                self.frozen[gp][k][l] = frozen[gp][k];
            }
        }
    }

    /// The block's elements' displacements from the global `u`.
    fn displacements(&self, u: &[f64]) -> [[f64; LANES]; 8] {
        std::array::from_fn(|i| std::array::from_fn(|l| u[self.dofs[i][l] as usize]))
    }

    /// [`element_response`] of the block in the SIMD lanes of `simd`, with
    /// whether J is in the lanes' range at every point of every lane
    /// ([`near_one`]: 0.7 < J < 1.4) and Jbar positive; else the block is
    /// computed element by element (an element is inverted or strained
    /// beyond that range).
    #[inline(always)]
    fn lanes_response<S: Simd>(
        &self,
        simd: S,
        ue: &[[f64; LANES]; 8],
        tangent: Option<&mut [[Lanes<S>; 8]; 8]>,
    ) -> ([Lanes<S>; 8], bool) {
        let mut u = [Lanes::splat(simd, 0.0); 8];
        for i in 0..8 {
            u[i] = Lanes::load(simd, &ue[i]);
        }
        let (force, j, j_bar) = element_response(&BlockLanes { block: self, simd }, &u, false, tangent);
        let mut in_range = true;
        for j in j {
            for j in j.to_array() {
                in_range &= near_one(j);
            }
        }
        for j_bar in j_bar.to_array() {
            in_range &= j_bar > 0.0;
        }
        (force, in_range)
    }

    /// Lane `l`'s element by [`internal_force`] itself.
    fn element_internal_force(
        &self,
        l: usize,
        geometry: &[Q4],
        ue: &[[f64; LANES]; 8],
        tangent: Option<&mut [[f64; 8]; 8]>,
    ) -> Result<[f64; 8], Inverted> {
        let law = NeoHookean { mu: self.mu[l], kappa: self.kappa[l] };
        let frozen = std::array::from_fn(|gp| std::array::from_fn(|k| self.frozen[gp][k][l]));
        let ue_l = std::array::from_fn(|i| ue[i][l]);
        internal_force(&geometry[self.elements[l]], &ue_l, &law, self.shear_ratio[l], &frozen, tangent)
    }

    /// Adds the internal forces of the block's elements at the global
    /// displacement `u` to `f` (element by element in lane order, as a loop
    /// over the elements with [`internal_force`] would), in the SIMD lanes
    /// of `simd`. Where some point has J outside 0.7..1.4 (`near_one`:
    /// an element inverted or strained beyond), or `simd` has fewer than
    /// [`LANES`] lanes, the block is computed by [`internal_force`] itself,
    /// which reports an inverted element.
    #[inline(always)]
    pub fn add_internal_forces<S: Simd>(
        &self,
        simd: S,
        geometry: &[Q4],
        u: &[f64],
        f: &mut [f64],
    ) -> Result<(), Inverted> {
        let ue = self.displacements(u);
        if Lanes::<S>::fits() {
            let (force, in_range) = self.lanes_response(simd, &ue, None);
            if in_range {
                let mut fe = [[0.0; LANES]; 8];
                for i in 0..8 {
                    fe[i] = force[i].to_array();
                }
                for l in 0..self.len {
                    for i in 0..8 {
                        f[self.dofs[i][l] as usize] += fe[i][l];
                    }
                }
                return Ok(());
            }
        }
        for l in 0..self.len {
            let fe = self.element_internal_force(l, geometry, &ue, None)?;
            for i in 0..8 {
                f[self.dofs[i][l] as usize] += fe[i];
            }
        }
        Ok(())
    }

    /// Calls `visit(element, tangent)` with the consistent tangent of
    /// [`internal_force`] of each of the block's elements at the global
    /// displacement `u`, in lane order, computed in the SIMD lanes of
    /// `simd` (the same to the bit), or element by element as
    /// [`ElementBlock::add_internal_forces`] is. Stops at an inverted
    /// element.
    #[inline(always)]
    pub fn visit_tangents<S: Simd>(
        &self,
        simd: S,
        geometry: &[Q4],
        u: &[f64],
        visit: &mut impl FnMut(usize, &[[f64; 8]; 8]),
    ) -> Result<(), Inverted> {
        let ue = self.displacements(u);
        if Lanes::<S>::fits() {
            let mut k = [[Lanes::splat(simd, 0.0); 8]; 8];
            let (_, in_range) = self.lanes_response(simd, &ue, Some(&mut k));
            if in_range {
                let mut k_lanes = [[[0.0; LANES]; 8]; 8];
                for r in 0..8 {
                    for c in 0..8 {
                        k_lanes[r][c] = k[r][c].to_array();
                    }
                }
                let k = k_lanes;
                for l in 0..self.len {
                    visit(self.elements[l], &std::array::from_fn(|r| std::array::from_fn(|c| k[r][c][l])));
                }
                return Ok(());
            }
        }
        for l in 0..self.len {
            let mut k = [[0.0; 8]; 8];
            self.element_internal_force(l, geometry, &ue, Some(&mut k))?;
            visit(self.elements[l], &k);
        }
        Ok(())
    }
}

impl ElementBlock {
    /// Calls `visit(element, s0)` with the instantaneous isochoric stress
    /// S0_iso of each of the block's elements at the global displacement
    /// `u` ([`isochoric_stresses`], to the bit), in lane order, computed in
    /// the SIMD lanes of `simd`, or element by element where some J is
    /// outside 0.7..1.4 (`near_one`).
    #[inline(always)]
    pub fn visit_isochoric_stresses<S: Simd>(
        &self,
        simd: S,
        geometry: &[Q4],
        u: &[f64],
        visit: &mut impl FnMut(usize, &[[f64; 4]; 4]),
    ) {
        let ue = self.displacements(u);
        if Lanes::<S>::fits() {
            let lanes = BlockLanes { block: self, simd };
            let (mu, _) = lanes.law();
            let mut u = [Lanes::splat(simd, 0.0); 8];
            for i in 0..8 {
                u[i] = Lanes::load(simd, &ue[i]);
            }
            let mut in_range = true;
            let mut s0 = [[[0.0; LANES]; 4]; 4];
            for gp in 0..4 {
                let f = gradient_at(&lanes.grad(gp), &u);
                let j = det(&f);
                for j in j.to_array() {
                    in_range &= near_one(j);
                }
                let (s0_gp, ..) = isochoric_parts(mu, &f, inverse_cbrt_squared_near_one(j));
                for k in 0..4 {
                    s0[gp][k] = s0_gp[k].to_array();
                }
            }
            if in_range {
                for l in 0..self.len {
                    visit(self.elements[l], &std::array::from_fn(|gp| std::array::from_fn(|k| s0[gp][k][l])));
                }
                return;
            }
        }
        for l in 0..self.len {
            let law = NeoHookean { mu: self.mu[l], kappa: self.kappa[l] };
            let ue_l = std::array::from_fn(|i| ue[i][l]);
            visit(self.elements[l], &isochoric_stresses(&geometry[self.elements[l]], &ue_l, &law));
        }
    }
}

/// An [`ElementBlock`]'s input to [`element_response`], loaded into the
/// SIMD lanes of `S` where it is used.
struct BlockLanes<'a, S: Simd> {
    block: &'a ElementBlock,
    simd: S,
}

impl<S: Simd> ElementInput<Lanes<S>> for BlockLanes<'_, S> {
    #[inline(always)]
    fn grad(&self, gp: usize) -> [[Lanes<S>; 2]; 4] {
        let mut n = [[Lanes::splat(self.simd, 0.0); 2]; 4];
        for a in 0..4 {
            for k in 0..2 {
                n[a][k] = Lanes::load(self.simd, &self.block.grad[gp][a][k]);
            }
        }
        n
    }
    #[inline(always)]
    fn weight(&self, gp: usize) -> Lanes<S> {
        Lanes::load(self.simd, &self.block.weight[gp])
    }
    #[inline(always)]
    fn reference_area(&self) -> Lanes<S> {
        Lanes::load(self.simd, &self.block.area)
    }
    #[inline(always)]
    fn law(&self) -> (Lanes<S>, Lanes<S>) {
        (Lanes::load(self.simd, &self.block.mu), Lanes::load(self.simd, &self.block.kappa))
    }
    #[inline(always)]
    fn shear_ratio(&self) -> Lanes<S> {
        Lanes::load(self.simd, &self.block.shear_ratio)
    }
    #[inline(always)]
    fn frozen(&self, gp: usize) -> [Lanes<S>; 4] {
        let mut s = [Lanes::splat(self.simd, 0.0); 4];
        for k in 0..4 {
            s[k] = Lanes::load(self.simd, &self.block.frozen[gp][k]);
        }
        s
    }
}
