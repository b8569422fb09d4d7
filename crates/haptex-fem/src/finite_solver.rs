//! The finite-strain solve path (`--kinematics finite`): the body is the
//! total-Lagrangian neo-Hookean one of [`crate::finite_element`], the
//! contact is the same penalty-Coulomb law on the deformed configuration
//! (the contact points move with the displaced skin nodes; the surface's
//! closest point, normal and arc are evaluated there by
//! [`crate::contact::ContactSet::evaluate`]).
//!
//! # Algorithm
//!
//! The body is no longer linear, so the exact condensation of
//! [`crate::solver`] no longer solves the problem by itself. It is kept as
//! the inner solve of an outer iteration on the body's nonlinearity: with K
//! an SPD stiffness whose condensation (Cholesky factor, pad compliance C,
//! its inverse S, drive responses psi) is at hand, each outer iteration
//! maps an iterate x (free displacements, and the driven y under load
//! control) to
//!
//! ```text
//!   u0   = x_f - K^-1 f_int(x)                         pad rows only
//!   v    = u0_s + dy psi_s + C F(v)                     the contact Newton
//!   G(x) = u0 + dy psi + K^-1 P S (v - u0_s - dy psi_s) one sparse solve
//! ```
//!
//! (the last term puts the pad exactly at v). K is factorized with the pad
//! DOFs ordered last ([`crate::linalg::SparseCholesky::with_trailing`]), so
//! with y = L^-1 f_int(x) (the forward half of a solve) u0_s = x_s -
//! L_tt^-T y_t, and L^-1 P S w = [0; L_tt^T w] (S = L_tt L_tt^T): G(x) =
//! x + dy psi + L^-T ([0; L_tt^T w] - y) costs one forward and one backward
//! sweep. The contact Newton inside an outer iteration stops at
//! [`FiniteSettings::inner_forcing`] times the outer residual (an inexact
//! inner solve; the outer test is unchanged). Its fixed point satisfies
//! f_int(u) = P F(u_s), the full nonlinear equilibrium on every free DOF,
//! whatever K is; K only sets the rate, |I - K^-1 K_T| where contact does
//! not dominate. Anderson acceleration (Walker & Ni 2011, 5 iterates)
//! speeds it up and is restarted whenever the residual grows. Convergence
//! is checked on the true residual at the iterate, f_int(x) - P F(x_s) on
//! all free DOFs (and the load under load control), within 1e-8 of the
//! largest nodal contact force.
//!
//! K: the small-strain stiffness of the step size diverges at the end of
//! the press on the shipped finger, so K is the tangent stiffness, condensed
//! anew at the current iterate whenever an outer iteration contracts the
//! residual by less than [`FiniteSettings::rebuild_contraction`] (the
//! residual there, just evaluated, is not evaluated again). A step of a new
//! size (the first, the slide's first, a halved one) starts on the tangent
//! at the committed state, which at rest is the small-strain stiffness; the
//! small-strain operators are the fallback where a tangent is not positive
//! definite. The condensation comes from the factorization itself: the
//! pad block L_tt of the pad-last factor is the condensed stiffness, S =
//! L_tt L_tt^T (kept as L_tt: S x = L_tt (L_tt^T x)), and gives C =
//! L_tt^-T L_tt^-1 (a triangular inverse and product), not one solve per
//! pad DOF. The drive responses psi are solved only for an attempt that
//! uses them (a step that moves the drive, or load control).
//!
//! The body's internal forces, the element tangents of a rebuild and the
//! isochoric stresses of a commit run four elements at a time in SIMD lanes
//! ([`crate::finite_element::ElementBlock`], the same arithmetic as
//! [`internal_force`] to the bit). The contact Newton of an outer
//! iteration starts from the contact evaluation of the residual at the
//! same iterate, and takes the stick predictor only at a step's first
//! contact solve. On the default bump a rebuild costs about 2.7 ms
//! (element tangents 0.7, factorization 1.7, condensation 0.4) and an outer
//! iteration about 0.7 ms (residual, body and contact, 0.16; sweeps 0.23;
//! contact Newton 0.29); `haptex simulate` prints the breakdown
//! ([`FiniteProfile`]) when `HAPTEX_PROFILE` is set.
//! A step that does not converge, or in which an element
//! inverts, is retried in halves exactly like the small-strain solver's; if
//! that fails the solver's error names the time, the step and the residual.

use std::time::Instant;

use crate::assembly::{DofMap, PRESCRIBED};
use crate::body::{Body, SubdomainModel};
use crate::contact::ContactTotals;
use crate::element::Q4;
use crate::finite_element::{ElementBlock, Inverted, cauchy_stress, internal_force};
use crate::hyperelastic::NeoHookean;
use crate::lanes::LANES;
use crate::linalg::{SparseCholesky, dot, schur_compliance, transpose, upper_solve, upper_times};
use crate::material::{StepCoefficients, advance_history, frozen_deviator, history_deviator};
use crate::solver::{
    Condensed, Drive, NewtonStart, PadStiffness, SolveError, Solver, StepFailure, StepOperators, StepReport, Stepping,
    advance_halving, newton,
};

/// The finite-strain state of the body: the neo-Hookean law of every
/// deformable subdomain and the visco-elastic history (isochoric second
/// Piola-Kirchhoff stresses) of every Gauss point.
#[derive(Debug, Clone)]
pub struct FiniteBody {
    laws: Vec<Option<NeoHookean>>,
    g_inf: Vec<f64>,
    /// S0_iso of point `4 e + gp`.
    history_s0: Vec<[f64; 4]>,
    /// H_i of the points, `history_start[e] + gp * terms + i`.
    history_h: Vec<[f64; 4]>,
    history_start: Vec<usize>,
    terms: Vec<usize>,
    /// The deformable elements in blocks of [`LANES`] for the trial
    /// internal forces, with the stress parts of the step they were last
    /// set for ([`FiniteBody::set_trial`]).
    blocks: Vec<ElementBlock>,
    /// The coefficients the blocks' stress parts were set for (None: not
    /// set, or the history changed since).
    trial_coefficients: Option<Vec<Option<StepCoefficients>>>,
    /// The CPU's SIMD level (AVX2 where it has it).
    arch: pulp::Arch,
}

