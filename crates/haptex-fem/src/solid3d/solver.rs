//! The static contact of a linear elastic 3D body with a rigid plane below
//! it, by penalty: at every contact point the pressure is p = eps_N d for
//! a penetration d > 0, and the tangential traction follows Coulomb's law
//! in both directions (a penalty eps_T on the slip since the last commit,
//! returned onto the disc |t| <= mu p). Two solvers:
//!
//! - [`ElasticBody::solve`], frictionless: the penalty law is piecewise
//!   linear, so Newton's method is an active-set iteration, one sparse
//!   Cholesky factorization (faer) per active set;
//! - [`ElasticBody::solve_frictional`]: the 2D model's condensation onto
//!   the contact nodes' unknowns (one factorization of K with them ordered
//!   last gives their condensed stiffness), then Newton's method with the
//!   consistent tangent on those unknowns alone, dense.
//!
//! The first pieces of the 3D finger pad (issue 39), validated against
//! Hertz's sphere on a flat and Cattaneo-Mindlin's partial slip.

use std::collections::HashSet;

use super::contact::ContactSurface;
use super::hex8::{Formulation, Hex8};
use super::mesh::{Mesh3, MeshError};
use crate::assembly::{DofMap, PRESCRIBED, Pattern};
use crate::linalg::{FactorError, SparseCholesky};

/// A linear elastic body, its prescribed displacements and its contact
/// surface.
pub struct ElasticBody {
    pub mesh: Mesh3,
    pub geometry: Vec<Hex8>,
    pub formulation: Formulation,
    /// Shear and bulk moduli (MPa) of each element.
    pub moduli: Vec<(f64, f64)>,
    pub contact: ContactSurface,
    /// Penalty stiffness eps_N in MPa/mm.
    pub penalty_mpa_per_mm: f64,
    /// Global DOF (3 n + direction) -> free index or PRESCRIBED.
    free: Vec<usize>,
    n_free: usize,
    /// The prescribed value of each global DOF (0 for free ones).
    prescribed_value: Vec<f64>,
    /// Stiffness values (lower triangle) without contact.
    base: Vec<f64>,
    /// For each contact point and direction (x, y, z), the slots of its
    /// 4 x 4 couplings in that direction (None where a DOF is prescribed,
    /// and for the upper triangle).
    point_slots: Vec<[[[Option<usize>; 4]; 4]; 3]>,
    /// Committed friction state of each contact point: its tangential
    /// traction on the plane and its tangential slip (mm) at the last
    /// commit ([`ElasticBody::commit_friction`]).
    committed_traction: Vec<[f64; 2]>,
    committed_slip: Vec<[f64; 2]>,
    /// The free unknowns of the contact nodes, ordered last in the
    /// factorization (their global DOFs, and each global DOF's place among
    /// them).
    contact_dofs: Vec<usize>,
    contact_global: Vec<usize>,
    contact_index: Vec<Option<usize>>,
    /// The condensed stiffness on them and their response to the
    /// prescribed displacements, once computed.
    condensed: Option<Condensed>,
    pattern: Pattern,
    /// The active-set solver's factorization (AMD ordering; K plus the
    /// contact penalties of the active set).
    cholesky: SparseCholesky,
    /// The condensed solver's factorization of K alone, with the contact
    /// unknowns ordered last; made at its first use (a large contact
    /// surface makes its trailing block dense and costly).
    trailing: Option<SparseCholesky>,
}

/// Why a body cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum BodyError {
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error("the stiffness pattern could not be analysed: {0}")]
    Factor(#[from] FactorError),
}

/// Why a contact problem has no solution here.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    #[error("the stiffness could not be factorized: {0}")]
    Factor(#[from] FactorError),
    #[error(
        "the active set did not settle in {iterations} iterations (it cycles): the penalty or the mesh is unsuitable"
    )]
    NoActiveSet { iterations: usize },
}

/// The body condensed on its contact unknowns.
struct Condensed {
    /// S, m x m column-major.
    stiffness: Vec<f64>,
    /// The contact unknowns' displacements under the prescribed ones alone.
    v0: Vec<f64>,
}

