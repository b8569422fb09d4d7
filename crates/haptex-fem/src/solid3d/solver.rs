//! The static, frictionless contact of a linear elastic 3D body with a
//! rigid plane below it, by penalty: at every contact point the pressure
//! is p = eps_N d for a penetration d > 0, else 0. The penalty law is
//! piecewise linear, so Newton's method is an active-set iteration: for a
//! set of points in contact the equations are linear,
//!
//!   (K + sum_active eps_N w N N^T) u_f = f_prescribed + sum_active eps_N w N (z_plane - Z),
//!
//! solved by one sparse Cholesky factorization (faer; symbolic analysis
//! once per problem, numeric per active set), and the set is updated
//! from the new gaps until it no longer changes. The first piece of the
//! 3D finger pad (issue 39), validated against Hertz's sphere on a flat.

use std::collections::HashSet;

use super::contact::ContactSurface;
use super::hex8::{Formulation, Hex8};
use super::mesh::{Mesh3, MeshError};
use crate::assembly::{PRESCRIBED, Pattern};
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
    /// For each contact point, the slots of its 4 x 4 z-z couplings
    /// (None where a DOF is prescribed).
    point_slots: Vec<[[Option<usize>; 4]; 4]>,
    cholesky: SparseCholesky,
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
        let mut free = vec![0usize; n_dofs];
        let mut prescribed_value = vec![0.0; n_dofs];
        for &(d, v) in prescribed {
            free[d] = PRESCRIBED;
            prescribed_value[d] = v;
        }
        let mut n_free = 0;
        for f in free.iter_mut() {
            if *f != PRESCRIBED {
                *f = n_free;
                n_free += 1;
            }
        }
        let element_dofs: Vec<Vec<usize>> =
            mesh.elements.iter().map(|nodes| (0..24).map(|i| free[3 * nodes[i / 3] + i % 3]).collect()).collect();
        let pattern = Pattern::from_element_dofs(n_free, &element_dofs);
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
                let dof = |a: usize| free[3 * p.nodes[a] + 2];
                std::array::from_fn(|a| {
                    std::array::from_fn(|b| {
                        let (i, j) = (dof(a), dof(b));
                        if i == PRESCRIBED || j == PRESCRIBED || i < j { None } else { pattern.slot(i, j) }
                    })
                })
            })
            .collect();
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
            base,
            point_slots,
            cholesky,
        })
    }

    /// Free unknowns.
    pub fn n_free(&self) -> usize {
        self.n_free
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
        let mut u: Vec<f64> = match start {
            Some(s) => s.to_vec(),
            None => self.prescribed_value.clone(),
        };
        for (g, &f) in self.free.iter().enumerate() {
            if f == PRESCRIBED {
                u[g] = self.prescribed_value[g];
            }
        }
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
                        if let Some(slot) = self.point_slots[q][a][b] {
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

    /// -K_fp u_p: the free DOFs' load from the prescribed displacements.
    fn prescribed_load(&self) -> Vec<f64> {
        let mut f = vec![0.0; self.n_free];
        for (e, nodes) in self.mesh.elements.iter().enumerate() {
            let dofs: [usize; 24] = std::array::from_fn(|i| 3 * nodes[i / 3] + i % 3);
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