impl FiniteBody {
    /// The body at rest (no history).
    pub fn new(body: &Body) -> Self {
        let mut laws = Vec::new();
        let mut g_inf = Vec::new();
        let mut n_terms = Vec::new();
        for s in &body.subdomains {
            match s {
                SubdomainModel::Deformable(m) => {
                    laws.push(Some(NeoHookean::from_material(m)));
                    g_inf.push(m.g_inf());
                    n_terms.push(m.prony.len());
                }
                SubdomainModel::Rigid => {
                    laws.push(None);
                    g_inf.push(1.0);
                    n_terms.push(0);
                }
            }
        }
        let mut history_start = Vec::with_capacity(body.mesh.n_elements());
        let mut terms = Vec::with_capacity(body.mesh.n_elements());
        let mut total = 0;
        for &sd in &body.mesh.subdomain {
            history_start.push(total);
            terms.push(n_terms[sd as usize]);
            total += 4 * n_terms[sd as usize];
        }
        let blocks = body
            .deformable_elements()
            .chunks(LANES)
            .map(|elements| {
                ElementBlock::new(
                    elements,
                    &body.geometry,
                    |e| DofMap::element_dofs(&body.mesh.elements[e]),
                    |e| laws[body.mesh.subdomain[e] as usize].expect("deformable element"),
                )
            })
            .collect();
        Self {
            laws,
            g_inf,
            history_s0: vec![[0.0; 4]; 4 * body.mesh.n_elements()],
            history_h: vec![[0.0; 4]; total],
            history_start,
            terms,
            blocks,
            trial_coefficients: None,
            arch: pulp::Arch::new(),
        }
    }

    fn law(&self, body: &Body, e: usize) -> &NeoHookean {
        self.laws[body.mesh.subdomain[e] as usize].as_ref().expect("deformable element")
    }

    fn h(&self, e: usize, gp: usize) -> &[[f64; 4]] {
        let n = self.terms[e];
        let start = self.history_start[e] + gp * n;
        &self.history_h[start..start + n]
    }

    /// The shear ratio and the frozen isochoric stress of element `e`'s
    /// points for a step with coefficients `c` (the trial state), or of
    /// the committed state with `c` = None.
    pub fn stress_parts(&self, body: &Body, e: usize, c: Option<&[Option<StepCoefficients>]>) -> (f64, [[f64; 4]; 4]) {
        let sd = body.mesh.subdomain[e] as usize;
        match c {
            Some(c) => {
                let coefficients = c[sd].as_ref().expect("deformable element");
                if coefficients.n_terms() == 0 {
                    return (coefficients.shear_ratio, [[0.0; 4]; 4]);
                }
                let frozen = std::array::from_fn(|gp| {
                    frozen_deviator(&self.history_s0[4 * e + gp], self.h(e, gp), coefficients)
                });
                (coefficients.shear_ratio, frozen)
            }
            None => {
                let committed = std::array::from_fn(|gp| {
                    history_deviator(&self.history_s0[4 * e + gp], self.h(e, gp), self.g_inf[sd])
                });
                (0.0, committed)
            }
        }
    }

    /// Adds the internal forces of `elements` at the global displacement
    /// `u` to the global vector `f`: of the step's trial state with
    /// coefficients `c`, or of the committed state (`c` = None, `u` the
    /// displacement it was committed at).
    pub fn add_internal_forces(
        &self,
        body: &Body,
        c: Option<&[Option<StepCoefficients>]>,
        elements: &[usize],
        u: &[f64],
        f: &mut [f64],
    ) -> Result<(), Inverted> {
        for &e in elements {
            if self.laws[body.mesh.subdomain[e] as usize].is_none() {
                continue;
            }
            let ue = body.element_displacement(e, u);
            let (ratio, frozen) = self.stress_parts(body, e, c);
            let fe = internal_force(&body.geometry[e], &ue, self.law(body, e), ratio, &frozen, None)?;
            for (i, d) in DofMap::element_dofs(&body.mesh.elements[e]).into_iter().enumerate() {
                f[d] += fe[i];
            }
        }
        Ok(())
    }

    /// Sets the stress parts of a step's trial state with coefficients `c`
    /// (constant over the step: its shear ratio and the frozen history
    /// stress) for [`FiniteBody::add_trial_internal_forces`].
    pub fn set_trial(&mut self, body: &Body, c: &[Option<StepCoefficients>]) {
        // Set already for these coefficients, and nothing committed since.
        if self.trial_coefficients.as_deref() == Some(c) {
            return;
        }
        let mut blocks = std::mem::take(&mut self.blocks);
        for block in &mut blocks {
            for l in 0..block.len {
                let (ratio, frozen) = self.stress_parts(body, block.elements[l], Some(c));
                block.set_stress_parts(l, ratio, &frozen);
            }
        }
        self.blocks = blocks;
        self.trial_coefficients = Some(c.to_vec());
    }

    /// Adds the internal forces of all deformable elements at the global
    /// displacement `u` to `f`, of the trial state last set by
    /// [`FiniteBody::set_trial`]: [`FiniteBody::add_internal_forces`] of
    /// every deformable element with those coefficients, to the bit, in
    /// SIMD lanes of [`LANES`] elements.
    pub fn add_trial_internal_forces(&self, body: &Body, u: &[f64], f: &mut [f64]) -> Result<(), Inverted> {
        self.arch.dispatch(TrialForces { blocks: &self.blocks, geometry: &body.geometry, u, f })
    }

    /// Calls `visit(element, tangent)` for every deformable element, in
    /// order, with the consistent tangent of its internal force at the
    /// global displacement `u` in the trial state last set by
    /// [`FiniteBody::set_trial`] (that of [`internal_force`], to the bit,
    /// in SIMD lanes of [`LANES`] elements). Stops at an inverted element.
    pub fn visit_trial_tangents(
        &self,
        body: &Body,
        u: &[f64],
        visit: &mut impl FnMut(usize, &[[f64; 8]; 8]),
    ) -> Result<(), Inverted> {
        self.arch.dispatch(TrialTangents { blocks: &self.blocks, geometry: &body.geometry, u, visit })
    }

    /// Advances the history of every point to the displacement `u` at the
    /// end of a step with coefficients `c`.
    pub fn commit(&mut self, body: &Body, c: &[Option<StepCoefficients>], u: &[f64]) {
        self.trial_coefficients = None;
        let (history_s0, history_h) = (&mut self.history_s0, &mut self.history_h);
        let (history_start, terms) = (&self.history_start, &self.terms);
        // S0_iso of every point (that of `isochoric_stresses`, in SIMD lanes).
        let mut advance = |e: usize, s0: &[[f64; 4]; 4]| {
            let coefficients = c[body.mesh.subdomain[e] as usize].as_ref().expect("deformable element");
            let n = terms[e];
            for gp in 0..4 {
                let start = history_start[e] + gp * n;
                let h = &mut history_h[start..start + n];
                advance_history(&mut history_s0[4 * e + gp], h, coefficients, &s0[gp]);
            }
        };
        self.arch.dispatch(BlockStresses { blocks: &self.blocks, geometry: &body.geometry, u, visit: &mut advance });
    }

