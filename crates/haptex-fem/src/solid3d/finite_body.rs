//! A 3D body at finite strain (NLGEOM, issue 39): the total-Lagrangian
//! hexahedra of [`super::finite_hex8`], each of one of several materials
//! (the finger's layers) with the 2D model's Prony series on the isochoric
//! second Piola-Kirchhoff stress ([`crate::hyperelastic`]'s recursion),
//! loaded by prescribed displacements and nodal forces.
//!
//! A step of size dt (0 for a static, elastic step) finds u with
//!
//! ```text
//!   f_int(u) = f_ext    on the free unknowns,
//! ```
//!
//! by Newton's method with the consistent tangent (symmetric, positive
//! definite while the body is stable; one sparse Cholesky factorization per
//! iteration, the symbolic analysis once). The prescribed displacements
//! move to their new values in sub-steps: each starts from the linear
//! predictor u_f += K_ff^-1 (r - K_fp du_p) at the last equilibrium, and a
//! sub-step that does not converge, or in which an element inverts, is
//! retried in halves. A Newton step that inverts an element or does not
//! lower the residual is halved (up to [`StaticSettings::backtracks`]
//! times). Convergence: the largest residual within `relative_tolerance`
//! of the largest internal force (reactions included) or of
//! `force_floor_n`.
//!
//! Validated without contact: tests/finite_strain_body_3d.rs (patch test,
//! uniaxial compression against the closed form, Prony relaxation) and
//! tests/calculix_reference_3d_nlgeom.rs (a block moved on its whole
//! surface, against CalculiX's NLGEOM). The finger's contact is balanced
//! against its internal forces by [`super::finite_contact`], which
//! calls [`FiniteBody3::begin_step`], [`FiniteBody3::internal_forces`]
//! and [`FiniteBody3::commit`] and not [`FiniteBody3::step`].

use super::finite_hex8::{NeoHookean3, Volumetric, internal_force, isochoric_stresses};
use super::hex8::Hex8;
use super::mesh::{Mesh3, MeshError};
use crate::assembly::{DofMap, PRESCRIBED, Pattern, free_entries};
use crate::finite_element::Inverted;
use crate::linalg::{FactorError, SparseCholesky};
use crate::material::{Material, MaterialError, StepCoefficients, advance_history, frozen_deviator, history_deviator};

/// Why a finite-strain body cannot be made or solved.
#[derive(Debug, thiserror::Error)]
pub enum FiniteBodyError {
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(transparent)]
    Material(#[from] MaterialError),
    #[error("element {element} has material {index}, and there are {count} materials")]
    NoSuchMaterial { element: usize, index: usize, count: usize },
    #[error("{what} has {got} values; the body has {expected} DOFs (3 per node)")]
    Length { what: &'static str, got: usize, expected: usize },
    #[error("the tangent stiffness could not be factorized: {0}")]
    Factor(#[from] FactorError),
    #[error("step size {0} s: it must be finite and not negative")]
    StepSize(f64),
    #[error(
        "no equilibrium reached: the load was halved {halvings} times and the last attempt, at {fraction:.4} of it, \
         stopped with a residual of {residual_n:.3e} N ({why})"
    )]
    NoConvergence { halvings: usize, fraction: f64, residual_n: f64, why: String },
}

/// The tolerances and limits of [`FiniteBody3::step`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticSettings {
    /// Sub-steps the prescribed displacements and forces move in at first.
    pub increments: usize,
    /// Newton iterations per sub-step.
    pub max_iterations: usize,
    /// Times a sub-step may be halved in all.
    pub max_halvings: usize,
    /// Halvings of a Newton step that inverts an element or does not lower
    /// the residual.
    pub backtracks: usize,
    pub relative_tolerance: f64,
    /// The smallest force the relative tolerance is taken of (N).
    pub force_floor_n: f64,
}

impl Default for StaticSettings {
    fn default() -> Self {
        Self {
            increments: 1,
            max_iterations: 30,
            max_halvings: 12,
            backtracks: 8,
            relative_tolerance: 1e-10,
            force_floor_n: 1e-9,
        }
    }
}

