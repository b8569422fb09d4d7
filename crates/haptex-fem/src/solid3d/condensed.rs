//! A linear 3D body condensed onto its contact nodes' unknowns, and the
//! contact equilibrium solved on them alone (the 2D model's scheme,
//! crate::solver, one dimension up).
//!
//! K, factorized once with the contact unknowns ordered last, gives their
//! condensed stiffness S (the factor's trailing block L, S = L L^T), its
//! inverse C = S^-1 (the contact unknowns' compliance) and, for a load f
//! on the free unknowns, their displacements v0 under f alone.
//! Equilibrium with the contact forces F(v) is
//!
//!   R(v) = S (v - v0) - F(v) = 0,  or  rho(v) = v - v0 - C F(v) = 0.
//!
//! Newton's method on it with the contact law's consistent tangent D (J =
//! S + D, unsymmetric where points slip) needs a solve with J. D acts on
//! the unknowns A of the nodes in contact only, so with C the step
//! delta = -J^-1 R = -rho - C D delta is, on A,
//!
//!   (I + C_AA D_AA) delta_A = -rho_A,
//!
//! a dense LU of the size of the contact patch (not of the whole region
//! that may touch), and then delta = -rho - C_:A (D_AA delta_A). F is
//! non-zero on the loaded unknowns only (A, and on a display the skin
//! its attraction reaches, whose tangent is left out where it is
//! negligible), so rho costs m times their number, not m^2. Backtracking on
//! |R|^2 (R = S rho = L (L^T rho), m^2; the Newton step is a descent
//! direction for it). The whole field follows from one more solve with K:
//! u = K^-1 (f + F(v)).

use super::contact::ContactSurface;
use crate::assembly::{PRESCRIBED, Pattern};
use crate::linalg::{DenseLu, FactorError, SparseCholesky, lower_times, schur_compliance};
// The 2D model's continuation: its damping where it starts (with 1 the
// iterates overshoot and cycle between active sets), the least before the
// step is Newton's, and its limit-cycle watch.
use crate::solver::{CONTINUATION_DAMPING, CycleWatch, MIN_DAMPING};

/// What a point's contact law gives the solver for its displacement (and,
/// when asked to, as if the point stuck, whatever its friction): the
/// force per unit area on the body (MPa) and its tangent -dF/du (MPa/mm);
/// `None` out of contact.
pub type PointForce = Option<([f64; 3], [[f64; 3]; 3])>;

/// Why the contact equilibrium was not found.
#[derive(Debug, thiserror::Error)]
pub enum EquilibriumError {
    #[error(
        "the contact equilibrium was not reached in {iterations} Newton iterations (largest residual {residual_n:.3e} N)"
    )]
    NoConvergence { iterations: usize, residual_n: f64 },
    #[error("the contact tangent is singular")]
    Singular,
    #[error("nothing is in contact, so no drive can carry the load")]
    NoContactForLoad,
}

/// How a point's law is asked for its force and tangent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointMode {
    /// The law as it is, with the exact tangent.
    Exact,
    /// The tangent without the surface's curvature's terms (the force is
    /// the same).
    NoCurvature,
    /// As if the point stuck, whatever its friction.
    Stick,
}

/// Where [`Condensation::equilibrium`] takes the exact tangent again after
/// dropping the curvature's term: |R| at this fraction of where it was
/// dropped.
pub const EXACT_AGAIN: f64 = 1e-2;

/// The tolerances and limits of [`Condensation::equilibrium`] (the 2D
/// model's [`crate::solver::SolverSettings`] give them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    pub max_iterations: usize,
    /// Further iterations once continuation has started.
    pub continuation_iterations: usize,
    pub relative_tolerance: f64,
    /// The smallest force the relative tolerance is taken of (N).
    pub force_floor_n: f64,
    pub increment_tolerance_mm: f64,
}