    /// Committed Cauchy stress (xx, yy, zz, xy; MPa) averaged over element
    /// `e`'s Gauss points, `u` the displacement it was committed at.
    pub fn element_stress(&self, body: &Body, e: usize, u: &[f64]) -> [f64; 4] {
        let ue = body.element_displacement(e, u);
        let sd = body.mesh.subdomain[e] as usize;
        let mut avg = [0.0; 4];
        for gp in 0..4 {
            let s = history_deviator(&self.history_s0[4 * e + gp], self.h(e, gp), self.g_inf[sd]);
            let sigma = cauchy_stress(&body.geometry[e], gp, &ue, self.law(body, e), &s);
            for k in 0..4 {
                avg[k] += 0.25 * sigma[k];
            }
        }
        avg
    }
}

/// The loop of [`FiniteBody::add_trial_internal_forces`], compiled for
/// each SIMD level [`pulp::Arch`] dispatches to.
struct TrialForces<'a> {
    blocks: &'a [ElementBlock],
    geometry: &'a [Q4],
    u: &'a [f64],
    f: &'a mut [f64],
}

impl pulp::WithSimd for TrialForces<'_> {
    type Output = Result<(), Inverted>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> Self::Output {
        for block in self.blocks {
            block.add_internal_forces(simd, self.geometry, self.u, self.f)?;
        }
        Ok(())
    }
}

/// The loop of [`FiniteBody::visit_trial_tangents`], compiled for each
/// SIMD level [`pulp::Arch`] dispatches to.
struct TrialTangents<'a, F> {
    blocks: &'a [ElementBlock],
    geometry: &'a [Q4],
    u: &'a [f64],
    visit: &'a mut F,
}

impl<F: FnMut(usize, &[[f64; 8]; 8])> pulp::WithSimd for TrialTangents<'_, F> {
    type Output = Result<(), Inverted>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> Self::Output {
        for block in self.blocks {
            block.visit_tangents(simd, self.geometry, self.u, self.visit)?;
        }
        Ok(())
    }
}

/// The loop of [`FiniteBody::commit`] over the blocks' isochoric
/// stresses, compiled for each SIMD level [`pulp::Arch`] dispatches to.
struct BlockStresses<'a, F> {
    blocks: &'a [ElementBlock],
    geometry: &'a [Q4],
    u: &'a [f64],
    visit: &'a mut F,
}

impl<F: FnMut(usize, &[[f64; 4]; 4])> pulp::WithSimd for BlockStresses<'_, F> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        for block in self.blocks {
            block.visit_isochoric_stresses(simd, self.geometry, self.u, self.visit);
        }
    }
}

/// Settings of the outer (body) iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FiniteSettings {
    /// Outer iterations per step attempt before it is cut.
    pub max_iterations: usize,
    /// Converged when the free-DOF residual |f_int - P F|_inf is at most
    /// this times the largest nodal contact force, floored as the contact
    /// Newton's (`SolverSettings::floor_penetration_mm`).
    pub relative_tolerance: f64,
    /// Anderson window (0: plain initial-stiffness iteration).
    pub anderson_depth: usize,
    /// Rebuild the condensed operators on the tangent stiffness when needed
    /// (false: the small-strain stiffness throughout, which diverges at the
    /// end of the press on the shipped finger).
    pub tangent_per_step: bool,
    /// Rebuild the tangent when an outer iteration reduces the residual by
    /// less than this factor (measured on the default bump with the pad-last
    /// condensation: 0.3, 0.1, 0.03, 0.01, 0.001 give 76, 86, 93, 100, 108
    /// rebuilds and 838, 800, 778, 742, 723 residual evaluations, the same
    /// run time within 3%).
    pub rebuild_contraction: f64,
    /// Forcing term of the inexact inner solve: the contact Newton inside an
    /// outer iteration stops at this times the outer residual (relative to
    /// the largest nodal contact force) or at its own tolerance, whichever
    /// is larger (Eisenstat & Walker 1996). Only the intermediate iterates
    /// change: convergence is still the outer test on the true residual.
    /// 0: every inner solve to its own tolerance.
    pub inner_forcing: f64,
}

impl Default for FiniteSettings {
    fn default() -> Self {
        Self {
            max_iterations: 60,
            relative_tolerance: 1e-8,
            anderson_depth: 5,
            tangent_per_step: true,
            rebuild_contraction: 0.3,
            inner_forcing: 0.01,
        }
    }
}

/// Where the finite-strain solve spends its time: counts and wall time
/// summed per phase over the run (read it from [`FiniteSolver::profile`];
/// `haptex simulate` prints it when `HAPTEX_PROFILE` is set).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FiniteProfile {
    /// Tangent rebuilds (condensations on the tangent stiffness).
    pub rebuilds: usize,
    /// Element tangents and their assembly, seconds.
    pub assembly_s: f64,
    /// Sparse numeric factorizations, seconds.
    pub factorization_s: f64,
    /// The pad compliance and its inverse (and the drive responses), seconds.
    pub condensation_s: f64,
    /// Residual evaluations (internal forces and contact), their number and seconds.
    pub residuals: usize,
    pub residual_s: f64,
    /// Sparse single-vector solves of the outer iteration (or, with the
    /// pad-last factor, forward and backward sweeps: two per iteration),
    /// their number and seconds.
    pub solves: usize,
    pub solve_s: f64,
    /// The contact Newton of the outer iterations, seconds.
    pub contact_newton_s: f64,
    /// Anderson updates, seconds.
    pub anderson_s: f64,
}

impl std::fmt::Display for FiniteProfile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let ms = |s: f64| s * 1e3;
        write!(
            f,
            "{} tangent rebuilds (assembly {:.0} ms, factorization {:.0} ms, condensation {:.0} ms); \
             {} residuals {:.0} ms; {} solves {:.0} ms; contact Newton {:.0} ms; Anderson {:.0} ms",
            self.rebuilds,
            ms(self.assembly_s),
            ms(self.factorization_s),
            ms(self.condensation_s),
            self.residuals,
            ms(self.residual_s),
            self.solves,
            ms(self.solve_s),
            ms(self.contact_newton_s),
            ms(self.anderson_s),
        )
    }
}