/// The contact of one set of displacements.
struct ContactState {
    forces: Vec<f64>,
    pressure: Vec<f64>,
    /// The trial traction of each point in contact (its direction is the
    /// slip's).
    trial: Vec<[f64; 2]>,
    traction: Vec<[f64; 2]>,
    sticking: Vec<bool>,
}

/// The solution of one frictional contact problem.
#[derive(Debug, Clone)]
pub struct FrictionalSolution {
    /// Global displacements (mm), 3 per node.
    pub u: Vec<f64>,
    /// Contact pressure (MPa) and tangential traction on the plane (MPa)
    /// at each contact point; zero where open.
    pub pressure: Vec<f64>,
    pub traction: Vec<[f64; 2]>,
    /// Whether each point in contact sticks (false: slips, or open).
    pub sticking: Vec<bool>,
    /// Total contact force on the body (N): tangential x, y and normal z.
    pub force_n: [f64; 3],
    /// Newton iterations taken, and sparse factorizations made (one, at
    /// the body's first frictional solve; none after).
    pub iterations: usize,
    pub factorizations: usize,
}

/// The solution of one contact problem.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Global displacements (mm), 3 per node.
    pub u: Vec<f64>,
    /// Contact pressure at each contact point (MPa), 0 where open.
    pub pressure: Vec<f64>,
    /// Total contact force on the body, +z (N).
    pub force_n: f64,
    /// Active-set iterations taken (each one factorization).
    pub iterations: usize,
}

impl ElasticBody {
    /// A body of linear elastic materials (E in MPa, Poisson's ratio nu),
    /// element e of `materials[element_material[e]]`, with the global DOFs
    /// in `prescribed` fixed at the values given and the contact
    /// `surface`; analyses the stiffness pattern.
    pub fn new(
        mesh: Mesh3,
        formulation: Formulation,
        materials: &[(f64, f64)],
        element_material: &[usize],
        prescribed: &[(usize, f64)],
        contact: ContactSurface,
        penalty_mpa_per_mm: f64,
    ) -> Result<Self, BodyError> {
        let geometry = mesh.geometry()?;
        let n_dofs = 3 * mesh.n_nodes();
        let mut prescribed_value = vec![0.0; n_dofs];
        for &(d, v) in prescribed {
            prescribed_value[d] = v;
        }
        let fixed: Vec<usize> = prescribed.iter().map(|&(d, _)| d).collect();
        let dofs = DofMap::with_dofs_per_node(mesh.n_nodes(), 3, &fixed);
        let pattern = mesh.pattern(&dofs);
        let DofMap { free, n_free } = dofs;
        assert_eq!(element_material.len(), mesh.elements.len(), "one material index per element");
        let moduli: Vec<(f64, f64)> = element_material
            .iter()
            .map(|&m| {
                let (e_mpa, nu) = materials[m];
                (e_mpa / (2.0 * (1.0 + nu)), e_mpa / (3.0 * (1.0 - 2.0 * nu)))
            })
            .collect();
        let mut base = vec![0.0; pattern.nnz()];
        for (e, h) in geometry.iter().enumerate() {
            let (g, k) = moduli[e];
            pattern.add_element(e, &h.stiffness(formulation, g, k), &mut base);
        }
        let point_slots = contact
            .points
            .iter()
            .map(|p| {
                std::array::from_fn(|d| {
                    let dof = |a: usize| free[3 * p.nodes[a] + d];
                    std::array::from_fn(|a| {
                        std::array::from_fn(|b| {
                            let (i, j) = (dof(a), dof(b));
                            if i == PRESCRIBED || j == PRESCRIBED || i < j { None } else { pattern.slot(i, j) }
                        })
                    })
                })
            })
            .collect();
        let n_points = contact.points.len();
        // The contact nodes' free unknowns, ordered last.
        let mut contact_global: Vec<usize> = contact
            .points
            .iter()
            .flat_map(|p| p.nodes)
            .flat_map(|n| (0..3).map(move |d| 3 * n + d))
            .filter(|&g| free[g] != PRESCRIBED)
            .collect();
        contact_global.sort_unstable();
        contact_global.dedup();
        let contact_dofs: Vec<usize> = contact_global.iter().map(|&g| free[g]).collect();
        let mut contact_index = vec![None; n_dofs];
        for (k, &g) in contact_global.iter().enumerate() {
            contact_index[g] = Some(k);
        }
        let cholesky = SparseCholesky::new(&pattern, 1)?;
        Ok(Self {
            mesh,
            geometry,
            formulation,
            moduli,
            contact,
            penalty_mpa_per_mm,
            free,
            n_free,
            prescribed_value,
            committed_traction: vec![[0.0; 2]; n_points],
            committed_slip: vec![[0.0; 2]; n_points],
            contact_dofs,
            contact_global,
            contact_index,
            condensed: None,
            pattern,
            trailing: None,
            base,
            point_slots,
            cholesky,
        })
    }

