//! A linear 3D body condensed onto its contact nodes' unknowns, and the
//! contact equilibrium solved on them alone (the 2D model's scheme,
//! crate::solver, one dimension up).
//!
//! K, factorized once with the contact unknowns ordered last, gives their
//! condensed stiffness S (the factor's trailing block L, S = L L^T) and,
//! for a load f on the free unknowns, their displacements v0 under f
//! alone. Equilibrium with the contact forces F(v) is then
//!
//!   R(v) = S (v - v0) - F(v) = 0,
//!
//! solved by Newton's method with the contact law's consistent tangent
//! (unsymmetric where points slip), dense LU, backtracking on |R|^2. The
//! whole field follows from one more solve with K: u = K^-1 (f + F(v)).

use super::contact::ContactSurface;
use crate::assembly::{PRESCRIBED, Pattern};
use crate::linalg::{DenseLu, FactorError, SparseCholesky};

/// What a point's contact law gives the solver for its displacement: the
/// force per unit area on the body (MPa) and its tangent -dF/du (MPa/mm);
/// `None` out of contact.
pub type PointForce = Option<([f64; 3], [[f64; 3]; 3])>;

/// Why the contact equilibrium was not found.
#[derive(Debug, thiserror::Error)]
pub enum EquilibriumError {
    #[error(
        "the contact equilibrium was not reached in {iterations} Newton iterations (largest residual {residual_n:e} N)"
    )]
    NoConvergence { iterations: usize, residual_n: f64 },
    #[error("the contact tangent is singular at Newton iteration {iteration}")]
    Singular { iteration: usize },
}