/// Anderson acceleration (type II, Walker & Ni 2011) of a fixed-point
/// iteration x -> G(x), with all memory allocated once (the 3D finite
/// strain's outer iteration uses it too, [`crate::solid3d::finite_contact`]).
pub(crate) struct Anderson {
    depth: usize,
    /// Differences of residuals f = G(x) - x and of G(x), ring buffers.
    df: Vec<Vec<f64>>,
    dg: Vec<Vec<f64>>,
    f_prev: Vec<f64>,
    g_prev: Vec<f64>,
    stored: usize,
    next: usize,
    has_prev: bool,
    normal: Vec<f64>,
    rhs: Vec<f64>,
}

impl Anderson {
    pub(crate) fn new(depth: usize, n: usize) -> Self {
        Self {
            depth,
            df: vec![vec![0.0; n]; depth],
            dg: vec![vec![0.0; n]; depth],
            f_prev: vec![0.0; n],
            g_prev: vec![0.0; n],
            stored: 0,
            next: 0,
            has_prev: false,
            normal: vec![0.0; depth * depth],
            rhs: vec![0.0; depth],
        }
    }

    pub(crate) fn reset(&mut self) {
        self.stored = 0;
        self.next = 0;
        self.has_prev = false;
    }

    /// Given the iterate `x` and its image `g` = G(x), writes the next
    /// iterate into `x`. Returns the largest |G(x) - x|.
    pub(crate) fn step(&mut self, x: &mut [f64], g: &[f64]) -> f64 {
        let n = x.len();
        let mut largest: f64 = 0.0;
        if self.depth == 0 {
            for (xi, gi) in x.iter().zip(g) {
                largest = largest.max((gi - xi).abs());
            }
            x.copy_from_slice(g);
            return largest;
        }
        // f = g - x into x's place after the differences are recorded.
        if self.has_prev {
            let slot = self.next;
            for i in 0..n {
                let f = g[i] - x[i];
                self.df[slot][i] = f - self.f_prev[i];
                self.dg[slot][i] = g[i] - self.g_prev[i];
            }
            self.next = (self.next + 1) % self.depth;
            self.stored = (self.stored + 1).min(self.depth);
        }
        for i in 0..n {
            self.f_prev[i] = g[i] - x[i];
            self.g_prev[i] = g[i];
            largest = largest.max(self.f_prev[i].abs());
        }
        self.has_prev = true;
        let m = self.stored;
        x.copy_from_slice(g);
        if m == 0 {
            return largest;
        }
        // Least squares min |f - dF gamma| by the normal equations, with a
        // small Tikhonov term (the columns can be nearly dependent).
        for a in 0..m {
            for b in 0..=a {
                let v = dot(&self.df[a], &self.df[b]);
                self.normal[a * m + b] = v;
                self.normal[b * m + a] = v;
            }
            self.rhs[a] = dot(&self.df[a], &self.f_prev);
        }
        let trace: f64 = (0..m).map(|a| self.normal[a * m + a]).sum();
        if !(trace > 0.0 && trace.is_finite()) {
            return largest;
        }
        for a in 0..m {
            self.normal[a * m + a] += 1e-10 * trace;
        }
        // Gaussian elimination (symmetric positive definite, m <= depth).
        for p in 0..m {
            let pivot = self.normal[p * m + p];
            for r in p + 1..m {
                let factor = self.normal[r * m + p] / pivot;
                for c in p..m {
                    self.normal[r * m + c] -= factor * self.normal[p * m + c];
                }
                self.rhs[r] -= factor * self.rhs[p];
            }
        }
        for p in (0..m).rev() {
            let mut v = self.rhs[p];
            for c in p + 1..m {
                v -= self.normal[p * m + c] * self.rhs[c];
            }
            self.rhs[p] = v / self.normal[p * m + p];
        }
        for a in 0..m {
            let gamma = self.rhs[a];
            for i in 0..n {
                x[i] -= gamma * self.dg[a][i];
            }
        }
        largest
    }
}

/// The finite-strain solver: the small-strain solver's operators and
/// contact Newton, wrapped in the outer iteration on the body.
pub struct FiniteSolver {
    /// Holds the problem, the step operators and the committed state
    /// (`u`, `t_s`, `slide_mm`, `drive_mm`, `forces`, `steps`).
    pub inner: Solver,
    pub body_state: FiniteBody,
    pub finite_settings: FiniteSettings,
    /// Outer iterations over the run.
    pub outer_iterations: usize,
    /// Largest free-DOF residual of a converged step relative to its
    /// largest nodal contact force.
    pub worst_relative_residual: f64,
    /// Time per phase over the run.
    pub profile: FiniteProfile,
    x: Vec<f64>,
    f_int: Vec<f64>,
    f_free: Vec<f64>,
    contact_forces: Vec<f64>,
    pad_gap: Vec<f64>,
    iterate: Vec<f64>,
    image: Vec<f64>,
    anderson: Anderson,
    reaction_elements: Vec<usize>,
    reaction_forces: Vec<f64>,
    /// Operators built on the tangent stiffness at a recent state, used in
    /// place of the small-strain ones of the same step size.
    tangent_ops: Option<StepOperators>,
    tangent_values: Vec<f64>,
    /// The symbolic analysis of the tangent with the pad DOFs ordered last
    /// (made on the first rebuild), and the pad block of its factor.
    tangent_base: Option<SparseCholesky>,
    trailing_factor: Vec<f64>,
    /// L_tt^T (column-major: L_tt by rows), for L_tt^T w and L_tt^-T y
    /// column by column.
    trailing_upper: Vec<f64>,
    trailing_scratch: Vec<f64>,
    /// A solve's forward half (factor order) and its trailing part.
    sweep: Vec<f64>,
    sweep_trailing: Vec<f64>,
    /// Whether the drive responses of `tangent_ops` are solved (see
    /// [`FiniteSolver::solve_tangent_drive_responses`]).
    tangent_psi_solved: bool,
    /// Contact Newton iterations and the drive's x of an attempt that
    /// stopped unconverged (to resume it).
    last_newton_iterations: usize,
    x_drive: f64,
    /// The residual, contact scale and totals at the iterate where the
    /// last attempt stopped (evaluated there: not evaluated again).
    stopped: Option<(f64, f64, ContactTotals)>,
    /// An attempt stops early when an iteration reduces the residual by
    /// less than this factor (to rebuild the tangent).
    slow_ratio: f64,
}

