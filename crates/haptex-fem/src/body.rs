//! The deformable body: mesh, element geometry, materials and the
//! visco-elastic history at every Gauss point, with the element loops the
//! solver needs (stiffness, step loads, history update, stresses, nodal
//! forces).
//!
//! Kinematics are linear (small strain; the paper's model is a small
//! deformation visco-elastic one), so for a fixed time-step size the
//! internal force is affine in the displacement:
//!
//!   f_int(u) = K(dt) u + f_frozen,
//!
//! with the algorithmic stiffness K(dt) (shear modulus G0 (g_inf + sum gamma_i))
//! and f_frozen the forces of the history part of the deviatoric stress.

use crate::assembly::{DofMap, PRESCRIBED, Pattern};
use crate::element::{Formulation, GAUSS_POINTS, Q4, deviator};
use crate::material::{Material, MaterialError, StepCoefficients, advance_history, frozen_deviator, history_deviator};
use crate::mesh::{Mesh, MeshError};

/// The body cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BodyError {
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error("subdomain {subdomain}: {cause}")]
    Material { subdomain: usize, cause: MaterialError },
    #[error("element {element} has subdomain {subdomain}, but only {n} materials are given")]
    MissingMaterial { element: usize, subdomain: usize, n: usize },
}

/// Adds `scale * f` (element vector) to the free entries of `f_free`.
fn scatter_free(dofs: &DofMap, nodes: &[usize; 4], f: &[f64; 8], scale: f64, f_free: &mut [f64]) {
    for (i, g) in DofMap::element_dofs(nodes).into_iter().enumerate() {
        let d = dofs.free[g];
        if d != PRESCRIBED {
            f_free[d] += scale * f[i];
        }
    }
}

/// A subdomain's constitutive description.
#[derive(Debug, Clone, PartialEq)]
pub enum SubdomainModel {
    /// Deformable, with this material.
    Deformable(Material),
    /// Rigid: not assembled; all its nodes must be prescribed.
    Rigid,
}

/// A deformable body in its reference configuration plus its history.
#[derive(Debug, Clone)]
pub struct Body {
    pub mesh: Mesh,
    pub geometry: Vec<Q4>,
    pub subdomains: Vec<SubdomainModel>,
    pub formulation: Formulation,
    /// Visco-elastic history at each Gauss point (4 per element), committed
    /// state: the instantaneous deviator s0 of every point, and the internal
    /// stresses h_i of all points in one array (point `4 e + gp` has its
    /// material's number of Prony terms from `history_start[e] + gp * terms`).
    history_s0: Vec<[f64; 4]>,
    history_h: Vec<[f64; 4]>,
    history_start: Vec<usize>,
    deformable: Vec<usize>,
}

impl Body {
    pub fn new(mesh: Mesh, subdomains: Vec<SubdomainModel>, formulation: Formulation) -> Result<Self, BodyError> {
        let geometry = mesh.geometry()?;
        for (i, s) in subdomains.iter().enumerate() {
            if let SubdomainModel::Deformable(m) = s {
                m.validate().map_err(|cause| BodyError::Material { subdomain: i, cause })?;
            }
        }
        let mut deformable = Vec::new();
        for (e, &sd) in mesh.subdomain.iter().enumerate() {
            match subdomains.get(sd as usize) {
                None => {
                    return Err(BodyError::MissingMaterial { element: e, subdomain: sd as usize, n: subdomains.len() });
                }
                Some(SubdomainModel::Deformable(_)) => deformable.push(e),
                Some(SubdomainModel::Rigid) => {}
            }
        }
        let mut history_start = Vec::with_capacity(mesh.n_elements());
        let mut terms = 0;
        for &sd in &mesh.subdomain {
            history_start.push(terms);
            if let SubdomainModel::Deformable(m) = &subdomains[sd as usize] {
                terms += 4 * m.prony.len();
            }
        }
        Ok(Self {
            history_s0: vec![[0.0; 4]; 4 * mesh.n_elements()],
            history_h: vec![[0.0; 4]; terms],
            history_start,
            mesh,
            geometry,
            subdomains,
            formulation,
            deformable,
        })
    }

    /// Indices of the deformable elements.
    pub fn deformable_elements(&self) -> &[usize] {
        &self.deformable
    }

