//! Quasi-static linear steps without contact: the prescribed displacements
//! and nodal loads are given, the free displacements solve
//!
//!   K(dt) u_f = f_ext - f_frozen - K_fp u_p.
//!
//! Used on its own by the validation cases (patch test, Lamé cylinder,
//! Prony relaxation) and as the base of the contact solver, which adds the
//! contact forces through the same factorization.

use crate::assembly::{DofMap, PRESCRIBED, Pattern};
use crate::body::Body;
use crate::linalg::{FactorError, SparseCholesky};
use crate::material::StepCoefficients;

/// The factorized stiffness of a body with a fixed set of prescribed DOFs.
pub struct LinearSystem {
    pub dofs: DofMap,
    pub pattern: Pattern,
    pub cholesky: SparseCholesky,
    values: Vec<f64>,
    /// The step size the current factorization is for.
    factored_dt: Option<f64>,
    pub coefficients: Vec<Option<StepCoefficients>>,
}

impl LinearSystem {
    /// Analyses the stiffness pattern of `body` with the global DOFs in
    /// `prescribed` removed; `max_rhs` as for [`SparseCholesky::new`].
    pub fn new(body: &Body, prescribed: &[usize], max_rhs: usize) -> Result<Self, FactorError> {
        let dofs = DofMap::new(body.mesh.n_nodes(), prescribed);
        let pattern = Pattern::new(&dofs, &body.mesh.elements, body.deformable_elements());
        let cholesky = SparseCholesky::new(&pattern, max_rhs)?;
        let values = vec![0.0; pattern.nnz()];
        Ok(Self { dofs, pattern, cholesky, values, factored_dt: None, coefficients: Vec::new() })
    }

    /// Makes the factorization current for step size `dt_s` (re-factorizes
    /// only when the step size changes).
    pub fn prepare(&mut self, body: &Body, dt_s: f64) -> Result<bool, FactorError> {
        if self.factored_dt == Some(dt_s) {
            return Ok(false);
        }
        self.coefficients = body.step_coefficients(dt_s);
        body.assemble(&self.coefficients, &self.pattern, &mut self.values);
        self.factored_dt = None;
        self.cholesky.factorize(&self.values)?;
        self.factored_dt = Some(dt_s);
        Ok(true)
    }

    /// The assembled stiffness values (lower triangle in `pattern`).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The free right-hand side of a step: external loads (global vector)
    /// minus the frozen history forces and the prescribed-displacement forces.
    pub fn right_hand_side(&self, body: &Body, u: &[f64], f_ext: &[f64], f_free: &mut [f64]) {
        f_free.fill(0.0);
        for (g, &d) in self.dofs.free.iter().enumerate() {
            if d != PRESCRIBED {
                f_free[d] = f_ext[g];
            }
        }
        body.add_history_loads(&self.coefficients, &self.dofs, f_free);
        body.add_prescribed_loads(&self.coefficients, &self.dofs, u, f_free);
    }

    /// Copies free values into the global vector.
    pub fn scatter(&self, free: &[f64], u: &mut [f64]) {
        for (g, &d) in self.dofs.free.iter().enumerate() {
            if d != PRESCRIBED {
                u[g] = free[d];
            }
        }
    }

    /// One linear step of size `dt_s`: `u` holds the prescribed values on
    /// entry and the full solution on return; the history is committed.
    pub fn step(&mut self, body: &mut Body, dt_s: f64, u: &mut [f64], f_ext: &[f64]) -> Result<(), FactorError> {
        self.prepare(body, dt_s)?;
        let mut f = vec![0.0; self.dofs.n_free];
        self.right_hand_side(body, u, f_ext, &mut f);
        self.cholesky.solve_vec(&mut f);
        self.scatter(&f, u);
        body.commit(&self.coefficients, u);
        Ok(())
    }
}