impl Stepping for FiniteSolver {
    fn committed(&mut self) -> &mut Solver {
        &mut self.inner
    }

    fn try_step(&mut self, dt_s: f64, slide_mm: f64, drive: Drive) -> Result<(usize, ContactTotals), StepFailure> {
        self.try_step_finite(dt_s, slide_mm, drive)
    }
}

impl FiniteSolver {
    pub fn new(inner: Solver, finite_settings: FiniteSettings) -> Self {
        let body_state = FiniteBody::new(&inner.problem.body);
        let n_dofs = inner.u.len();
        let n_free = inner.dofs.n_free;
        let m2 = inner.candidate_free.len();
        let reaction_elements = inner.problem.body.elements_touching(&inner.problem.driven_nodes);
        Self {
            body_state,
            finite_settings,
            outer_iterations: 0,
            worst_relative_residual: 0.0,
            profile: FiniteProfile::default(),
            x: vec![0.0; n_dofs],
            f_int: vec![0.0; n_dofs],
            f_free: vec![0.0; n_free],
            contact_forces: vec![0.0; m2],
            pad_gap: vec![0.0; m2],
            iterate: vec![0.0; n_free + 1],
            image: vec![0.0; n_free + 1],
            anderson: Anderson::new(finite_settings.anderson_depth, n_free + 1),
            reaction_elements,
            reaction_forces: vec![0.0; n_dofs],
            tangent_ops: None,
            tangent_values: vec![0.0; inner.pattern.nnz()],
            tangent_base: None,
            tangent_psi_solved: false,
            trailing_factor: vec![0.0; m2 * m2],
            trailing_upper: vec![0.0; m2 * m2],
            trailing_scratch: vec![0.0; m2 * m2],
            sweep: vec![0.0; n_free],
            sweep_trailing: vec![0.0; m2],
            last_newton_iterations: 0,
            x_drive: 0.0,
            stopped: None,
            slow_ratio: f64::INFINITY,
            inner,
        }
    }

    /// As [`Solver::advance`]: advances to `slide_mm` with the driven set
    /// loaded by `drive` over `dt_s`, halving the step on failure.
    pub fn advance(&mut self, dt_s: f64, slide_mm: f64, drive: Drive) -> Result<StepReport, SolveError> {
        advance_halving(self, dt_s, slide_mm, drive)
    }

    /// One attempt at a step; commits only on success. Returns the contact
    /// Newton iterations summed over the outer iterations.
    fn try_step_finite(
        &mut self,
        dt_s: f64,
        slide_mm: f64,
        drive: Drive,
    ) -> Result<(usize, ContactTotals), StepFailure> {
        let max = self.finite_settings.max_iterations;
        if !self.finite_settings.tangent_per_step {
            let k = self.inner.operators_for(dt_s).map_err(StepFailure::Fatal)?;
            return self.attempt(Some(k), dt_s, slide_mm, drive, false, max);
        }
        // Iterate on the last tangent while it contracts the residual well;
        // when it does not, rebuild the tangent at the iterate reached (the
        // first iteration has moved the pad to this step's contact) and go
        // on from there. A step of another size (the first, the slide's
        // first, a halved one) starts on the tangent at the committed state
        // (at rest, the small-strain stiffness).
        if !self.tangent_fits(dt_s) {
            self.build_tangent_operators(dt_s, false).map_err(StepFailure::Fatal)?;
        }
        let k = self.fallback_operators(dt_s)?;
        self.slow_ratio = self.finite_settings.rebuild_contraction;
        let result = self.attempt(k, dt_s, slide_mm, drive, false, max);
        self.slow_ratio = f64::INFINITY;
        match result {
            Err(StepFailure::Newton { .. }) => {}
            other => return other,
        }
        let iterations = self.last_newton_iterations;
        self.build_tangent_operators(dt_s, true).map_err(StepFailure::Fatal)?;
        let k = self.fallback_operators(dt_s)?;
        let (its, totals) = self.attempt(k, dt_s, slide_mm, drive, true, max)?;
        Ok((iterations + its, totals))
    }

    /// Whether the tangent operators at hand are of step size `dt_s`.
    fn tangent_fits(&self, dt_s: f64) -> bool {
        self.tangent_ops.as_ref().is_some_and(|o| o.dt_s == dt_s)
    }

    /// The small-strain operators of step size `dt_s` when there are no
    /// tangent ones of that size (the tangent was not positive definite).
    fn fallback_operators(&mut self, dt_s: f64) -> Result<Option<usize>, StepFailure> {
        if self.tangent_fits(dt_s) {
            return Ok(None);
        }
        self.inner.operators_for(dt_s).map(Some).map_err(StepFailure::Fatal)
    }