    /// Free unknowns.
    pub fn n_free(&self) -> usize {
        self.n_free
    }

    /// The contact nodes' free unknowns (the condensed system's size).
    pub fn contact_unknowns(&self) -> usize {
        self.contact_dofs.len()
    }

    /// Non-zeros of the Cholesky factor.
    pub fn factor_nnz(&self) -> usize {
        self.cholesky.factor_nnz()
    }

    /// Pressed onto the rigid plane z = `plane_z` (mm): the equilibrium,
    /// starting from the active set of the displacements `start` (or of
    /// the prescribed ones alone).
    pub fn solve(&mut self, plane_z: f64, start: Option<&[f64]>) -> Result<Solution, SolveError> {
        const MAX_ITERATIONS: usize = 100;
        let eps = self.penalty_mpa_per_mm;
        let n_dofs = self.free.len();
        let mut u = self.starting_displacements(start);
        let mut active: Vec<bool> =
            (0..self.contact.points.len()).map(|q| self.contact.gap(q, &u, plane_z) < 0.0).collect();
        let mut seen: HashSet<Vec<bool>> = HashSet::new();
        let prescribed_load = self.prescribed_load();
        let mut values = vec![0.0; self.base.len()];
        let mut rhs = vec![0.0; self.n_free];
        for iteration in 1..=MAX_ITERATIONS {
            if !seen.insert(active.clone()) {
                return Err(SolveError::NoActiveSet { iterations: iteration });
            }
            values.copy_from_slice(&self.base);
            rhs.copy_from_slice(&prescribed_load);
            for (q, p) in self.contact.points.iter().enumerate() {
                if !active[q] {
                    continue;
                }
                let c = eps * p.weight;
                // Prescribed z-DOFs of the point move to the right-hand side.
                let fixed: f64 = (0..4)
                    .filter(|&b| self.free[3 * p.nodes[b] + 2] == PRESCRIBED)
                    .map(|b| p.shape[b] * self.prescribed_value[3 * p.nodes[b] + 2])
                    .sum();
                for a in 0..4 {
                    let i = self.free[3 * p.nodes[a] + 2];
                    if i == PRESCRIBED {
                        continue;
                    }
                    rhs[i] += c * p.shape[a] * (plane_z - p.position[2] - fixed);
                    for b in 0..4 {
                        if let Some(slot) = self.point_slots[q][2][a][b] {
                            values[slot] += c * p.shape[a] * p.shape[b];
                        }
                    }
                }
            }
            self.cholesky.factorize(&values)?;
            self.cholesky.solve_vec(&mut rhs);
            for g in 0..n_dofs {
                let f = self.free[g];
                u[g] = if f == PRESCRIBED { self.prescribed_value[g] } else { rhs[f] };
            }
            let next: Vec<bool> =
                (0..self.contact.points.len()).map(|q| self.contact.gap(q, &u, plane_z) < 0.0).collect();
            if next == active {
                let pressure: Vec<f64> = (0..self.contact.points.len())
                    .map(|q| if active[q] { -eps * self.contact.gap(q, &u, plane_z) } else { 0.0 })
                    .collect();
                let force_n = pressure.iter().zip(&self.contact.points).map(|(p, c)| p * c.weight).sum();
                return Ok(Solution { u, pressure, force_n, iterations: iteration });
            }
            active = next;
        }
        Err(SolveError::NoActiveSet { iterations: MAX_ITERATIONS })
    }

