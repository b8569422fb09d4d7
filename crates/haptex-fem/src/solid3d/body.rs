//! A visco-elastic 3D body of hexahedra, each of one of several materials
//! (the finger's layers): the 2D model's Prony series on the deviatoric
//! stress (Simo-Hughes recursion, crate::material), the bulk modulus
//! elastic. For a time step dt the body is linear,
//!
//!   K(dt) u = f_ext - f_frozen(history),
//!
//! with K(dt) the stiffness at the algorithmic shear modulus G0 r(dt) and
//! f_frozen the forces of the part of the deviator that does not depend on
//! the new strain. One factorization per step size (the symbolic analysis
//! once): the 3D counterpart of crate::body and crate::statics.

use super::hex8::{Formulation, Hex8};
use super::mesh::{Mesh3, MeshError};
use crate::assembly::{DofMap, PRESCRIBED, Pattern};
use crate::linalg::{FactorError, SparseCholesky};
use crate::material::{Material, MaterialError, StepCoefficients, advance_history, frozen_deviator, history_deviator};

/// Why a body cannot be made or stepped.
#[derive(Debug, thiserror::Error)]
pub enum BodyError {
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(transparent)]
    Material(#[from] MaterialError),
    #[error("element {element} has material {index}, and there are {count} materials")]
    NoSuchMaterial { element: usize, index: usize, count: usize },
    #[error("the stiffness could not be factorized: {0}")]
    Factor(#[from] FactorError),
    #[error("step size {0} s: it must be finite and not negative")]
    StepSize(f64),
}

/// A visco-elastic body with a fixed set of prescribed DOFs.
pub struct ViscoelasticBody {
    pub mesh: Mesh3,
    pub geometry: Vec<Hex8>,
    pub formulation: Formulation,
    pub materials: Vec<Material>,
    pub element_material: Vec<usize>,
    free: Vec<usize>,
    n_free: usize,
    pattern: Pattern,
    /// The body's own factorization of K(dt), made at the first
    /// [`ViscoelasticBody::step`] (a contact solver factorizes its own).
    cholesky: Option<SparseCholesky>,
    /// The step size whose K `cholesky` holds.
    factored_dt: Option<f64>,
    values: Vec<f64>,
    assembled_dt: Option<f64>,
    coefficients: Vec<StepCoefficients>,
    /// Per element and Gauss point: the instantaneous deviator s0, then one
    /// internal stress per Prony term of its material (6 components each).
    history: Vec<[f64; 6]>,
    history_start: Vec<usize>,
}

impl ViscoelasticBody {
    /// A body of `mesh` whose element e is of `materials[element_material[e]]`,
    /// with the global DOFs (3 n + direction) in `prescribed` fixed.
    pub fn new(
        mesh: Mesh3,
        formulation: Formulation,
        materials: Vec<Material>,
        element_material: Vec<usize>,
        prescribed: &[usize],
    ) -> Result<Self, BodyError> {
        for m in &materials {
            m.validate()?;
        }
        for (element, &index) in element_material.iter().enumerate() {
            if index >= materials.len() {
                return Err(BodyError::NoSuchMaterial { element, index, count: materials.len() });
            }
        }
        assert_eq!(element_material.len(), mesh.elements.len(), "one material index per element");
        let geometry = mesh.geometry()?;
        let dofs = DofMap::with_dofs_per_node(mesh.n_nodes(), 3, prescribed);
        let pattern = mesh.pattern(&dofs);
        let DofMap { free, n_free } = dofs;
        let history_start = history_starts(&materials, &element_material);
        let count = *history_start.last().expect("one entry past the last element");
        Ok(Self {
            values: vec![0.0; pattern.nnz()],
            mesh,
            geometry,
            formulation,
            materials,
            element_material,
            free,
            n_free,
            pattern,
            cholesky: None,
            factored_dt: None,
            assembled_dt: None,
            coefficients: Vec::new(),
            history: vec![[0.0; 6]; count],
            history_start,
        })
    }

    /// Free unknowns.
    pub fn n_free(&self) -> usize {
        self.n_free
    }

    /// Assembles K(dt_s) and the step's coefficients, unless they are
    /// already for this step size; true if they changed.
    pub fn prepare(&mut self, dt_s: f64) -> Result<bool, BodyError> {
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            return Err(BodyError::StepSize(dt_s));
        }
        if self.assembled_dt == Some(dt_s) {
            return Ok(false);
        }
        self.assembled_dt = None;
        self.coefficients = self.materials.iter().map(|m| m.step(dt_s)).collect();
        self.values.fill(0.0);
        for (e, h) in self.geometry.iter().enumerate() {
            let m = &self.materials[self.element_material[e]];
            let g = m.shear_mpa() * self.coefficients[self.element_material[e]].shear_ratio;
            self.pattern.add_element(e, &h.stiffness(self.formulation, g, m.bulk_mpa()), &mut self.values);
        }
        self.assembled_dt = Some(dt_s);
        Ok(true)
    }

    /// K(dt) of the last [`ViscoelasticBody::prepare`], on [`ViscoelasticBody::pattern`].
    pub fn stiffness_values(&self) -> &[f64] {
        &self.values
    }

    /// The stiffness pattern over the free unknowns.
    pub fn pattern(&self) -> &Pattern {
        &self.pattern
    }

    /// Global DOF (3 n + direction) -> free index, or PRESCRIBED.
    pub fn free(&self) -> &[usize] {
        &self.free
    }

    /// The free unknowns' load of the step last prepared, besides external
    /// forces: minus the frozen history's forces and minus K_fp u_p, the
    /// prescribed displacements' (`u` holds their values).
    pub fn step_load(&self, u: &[f64]) -> Vec<f64> {
        let mut rhs = vec![0.0; self.n_free];
        for (e, h) in self.geometry.iter().enumerate() {
            let mi = self.element_material[e];
            let (m, c) = (&self.materials[mi], &self.coefficients[mi]);
            let dofs = self.mesh.element_dofs(e);
            let mut f = [0.0; 24];
            let per_point = 1 + m.prony.len();
            for gp in 0..8 {
                let at = self.history_start[e] + gp * per_point;
                let s = frozen_deviator(&self.history[at], &self.history[at + 1..at + per_point], c);
                h.add_deviator_force(gp, &s, &mut f);
            }
            if dofs.iter().any(|&d| self.free[d] == PRESCRIBED && u[d] != 0.0) {
                let k = h.stiffness(self.formulation, m.shear_mpa() * c.shear_ratio, m.bulk_mpa());
                let moved = super::hex8::prescribed_forces(&k, &dofs, |d| (self.free[d] == PRESCRIBED).then(|| u[d]));
                for (fi, m) in f.iter_mut().zip(moved) {
                    *fi += m;
                }
            }
            for i in 0..24 {
                let d = self.free[dofs[i]];
                if d != PRESCRIBED {
                    rhs[d] -= f[i];
                }
            }
        }
        rhs
    }

    /// One step of size `dt_s`: `u` (3 per node) holds the prescribed
    /// values on entry and the whole solution on return; `f_ext` the
    /// external nodal forces (global). The history is committed.
    pub fn step(&mut self, dt_s: f64, u: &mut [f64], f_ext: &[f64]) -> Result<(), BodyError> {
        self.prepare(dt_s)?;
        if self.cholesky.is_none() {
            self.cholesky = Some(SparseCholesky::new(&self.pattern, 1)?);
        }
        if self.factored_dt != Some(dt_s) {
            self.factored_dt = None;
            self.cholesky.as_mut().expect("made above").factorize(&self.values)?;
            self.factored_dt = Some(dt_s);
        }
        let mut rhs = self.step_load(u);
        for (g, &d) in self.free.iter().enumerate() {
            if d != PRESCRIBED {
                rhs[d] += f_ext[g];
            }
        }
        self.cholesky.as_mut().expect("made above").solve_vec(&mut rhs);
        for (g, &d) in self.free.iter().enumerate() {
            if d != PRESCRIBED {
                u[g] = rhs[d];
            }
        }
        self.commit(u);
        Ok(())
    }

    /// Advances every point's history to the displacements `u` of the
    /// step last prepared.
    pub fn commit(&mut self, u: &[f64]) {
        for (e, h) in self.geometry.iter().enumerate() {
            let mi = self.element_material[e];
            let (m, c) = (&self.materials[mi], &self.coefficients[mi]);
            let ue = self.element_displacements(e, u);
            let per_point = 1 + m.prony.len();
            for gp in 0..8 {
                let eps = h.strain(gp, &ue);
                let mean = (eps[0] + eps[1] + eps[2]) / 3.0;
                let g2 = 2.0 * m.shear_mpa();
                let s0_new = [
                    g2 * (eps[0] - mean),
                    g2 * (eps[1] - mean),
                    g2 * (eps[2] - mean),
                    g2 * eps[3],
                    g2 * eps[4],
                    g2 * eps[5],
                ];
                let at = self.history_start[e] + gp * per_point;
                let (s0, rest) = self.history[at..at + per_point].split_at_mut(1);
                advance_history(&mut s0[0], rest, c, &s0_new);
            }
        }
    }

    fn element_displacements(&self, e: usize, u: &[f64]) -> [f64; 24] {
        self.mesh.element_dofs(e).map(|d| u[d])
    }

    /// The stress (tensor components xx, yy, zz, xy, yz, zx; MPa) at Gauss
    /// point `gp` of element `e` after the last step, for its displacements
    /// `u`: the relaxed deviator of the history plus K theta.
    pub fn stress(&self, e: usize, gp: usize, u: &[f64]) -> [f64; 6] {
        let m = &self.materials[self.element_material[e]];
        let per_point = 1 + m.prony.len();
        let at = self.history_start[e] + gp * per_point;
        let s = history_deviator(&self.history[at], &self.history[at + 1..at + per_point], m.g_inf());
        let p = m.bulk_mpa() * self.geometry[e].dilatation(self.formulation, gp, &self.element_displacements(e, u));
        [s[0] + p, s[1] + p, s[2] + p, s[3], s[4], s[5]]
    }
}

/// Where each element's history starts in a body's history array (8 Gauss
/// points of 1 + (Prony terms of its material) stresses each), and one
/// entry past the last element: the array's length.
pub(crate) fn history_starts(materials: &[Material], element_material: &[usize]) -> Vec<usize> {
    let mut starts = Vec::with_capacity(element_material.len() + 1);
    let mut count = 0;
    for &m in element_material {
        starts.push(count);
        count += 8 * (1 + materials[m].prony.len());
    }
    starts.push(count);
    starts
}