/// The body's stiffness condensed on the contact unknowns.
pub struct Condensation {
    factor: SparseCholesky,
    /// S, m x m, column-major.
    stiffness: Vec<f64>,
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
            stiffness: vec![0.0; m * m],
            global,
            free_index,
            index,
            lu: DenseLu::new(m),
        })
    }

    /// The contact unknowns (the dense system's size).
    pub fn unknowns(&self) -> usize {
        self.global.len()
    }

    /// Non-zeros of the sparse factor.
    pub fn factor_nnz(&self) -> usize {
        self.factor.factor_nnz()
    }

    /// Factorizes K (`values` on the pattern) and forms S.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), FactorError> {
        self.factor.factorize(values)?;
        let m = self.global.len();
        let mut l = vec![0.0; m * m];
        self.factor.trailing_factor(&mut l);
        // S = L L^T (column-major, symmetric; L lower).
        for j in 0..m {
            for i in j..m {
                let sum: f64 = (0..=j).map(|k| l[k * m + i] * l[k * m + j]).sum();
                self.stiffness[j * m + i] = sum;
                self.stiffness[i * m + j] = sum;
            }
        }
        Ok(())
    }

    /// K^-1 applied in place to a vector over the free unknowns.
    pub fn solve(&mut self, rhs: &mut [f64]) {
        self.factor.solve_vec(rhs);
    }

    /// The equilibrium of the body under the load `load` (over the free
    /// unknowns; the prescribed displacements' share included) with the
    /// contact of `surface`, whose point q with displacement w (mm) has
    /// the force and tangent `point(q, w)`. `u` (3 per node) holds the
    /// prescribed values and a start for the contact nodes on entry, the
    /// whole solution on return.
    ///
    /// Converged when the largest residual is below 1e-10 of the largest
    /// nodal contact force (or of 1 mN, whichever is larger) and the last
    /// correction below 1e-10 mm.
    pub fn equilibrium(
        &mut self,
        load: &[f64],
        free: &[usize],
        u: &mut [f64],
        surface: &ContactSurface,
        point: &mut dyn FnMut(usize, [f64; 3]) -> PointForce,
    ) -> Result<Effort, EquilibriumError> {
        const MAX_ITERATIONS: usize = 100;
        let m = self.global.len();
        let mut u0 = load.to_vec();
        self.factor.solve_vec(&mut u0);
        let v0: Vec<f64> = self.free_index.iter().map(|&f| u0[f]).collect();
        let mut forces = vec![0.0; m];
        let mut residual = vec![0.0; m];
        let mut candidate = vec![0.0; m];
        let norm2 = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
        for iteration in 1..=MAX_ITERATIONS {
            // R and J = S + the points' tangents, then the Newton step.
            let largest = self.residual(u, &v0, surface, point, &mut forces, &mut residual, true);
            if !self.lu.factor() {
                return Err(EquilibriumError::Singular { iteration });
            }
            let mut step: Vec<f64> = residual.iter().map(|v| -v).collect();
            self.lu.solve(&mut step);
            let r_max = residual.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let step_max = step.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if r_max <= 1e-10 * largest.max(1e-3) && step_max <= 1e-10 {
                // The whole field: u = K^-1 (f + F).
                let mut full = load.to_vec();
                for (k, &f) in self.free_index.iter().enumerate() {
                    full[f] += forces[k];
                }
                self.factor.solve_vec(&mut full);
                for (g, &f) in free.iter().enumerate() {
                    if f != PRESCRIBED {
                        u[g] = full[f];
                    }
                }
                return Ok(Effort { iterations: iteration });
            }
            let before = norm2(&residual);
            let original: Vec<f64> = self.global.iter().map(|&g| u[g]).collect();
            let mut alpha = 1.0;
            loop {
                for (k, &g) in self.global.iter().enumerate() {
                    u[g] = original[k] + alpha * step[k];
                }
                self.residual(u, &v0, surface, point, &mut forces, &mut candidate, false);
                if norm2(&candidate) <= (1.0 - 1e-4 * alpha) * before || alpha < 1e-3 {
                    break;
                }
                alpha *= 0.5;
            }
        }
        let residual_n = residual.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        Err(EquilibriumError::NoConvergence { iterations: MAX_ITERATIONS, residual_n })
    }

    /// R(v) = S (v - v0) - F(v) into `residual` and F into `forces`; with
    /// `jacobian`, J = S + the tangents into the LU's matrix. Returns the
    /// largest nodal contact force (N).
    #[allow(clippy::too_many_arguments)]
    fn residual(
        &mut self,
        u: &[f64],
        v0: &[f64],
        surface: &ContactSurface,
        point: &mut dyn FnMut(usize, [f64; 3]) -> PointForce,
        forces: &mut [f64],
        residual: &mut [f64],
        jacobian: bool,
    ) -> f64 {
        let m = self.global.len();
        forces.fill(0.0);
        let mut jac = jacobian.then(|| self.lu.matrix_mut(m));
        if let Some(jac) = jac.as_mut() {
            for j in 0..m {
                for i in 0..m {
                    jac[(i, j)] = self.stiffness[j * m + i];
                }
            }
        }
        for (q, p) in surface.points.iter().enumerate() {
            let w: [f64; 3] = std::array::from_fn(|d| (0..4).map(|a| p.shape[a] * u[3 * p.nodes[a] + d]).sum());
            let Some((force, tangent)) = point(q, w) else {
                continue;
            };
            for a in 0..4 {
                let row = |d: usize| self.index[3 * p.nodes[a] + d];
                for d in 0..3 {
                    if let Some(i) = row(d) {
                        forces[i] += p.weight * p.shape[a] * force[d];
                    }
                }
                let Some(jac) = jac.as_mut() else {
                    continue;
                };
                for b in 0..4 {
                    let nn = p.weight * p.shape[a] * p.shape[b];
                    for d in 0..3 {
                        let Some(i) = row(d) else {
                            continue;
                        };
                        for e in 0..3 {
                            if let Some(j) = self.index[3 * p.nodes[b] + e] {
                                jac[(i, j)] += nn * tangent[d][e];
                            }
                        }
                    }
                }
            }
        }
        residual.fill(0.0);
        for j in 0..m {
            let dv = u[self.global[j]] - v0[j];
            if dv != 0.0 {
                let column = &self.stiffness[j * m..(j + 1) * m];
                for (r, s) in residual.iter_mut().zip(column) {
                    *r += s * dv;
                }
            }
        }
        for (r, f) in residual.iter_mut().zip(forces.iter()) {
            *r -= f;
        }
        forces.iter().fold(0.0f64, |a, v| a.max(v.abs()))
    }
}