/// What a step took.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StepReport {
    /// Newton iterations of each converged sub-step.
    pub iterations: Vec<usize>,
    /// Sub-steps given up and halved.
    pub halvings: usize,
    /// The largest residual at the end, N.
    pub residual_n: f64,
}

/// A hyperelastic, visco-elastic 3D body with a fixed set of prescribed DOFs.
pub struct FiniteBody3 {
    pub mesh: Mesh3,
    pub geometry: Vec<Hex8>,
    materials: Vec<Material>,
    laws: Vec<NeoHookean3>,
    element_material: Vec<usize>,
    free: Vec<usize>,
    n_free: usize,
    pattern: Pattern,
    cholesky: Option<SparseCholesky>,
    values: Vec<f64>,
    /// Per material, the step's Prony coefficients (set by `step`).
    coefficients: Vec<StepCoefficients>,
    /// Per Gauss point and material: S0_iso at the last commit, then one
    /// internal stress per Prony term.
    history: Vec<[f64; 6]>,
    history_start: Vec<usize>,
}

/// The tangent's values and the free unknowns' load per unit of a
/// prescribed move ([`FiniteBody3::tangent_and_drive_load`]).
pub type TangentAndDriveLoad<'a> = (&'a [f64], Vec<f64>);

impl FiniteBody3 {
    /// A body of `mesh` whose element e is of `materials[element_material[e]]`
    /// (its moduli as the neo-Hookean law's, with `volumetric`), with the
    /// global DOFs (3 n + direction) in `prescribed` fixed.
    pub fn new(
        mesh: Mesh3,
        materials: Vec<Material>,
        element_material: Vec<usize>,
        volumetric: Volumetric,
        prescribed: &[usize],
    ) -> Result<Self, FiniteBodyError> {
        for m in &materials {
            m.validate()?;
        }
        if element_material.len() != mesh.elements.len() {
            return Err(FiniteBodyError::Length {
                what: "the element materials",
                got: element_material.len(),
                expected: mesh.elements.len(),
            });
        }
        for (element, &index) in element_material.iter().enumerate() {
            if index >= materials.len() {
                return Err(FiniteBodyError::NoSuchMaterial { element, index, count: materials.len() });
            }
        }
        let n_dofs = 3 * mesh.n_nodes();
        if let Some(&d) = prescribed.iter().find(|&&d| d >= n_dofs) {
            return Err(FiniteBodyError::Length { what: "a prescribed DOF's index", got: d, expected: n_dofs });
        }
        let geometry = mesh.geometry()?;
        let dofs = DofMap::with_dofs_per_node(mesh.n_nodes(), 3, prescribed);
        let pattern = mesh.pattern(&dofs);
        let DofMap { free, n_free } = dofs;
        let history_start = super::body::history_starts(&materials, &element_material);
        let count = *history_start.last().expect("one entry past the last element");
        let laws = materials.iter().map(|m| NeoHookean3::from_material(m).with_volumetric(volumetric)).collect();
        let coefficients = materials.iter().map(|m| m.step(0.0)).collect();
        Ok(Self {
            values: vec![0.0; pattern.nnz()],
            mesh,
            geometry,
            materials,
            laws,
            element_material,
            free,
            n_free,
            pattern,
            cholesky: None,
            coefficients,
            history: vec![[0.0; 6]; count],
            history_start,
        })
    }

    /// Free unknowns.
    pub fn n_free(&self) -> usize {
        self.n_free
    }

    /// Global DOF (3 n + direction) -> free index, or PRESCRIBED.
    pub fn free(&self) -> &[usize] {
        &self.free
    }

    /// The frozen visco-elastic stress of every Gauss point of element `e`
    /// for the step's coefficients.
    fn frozen(&self, e: usize) -> [[f64; 6]; 8] {
        let mi = self.element_material[e];
        let c = &self.coefficients[mi];
        let per_point = 1 + self.materials[mi].prony.len();
        std::array::from_fn(|gp| {
            let at = self.history_start[e] + gp * per_point;
            frozen_deviator(&self.history[at], &self.history[at + 1..at + per_point], c)
        })
    }