    /// One attempt at a step with the current operators (the tangent ones
    /// if of this step size, else the small-strain set `k`), at most
    /// `max_outer` outer iterations, from the predictor or (`resume`) from
    /// the iterate where the last attempt stopped.
    fn attempt(
        &mut self,
        k: Option<usize>,
        dt_s: f64,
        slide_mm: f64,
        drive: Drive,
        resume: bool,
        max_outer: usize,
    ) -> Result<(usize, ContactTotals), StepFailure> {
        let debug = std::env::var_os("HAPTEX_DEBUG").is_some();
        let placement = self.inner.placement(slide_mm);
        let settings = self.finite_settings;
        // The drive responses psi enter the predictor of a step that moves
        // the drive, and every iteration under load control.
        let moves_drive = match drive {
            Drive::Displacement(target) => target != self.inner.drive_mm,
            Drive::Load { x_mm, .. } => x_mm != self.inner.drive_mm[0],
        };
        let load_control = matches!(drive, Drive::Load { .. });
        if load_control || (moves_drive && !resume) {
            self.solve_tangent_drive_responses();
        }
        let inner = &mut self.inner;
        // The tangent operators come with the pad block L_tt of their
        // pad-last factor (`self.trailing_factor`): G(x) then costs one
        // solve (see below) instead of two.
        let (ops_k, pad_last): (&mut StepOperators, bool) = match (self.tangent_ops.as_mut(), k) {
            (Some(o), _) if o.dt_s == dt_s => (o, true),
            (_, Some(k)) => (&mut inner.operators[k], false),
            _ => {
                return Err(StepFailure::Fatal(SolveError::Settings(format!(
                    "no operators for the step size {dt_s} s"
                ))));
            }
        };
        let n = inner.dofs.n_free;
        let m2 = inner.candidate_free.len();
        let (x_drive, load) = match drive {
            Drive::Displacement([x, _]) => (x, None),
            Drive::Load { x_mm, fy_n } => (x_mm, Some(fy_n)),
        };
        let y_target = match drive {
            Drive::Displacement([_, y]) => y,
            Drive::Load { .. } => inner.drive_mm[1],
        };
        // Predictor: the committed state plus the small-strain response to
        // the change of the drive.
        let ops = &*ops_k;
        let change = [x_drive - inner.drive_mm[0], y_target - inner.drive_mm[1]];
        if !resume {
            for (g, &d) in inner.dofs.free.iter().enumerate() {
                if d != PRESCRIBED {
                    self.iterate[d] = if moves_drive {
                        inner.u[g] + change[0] * ops.psi[0][d] + change[1] * ops.psi[1][d]
                    } else {
                        inner.u[g]
                    };
                }
            }
            self.iterate[n] = y_target;
        }
        self.body_state.set_trial(&inner.problem.body, &ops.coefficients);
        self.anderson.reset();
        if !resume {
            self.stopped = None;
        }
        let floor = inner.force_floor_n;
        let tolerance_of = |scale: f64| settings.relative_tolerance * scale.max(floor);
        let mut change = f64::NAN;
        let mut newton_iterations = 0;
        let mut last_norm = f64::INFINITY;
        let mut residual = f64::INFINITY;
        let mut tolerance = f64::NAN;
        // Outer iterations (maps x -> G(x)) performed.
        let mut performed = 0;
        for outer in 0..=max_outer {
            performed = outer;
            // The global displacement of the iterate.
            let y = self.iterate[n];
            for (g, &d) in inner.dofs.free.iter().enumerate() {
                self.x[g] = if d != PRESCRIBED { self.iterate[d] } else { 0.0 };
            }
            for &node in &inner.problem.driven_nodes {
                self.x[2 * node] = x_drive;
                self.x[2 * node + 1] = y;
            }
            // Its residual on every free DOF: f_int(x) - P F(x_s), unless
            // the last attempt stopped at this iterate after evaluating it
            // (`self.f_free`, the contact forces and trial states are then
            // those of this iterate).
            let reuse = if outer == 0 && resume { self.stopped.take() } else { None };
            let evaluated_here = reuse.is_none();
            let (norm, scale, totals) = if let Some(stopped) = reuse {
                stopped
            } else {
                let timer = Instant::now();
                self.f_int.fill(0.0);
                let body = &inner.problem.body;
                if let Err(e) = self.body_state.add_trial_internal_forces(body, &self.x, &mut self.f_int) {
                    if debug {
                        eprintln!("finite: outer {outer}: {e}");
                    }
                    return Err(StepFailure::Newton {
                        residual: f64::INFINITY,
                        tolerance: f64::NAN,
                        correction_mm: f64::NAN,
                    });
                }
                for (g, &d) in inner.dofs.free.iter().enumerate() {
                    if d != PRESCRIBED {
                        self.f_free[d] = self.f_int[g];
                    }
                }
                let s = &mut inner.scratch;
                for (c, &node) in inner.problem.contact.nodes.iter().enumerate() {
                    s.v[2 * c] = self.x[2 * node];
                    s.v[2 * c + 1] = self.x[2 * node + 1];
                }
                let totals = inner.problem.contact.evaluate(
                    &s.v,
                    &inner.problem.surface,
                    placement,
                    &inner.problem.law,
                    &mut self.contact_forces,
                    &mut s.blocks,
                );
                let scale = self.contact_forces.iter().fold(0.0f64, |m, f| m.max(f.abs()));
                let mut norm: f64 = 0.0;
                for (c, &row) in inner.candidate_free.iter().enumerate() {
                    self.f_free[row] -= self.contact_forces[c];
                }
                for &r in &self.f_free {
                    norm = norm.max(r.abs());
                }
                if let Some(load) = load {
                    let total: f64 = (0..m2 / 2).map(|i| self.contact_forces[2 * i + 1]).sum();
                    norm = norm.max((total - load).abs());
                }
                for (c, &row) in inner.candidate_free.iter().enumerate() {
                    self.f_free[row] += self.contact_forces[c];
                }
                self.profile.residuals += 1;
                self.profile.residual_s += timer.elapsed().as_secs_f64();
                (norm, scale, totals)
            };
            let s = &mut inner.scratch;
            residual = norm;
            tolerance = tolerance_of(scale);
            if debug {
                eprintln!(
                    "finite: outer {outer}: residual {norm:.3e} (tolerance {tolerance:.3e}), {} active",
                    totals.active_points
                );
            }
            if !norm.is_finite() {
                break;
            }
            if norm <= tolerance {
                self.outer_iterations += outer;
                let relative = norm / scale.max(floor);
                self.worst_relative_residual = self.worst_relative_residual.max(relative);
                return self.commit(k, dt_s, slide_mm, [x_drive, y], newton_iterations, totals);
            }
            // Restart the acceleration when the residual grows.
            if norm > last_norm {
                self.anderson.reset();
            }
            let slow = outer >= 1 && norm > self.slow_ratio * last_norm;
            last_norm = norm;
            if outer == max_outer || slow {
                self.stopped = Some((norm, scale, totals));
                break;
            }
            // u0 = x_f - K^-1 f_int(x). With the pad-last factor only its
            // pad rows are needed now: u0_s = x_s - L_tt^-T y_t, y = L^-1 f
            // (the forward half of the solve).
            let timer = Instant::now();
            if pad_last {
                ops_k.cholesky.forward(&self.f_free, &mut self.sweep);
                self.sweep_trailing.copy_from_slice(&self.sweep[n - m2..]);
                upper_solve(&self.trailing_upper, m2, &mut self.sweep_trailing);
                for (c, &row) in inner.candidate_free.iter().enumerate() {
                    s.u0_s[c] = self.iterate[row] - self.sweep_trailing[c];
                }
            } else {
                ops_k.cholesky.solve_vec(&mut self.f_free);
                for i in 0..n {
                    self.image[i] = self.iterate[i] - self.f_free[i];
                }
                for (c, &row) in inner.candidate_free.iter().enumerate() {
                    s.u0_s[c] = self.image[row];
                }
            }
            self.profile.solves += 1;
            self.profile.solve_s += timer.elapsed().as_secs_f64();
            let ops = &*ops_k;
            for (c, &row) in inner.candidate_free.iter().enumerate() {
                s.psi_y_s[c] = if load.is_some() { ops.psi[1][row] } else { 0.0 };
            }
            let stiffness = if pad_last {
                PadStiffness::Factor { lower: &self.trailing_factor, upper: &self.trailing_upper }
            } else {
                PadStiffness::Dense(&ops.stiffness)
            };
            let condensed =
                Condensed { m2, compliance: &ops.compliance, stiffness, load, force_floor_n: inner.force_floor_n };
            let mut dy = 0.0;
            let timer = Instant::now();
            let mut inner_settings = inner.settings;
            inner_settings.relative_tolerance =
                inner_settings.relative_tolerance.max(settings.inner_forcing * norm / scale.max(floor));
            // The contact was evaluated at the pad's iterate for the
            // residual: the contact Newton starts from that evaluation.
            if evaluated_here {
                s.forces.copy_from_slice(&self.contact_forces);
            }
            let (its, _) = newton(
                &condensed,
                &mut inner.problem.contact,
                &inner.problem.surface,
                placement,
                &inner.problem.law,
                &inner_settings,
                s,
                &mut dy,
                NewtonStart { evaluated: evaluated_here.then_some(totals), stick_predictor: outer == 0 && !resume },
            )?;
            newton_iterations += its;
            self.profile.contact_newton_s += timer.elapsed().as_secs_f64();
            // G(x) = u0 + dy psi_y + K^-1 P Fpad, with the pad forces Fpad =
            // S (v - u0_s - dy psi_s) that put the pad exactly at the
            // contact Newton's v (Fpad is its F(v) up to the inner force
            // residual; using F(v) itself, the outer residual would
            // measure the inner one amplified by the contact's stiffness
            // over the tissue's, D C ~ 10^3, and stall above the
            // tolerance). One sparse solve, cheaper than Phi Fpad.
            for c in 0..m2 {
                self.pad_gap[c] = s.v[c] - s.u0_s[c] - dy * s.psi_y_s[c];
            }
            let timer = Instant::now();
            if pad_last {
                // G(x) = x + dy psi_y + K^-1 (P S w - f_int), w the pad gap:
                // with S = L_tt L_tt^T, L^-1 P S w = [0; L_tt^T w], so the
                // backward half of the solve finishes it.
                for value in &mut self.sweep[..n - m2] {
                    *value = -*value;
                }
                upper_times(&self.trailing_upper, m2, &self.pad_gap, &mut self.sweep_trailing);
                for (value, add) in self.sweep[n - m2..].iter_mut().zip(&self.sweep_trailing) {
                    *value = add - *value;
                }
                ops_k.cholesky.backward(&mut self.sweep, &mut self.f_free);
                for i in 0..n {
                    self.image[i] = self.iterate[i] + self.f_free[i];
                }
            } else {
                self.f_free.fill(0.0);
                for (r, &row) in inner.candidate_free.iter().enumerate() {
                    // S is symmetric: row r is column r.
                    let column = &ops.stiffness[r * m2..(r + 1) * m2];
                    self.f_free[row] = column.iter().zip(&self.pad_gap).map(|(a, b)| a * b).sum();
                }
                ops_k.cholesky.solve_vec(&mut self.f_free);
                for i in 0..n {
                    self.image[i] += self.f_free[i];
                }
            }
            self.profile.solves += 1;
            self.profile.solve_s += timer.elapsed().as_secs_f64();
            if load.is_some() {
                let ops = &*ops_k;
                for i in 0..n {
                    self.image[i] += dy * ops.psi[1][i];
                }
            }
            self.image[n] = y + dy;
            let timer = Instant::now();
            change = self.anderson.step(&mut self.iterate, &self.image);
            self.profile.anderson_s += timer.elapsed().as_secs_f64();
        }
        self.outer_iterations += performed;
        self.last_newton_iterations = newton_iterations;
        self.x_drive = x_drive;
        Err(StepFailure::Newton { residual, tolerance, correction_mm: change })
    }

