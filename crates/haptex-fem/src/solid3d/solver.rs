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
//!   the contact nodes' unknowns ([`super::condensed`]), then Newton's
//!   method with the consistent tangent of the contact law
//!   ([`super::friction`]) on those unknowns alone, dense.
//!
//! The first pieces of the 3D finger pad (issue 39), validated against
//! Hertz's sphere on a flat and Cattaneo-Mindlin's partial slip.

use std::collections::HashSet;

use super::condensed::{Condensation, EquilibriumError, NewtonSettings, PointMode};
use super::contact::ContactSurface;
use super::friction::{Committed, FrictionLaw};
use super::hex8::{Formulation, Hex8};
use super::mesh::{Mesh3, MeshError};
use super::surface::HeightField;
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
    /// Committed friction state of each contact point: its position
    /// relative to the plane and its tangential traction at the last
    /// commit ([`ElasticBody::commit_friction`]).
    committed: Vec<Committed>,
    pattern: Pattern,
    /// The active-set solver's factorization (AMD ordering; K plus the
    /// contact penalties of the active set).
    cholesky: SparseCholesky,
    /// The condensed solver's factorization of K alone, with the contact
    /// unknowns ordered last; made at its first use (a large contact
    /// surface makes its trailing block dense and costly).
    condensation: Option<Condensation>,
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
    #[error(transparent)]
    Equilibrium(#[from] EquilibriumError),
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
            committed: vec![Committed::default(); n_points],
            pattern,
            condensation: None,
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
        let mut dofs: Vec<usize> = (self.contact.points.iter().flat_map(|p| p.nodes))
            .flat_map(|n| (0..3).map(move |d| 3 * n + d))
            .filter(|&g| self.free[g] != PRESCRIBED)
            .collect();
        dofs.sort_unstable();
        dofs.dedup();
        dofs.len()
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

    /// The position (mm) of contact point `q` with displacement `w`
    /// relative to the plane z = `plane_z` shifted tangentially by
    /// `shift`.
    fn relative(&self, q: usize, w: [f64; 3], plane_z: f64, shift: [f64; 2]) -> [f64; 3] {
        let x = self.contact.points[q].position;
        let origin = [shift[0], shift[1], plane_z];
        std::array::from_fn(|d| x[d] + w[d] - origin[d])
    }

    /// Commits the friction state of the solution `u` on the plane shifted
    /// by `shift`: each point's position relative to the plane and its
    /// traction become the reference of the next load step.
    pub fn commit_friction(&mut self, u: &[f64], shift: [f64; 2], traction: &[[f64; 2]]) {
        for q in 0..self.contact.points.len() {
            let w = self.contact.points[q].displacement(u);
            // The plane's height does not enter the tangential slip.
            self.committed[q] = Committed {
                position: self.relative(q, w, 0.0, shift),
                traction: [traction[q][0], traction[q][1], 0.0],
            };
        }
    }

    /// Pressed onto the rigid plane z = `plane_z` shifted tangentially by
    /// `shift` (mm) from the last commit, with Coulomb friction `mu` in
    /// both tangential directions (penalty `penalty_t` MPa/mm on the slip,
    /// return mapping onto the disc |t| <= mu p, [`FrictionLaw`]).
    /// Path-dependent: the trial traction is the committed one plus
    /// penalty_t times the slip since the commit.
    ///
    /// Solved on the contact nodes' unknowns alone ([`Condensation`]: K
    /// factorized once, at the body's first frictional solve, with those
    /// unknowns ordered last), Newton's method with the consistent tangent.
    pub fn solve_frictional(
        &mut self,
        plane_z: f64,
        shift: [f64; 2],
        mu: f64,
        penalty_t: f64,
        start: Option<&[f64]>,
    ) -> Result<FrictionalSolution, SolveError> {
        let factorized_now = self.condensation.is_none();
        if self.condensation.is_none() {
            let mut condensation = Condensation::new(&self.pattern, &self.free, &self.contact)?;
            condensation.factorize(&self.base)?;
            self.condensation = Some(condensation);
        }
        let law = FrictionLaw { penalty_n: self.penalty_mpa_per_mm, smoothing_mm: 0.0, penalty_t, mu };
        let mut u = self.starting_displacements(start);
        let load = self.prescribed_load();
        let mut condensation = self.condensation.take().expect("made above");
        let sticking = FrictionLaw { mu: f64::INFINITY, ..law };
        let evaluate = |body: &Self, q: usize, w: [f64; 3], mode: PointMode| {
            let relative = body.relative(q, w, plane_z, shift);
            let law = if mode == PointMode::Stick { &sticking } else { &law };
            law.evaluate(&HeightField::Flat.at(relative), relative, &body.committed[q])
        };
        let lightest = self.contact.points.iter().map(|p| p.weight).fold(f64::INFINITY, f64::min);
        let settings = NewtonSettings {
            max_iterations: 100,
            continuation_iterations: 1000,
            relative_tolerance: 1e-10,
            force_floor_n: self.penalty_mpa_per_mm * 1e-3 * lightest,
            increment_tolerance_mm: 1e-10,
        };
        let effort = condensation.equilibrium(
            &load,
            &self.free,
            &mut u,
            &self.contact,
            &mut |q, w, mode| evaluate(self, q, w, mode).map(|r| (r.force, r.tangent)),
            false,
            &settings,
            None,
        );
        self.condensation = Some(condensation);
        let effort = effort?;
        let n_points = self.contact.points.len();
        let mut solution = FrictionalSolution {
            pressure: vec![0.0; n_points],
            traction: vec![[0.0; 2]; n_points],
            sticking: vec![false; n_points],
            force_n: [0.0; 3],
            iterations: effort.iterations,
            factorizations: usize::from(factorized_now),
            u: Vec::new(),
        };
        for (q, p) in self.contact.points.iter().enumerate() {
            if let Some(r) = evaluate(self, q, self.contact.points[q].displacement(&u), PointMode::Exact) {
                solution.pressure[q] = r.pressure;
                solution.traction[q] = [r.traction[0], r.traction[1]];
                solution.sticking[q] = r.sticking;
                for d in 0..3 {
                    solution.force_n[d] += p.weight * r.force[d];
                }
            }
        }
        solution.u = u;
        Ok(solution)
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
            let moved = super::hex8::prescribed_forces(&k, &dofs, |d| {
                (self.free[d] == PRESCRIBED).then(|| self.prescribed_value[d])
            });
            for (i, m) in moved.iter().enumerate() {
                let fi = self.free[dofs[i]];
                if fi != PRESCRIBED {
                    f[fi] -= m;
                }
            }
        }
        f
    }
}