/// Load control: the driven nodes' vertical displacement is an unknown
/// and the total normal contact force is given. `per_mm` is the free
/// unknowns' load per mm of the drive (the prescribed displacements'
/// share of a unit drive); `change_mm` returns the drive's change.
#[derive(Debug)]
pub struct LoadControl<'a> {
    pub per_mm: &'a [f64],
    pub normal_force_n: f64,
    pub change_mm: f64,
}

/// The body's stiffness condensed on the contact unknowns.
pub struct Condensation {
    factor: SparseCholesky,
    /// L (S = L L^T) and C = S^-1, m x m, column-major.
    l: Vec<f64>,
    compliance: Vec<f64>,
    /// Global DOF of each contact unknown, its free index, and for each
    /// global DOF its place among the contact unknowns.
    global: Vec<usize>,
    free_index: Vec<usize>,
    index: Vec<Option<usize>>,
    lu: DenseLu,
}

/// Newton's method's effort.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Effort {
    pub iterations: usize,
}

/// The contact forces of one set of contact displacements, and the
/// tangent's entries on the unknowns in contact.
struct Forces {
    /// F on the contact unknowns.
    f: Vec<f64>,
    /// The unknowns in contact (A, ascending).
    active: Vec<usize>,
    /// D_AA, |A| x |A| column-major (filled only when asked for).
    d: Vec<f64>,
    /// rho = v - v0 - dz w - C F (with the tangent only).
    rho: Vec<f64>,
    /// The total normal contact force (N) and, with the tangent, its
    /// derivative with respect to the contact unknowns.
    normal_n: f64,
    g: Vec<f64>,
    /// The largest nodal contact force (N).
    largest: f64,
}

impl Condensation {
    /// The symbolic analysis of K (its `pattern`, over the free unknowns
    /// `free`: global DOF -> free index or PRESCRIBED) with the free
    /// unknowns of the `surface`'s nodes ordered last.
    pub fn new(pattern: &Pattern, free: &[usize], surface: &ContactSurface) -> Result<Self, FactorError> {
        let mut global: Vec<usize> = surface
            .points
            .iter()
            .flat_map(|p| p.nodes)
            .flat_map(|n| (0..3).map(move |d| 3 * n + d))
            .filter(|&g| free[g] != PRESCRIBED)
            .collect();
        global.sort_unstable();
        global.dedup();
        let free_index: Vec<usize> = global.iter().map(|&g| free[g]).collect();
        let mut index = vec![None; free.len()];
        for (k, &g) in global.iter().enumerate() {
            index[g] = Some(k);
        }
        let m = global.len();
        Ok(Self {
            factor: SparseCholesky::with_trailing(pattern, &free_index, 1)?,
            l: vec![0.0; m * m],
            compliance: vec![0.0; m * m],
            global,
            free_index,
            index,
            lu: DenseLu::new(m),
        })
    }

    /// The contact unknowns (the condensed system's size).
    pub fn unknowns(&self) -> usize {
        self.global.len()
    }

    /// Non-zeros of the sparse factor.
    pub fn factor_nnz(&self) -> usize {
        self.factor.factor_nnz()
    }