    /// Commits the converged iterate in `self.x` (contact trial states and
    /// forces evaluated there).
    fn commit(
        &mut self,
        k: Option<usize>,
        dt_s: f64,
        slide_mm: f64,
        drive_mm: [f64; 2],
        iterations: usize,
        totals: ContactTotals,
    ) -> Result<(usize, ContactTotals), StepFailure> {
        let inner = &mut self.inner;
        let placement = inner.placement(slide_mm);
        let u = &self.x;
        for &node in &inner.problem.other_surface_nodes {
            let p = inner.problem.body.mesh.nodes[node];
            let x = [p[0] + u[2 * node] + placement.slide_mm, p[1] + u[2 * node + 1] - placement.lift_mm];
            if inner.problem.surface.project(x).is_some_and(|proj| proj.depth > 1e-9) {
                return Err(StepFailure::Fatal(SolveError::OutsideContactRegion {
                    t_s: inner.t_s + dt_s,
                    node,
                    x_mm: p[0] + u[2 * node],
                }));
            }
        }
        let coefficients = match (&self.tangent_ops, k) {
            (Some(o), _) if o.dt_s == dt_s => &o.coefficients,
            (_, Some(k)) => &inner.operators[k].coefficients,
            _ => {
                return Err(StepFailure::Fatal(SolveError::Settings(format!(
                    "no operators for the step size {dt_s} s"
                ))));
            }
        };
        self.body_state.commit(&inner.problem.body, coefficients, u);
        inner.problem.contact.commit();
        inner.u.copy_from_slice(u);
        inner.forces.copy_from_slice(&self.contact_forces);
        inner.t_s += dt_s;
        inner.slide_mm = slide_mm;
        inner.drive_mm = drive_mm;
        Ok((iterations, totals))
    }