    /// Nodes of the rigid subdomains (they must be prescribed).
    pub fn rigid_nodes(&self) -> Vec<usize> {
        self.mesh.nodes_of_subdomains(|s| self.subdomains[s as usize] == SubdomainModel::Rigid)
    }

    fn material(&self, e: usize) -> &Material {
        match &self.subdomains[self.mesh.subdomain[e] as usize] {
            SubdomainModel::Deformable(m) => m,
            SubdomainModel::Rigid => unreachable!("rigid elements are never evaluated"),
        }
    }

    /// The step coefficients of each subdomain for step size `dt_s`.
    pub fn step_coefficients(&self, dt_s: f64) -> Vec<Option<StepCoefficients>> {
        self.subdomains
            .iter()
            .map(|s| match s {
                SubdomainModel::Deformable(m) => Some(m.step(dt_s)),
                SubdomainModel::Rigid => None,
            })
            .collect()
    }

    /// The internal stresses h_i of Gauss point `gp` of deformable element `e`.
    fn history_h(&self, e: usize, gp: usize) -> &[[f64; 4]] {
        let n = self.material(e).prony.len();
        let start = self.history_start[e] + gp * n;
        &self.history_h[start..start + n]
    }

    fn coefficients<'c>(&self, e: usize, c: &'c [Option<StepCoefficients>]) -> &'c StepCoefficients {
        c[self.mesh.subdomain[e] as usize].as_ref().expect("deformable element")
    }

    /// Algorithmic stiffness of element `e` for the step coefficients `c`.
    pub fn element_stiffness(&self, e: usize, c: &[Option<StepCoefficients>]) -> [[f64; 8]; 8] {
        let m = self.material(e);
        let g = m.shear_mpa() * self.coefficients(e, c).shear_ratio;
        self.geometry[e].stiffness(self.formulation, g, m.bulk_mpa())
    }

    /// Assembles the free-free stiffness (lower triangle) into `values`.
    pub fn assemble(&self, c: &[Option<StepCoefficients>], pattern: &Pattern, values: &mut [f64]) {
        values.fill(0.0);
        for &e in &self.deformable {
            pattern.add_element(e, &self.element_stiffness(e, c), values);
        }
    }

    /// Adds to the free right-hand side the loads of the history part of the
    /// stress, -f_frozen, for a step with coefficients `c`.
    pub fn add_history_loads(&self, c: &[Option<StepCoefficients>], dofs: &DofMap, f_free: &mut [f64]) {
        for &e in &self.deformable {
            let coefficients = self.coefficients(e, c);
            if coefficients.n_terms() == 0 {
                continue;
            }
            let mut f = [0.0; 8];
            for gp in 0..4 {
                let frozen = frozen_deviator(&self.history_s0[4 * e + gp], self.history_h(e, gp), coefficients);
                self.geometry[e].add_deviator_force(gp, &frozen, &mut f);
            }
            scatter_free(dofs, &self.mesh.elements[e], &f, -1.0, f_free);
        }
    }

    /// Adds to the free right-hand side -K_fp u_p: the forces of the
    /// prescribed displacements held in the global vector `u`.
    pub fn add_prescribed_loads(&self, c: &[Option<StepCoefficients>], dofs: &DofMap, u: &[f64], f_free: &mut [f64]) {
        for &e in &self.deformable {
            let global = DofMap::element_dofs(&self.mesh.elements[e]);
            let prescribed: [f64; 8] =
                std::array::from_fn(|i| if dofs.is_free(global[i]) { 0.0 } else { u[global[i]] });
            if prescribed.iter().all(|&v| v == 0.0) {
                continue;
            }
            let k = self.element_stiffness(e, c);
            let f: [f64; 8] = std::array::from_fn(|i| k[i].iter().zip(&prescribed).map(|(a, b)| a * b).sum::<f64>());
            scatter_free(dofs, &self.mesh.elements[e], &f, -1.0, f_free);
        }
    }

    /// Advances the history of every Gauss point to the displacement `u`
    /// (global vector) at the end of a step with coefficients `c`.
    pub fn commit(&mut self, c: &[Option<StepCoefficients>], u: &[f64]) {
        for i in 0..self.deformable.len() {
            let e = self.deformable[i];
            let ue = self.element_displacement(e, u);
            let m = self.material(e);
            let (g0, n) = (m.shear_mpa(), m.prony.len());
            let coefficients = self.coefficients(e, c);
            for gp in 0..4 {
                let s0 = deviator(&self.geometry[e].strain(gp, &ue)).map(|v| 2.0 * g0 * v);
                let start = self.history_start[e] + gp * n;
                let h = &mut self.history_h[start..start + n];
                advance_history(&mut self.history_s0[4 * e + gp], h, coefficients, &s0);
            }
        }
    }

    /// Displacements of element `e`'s nodes from the global vector `u`.
    pub fn element_displacement(&self, e: usize, u: &[f64]) -> [f64; 8] {
        DofMap::element_dofs(&self.mesh.elements[e]).map(|d| u[d])
    }

    /// Committed stress (xx, yy, zz, xy; MPa) at Gauss point `gp` of element
    /// `e`, with `u` the displacement the history was committed at.
    pub fn stress(&self, e: usize, gp: usize, u: &[f64]) -> [f64; 4] {
        let m = self.material(e);
        let ue = self.element_displacement(e, u);
        let p = m.bulk_mpa() * self.geometry[e].dilatation(self.formulation, gp, &ue);
        let s = history_deviator(&self.history_s0[4 * e + gp], self.history_h(e, gp), m.g_inf());
        [s[0] + p, s[1] + p, s[2] + p, s[3]]
    }

    /// Committed stress averaged over the element's Gauss points.
    pub fn element_stress(&self, e: usize, u: &[f64]) -> [f64; 4] {
        let mut avg = [0.0; 4];
        for gp in 0..4 {
            let s = self.stress(e, gp, u);
            for k in 0..4 {
                avg[k] += 0.25 * s[k];
            }
        }
        avg
    }

    /// Adds the internal nodal forces of the committed stress state of the
    /// elements in `elements` to the global vector `f` (N per mm of width).
    pub fn add_internal_forces(&self, elements: &[usize], u: &[f64], f: &mut [f64]) {
        for &e in elements {
            if !matches!(self.subdomains[self.mesh.subdomain[e] as usize], SubdomainModel::Deformable(_)) {
                continue;
            }
            let m = self.material(e);
            let ue = self.element_displacement(e, u);
            let q = &self.geometry[e];
            let mut fe = [0.0; 8];
            for gp in 0..4 {
                let s = history_deviator(&self.history_s0[4 * e + gp], self.history_h(e, gp), m.g_inf());
                q.add_deviator_force(gp, &s, &mut fe);
                if self.formulation == Formulation::Plain {
                    q.add_pressure_force(
                        Formulation::Plain,
                        gp,
                        m.bulk_mpa() * q.dilatation(Formulation::Plain, gp, &ue),
                        &mut fe,
                    );
                }
            }
            if self.formulation == Formulation::BBar {
                q.add_pressure_force(
                    Formulation::BBar,
                    0,
                    m.bulk_mpa() * q.dilatation(Formulation::BBar, 0, &ue),
                    &mut fe,
                );
            }
            for (i, d) in DofMap::element_dofs(&self.mesh.elements[e]).into_iter().enumerate() {
                f[d] += fe[i];
            }
        }
    }

    /// Elements with at least one node in `nodes`.
    pub fn elements_touching(&self, nodes: &[usize]) -> Vec<usize> {
        let mut flag = vec![false; self.mesh.n_nodes()];
        for &n in nodes {
            flag[n] = true;
        }
        (0..self.mesh.n_elements()).filter(|&e| self.mesh.elements[e].iter().any(|&n| flag[n])).collect()
    }

    /// Reference position of Gauss point `gp` of element `e`.
    pub fn gauss_point_position(&self, e: usize, gp: usize) -> [f64; 2] {
        let [r, s] = GAUSS_POINTS[gp];
        let n = crate::element::shape_functions(r, s);
        let x = self.mesh.element_coords(e);
        let mut p = [0.0; 2];
        for a in 0..4 {
            p[0] += n[a] * x[a][0];
            p[1] += n[a] * x[a][1];
        }
        p
    }
}