    /// The internal nodal forces (global, 3 per node; N) at `u` with the
    /// visco-elastic stresses of a step of the last step's size from the
    /// committed history (what [`FiniteBody3::step`] balances); the
    /// element that inverts, if one does. For the forces of the committed
    /// state itself, see [`FiniteBody3::committed_forces`].
    pub fn internal_forces(&self, u: &[f64]) -> Result<Vec<f64>, (usize, Inverted)> {
        self.forces_with(u, |e| (self.coefficients[self.element_material[e]].shear_ratio, self.frozen(e)))
    }

    /// The internal nodal forces (global; N) of the committed state, `u`
    /// the displacements the last step returned: each point's isochoric
    /// stress is its committed one, g_inf S0_iso + sum h_i. The reactions
    /// of the prescribed DOFs are these forces there.
    pub fn committed_forces(&self, u: &[f64]) -> Result<Vec<f64>, (usize, Inverted)> {
        self.forces_with(u, |e| {
            let mi = self.element_material[e];
            let per_point = 1 + self.materials[mi].prony.len();
            let g_inf = self.materials[mi].g_inf();
            let stress = std::array::from_fn(|gp| {
                let at = self.history_start[e] + gp * per_point;
                history_deviator(&self.history[at], &self.history[at + 1..at + per_point], g_inf)
            });
            (0.0, stress)
        })
    }

    /// The internal forces with element e's isochoric stress `stress(e)` =
    /// (shear ratio, frozen part).
    fn forces_with(
        &self,
        u: &[f64],
        stress: impl Fn(usize) -> (f64, [[f64; 6]; 8]),
    ) -> Result<Vec<f64>, (usize, Inverted)> {
        let mut f = vec![0.0; u.len()];
        for e in 0..self.geometry.len() {
            let dofs = self.mesh.element_dofs(e);
            let ue = dofs.map(|d| u[d]);
            let (ratio, frozen) = stress(e);
            let fe = internal_force(&self.geometry[e], &ue, &self.laws[self.element_material[e]], ratio, &frozen, None)
                .map_err(|err| (e, err))?;
            for i in 0..24 {
                f[dofs[i]] += fe[i];
            }
        }
        Ok(f)
    }

    /// Assembles the tangent on the free unknowns at `u` into `self.values`
    /// and returns the internal forces (global); with `moved`, the
    /// prescribed DOFs' increments, also K_fp moved (on the free unknowns).
    fn assemble(&mut self, u: &[f64], moved: Option<(&[f64], &mut [f64])>) -> Result<Vec<f64>, (usize, Inverted)> {
        self.values.fill(0.0);
        let mut f = vec![0.0; u.len()];
        let mut moved = moved;
        let mut k = [[0.0; 24]; 24];
        for e in 0..self.geometry.len() {
            let dofs = self.mesh.element_dofs(e);
            let ue = dofs.map(|d| u[d]);
            let mi = self.element_material[e];
            let fe = internal_force(
                &self.geometry[e],
                &ue,
                &self.laws[mi],
                self.coefficients[mi].shear_ratio,
                &self.frozen(e),
                Some(&mut k),
            )
            .map_err(|err| (e, err))?;
            for i in 0..24 {
                f[dofs[i]] += fe[i];
            }
            self.pattern.add_element(e, &k, &mut self.values);
            if let Some((du, out)) = moved.as_mut() {
                for i in 0..24 {
                    let fi = self.free[dofs[i]];
                    if fi == PRESCRIBED {
                        continue;
                    }
                    for j in 0..24 {
                        if self.free[dofs[j]] == PRESCRIBED {
                            out[fi] += k[i][j] * du[dofs[j]];
                        }
                    }
                }
            }
        }
        Ok(f)
    }