    /// The tangential slip (mm) of contact point `q` relative to a plane
    /// shifted by `shift`: the point's tangential displacement minus the
    /// plane's.
    fn slip(&self, q: usize, u: &[f64], shift: [f64; 2]) -> [f64; 2] {
        let p = &self.contact.points[q];
        std::array::from_fn(|d| (0..4).map(|a| p.shape[a] * u[3 * p.nodes[a] + d]).sum::<f64>() - shift[d])
    }

    /// Commits the friction state of the solution `u` on the plane shifted
    /// by `shift`: each point's slip and traction become the reference of
    /// the next load step.
    pub fn commit_friction(&mut self, u: &[f64], shift: [f64; 2], traction: &[[f64; 2]]) {
        for q in 0..self.contact.points.len() {
            self.committed_slip[q] = self.slip(q, u, shift);
            self.committed_traction[q] = traction[q];
        }
    }

    /// Pressed onto the rigid plane z = `plane_z` shifted tangentially by
    /// `shift` (mm) from the last commit, with Coulomb friction `mu` in
    /// both tangential directions (penalty `penalty_t` MPa/mm on the slip,
    /// return mapping onto the disc |t| <= mu p). Path-dependent: the
    /// trial traction is the committed one plus penalty_t times the slip
    /// since the commit.
    ///
    /// Solved on the contact nodes' unknowns alone (the 2D model's
    /// condensation, crate::solver): the stiffness K, factorized once with
    /// those unknowns ordered last, gives their condensed stiffness S (the
    /// factor's trailing block L, S = L L^T), and the body's response to
    /// the prescribed displacements v0; equilibrium is S (v - v0) = F(v),
    /// F the contact forces. Newton's method with the consistent tangent
    /// (unsymmetric where slipping: the slip limit follows the pressure),
    /// dense LU, backtracking on |R|^2; converged when |R| is below 1e-10
    /// of the largest contact force and the correction below 1e-10 mm.
    pub fn solve_frictional(
        &mut self,
        plane_z: f64,
        shift: [f64; 2],
        mu: f64,
        penalty_t: f64,
        start: Option<&[f64]>,
    ) -> Result<FrictionalSolution, SolveError> {
        const MAX_ITERATIONS: usize = 100;
        let m = self.contact_dofs.len();
        let factorized_now = self.trailing.is_none();
        if self.trailing.is_none() {
            let mut trailing = SparseCholesky::with_trailing(&self.pattern, &self.contact_dofs, 1)?;
            trailing.factorize(&self.base)?;
            let mut l = vec![0.0; m * m];
            trailing.trailing_factor(&mut l);
            // S = L L^T (column-major, symmetric).
            let mut s = vec![0.0; m * m];
            for j in 0..m {
                for i in j..m {
                    let mut sum = 0.0;
                    for k in 0..=j {
                        sum += l[k * m + i] * l[k * m + j];
                    }
                    s[j * m + i] = sum;
                    s[i * m + j] = sum;
                }
            }
            let mut u0 = self.prescribed_load();
            trailing.solve_vec(&mut u0);
            let v0 = self.contact_dofs.iter().map(|&f| u0[f]).collect();
            self.condensed = Some(Condensed { stiffness: s, v0 });
            self.trailing = Some(trailing);
        }
        let eps_n = self.penalty_mpa_per_mm;
        let mut u = self.starting_displacements(start);
        let condensed = self.condensed.as_ref().expect("made above");
        if start.is_none() {
            for (k, &f) in self.contact_dofs.iter().enumerate() {
                u[self.contact_global[k]] = condensed.v0[k];
                let _ = f;
            }
        }
        let residual_of = |body: &Self, u: &[f64]| -> (Vec<f64>, ContactState) {
            let state = body.contact_state(u, plane_z, shift, mu, penalty_t);
            let c = body.condensed.as_ref().expect("made above");
            let mut r = vec![0.0; m];
            for j in 0..m {
                let dv = u[body.contact_global[j]] - c.v0[j];
                for i in 0..m {
                    r[i] += c.stiffness[j * m + i] * dv;
                }
            }
            for (k, &g) in body.contact_global.iter().enumerate() {
                r[k] -= state.forces[g];
            }
            (r, state)
        };
        let norm2 = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
        let (mut r, mut state) = residual_of(self, &u);
        let mut lu = crate::linalg::DenseLu::new(m);
        for iteration in 1..=MAX_ITERATIONS {
            let largest_force = state.forces.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let r_max = r.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            // J = S + D, D = -dF/dv of each point in contact.
            {
                let c = self.condensed.as_ref().expect("made above");
                let mut jac = lu.matrix_mut(m);
                for j in 0..m {
                    for i in 0..m {
                        jac[(i, j)] = c.stiffness[j * m + i];
                    }
                }
                for (q, p) in self.contact.points.iter().enumerate() {
                    if state.pressure[q] <= 0.0 {
                        continue;
                    }
                    // d(traction)/d(u) of the point: rows x, y (traction),
                    // columns x, y, z (displacement); the pressure's -eps_N.
                    let mut dt = [[0.0; 3]; 2];
                    if state.sticking[q] {
                        dt[0][0] = penalty_t;
                        dt[1][1] = penalty_t;
                    } else {
                        let trial = state.trial[q];
                        let size = trial[0].hypot(trial[1]);
                        let n = [trial[0] / size, trial[1] / size];
                        let c = mu * state.pressure[q] * penalty_t / size;
                        for a in 0..2 {
                            for b in 0..2 {
                                dt[a][b] = c * (if a == b { 1.0 } else { 0.0 } - n[a] * n[b]);
                            }
                            dt[a][2] = -mu * eps_n * n[a];
                        }
                    }
                    for a in 0..4 {
                        for b in 0..4 {
                            let nn = p.weight * p.shape[a] * p.shape[b];
                            let row = |d: usize| self.contact_index[3 * p.nodes[a] + d];
                            let col = |d: usize| self.contact_index[3 * p.nodes[b] + d];
                            // Normal: F_z = w N p, dF_z/du_z = -eps_N w N N.
                            if let (Some(i), Some(j)) = (row(2), col(2)) {
                                jac[(i, j)] += eps_n * nn;
                            }
                            // Tangential: F_t = -w N t, D = +w N N dt/du.
                            for d in 0..2 {
                                if let Some(i) = row(d) {
                                    for e in 0..3 {
                                        if dt[d][e] != 0.0
                                            && let Some(j) = col(e)
                                        {
                                            jac[(i, j)] += nn * dt[d][e];
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
            if !lu.factor() {
                return Err(SolveError::NoActiveSet { iterations: iteration });
            }
            let mut dv: Vec<f64> = r.iter().map(|v| -v).collect();
            lu.solve(&mut dv);
            let step_max = dv.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if r_max <= 1e-10 * largest_force.max(1e-12) && step_max <= 1e-10 {
                let mut full = self.prescribed_load();
                for (g, &f) in self.free.iter().enumerate() {
                    if f != PRESCRIBED {
                        full[f] += state.forces[g];
                    }
                }
                self.trailing.as_mut().expect("made above").solve_vec(&mut full);
                for (g, &f) in self.free.iter().enumerate() {
                    if f != PRESCRIBED {
                        u[g] = full[f];
                    }
                }
                let mut force = [0.0; 3];
                for (q, p) in self.contact.points.iter().enumerate() {
                    force[0] -= p.weight * state.traction[q][0];
                    force[1] -= p.weight * state.traction[q][1];
                    force[2] += p.weight * state.pressure[q];
                }
                return Ok(FrictionalSolution {
                    u,
                    pressure: state.pressure,
                    traction: state.traction,
                    sticking: state.sticking,
                    force_n: force,
                    iterations: iteration,
                    factorizations: usize::from(factorized_now),
                });
            }
            // Backtracking on |R|^2.
            let before = norm2(&r);
            let mut alpha = 1.0;
            let original: Vec<f64> = self.contact_global.iter().map(|&g| u[g]).collect();
            for _ in 0..12 {
                for (k, &g) in self.contact_global.iter().enumerate() {
                    u[g] = original[k] + alpha * dv[k];
                }
                let (r_new, state_new) = residual_of(self, &u);
                if norm2(&r_new) <= (1.0 - 1e-4 * alpha) * before || alpha < 1e-3 {
                    r = r_new;
                    state = state_new;
                    break;
                }
                alpha *= 0.5;
            }
        }
        Err(SolveError::NoActiveSet { iterations: MAX_ITERATIONS })
    }

    /// The contact tractions of displacements `u` and the nodal forces they
    /// put on the body (global vector).
    fn contact_state(&self, u: &[f64], plane_z: f64, shift: [f64; 2], mu: f64, penalty_t: f64) -> ContactState {
        let n_points = self.contact.points.len();
        let mut state = ContactState {
            forces: vec![0.0; u.len()],
            pressure: vec![0.0; n_points],
            trial: vec![[0.0; 2]; n_points],
            traction: vec![[0.0; 2]; n_points],
            sticking: vec![false; n_points],
        };
        for (q, p) in self.contact.points.iter().enumerate() {
            let depth = -self.contact.gap(q, u, plane_z);
            if depth <= 0.0 {
                continue;
            }
            let pressure = self.penalty_mpa_per_mm * depth;
            let slip = self.slip(q, u, shift);
            let (t0, s0) = (self.committed_traction[q], self.committed_slip[q]);
            let trial = [t0[0] + penalty_t * (slip[0] - s0[0]), t0[1] + penalty_t * (slip[1] - s0[1])];
            let size = trial[0].hypot(trial[1]);
            let limit = mu * pressure;
            let traction = if size <= limit {
                state.sticking[q] = true;
                trial
            } else {
                [limit * trial[0] / size, limit * trial[1] / size]
            };
            state.pressure[q] = pressure;
            state.trial[q] = trial;
            state.traction[q] = traction;
            for a in 0..4 {
                let base = 3 * p.nodes[a];
                let w = p.weight * p.shape[a];
                // The plane pushes the body up and resists its slip.
                state.forces[base] -= w * traction[0];
                state.forces[base + 1] -= w * traction[1];
                state.forces[base + 2] += w * pressure;
            }
        }
        state
    }

    /// `start` (or zero) with the prescribed values in place.
    fn starting_displacements(&self, start: Option<&[f64]>) -> Vec<f64> {
        let mut u = start.map_or_else(|| vec![0.0; self.free.len()], <[f64]>::to_vec);
        for (g, &f) in self.free.iter().enumerate() {
            if f == PRESCRIBED {
                u[g] = self.prescribed_value[g];
            }
        }
        u
    }

    /// -K_fp u_p: the free DOFs' load from the prescribed displacements.
    fn prescribed_load(&self) -> Vec<f64> {
        let mut f = vec![0.0; self.n_free];
        for e in 0..self.mesh.elements.len() {
            let dofs = self.mesh.element_dofs(e);
            if dofs.iter().all(|&d| self.prescribed_value[d] == 0.0) {
                continue;
            }
            let (g, bulk) = self.moduli[e];
            let k = self.geometry[e].stiffness(self.formulation, g, bulk);
            for i in 0..24 {
                let fi = self.free[dofs[i]];
                if fi == PRESCRIBED {
                    continue;
                }
                for j in 0..24 {
                    if self.free[dofs[j]] == PRESCRIBED {
                        f[fi] -= k[i][j] * self.prescribed_value[dofs[j]];
                    }
                }
            }
        }
        f
    }
}