    /// Builds the condensed operators of the step size `dt_s` on the
    /// tangent stiffness at the committed state or (`at_iterate`) at the
    /// iterate where the last attempt stopped, into `self.tangent_ops`.
    /// Leaves them unset when the tangent is not positive definite, and as
    /// they were when an element is inverted there.
    fn build_tangent_operators(&mut self, dt_s: f64, at_iterate: bool) -> Result<(), SolveError> {
        let timer = Instant::now();
        let phase = Instant::now();
        self.profile.rebuilds += 1;
        if at_iterate {
            // The global displacement of the iterate where the last attempt
            // stopped.
            let n = self.inner.dofs.n_free;
            for (g, &d) in self.inner.dofs.free.iter().enumerate() {
                self.x[g] = if d != PRESCRIBED { self.iterate[d] } else { 0.0 };
            }
            for &node in &self.inner.problem.driven_nodes {
                self.x[2 * node] = self.x_drive;
                self.x[2 * node + 1] = self.iterate[n];
            }
        }
        let inner = &mut self.inner;
        let body = &inner.problem.body;
        let coefficients = body.step_coefficients(dt_s);
        let values = &mut self.tangent_values;
        values.fill(0.0);
        let n = inner.dofs.n_free;
        let m2 = inner.candidate_free.len();
        let mut psi = [vec![0.0; n], vec![0.0; n]];
        let mut driven = vec![false; body.mesh.n_nodes()];
        for &node in &inner.problem.driven_nodes {
            driven[node] = true;
        }
        self.body_state.set_trial(body, &coefficients);
        let u = if at_iterate { &self.x } else { &inner.u };
        let assembled = self.body_state.visit_trial_tangents(body, u, &mut |e, ke| {
            inner.pattern.add_element(e, ke, values);
            // -K_fp e_axis: the loads of a unit translation of the driven set.
            let nodes = &body.mesh.elements[e];
            if nodes.iter().any(|&a| driven[a]) {
                let global = DofMap::element_dofs(nodes);
                for (axis, response) in psi.iter_mut().enumerate() {
                    for i in 0..8 {
                        let d = inner.dofs.free[global[i]];
                        if d == PRESCRIBED {
                            continue;
                        }
                        for j in 0..8 {
                            if driven[nodes[j / 2]] && j % 2 == axis {
                                response[d] -= ke[i][j];
                            }
                        }
                    }
                }
            }
        });
        if assembled.is_err() {
            // An inverted element: keep the operators there are; the
            // attempt itself fails there and the step is cut.
            return Ok(());
        }
        self.profile.assembly_s += phase.elapsed().as_secs_f64();
        let phase = Instant::now();
        // The pad-last factorization (one symbolic analysis per run): the
        // condensed stiffness is the trailing block of its factor.
        if self.tangent_base.is_none() {
            self.tangent_base = Some(SparseCholesky::with_trailing(&inner.pattern, &inner.candidate_free, 1)?);
        }
        // No dense stiffness: it is L_tt (`self.trailing_factor`).
        let (mut cholesky, mut compliance, stiffness) = match (self.tangent_ops.take(), &self.tangent_base) {
            (Some(ops), _) => (ops.cholesky, ops.compliance, ops.stiffness),
            (None, Some(base)) => (base.share(1), vec![0.0; m2 * m2], Vec::new()),
            (None, None) => unreachable!("the pad-last analysis was just made"),
        };
        let factorized = cholesky.factorize(values);
        self.profile.factorization_s += phase.elapsed().as_secs_f64();
        let phase = Instant::now();
        if factorized.is_err() {
            return Ok(());
        }
        cholesky.trailing_factor(&mut self.trailing_factor);
        transpose(&self.trailing_factor, m2, &mut self.trailing_upper);
        // The condensed stiffness is L_tt itself (S = L_tt L_tt^T, see
        // `PadStiffness::Factor`): only the compliance is formed.
        schur_compliance(&self.trailing_factor, m2, &mut self.trailing_scratch, &mut compliance);
        // psi holds the loads of unit drive translations; they are solved
        // for the responses only when an attempt needs them
        // ([`FiniteSolver::solve_tangent_drive_responses`]): not in a slide
        // under a fixed drive, where most rebuilds are.
        self.tangent_psi_solved = false;
        // Phi, the response to unit pad forces, is not needed here: G(x)
        // puts the pad at v by one sparse solve.
        let phi = Vec::new();
        self.tangent_ops = Some(StepOperators { dt_s, coefficients, cholesky, phi, compliance, stiffness, psi });
        self.profile.condensation_s += phase.elapsed().as_secs_f64();
        if std::env::var_os("HAPTEX_DEBUG").is_some() {
            eprintln!("finite: tangent operators for dt {dt_s}: {:.1} ms", timer.elapsed().as_secs_f64() * 1e3);
        }
        Ok(())
    }

    /// Solves the tangent operators' drive responses psi from the loads
    /// [`FiniteSolver::build_tangent_operators`] left there, once.
    fn solve_tangent_drive_responses(&mut self) {
        if let Some(ops) = self.tangent_ops.as_mut()
            && !self.tangent_psi_solved
        {
            let timer = Instant::now();
            for response in ops.psi.iter_mut() {
                ops.cholesky.solve_vec(response);
            }
            self.tangent_psi_solved = true;
            self.profile.condensation_s += timer.elapsed().as_secs_f64();
        }
    }

    /// The reaction on the driven set (N per mm of width) from the
    /// committed finite-strain stresses, element by element.
    pub fn driven_reaction(&mut self) -> [f64; 2] {
        let f = &mut self.reaction_forces;
        f.fill(0.0);
        let body = &self.inner.problem.body;
        // The committed state was accepted, so no element is inverted.
        let _ = self.body_state.add_internal_forces(body, None, &self.reaction_elements, &self.inner.u, f);
        let mut r = [0.0; 2];
        for &node in &self.inner.problem.driven_nodes {
            r[0] += f[2 * node];
            r[1] += f[2 * node + 1];
        }
        r
    }

    /// The largest residual |f_int - P F|_inf over the free DOFs of the
    /// committed state (N per mm of width), computed afresh: the check
    /// that the committed state is in full nonlinear equilibrium.
    pub fn committed_residual(&self) -> f64 {
        let inner = &self.inner;
        let body = &inner.problem.body;
        let mut f = vec![0.0; inner.u.len()];
        if self.body_state.add_internal_forces(body, None, body.deformable_elements(), &inner.u, &mut f).is_err() {
            return f64::INFINITY;
        }
        for (c, &node) in inner.problem.contact.nodes.iter().enumerate() {
            f[2 * node] -= inner.forces[2 * c];
            f[2 * node + 1] -= inner.forces[2 * c + 1];
        }
        inner
            .dofs
            .free
            .iter()
            .enumerate()
            .filter(|(_, d)| **d != PRESCRIBED)
            .map(|(g, _)| f[g].abs())
            .fold(0.0, f64::max)
    }

    /// Number of free DOFs and of stored entries of the Cholesky factor.
    pub fn sizes(&self) -> (usize, usize) {
        self.inner.sizes()
    }
}