    /// One step of size `dt_s` (0: static, the instantaneous elastic law):
    /// `u` (3 per node) holds the last equilibrium on entry, with `target`
    /// the prescribed DOFs' new values (its free entries are ignored) and
    /// `f_ext` the external nodal forces (global) at the end of the step;
    /// on return `u` is the new equilibrium and the history is committed.
    /// On an error `u` and the history are as on entry.
    pub fn step(
        &mut self,
        dt_s: f64,
        u: &mut [f64],
        target: &[f64],
        f_ext: &[f64],
        settings: &StaticSettings,
    ) -> Result<StepReport, FiniteBodyError> {
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            return Err(FiniteBodyError::StepSize(dt_s));
        }
        let n = 3 * self.mesh.n_nodes();
        for (what, v) in [("the displacements", u.len()), ("the targets", target.len()), ("the forces", f_ext.len())] {
            if v != n {
                return Err(FiniteBodyError::Length { what, got: v, expected: n });
            }
        }
        self.begin_step(dt_s);
        if self.cholesky.is_none() {
            self.cholesky = Some(SparseCholesky::new(&self.pattern, 1)?);
        }
        let start = u.to_vec();
        let f_start = match self.internal_forces(u) {
            // The internal forces of the start under this step's law: the
            // sub-steps' load goes from them to f_ext, so that the start is
            // its own equilibrium at the fraction 0 (they are the last
            // step's external forces only at dt = 0, where the history's
            // relaxation does not move them).
            Ok(f) => f,
            Err((e, err)) => {
                return Err(FiniteBodyError::NoConvergence {
                    halvings: 0,
                    fraction: 0.0,
                    residual_n: f64::NAN,
                    why: format!("element {e} at the start: {err}"),
                });
            }
        };
        let mut report = StepReport::default();
        let mut done = 0.0f64;
        let mut size = 1.0 / settings.increments.max(1) as f64;
        let mut current = start.clone();
        while done < 1.0 {
            let next = (done + size).min(1.0);
            let attempt = self.sub_step(&current, &start, &f_start, target, f_ext, next, settings);
            match attempt {
                Ok((state, iterations, residual)) => {
                    current = state;
                    done = next;
                    report.iterations.push(iterations);
                    report.residual_n = residual;
                    if iterations <= 4 {
                        size *= 2.0;
                    }
                }
                Err((residual, why)) => {
                    if report.halvings >= settings.max_halvings {
                        return Err(FiniteBodyError::NoConvergence {
                            halvings: report.halvings,
                            fraction: next,
                            residual_n: residual,
                            why,
                        });
                    }
                    report.halvings += 1;
                    size *= 0.5;
                }
            }
        }
        u.copy_from_slice(&current);
        self.commit(u);
        Ok(report)
    }

    /// The sub-step to the fraction `s` of the step from `current`: the
    /// state, its iterations and residual, or the residual and why it failed.
    #[allow(clippy::too_many_arguments)]
    fn sub_step(
        &mut self,
        current: &[f64],
        start: &[f64],
        f_start: &[f64],
        target: &[f64],
        f_ext: &[f64],
        s: f64,
        settings: &StaticSettings,
    ) -> Result<(Vec<f64>, usize, f64), (f64, String)> {
        let n = current.len();
        let load: Vec<f64> = (0..n).map(|d| f_start[d] + s * (f_ext[d] - f_start[d])).collect();
        // Prescribed increments of this sub-step.
        let du: Vec<f64> = (0..n)
            .map(|d| if self.free[d] == PRESCRIBED { start[d] + s * (target[d] - start[d]) - current[d] } else { 0.0 })
            .collect();
        let mut u = current.to_vec();
        // The linear predictor from the last equilibrium.
        let mut kfp = vec![0.0; self.n_free];
        let f =
            self.assemble(&u, Some((&du, &mut kfp))).map_err(|(e, err)| (f64::NAN, format!("element {e}: {err}")))?;
        let mut rhs = free_entries(&self.free, self.n_free, |d| load[d] - f[d] - kfp[self.free[d]]);
        self.solve(&mut rhs).map_err(|err| (f64::NAN, err.to_string()))?;
        for d in 0..n {
            let fi = self.free[d];
            u[d] += if fi == PRESCRIBED { du[d] } else { rhs[fi] };
        }
        let mut residual = f64::INFINITY;
        for iteration in 0..=settings.max_iterations {
            let f = match self.assemble(&u, None) {
                Ok(f) => f,
                Err((e, err)) => return Err((residual, format!("element {e}: {err}"))),
            };
            let scale = f.iter().chain(load.iter()).fold(settings.force_floor_n, |m, v| m.max(v.abs()));
            let mut r = free_entries(&self.free, self.n_free, |d| load[d] - f[d]);
            residual = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if residual <= settings.relative_tolerance * scale {
                return Ok((u, iteration, residual));
            }
            if iteration == settings.max_iterations {
                break;
            }
            let norm: f64 = r.iter().map(|v| v * v).sum();
            self.solve(&mut r).map_err(|err| (residual, err.to_string()))?;
            // Backtracking on |R|^2: the full Newton step unless it
            // inverts an element or does not lower the residual, then
            // halved, up to `backtracks` times; if none lowers it, the
            // shortest is taken (Newton's iterates may have to pass a
            // larger residual on their way).
            let mut alpha = 1.0;
            let mut fallback = None;
            let mut accepted = false;
            for attempt in 0..=settings.backtracks {
                let trial: Vec<f64> = (0..n)
                    .map(|d| if self.free[d] == PRESCRIBED { u[d] } else { u[d] + alpha * r[self.free[d]] })
                    .collect();
                if let Ok(ft) = self.internal_forces(&trial) {
                    let trial_norm: f64 =
                        free_entries(&self.free, self.n_free, |d| load[d] - ft[d]).iter().map(|v| v * v).sum();
                    if trial_norm.is_finite() {
                        if trial_norm < norm {
                            u = trial;
                            accepted = true;
                            break;
                        }
                        if attempt == settings.backtracks {
                            fallback = Some(trial);
                        }
                    }
                }
                alpha *= 0.5;
            }
            if !accepted {
                match fallback {
                    Some(trial) => u = trial,
                    None => return Err((residual, "every Newton step inverted an element".into())),
                }
            }
        }
        Err((residual, format!("{} iterations", settings.max_iterations)))
    }

    fn solve(&mut self, rhs: &mut [f64]) -> Result<(), FactorError> {
        let cholesky = self.cholesky.as_mut().expect("made by step");
        cholesky.factorize(&self.values)?;
        cholesky.solve_vec(rhs);
        Ok(())
    }

    /// The consistent tangent stiffness at `u` on the free unknowns (values
    /// on the pattern of [`crate::solid3d::mesh::Mesh3::pattern`] for this
    /// body's DOFs, lower triangle), with the step's visco-elastic
    /// coefficients; the element that inverts, if one does.
    pub fn tangent(&mut self, u: &[f64]) -> Result<&[f64], (usize, Inverted)> {
        self.assemble(u, None)?;
        Ok(&self.values)
    }

    /// [`FiniteBody3::tangent`], and the free unknowns' load per unit of
    /// the prescribed increments `moved` (global, 3 per node; its free
    /// entries ignored) under that tangent: -K_fp moved, the slope of the
    /// load in a drive the prescribed DOFs follow.
    pub fn tangent_and_drive_load(
        &mut self,
        u: &[f64],
        moved: &[f64],
    ) -> Result<TangentAndDriveLoad<'_>, (usize, Inverted)> {
        let mut coupling = vec![0.0; self.n_free];
        self.assemble(u, Some((moved, &mut coupling)))?;
        coupling.iter_mut().for_each(|v| *v = -*v);
        Ok((&self.values, coupling))
    }

    /// Sets the visco-elastic coefficients of a step of `dt_s` (finite,
    /// not negative: checked by the callers), for [`FiniteBody3::internal_forces`]
    /// and [`FiniteBody3::commit`] when the body is solved by another
    /// solver ([`super::finite_contact`]).
    pub fn begin_step(&mut self, dt_s: f64) {
        self.coefficients = self.materials.iter().map(|m| m.step(dt_s)).collect();
    }

    /// Advances every point's history to `u` with the step's coefficients
    /// ([`FiniteBody3::step`] does it itself).
    pub fn commit(&mut self, u: &[f64]) {
        for e in 0..self.geometry.len() {
            let mi = self.element_material[e];
            let per_point = 1 + self.materials[mi].prony.len();
            let ue = self.mesh.element_dofs(e).map(|d| u[d]);
            let s0_new = isochoric_stresses(&self.geometry[e], &ue, &self.laws[mi]);
            for (gp, s0_new) in s0_new.iter().enumerate() {
                let at = self.history_start[e] + gp * per_point;
                let (s0, rest) = self.history[at..at + per_point].split_at_mut(1);
                advance_history(&mut s0[0], rest, &self.coefficients[mi], s0_new);
            }
        }
    }
}