    /// Factorizes K (`values` on the pattern) and forms L and C.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.factor.factorize(values)?;
        let m = self.global.len();
        self.factor.trailing_factor(&mut self.l);
        let mut scratch = vec![0.0; m * m];
        schur_compliance(&self.l, m, &mut scratch, &mut self.compliance);
        Ok(())
    }

    /// K^-1 applied in place to a vector over the free unknowns.
    pub fn solve(&mut self, rhs: &mut [f64]) {
        self.factor.solve_vec(rhs);
    }

    /// The equilibrium of the body under the load `load` (over the free
    /// unknowns; the prescribed displacements' share included) with the
    /// contact of `surface`, whose point q with displacement w (mm) has
    /// the force and tangent `point(q, w, mode)`. `u` (3 per node) holds
    /// the prescribed values and a start for the contact nodes on entry,
    /// the whole solution on return.
    ///
    /// The 2D model's contact Newton (crate::solver::newton), step for
    /// step:
    ///
    /// - with `stick_predictor`, the first step is Newton's for every
    ///   point in contact sticking (where the pad still sticks, as at a
    ///   slide's start, the linearised slip of the last state drags it
    ///   past the surface and the iterates flip the slip directions back
    ///   and forth);
    /// - Newton's method with the exact tangent, backtracking on |R|^2 to
    ///   1/128 of the step;
    /// - where that finds no decrease (a kink of the residual within the
    ///   step: a point entering or leaving contact or changing between
    ///   stick and slip, or no equilibrium near, the skin snapping off a
    ///   crest), the curvature's term of the tangent is dropped; the
    ///   first time the full Newton step is taken, after that
    ///   pseudo-transient continuation. Without the curvature's term the
    ///   iteration converges only linearly (on the 0.06 mm crest of a 0.5
    ///   by 0.5 mm bump, 0.8 a step: a step ended unconverged at 100
    ///   iterations and |R| 1e-9 N), so once a full step has brought |R|
    ///   to [`EXACT_AGAIN`] of where the term was dropped, the exact
    ///   tangent is taken again, once per solve (that bump's 10 mm slide
    ///   on the coarse mesh: 15.0 s instead of 30.1 s). The continuation
    ///   is the damped step of
    ///   ((1 + tau) S + D) delta = -R, with tau from
    ///   [`CONTINUATION_DAMPING`] falling with the residual, which turns
    ///   into Newton's method near the solution; a limit cycle of it ends
    ///   the attempt.
    ///
    /// Converged when the largest residual force is below
    /// `relative_tolerance` of the largest nodal contact force (or of
    /// `force_floor_n`) and the part of the last Newton step not taken
    /// below `increment_tolerance_mm`.
    #[allow(clippy::too_many_arguments)]
    pub fn equilibrium(
        &mut self,
        load: &[f64],
        free: &[usize],
        u: &mut [f64],
        surface: &ContactSurface,
        point: &mut dyn FnMut(usize, [f64; 3], PointMode) -> PointForce,
        stick_predictor: bool,
        settings: &NewtonSettings,
        mut control: Option<&mut LoadControl<'_>>,
    ) -> Result<Effort, EquilibriumError> {
        let m = self.global.len();
        let mut u0 = load.to_vec();
        self.factor.solve_vec(&mut u0);
        let v0: Vec<f64> = self.free_index.iter().map(|&f| u0[f]).collect();
        // Under load control: the contact unknowns' displacement per mm of
        // the drive, and the drive's change dz (mm) from where it started.
        let w: Vec<f64> = match &control {
            Some(c) => {
                let mut per = c.per_mm.to_vec();
                self.factor.solve_vec(&mut per);
                self.free_index.iter().map(|&f| per[f]).collect()
            }
            None => Vec::new(),
        };
        let target = control.as_ref().map(|c| c.normal_force_n);
        let mut dz = 0.0f64;
        let mut residual = vec![0.0; m];
        let mut trial_residual = vec![0.0; m];
        let mut half = vec![0.0; m];
        // The elastic force e = S (v - v0 - dz w), so that R = e - F. It is
        // linear in the iterate, so a step's change of it follows from the
        // step's equation without a product with the dense S (D is sparse),
        // and it is computed afresh where convergence is declared.
        let sw: Vec<f64> = if w.is_empty() {
            Vec::new()
        } else {
            let mut out = vec![0.0; m];
            self.stiffness_times(&w, &mut half, &mut out);
            out
        };
        let mut elastic = vec![0.0; m];
        let elastic_afresh = |this: &Self, u: &[f64], dz: f64, half: &mut [f64], out: &mut [f64]| {
            let x: Vec<f64> =
                (0..m).map(|k| u[this.global[k]] - v0[k] - if w.is_empty() { 0.0 } else { dz * w[k] }).collect();
            this.stiffness_times(&x, half, out);
        };
        elastic_afresh(self, u, dz, &mut half, &mut elastic);
        let residual_of = |elastic: &[f64], state: &Forces, out: &mut [f64]| {
            for ((r, e), f) in out.iter_mut().zip(elastic).zip(&state.f) {
                *r = e - f;
            }
        };
        let norm2 = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
        let max_abs = |r: &[f64]| r.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let debug = std::env::var_os("HAPTEX_DEBUG").is_some();
        let tolerance = |scale: f64| settings.relative_tolerance * scale.max(settings.force_floor_n);
        // The residual's size and merit: |R| max and |R|^2 with the load's
        // residual beside R.
        let measure = |r: &[f64], state: &Forces| {
            let load_residual = target.map_or(0.0, |t| state.normal_n - t);
            (max_abs(r).max(load_residual.abs()), norm2(r) + load_residual * load_residual)
        };
        let mut mode = if stick_predictor { PointMode::Stick } else { PointMode::Exact };
        let mut damping = 0.0f64;
        let mut continuation_start = 0.0f64;
        let mut stalls = 0;
        // |R| where the curvature's term was dropped, and whether the
        // exact tangent was taken again since.
        let (mut dropped_at, mut exact_again) = (f64::INFINITY, false);
        let mut correction = 0.0f64;
        let mut limit = settings.max_iterations;
        let mut cycle = CycleWatch::EMPTY;
        let mut norm = f64::INFINITY;
        let mut iteration = 0;
        while iteration < limit {
            iteration += 1;
            let state = self.forces(u, &v0, &w, dz, surface, point, true, mode);
            residual_of(&elastic, &state, &mut residual);
            let mut merit;
            (norm, merit) = measure(&residual, &state);
            if !norm.is_finite() {
                break;
            }
            if debug {
                eprintln!(
                    "  3D contact iteration {iteration}: |R| {norm:.3e} N, largest force {:.3e} N, {} unknowns in \
                     contact, damping {damping:.1e}, drive change {dz:.3e} mm",
                    state.largest,
                    state.active.len()
                );
            }
            let converged = |norm: f64| {
                mode != PointMode::Stick
                    && norm <= tolerance(state.largest)
                    && correction <= settings.increment_tolerance_mm
            };
            if converged(norm) {
                // Confirmed with e computed afresh (no drift of the updates).
                elastic_afresh(self, u, dz, &mut half, &mut elastic);
                residual_of(&elastic, &state, &mut residual);
                (norm, merit) = measure(&residual, &state);
            }
            if converged(norm) {
                // The whole field: u = K^-1 (f + dz f_z + F).
                let mut full = load.to_vec();
                if let Some(c) = control.as_mut() {
                    for (f, p) in full.iter_mut().zip(c.per_mm) {
                        *f += dz * p;
                    }
                    c.change_mm = dz;
                }
                for (k, &f) in self.free_index.iter().enumerate() {
                    full[f] += state.f[k];
                }
                self.factor.solve_vec(&mut full);
                for (g, &f) in free.iter().enumerate() {
                    if f != PRESCRIBED {
                        u[g] = full[f];
                    }
                }
                return Ok(Effort { iterations: iteration });
            }
            // The step: Newton's (damped in continuation), bordered by the
            // load's row under load control: with (gamma I + C D) a = -rho
            // and (gamma I + C D) b = w, delta = a + ddz b and the load's
            // linearised residual g . delta + (F_z - F) = 0 gives ddz.
            self.factor_direction(&state, damping)?;
            let mut step = self.solve_direction(&state, damping, state.rho.iter().map(|v| -v).collect());
            let mut ddz = 0.0;
            if let Some(t) = target {
                let b = self.solve_direction(&state, damping, w.clone());
                let (ga, gb) = (crate::linalg::dot(&state.g, &step), crate::linalg::dot(&state.g, &b));
                if gb == 0.0 || gb.is_nan() {
                    return Err(EquilibriumError::NoContactForLoad);
                }
                ddz = (t - state.normal_n - ga) / gb;
                for (s, bi) in step.iter_mut().zip(&b) {
                    *s += ddz * bi;
                }
            }
            let step_max = max_abs(&step).max(ddz.abs());
            // The step's change of e: from (gamma S + D) delta = -R + ddz S w,
            // S delta = (-R + ddz S w - D delta) / gamma, and e changes by
            // S delta - ddz S w.
            let gamma = 1.0 + damping;
            let mut d_elastic: Vec<f64> = residual.iter().map(|r| -r / gamma).collect();
            let k = state.active.len();
            for (i, &row) in state.active.iter().enumerate() {
                let d_delta: f64 = (0..k).map(|j| state.d[j * k + i] * step[state.active[j]]).sum();
                d_elastic[row] -= d_delta / gamma;
            }
            if !sw.is_empty() {
                for (de, s) in d_elastic.iter_mut().zip(&sw) {
                    *de += ddz * s * (1.0 / gamma - 1.0);
                }
            }
            let elastic_start = elastic.clone();
            let original: Vec<f64> = self.global.iter().map(|&g| u[g]).collect();
            let dz_start = dz;
            let set = |u: &mut [f64], dz: &mut f64, elastic: &mut [f64], alpha: f64| {
                for (k, &g) in self.global.iter().enumerate() {
                    u[g] = original[k] + alpha * step[k];
                }
                *dz = dz_start + alpha * ddz;
                for ((e, e0), de) in elastic.iter_mut().zip(&elastic_start).zip(&d_elastic) {
                    *e = e0 + alpha * de;
                }
            };
            if mode == PointMode::Stick {
                // The predictor's whole step, then Newton's method.
                set(u, &mut dz, &mut elastic, 1.0);
                mode = PointMode::Exact;
                correction = 0.0;
                continue;
            }
            if damping > 0.0 {
                // Continuation: the whole damped step; the damping follows
                // the residual relative to where continuation started, at
                // most halved per step.
                set(u, &mut dz, &mut elastic, 1.0);
                let trial = self.forces(u, &v0, &w, dz, surface, point, false, mode);
                residual_of(&elastic, &trial, &mut trial_residual);
                let (next, _) = measure(&trial_residual, &trial);
                correction = damping * step_max;
                damping = if next.is_finite() && continuation_start > 0.0 {
                    (CONTINUATION_DAMPING * (next / continuation_start).min(1.0)).max(0.5 * damping)
                } else {
                    CONTINUATION_DAMPING
                };
                if damping < MIN_DAMPING {
                    damping = 0.0;
                }
                if cycle.push(next).is_some() {
                    break;
                }
                continue;
            }
            // Newton's step, backtracking on the merit.
            let mut alpha = 1.0;
            let mut accepted = false;
            let mut trial_norm_accepted = f64::INFINITY;
            for _ in 0..8 {
                set(u, &mut dz, &mut elastic, alpha);
                let trial = self.forces(u, &v0, &w, dz, surface, point, false, mode);
                residual_of(&elastic, &trial, &mut trial_residual);
                let (trial_norm, trial_merit) = measure(&trial_residual, &trial);
                if trial_merit.is_finite()
                    && (trial_merit < (1.0 - 1e-4 * alpha) * merit || trial_norm <= tolerance(trial.largest))
                {
                    accepted = true;
                    trial_norm_accepted = trial_norm;
                    break;
                }
                alpha *= 0.5;
            }
            if accepted
                && alpha == 1.0
                && mode == PointMode::NoCurvature
                && !exact_again
                && trial_norm_accepted <= EXACT_AGAIN * dropped_at
            {
                mode = PointMode::Exact;
                exact_again = true;
            }
            if !accepted && exact_again && mode == PointMode::Exact {
                // The exact tangent failed again near the solution: without
                // the curvature's term for good, the full step taken.
                mode = PointMode::NoCurvature;
                alpha = 1.0;
                set(u, &mut dz, &mut elastic, 1.0);
            } else if !accepted {
                if mode == PointMode::Exact {
                    dropped_at = norm;
                }
                mode = PointMode::NoCurvature;
                stalls += 1;
                if stalls == 1 {
                    alpha = 1.0;
                    set(u, &mut dz, &mut elastic, 1.0);
                } else {
                    alpha = 0.0;
                    set(u, &mut dz, &mut elastic, 0.0);
                    damping = CONTINUATION_DAMPING;
                    continuation_start = norm;
                    limit = limit.max(iteration + 1 + settings.continuation_iterations);
                }
            }
            correction = (1.0 - alpha) * step_max;
            if debug {
                eprintln!("    step length {}", if accepted { alpha } else { f64::NAN });
            }
        }
        Err(EquilibriumError::NoConvergence { iterations: iteration, residual_n: norm })
    }

    /// Factorizes the step's matrix at `state`: Newton's, or with
    /// `damping` tau > 0 that of ((1 + tau) S + D) delta = -R; in
    /// compliance form (gamma I + C_AA D_AA), gamma = 1 + tau, on the
    /// unknowns in contact.
    fn factor_direction(&mut self, state: &Forces, damping: f64) -> Result<(), EquilibriumError> {
        let m = self.global.len();
        let k = state.active.len();
        let gamma = 1.0 + damping;
        // C_AA gathered once (column-major), then each column of C_AA D_AA
        // as a sum of C_AA's columns over D's non-zeros (D is sparse: a
        // node couples to its faces' neighbours only).
        let mut c_aa = vec![0.0; k * k];
        for (l, &col) in state.active.iter().enumerate() {
            let c_col = &self.compliance[col * m..(col + 1) * m];
            for (i, &row) in state.active.iter().enumerate() {
                c_aa[l * k + i] = c_col[row];
            }
        }
        let mut column_out = vec![0.0; k];
        let mut matrix = self.lu.matrix_mut(k);
        for (j, column) in state.d.chunks_exact(k.max(1)).take(k).enumerate() {
            column_out.fill(0.0);
            column_out[j] = gamma;
            for (l, &d_lj) in column.iter().enumerate() {
                if d_lj != 0.0 {
                    for (o, c) in column_out.iter_mut().zip(&c_aa[l * k..(l + 1) * k]) {
                        *o += c * d_lj;
                    }
                }
            }
            for (i, &v) in column_out.iter().enumerate() {
                matrix[(i, j)] = v;
            }
        }
        if self.lu.factor() { Ok(()) } else { Err(EquilibriumError::Singular) }
    }

    /// x with (gamma I + C D) x = y (the matrix of
    /// [`Condensation::factor_direction`]): x_A from the LU, then
    /// x = (y - C_:A (D_AA x_A)) / gamma.
    fn solve_direction(&mut self, state: &Forces, damping: f64, y: Vec<f64>) -> Vec<f64> {
        let m = self.global.len();
        let k = state.active.len();
        let gamma = 1.0 + damping;
        let mut x_a: Vec<f64> = state.active.iter().map(|&i| y[i]).collect();
        self.lu.solve(&mut x_a);
        let mut x = y;
        for (l, &col) in state.active.iter().enumerate() {
            let d_x: f64 = (0..k).map(|j| state.d[j * k + l] * x_a[j]).sum::<f64>();
            if d_x != 0.0 {
                for (s, c) in x.iter_mut().zip(&self.compliance[col * m..(col + 1) * m]) {
                    *s -= c * d_x;
                }
            }
        }
        if damping > 0.0 {
            x.iter_mut().for_each(|s| *s /= gamma);
        }
        x
    }

    /// R = S rho = L (L^T rho) into `out` (`half` is scratch).
    fn stiffness_times(&self, rho: &[f64], half: &mut [f64], out: &mut [f64]) {
        let m = self.global.len();
        for (i, h) in half.iter_mut().enumerate() {
            *h = crate::linalg::dot(&self.l[i * m + i..(i + 1) * m], &rho[i..]);
        }
        lower_times(&self.l, m, half, out);
    }

    /// F, rho and (with `tangent`) D_AA at the displacements `u`, each
    /// point's law in `mode`.
    #[allow(clippy::too_many_arguments)]
    fn forces(
        &self,
        u: &[f64],
        v0: &[f64],
        drive: &[f64],
        dz: f64,
        surface: &ContactSurface,
        point: &mut dyn FnMut(usize, [f64; 3], PointMode) -> PointForce,
        tangent: bool,
        mode: PointMode,
    ) -> Forces {
        let m = self.global.len();
        let mut f = vec![0.0; m];
        let responses: Vec<PointForce> =
            surface.points.iter().enumerate().map(|(q, p)| point(q, p.displacement(u), mode)).collect();
        let mut place = vec![None; m];
        let mut active = Vec::new();
        let mut loaded = vec![false; m];
        let mut normal_n = 0.0;
        for (p, response) in surface.points.iter().zip(&responses) {
            let Some((force, t)) = response else {
                continue;
            };
            normal_n += p.weight * force[2];
            // A point whose tangent is zero (a display's attraction on
            // skin far from it) loads its nodes without making them
            // unknowns of the step's dense system.
            let stiff = t.iter().flatten().any(|&v| v != 0.0);
            for a in 0..4 {
                for d in 0..3 {
                    if let Some(i) = self.index[3 * p.nodes[a] + d] {
                        f[i] += p.weight * p.shape[a] * force[d];
                        loaded[i] = true;
                        if stiff && place[i].is_none() {
                            place[i] = Some(0);
                            active.push(i);
                        }
                    }
                }
            }
        }
        active.sort_unstable();
        for (k, &i) in active.iter().enumerate() {
            place[i] = Some(k);
        }
        let k = active.len();
        let mut d = Vec::new();
        let mut g = Vec::new();
        if tangent {
            d = vec![0.0; k * k];
            g = vec![0.0; m];
            for (p, response) in surface.points.iter().zip(&responses) {
                let Some((_, t)) = response else {
                    continue;
                };
                // The total normal force's derivative: -w N_b K[z][c].
                for b in 0..4 {
                    for c in 0..3 {
                        if let Some(j) = self.index[3 * p.nodes[b] + c] {
                            g[j] -= p.weight * p.shape[b] * t[2][c];
                        }
                    }
                }
                for a in 0..4 {
                    for b in 0..4 {
                        let nn = p.weight * p.shape[a] * p.shape[b];
                        for r in 0..3 {
                            let Some(i) = self.index[3 * p.nodes[a] + r].and_then(|i| place[i]) else {
                                continue;
                            };
                            for c in 0..3 {
                                if let Some(j) = self.index[3 * p.nodes[b] + c].and_then(|j| place[j]) {
                                    d[j * k + i] += nn * t[r][c];
                                }
                            }
                        }
                    }
                }
            }
        }
        // rho = v - v0 - dz w - C F, F non-zero on the loaded unknowns
        // only (with the tangent: a line search's trial needs F alone).
        let mut rho = Vec::new();
        if tangent {
            rho = self.global.iter().zip(v0).map(|(&g, v)| u[g] - v).collect();
            if dz != 0.0 {
                for (r, w) in rho.iter_mut().zip(drive) {
                    *r -= dz * w;
                }
            }
            for i in (0..m).filter(|&i| loaded[i]) {
                if f[i] != 0.0 {
                    for (r, c) in rho.iter_mut().zip(&self.compliance[i * m..(i + 1) * m]) {
                        *r -= c * f[i];
                    }
                }
            }
        }
        let largest = f.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        Forces { f, active, d, g, rho, largest, normal_n }
    }
}
