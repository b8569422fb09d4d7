//! The quasi-static contact solver: a deformable body, a rigid set of
//! driven nodes (bone and nail), and penalty contact with friction against
//! a rigid surface that moves.
//!
//! # Algorithm
//!
//! With small-strain kinematics the body is linear for a given step size dt:
//! f_int = K(dt) u + f_frozen (see [`crate::body`]). Only the contact is
//! nonlinear, and it acts on the few nodes of the pad. The solver therefore
//! condenses the problem exactly onto those candidate contact DOFs s
//! (static condensation, Guyan 1965 — exact for a linear body):
//!
//! ```text
//!   Phi = K_ff^-1 P_s        response of all free DOFs to unit forces at s
//!   C   = P_s^T Phi          compliance of the pad (dense, 2m x 2m)
//!   u_f = u0 + Phi F(u_s)    u0: response to the driven motion and history
//!   R(u_s) = u_s - u0_s - C F(u_s) = 0
//! ```
//!
//! `Phi`, `C` and its inverse `S` (the condensed stiffness) are computed once
//! per step size from one sparse Cholesky factorization (symbolic analysis
//! shared by all step sizes). Each step costs one sparse solve for the
//! history load and a Newton iteration on R whose Jacobian I - C D (D the
//! contact tangent) is only non-trivial on the active DOFs A:
//!
//! ```text
//!   (I - C_AA D_AA) du_A = -R_A,     du = -R + (C D)_{:,A} du_A.
//! ```
//!
//! Convergence is measured on the force residual S R (N per mm of width),
//! relative to the largest nodal contact force; a backtracking line search
//! on |S R| guards the semi-smooth Newton iteration against active-set
//! cycling. A step that does not converge is retried in halves (with the
//! history untouched), down to 1/2^max_cuts of the step; if that fails the
//! error names the time, the step and the residual. Nothing is committed
//! from a failed attempt.

use faer::MatMut;
use faer::linalg::solvers::DenseSolveCore;

use crate::assembly::{DofMap, Pattern};
use crate::body::Body;
use crate::contact::{Block, ContactLaw, ContactSet, ContactTotals, SurfacePlacement};
use crate::display::Display;
use crate::linalg::{DenseLu, FactorError, SparseCholesky, lower_times, symmetric_times, upper_times};
use crate::material::StepCoefficients;
use crate::surface::RigidSurface;

/// A contact problem: body, driven rigid set, candidate contact region,
/// rigid surface and contact law.
#[derive(Debug, Clone)]
pub struct ContactProblem {
    pub body: Body,
    /// Nodes moved together as a rigid body (translation only).
    pub driven_nodes: Vec<usize>,
    pub contact: ContactSet,
    /// Boundary nodes outside the candidate region, checked for penetration.
    pub other_surface_nodes: Vec<usize>,
    pub surface: RigidSurface,
    pub law: ContactLaw,
    /// A display's electrode: the surface then attracts the skin with the
    /// voltage at the finger's position (`law.electrostatic` is set from it
    /// at every step).
    pub display: Option<Display>,
}

/// Most candidate contact nodes a problem may have: the condensed system
/// holds several dense (2m)^2 matrices (the finger's finest mesh with the
/// longest contact region has 811 nodes).
pub const MAX_CONTACT_NODES: usize = 2000;

/// Newton settings.
///
/// A step has converged when both hold:
///
/// - the force residual |S R|_inf (N per mm of width) is at most
///   `relative_tolerance` times the current contact force scale: the
///   largest nodal contact force, or, if larger, the force of
///   `floor_penetration_mm` of penetration at one contact point (penalty x
///   depth x the smallest point weight). The floor is what the contact
///   discretization resolves; it matters only while the first points touch,
///   when the contact force itself is near 0;
/// - the part of the last Newton correction that was not taken, (1 - alpha)
///   |dv|_inf with alpha the line search's step, is at most
///   `increment_tolerance_mm`: the iterate is where Newton's method
///   pointed, not merely somewhere along a damped step where the residual
///   happens to dip (a full step leaves nothing untaken).
///
/// Newton's method has `max_iterations`; a step that falls back to
/// pseudo-transient continuation (see [`newton`]) gets
/// `continuation_iterations` more, since crossing to the next equilibrium
/// after a snap takes a few hundred short damped steps, and leaving an
/// unstable one takes thousands: where Newton's method stalls at a small
/// residual (the pad in full slip at the leading edge of a steep bump, an
/// equilibrium that friction makes unstable), the damped motion first
/// creeps away from it and then settles on the next. Measured on the fine
/// mesh, bump r_w 0.5551, r_h 0.4014 mm, 58.433 mm/s, visco-elastic, the
/// database's settings: the escape took 1922 damped steps (the residual
/// rising from 2e-6 to 4.5e-5 N/mm over 800 of them, then falling to the
/// tolerance); with 1000 the step failed at every halving and the run
/// with it. A limit cycle is stopped long before the limit ([`CycleWatch`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    pub max_iterations: usize,
    /// Further iterations once continuation has started.
    pub continuation_iterations: usize,
    pub relative_tolerance: f64,
    pub floor_penetration_mm: f64,
    pub increment_tolerance_mm: f64,
    /// Halvings of a step before giving up.
    pub max_cuts: u32,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            continuation_iterations: 5000,
            relative_tolerance: 1e-9,
            floor_penetration_mm: 1e-3,
            increment_tolerance_mm: 1e-6,
            max_cuts: 10,
        }
    }
}

impl SolverSettings {
    /// Iterations 1 ..= 10^4 (continuation at most 10^5), halvings at most
    /// 40 (a step of 1e-12 of the original), tolerances and the floor's
    /// depth positive and finite.
    pub fn validate(&self) -> Result<(), SolveError> {
        let ok = (1..=10_000).contains(&self.max_iterations)
            && self.continuation_iterations <= 100_000
            && self.max_cuts <= 40
            && self.relative_tolerance.is_finite()
            && self.relative_tolerance > 0.0
            && self.floor_penetration_mm.is_finite()
            && self.floor_penetration_mm > 0.0
            && self.increment_tolerance_mm.is_finite()
            && self.increment_tolerance_mm > 0.0;
        if ok { Ok(()) } else { Err(SolveError::Settings(format!("out of range: {self:?}"))) }
    }
}

/// How the driven set is loaded during a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Drive {
    /// Rigid translation (x, y) of the driven set, mm.
    Displacement([f64; 2]),
    /// x displacement held at the given value, and a vertical force pushing
    /// the driven set down with `fy_n` (N per mm of width, > 0); its
    /// vertical displacement is an unknown.
    Load { x_mm: f64, fy_n: f64 },
}

/// The solver failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolveError {
    #[error(transparent)]
    Factor(#[from] FactorError),
    #[error(
        "Newton iteration did not converge at t = {t_s:.6} s (step {step}, slide {slide_mm:.4} mm) after {cuts} step \
         halvings: force residual {residual:.3e} N/mm (tolerance {tolerance:.3e}), Newton correction not taken \
         {correction_mm:.3e} mm (tolerance {correction_tolerance_mm:.1e})"
    )]
    NotConverged {
        t_s: f64,
        step: usize,
        slide_mm: f64,
        cuts: u32,
        residual: f64,
        tolerance: f64,
        correction_mm: f64,
        correction_tolerance_mm: f64,
    },
    #[error(
        "the skin touches the surface outside the meshed contact region at t = {t_s:.6} s (node {node}, x = \
         {x_mm:.3} mm): enlarge contact.contact_half_arc_mm in the finger model"
    )]
    OutsideContactRegion { t_s: f64, node: usize, x_mm: f64 },
    #[error("solver settings: {0}")]
    Settings(String),
    #[error("contact candidate node {node} is driven or rigid: the contact region must be free skin")]
    PrescribedContactNode { node: usize },
    #[error(
        "{nodes} contact candidate nodes: at most {MAX_CONTACT_NODES} (the condensed contact system is dense, its \
         memory grows with the square of this count)"
    )]
    TooManyContactNodes { nodes: usize },
}

/// The converged state after a step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport {
    pub t_s: f64,
    pub slide_mm: f64,
    /// Rigid displacement of the driven set, mm.
    pub drive_mm: [f64; 2],
    pub totals: ContactTotals,
    /// Newton iterations of this step (summed over sub-steps if it was cut).
    pub iterations: usize,
    /// Step halvings that were needed.
    pub cuts: u32,
}

/// Operators that depend on the step size.
pub(crate) struct StepOperators {
    pub(crate) dt_s: f64,
    pub(crate) coefficients: Vec<Option<StepCoefficients>>,
    pub(crate) cholesky: SparseCholesky,
    /// n_free x 2m, column-major.
    pub(crate) phi: Vec<f64>,
    /// 2m x 2m compliance and its inverse, column-major.
    pub(crate) compliance: Vec<f64>,
    pub(crate) stiffness: Vec<f64>,
    /// Free response to a unit translation of the driven set in x and in y.
    pub(crate) psi: [Vec<f64>; 2],
}

/// Work arrays of the Newton iteration, allocated once.
pub(crate) struct Scratch {
    pub(crate) last_ddy: f64,
    /// S v, S v_trial, S u0_s, S psi_s, S dv.
    pub(crate) sv: Vec<f64>,
    /// L^T x of S x = L (L^T x) (see [`PadStiffness`]).
    pub(crate) stiffness_half: Vec<f64>,
    pub(crate) sv_trial: Vec<f64>,
    pub(crate) su0: Vec<f64>,
    pub(crate) spsi: Vec<f64>,
    pub(crate) sdv: Vec<f64>,
    /// D on the active DOFs, dense.
    pub(crate) d_active: Vec<f64>,
    /// Its nonzeros column by column, rows ascending (compressed sparse
    /// columns: column c's are `d_rows[d_start[c]..d_start[c + 1]]`),
    /// found from the blocks rather than by scanning all n_a^2 entries.
    pub(crate) d_start: Vec<usize>,
    pub(crate) d_rows: Vec<usize>,
    pub(crate) d_values: Vec<f64>,
    pub(crate) u0_free: Vec<f64>,
    pub(crate) u_next: Vec<f64>,
    pub(crate) u0_s: Vec<f64>,
    pub(crate) psi_y_s: Vec<f64>,
    pub(crate) v: Vec<f64>,
    pub(crate) v_trial: Vec<f64>,
    pub(crate) dv: Vec<f64>,
    pub(crate) forces: Vec<f64>,
    pub(crate) forces_trial: Vec<f64>,
    pub(crate) residual: Vec<f64>,
    pub(crate) force_residual: Vec<f64>,
    pub(crate) blocks: Vec<Block>,
    pub(crate) blocks_trial: Vec<Block>,
    pub(crate) active: Vec<usize>,
    pub(crate) position: Vec<usize>,
    pub(crate) cd: Vec<f64>,
    pub(crate) rhs: Vec<f64>,
    pub(crate) lu: DenseLu,
}

/// The solver and the committed state.
pub struct Solver {
    pub problem: ContactProblem,
    pub settings: SolverSettings,
    pub(crate) dofs: DofMap,
    pub(crate) base: SparseCholesky,
    pub(crate) pattern: Pattern,
    values: Vec<f64>,
    /// Free index of each candidate DOF (2 per candidate node).
    pub(crate) candidate_free: Vec<usize>,
    pub(crate) operators: Vec<StepOperators>,
    pub(crate) scratch: Scratch,
    /// Committed global displacement.
    pub u: Vec<f64>,
    pub t_s: f64,
    pub slide_mm: f64,
    pub drive_mm: [f64; 2],
    /// Contact forces of the last converged step (per candidate DOF).
    pub forces: Vec<f64>,
    pub steps: usize,
    pub placement_lift_mm: f64,
    /// The force floor of the convergence test (N per mm of width): see
    /// [`SolverSettings`].
    pub(crate) force_floor_n: f64,
    pub total_iterations: usize,
    pending: Vec<(f64, f64)>,
    /// Elements touching the driven nodes, and a force buffer, for reactions.
    reaction_elements: Vec<usize>,
    reaction_forces: Vec<f64>,
}

impl Solver {
    /// Analyses the problem: DOF numbering, stiffness pattern, symbolic
    /// factorization. `lift_mm` places the surface vertically.
    pub fn new(problem: ContactProblem, settings: SolverSettings, lift_mm: f64) -> Result<Self, SolveError> {
        settings.validate()?;
        if !lift_mm.is_finite() {
            return Err(SolveError::Settings(format!("the surface's placement {lift_mm} mm is not finite")));
        }
        let mut prescribed: Vec<usize> = problem.driven_nodes.iter().flat_map(|&n| [2 * n, 2 * n + 1]).collect();
        // Rigid subdomains' nodes must be driven; they are by construction of
        // the finger, checked here for other problems.
        for n in problem.body.rigid_nodes() {
            if !problem.driven_nodes.contains(&n) {
                prescribed.extend([2 * n, 2 * n + 1]);
            }
        }
        let dofs = DofMap::new(problem.body.mesh.n_nodes(), &prescribed);
        if problem.contact.n_nodes() > MAX_CONTACT_NODES {
            return Err(SolveError::TooManyContactNodes { nodes: problem.contact.n_nodes() });
        }
        if let Some(&node) = problem.contact.nodes.iter().find(|&&n| !dofs.is_free(2 * n) || !dofs.is_free(2 * n + 1)) {
            return Err(SolveError::PrescribedContactNode { node });
        }
        let pattern = Pattern::new(&dofs, &problem.body.mesh.elements, problem.body.deformable_elements());
        let m2 = 2 * problem.contact.n_nodes();
        let base = SparseCholesky::new(&pattern, m2)?;
        let candidate_free: Vec<usize> =
            problem.contact.nodes.iter().flat_map(|&n| [dofs.free[2 * n], dofs.free[2 * n + 1]]).collect();
        let n_free = dofs.n_free;
        let scratch = Scratch {
            last_ddy: 0.0,
            sv: vec![0.0; m2],
            stiffness_half: vec![0.0; m2],
            sv_trial: vec![0.0; m2],
            su0: vec![0.0; m2],
            spsi: vec![0.0; m2],
            sdv: vec![0.0; m2],
            d_active: vec![0.0; m2 * m2],
            d_start: vec![0; m2 + 2],
            d_rows: Vec::with_capacity(16 * problem.contact.n_points()),
            d_values: Vec::with_capacity(16 * problem.contact.n_points()),
            u0_free: vec![0.0; n_free],
            u_next: vec![0.0; 2 * problem.body.mesh.n_nodes()],
            u0_s: vec![0.0; m2],
            psi_y_s: vec![0.0; m2],
            v: vec![0.0; m2],
            v_trial: vec![0.0; m2],
            dv: vec![0.0; m2],
            forces: vec![0.0; m2],
            forces_trial: vec![0.0; m2],
            residual: vec![0.0; m2],
            force_residual: vec![0.0; m2],
            blocks: Vec::with_capacity(4 * problem.contact.n_points()),
            blocks_trial: Vec::with_capacity(4 * problem.contact.n_points()),
            active: Vec::with_capacity(m2),
            position: vec![usize::MAX; m2],
            cd: vec![0.0; m2 * (m2 + 1)],
            rhs: vec![0.0; m2 + 1],
            lu: DenseLu::new(m2 + 1),
        };
        let n_nodes = problem.body.mesh.n_nodes();
        let mut solver = Self {
            problem,
            settings,
            dofs,
            base,
            values: vec![0.0; pattern.nnz()],
            pattern,
            candidate_free,
            operators: Vec::new(),
            scratch,
            u: vec![0.0; 2 * n_nodes],
            t_s: 0.0,
            slide_mm: 0.0,
            drive_mm: [0.0; 2],
            forces: vec![0.0; m2],
            steps: 0,
            placement_lift_mm: lift_mm,
            force_floor_n: 0.0,
            total_iterations: 0,
            pending: Vec::with_capacity(2 * settings.max_cuts as usize + 2),
            reaction_elements: Vec::new(),
            reaction_forces: vec![0.0; 2 * n_nodes],
        };
        solver.reaction_elements = solver.problem.body.elements_touching(&solver.problem.driven_nodes);
        let lightest = solver.problem.contact.point_weights().into_iter().fold(f64::INFINITY, f64::min);
        solver.force_floor_n = solver.problem.law.penalty_normal * settings.floor_penetration_mm * lightest;
        let placement = solver.placement(0.0);
        let u_s = solver.candidate_displacements();
        solver.problem.contact.initialize(&u_s, &solver.problem.surface, placement);
        Ok(solver)
    }

    /// Number of free DOFs and of stored entries of the Cholesky factor.
    pub fn sizes(&self) -> (usize, usize) {
        (self.dofs.n_free, self.base.factor_nnz())
    }

    pub(crate) fn placement(&self, slide_mm: f64) -> SurfacePlacement {
        SurfacePlacement { slide_mm, lift_mm: self.placement_lift_mm }
    }

    fn candidate_displacements(&self) -> Vec<f64> {
        self.problem.contact.nodes.iter().flat_map(|&n| [self.u[2 * n], self.u[2 * n + 1]]).collect()
    }

    /// The operators for step size `dt_s`, built on first use.
    pub(crate) fn operators_for(&mut self, dt_s: f64) -> Result<usize, SolveError> {
        if let Some(i) = self.operators.iter().position(|o| o.dt_s == dt_s) {
            return Ok(i);
        }
        let timer = std::time::Instant::now();
        let body = &self.problem.body;
        let coefficients = body.step_coefficients(dt_s);
        body.assemble(&coefficients, &self.pattern, &mut self.values);
        let m2 = self.candidate_free.len();
        let n = self.dofs.n_free;
        let mut cholesky = self.base.share(m2);
        cholesky.factorize(&self.values)?;
        // Phi = K^-1 P_s.
        let mut phi = vec![0.0; n * m2];
        for (c, &row) in self.candidate_free.iter().enumerate() {
            phi[c * n + row] = 1.0;
        }
        cholesky.solve_in_place(MatMut::from_column_major_slice_mut(&mut phi, n, m2));
        let mut compliance = vec![0.0; m2 * m2];
        for c in 0..m2 {
            for (r, &row) in self.candidate_free.iter().enumerate() {
                compliance[c * m2 + r] = phi[c * n + row];
            }
        }
        // S = C^-1 (C is symmetric positive definite).
        let c_mat = faer::MatRef::from_column_major_slice(&compliance, m2, m2);
        let llt = c_mat
            .llt(faer::Side::Lower)
            .map_err(|e| FactorError::NotPositiveDefinite(format!("pad compliance: {e:?}")))?;
        let s_mat = llt.inverse();
        let mut stiffness = vec![0.0; m2 * m2];
        for c in 0..m2 {
            for r in 0..m2 {
                stiffness[c * m2 + r] = s_mat[(r, c)];
            }
        }
        // Responses to unit translations of the driven set.
        let mut psi = [vec![0.0; n], vec![0.0; n]];
        for (axis, response) in psi.iter_mut().enumerate() {
            let mut u = vec![0.0; self.u.len()];
            for &node in &self.problem.driven_nodes {
                u[2 * node + axis] = 1.0;
            }
            body.add_prescribed_loads(&coefficients, &self.dofs, &u, response);
            cholesky.solve_vec(response);
        }
        self.operators.push(StepOperators { dt_s, coefficients, cholesky, phi, compliance, stiffness, psi });
        if std::env::var_os("HAPTEX_DEBUG").is_some() {
            eprintln!("operators for dt {dt_s}: {:.1} ms", timer.elapsed().as_secs_f64() * 1e3);
        }
        Ok(self.operators.len() - 1)
    }

    /// Advances to `slide_mm` with the driven set loaded by `drive` over a
    /// time `dt_s`, halving the step on failure. Returns the report of the
    /// (possibly subdivided) step.
    pub fn advance(&mut self, dt_s: f64, slide_mm: f64, drive: Drive) -> Result<StepReport, SolveError> {
        advance_halving(self, dt_s, slide_mm, drive)
    }

    /// One attempt at a step; commits only on success.
    fn try_step_small(
        &mut self,
        dt_s: f64,
        slide_mm: f64,
        drive: Drive,
    ) -> Result<(usize, ContactTotals), StepFailure> {
        let k = self.operators_for(dt_s).map_err(StepFailure::Fatal)?;
        let placement = self.placement(slide_mm);
        let m2 = self.candidate_free.len();
        let n = self.dofs.n_free;
        let (x_drive, y_drive, load) = match drive {
            Drive::Displacement([x, y]) => (x, y, None),
            Drive::Load { x_mm, fy_n } => (x_mm, self.drive_mm[1], Some(fy_n)),
        };
        // u0: the response to the history load and to the driven motion
        // (under load control, to the last y; y then changes by dy).
        {
            let ops = &mut self.operators[k];
            let s = &mut self.scratch;
            s.u0_free.fill(0.0);
            if ops.coefficients.iter().flatten().any(|c| c.n_terms() > 0) {
                self.problem.body.add_history_loads(&ops.coefficients, &self.dofs, &mut s.u0_free);
                ops.cholesky.solve_vec(&mut s.u0_free);
            }
            for i in 0..n {
                s.u0_free[i] += x_drive * ops.psi[0][i] + y_drive * ops.psi[1][i];
            }
            for (c, &row) in self.candidate_free.iter().enumerate() {
                s.u0_s[c] = s.u0_free[row];
                s.psi_y_s[c] = ops.psi[1][row];
            }
        }
        let ops = &self.operators[k];
        let condensed = Condensed {
            m2,
            compliance: &ops.compliance,
            stiffness: PadStiffness::Dense(&ops.stiffness),
            load,
            force_floor_n: self.force_floor_n,
        };
        // Predictor: the last converged pad displacement. (Extrapolating
        // the last increment was tried and is worse: near a feature's top it
        // lifts the pad off and Newton restarts from no contact at all.)
        let s = &mut self.scratch;
        for (c, &node) in self.problem.contact.nodes.iter().enumerate() {
            s.v[2 * c] = self.u[2 * node];
            s.v[2 * c + 1] = self.u[2 * node + 1];
        }
        let mut dy = 0.0;
        let outcome = newton(
            &condensed,
            &mut self.problem.contact,
            &self.problem.surface,
            placement,
            &self.problem.law,
            &self.settings,
            s,
            &mut dy,
            NewtonStart::STEP,
        )?;
        // Converged: recover the full field u_f = u0 + dy psi_y + Phi F.
        let s = &mut self.scratch;
        let u_free = &mut s.u0_free;
        if load.is_some() {
            for i in 0..n {
                u_free[i] += dy * ops.psi[1][i];
            }
        }
        for c in 0..m2 {
            let f = s.forces[c];
            if f != 0.0 {
                let column = &ops.phi[c * n..(c + 1) * n];
                for i in 0..n {
                    u_free[i] += column[i] * f;
                }
            }
        }
        let drive_mm = [x_drive, y_drive + dy];
        let u = &mut s.u_next;
        for (g, &d) in self.dofs.free.iter().enumerate() {
            if d != crate::assembly::PRESCRIBED {
                u[g] = u_free[d];
            }
        }
        for &node in &self.problem.driven_nodes {
            u[2 * node] = drive_mm[0];
            u[2 * node + 1] = drive_mm[1];
        }
        // No skin outside the candidate region may touch the surface.
        for &node in &self.problem.other_surface_nodes {
            let p = self.problem.body.mesh.nodes[node];
            let x = [p[0] + u[2 * node] + placement.slide_mm, p[1] + u[2 * node + 1] - placement.lift_mm];
            if self.problem.surface.project(x).is_some_and(|proj| proj.depth > 1e-9) {
                return Err(StepFailure::Fatal(SolveError::OutsideContactRegion {
                    t_s: self.t_s + dt_s,
                    node,
                    x_mm: p[0] + u[2 * node],
                }));
            }
        }
        // Commit.
        self.problem.body.commit(&ops.coefficients, u);
        self.problem.contact.commit();
        std::mem::swap(&mut self.u, &mut s.u_next);
        self.forces.copy_from_slice(&s.forces);
        self.t_s += dt_s;
        self.slide_mm = slide_mm;
        self.drive_mm = drive_mm;
        Ok(outcome)
    }

    /// The reaction on the driven set (N per mm of width): the sum of the
    /// internal forces of the committed stresses at the driven nodes,
    /// computed element by element (independently of the condensation).
    pub fn driven_reaction(&mut self) -> [f64; 2] {
        let f = &mut self.reaction_forces;
        f.fill(0.0);
        self.problem.body.add_internal_forces(&self.reaction_elements, &self.u, f);
        let mut r = [0.0; 2];
        for &node in &self.problem.driven_nodes {
            r[0] += f[2 * node];
            r[1] += f[2 * node + 1];
        }
        r
    }
}

/// A solver that advances by attempts that commit only on success: the
/// small-strain [`Solver`] and the finite-strain one, which share the
/// committed state (time, slide, drive, step count, settings, the stack of
/// pending sub-steps) held in a [`Solver`].
pub(crate) trait Stepping {
    /// The committed state.
    fn committed(&mut self) -> &mut Solver;
    /// One attempt at a step of `dt_s` to `slide_mm` under `drive`.
    fn try_step(&mut self, dt_s: f64, slide_mm: f64, drive: Drive) -> Result<(usize, ContactTotals), StepFailure>;
}

impl Stepping for Solver {
    fn committed(&mut self) -> &mut Solver {
        self
    }

    fn try_step(&mut self, dt_s: f64, slide_mm: f64, drive: Drive) -> Result<(usize, ContactTotals), StepFailure> {
        self.try_step_small(dt_s, slide_mm, drive)
    }
}

/// Advances `solver` to `slide_mm` with the driven set loaded by `drive`
/// over `dt_s`, retrying a failed attempt in halves (nothing is committed
/// from it) down to 1/2^max_cuts of the step; past that, the error names
/// the time, the step, the slide and the residual.
pub(crate) fn advance_halving<S: Stepping>(
    solver: &mut S,
    dt_s: f64,
    slide_mm: f64,
    drive: Drive,
) -> Result<StepReport, SolveError> {
    let state = solver.committed();
    let (start_drive, start_slide) = (state.drive_mm, state.slide_mm);
    // Work still to do, as fractions (from, to) of the step: a stack that
    // step halving pushes onto (kept in the solver: no allocation).
    let mut pending = std::mem::take(&mut state.pending);
    pending.clear();
    pending.push((0.0f64, 1.0f64));
    let (mut iterations, mut cuts, mut last) = (0, 0, None);
    while let Some((from, to)) = pending.pop() {
        let fraction = to - from;
        let target_slide = start_slide + to * (slide_mm - start_slide);
        let target_drive = match drive {
            Drive::Displacement(d) => Drive::Displacement([
                start_drive[0] + to * (d[0] - start_drive[0]),
                start_drive[1] + to * (d[1] - start_drive[1]),
            ]),
            Drive::Load { x_mm, fy_n } => Drive::Load { x_mm: start_drive[0] + to * (x_mm - start_drive[0]), fy_n },
        };
        // The voltage is the one at the finger's position at the end of the
        // (sub-)step, as every other load of the implicit step.
        let problem = &mut solver.committed().problem;
        if let Some(display) = &problem.display {
            problem.law.electrostatic = Some(display.electrostatic_at(target_slide));
            // A vibrating plate: the friction coefficient at the finger's
            // position, mu_HD rho(a(x_f)), like the voltage.
            if let Some(mu) = display.friction_at(target_slide) {
                problem.law.mu = mu;
            }
        }
        match solver.try_step(fraction * dt_s, target_slide, target_drive) {
            Ok((its, totals)) => {
                iterations += its;
                last = Some(totals);
            }
            Err(StepFailure::Fatal(e)) => {
                solver.committed().pending = pending;
                return Err(e);
            }
            Err(StepFailure::Newton { residual, tolerance, correction_mm }) => {
                let depth = (1.0 / fraction).log2().round() as u32;
                let state = solver.committed();
                if depth >= state.settings.max_cuts {
                    state.pending = pending;
                    return Err(SolveError::NotConverged {
                        t_s: state.t_s + fraction * dt_s,
                        step: state.steps + 1,
                        slide_mm: target_slide,
                        cuts: depth,
                        residual,
                        tolerance,
                        correction_mm,
                        correction_tolerance_mm: state.settings.increment_tolerance_mm,
                    });
                }
                cuts += 1;
                let middle = 0.5 * (from + to);
                pending.push((middle, to));
                pending.push((from, middle));
            }
        }
    }
    let state = solver.committed();
    state.pending = pending;
    state.steps += 1;
    state.total_iterations += iterations;
    Ok(StepReport {
        t_s: state.t_s,
        slide_mm: state.slide_mm,
        drive_mm: state.drive_mm,
        totals: last.expect("at least one sub-step"),
        iterations,
        cuts,
    })
}

/// Why one attempt at a step failed.
pub(crate) enum StepFailure {
    Newton { residual: f64, tolerance: f64, correction_mm: f64 },
    Fatal(SolveError),
}

/// The condensed stiffness S of a step: dense, or as the trailing factor
/// L of a pad-last factorization (S = L L^T; with L^T kept column-major).
#[derive(Clone, Copy)]
pub(crate) enum PadStiffness<'a> {
    Dense(&'a [f64]),
    Factor { lower: &'a [f64], upper: &'a [f64] },
}

/// The condensed operators of one step.
pub(crate) struct Condensed<'a> {
    pub(crate) m2: usize,
    pub(crate) compliance: &'a [f64],
    pub(crate) stiffness: PadStiffness<'a>,
    /// Vertical load on the driven set (load control), N per mm of width.
    pub(crate) load: Option<f64>,
    /// The convergence test's force floor, N per mm of width.
    pub(crate) force_floor_n: f64,
}

impl Condensed<'_> {
    /// out = S x (m2 x m2 dense; a few times per step, and per outer
    /// iteration of the finite-strain solver), column by column in SIMD
    /// lanes (dense: each out_r sums S_rc x_c over c in order, the sum of a
    /// row-by-row dot product to the bit); as a factor, L (L^T x) through
    /// `half`.
    fn stiffness_times(&self, x: &[f64], out: &mut [f64], half: &mut [f64]) {
        match self.stiffness {
            PadStiffness::Dense(s) => symmetric_times(s, self.m2, x, out),
            PadStiffness::Factor { lower, upper } => {
                upper_times(upper, self.m2, x, half);
                lower_times(lower, self.m2, half, out);
            }
        }
    }

    /// The residual R = v - u0_s - dy psi_s - C F into `s.residual` and the
    /// force residual S R = S v - S u0_s - dy S psi_s - F into
    /// `s.force_residual`, with S v kept up to date incrementally (S C = I),
    /// so an evaluation costs O(m2 x active) instead of O(m2^2). Returns
    /// (|S R, load residual|_inf, squared norm, largest nodal force).
    fn residual(&self, s: &mut Scratch, trial: bool, dy: f64) -> (f64, f64, f64) {
        let m2 = self.m2;
        let (v, sv, forces) = if trial { (&s.v_trial, &s.sv_trial, &s.forces_trial) } else { (&s.v, &s.sv, &s.forces) };
        for r in 0..m2 {
            s.residual[r] = v[r] - s.u0_s[r] - dy * s.psi_y_s[r];
        }
        for c in 0..m2 {
            let f = forces[c];
            if f != 0.0 {
                let column = &self.compliance[c * m2..(c + 1) * m2];
                for r in 0..m2 {
                    s.residual[r] -= column[r] * f;
                }
            }
        }
        let mut norm: f64 = 0.0;
        let mut merit = 0.0;
        let mut force_scale: f64 = 0.0;
        for r in 0..m2 {
            let value = sv[r] - s.su0[r] - dy * s.spsi[r] - forces[r];
            s.force_residual[r] = value;
            norm = norm.max(value.abs());
            merit += value * value;
            force_scale = force_scale.max(forces[r].abs());
        }
        if let Some(load) = self.load {
            let total: f64 = (0..m2 / 2).map(|i| forces[2 * i + 1]).sum();
            let load_residual = total - load;
            norm = norm.max(load_residual.abs());
            merit += load_residual * load_residual;
        }
        (norm, merit, force_scale)
    }
}

/// Damping of pseudo-transient continuation while the residual is at or
/// above its value where continuation started (a pseudo-time step of 1/10
/// of the pad's own relaxation), and the smallest, below which the step is
/// Newton's to 1e-12. Measured on the half-disc over the sharpest corners
/// (r_w 0.5, r_h 0.5 mm): the skin resting on a crest sits at an unstable
/// or vanishing equilibrium, the residual grows by about 0.9/(1 + damping)
/// per damped step while the skin snaps to the crest's other side, and
/// with damping 1 the iterates, too long, overshoot the new equilibrium and
/// cycle between active sets; with 10 all of them cross.
pub(crate) const CONTINUATION_DAMPING: f64 = 10.0;
pub(crate) const MIN_DAMPING: f64 = 1e-12;

/// A limit cycle of pseudo-transient continuation: the residual norms of
/// the last damped steps repeat, one period apart, to [`CYCLE_AGREEMENT`]
/// (relative) over [`CYCLE_REPEATS`] periods of at most [`CYCLE_PERIOD`]
/// steps. The iteration is deterministic, so a state that comes back does
/// so forever: the attempt is given up and the step halved, as it would be
/// at the iteration limit, 1000 damped steps later.
///
/// Measured on the half-disc over the sharpest sine (r_w 0.5, r_h 0.5 mm,
/// default settings): 36 attempts failed, each after the full limit, 65 %
/// of the run's iterations; in 25 of them the pad alternated between
/// touching the surface at some 44 DOFs and not at all (a 2-cycle, the
/// norms equal to 1e-12) or went round a longer cycle, found by this rule
/// after a median of 89 iterations. Over the 2533 contact solves of the
/// seven hardest runs of the robustness matrix (the sharp corners under the
/// half-disc and the finger, fine mesh, penalty 1000, a quarter step) no
/// attempt that converged ever repeated so: the rule changes no result
/// (the profiles of those runs are identical to the bit), only when a
/// failing attempt ends.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CycleWatch {
    /// The last norms, most recent at `norms[(next + W - 1) % W]`.
    norms: [f64; CYCLE_WINDOW],
    next: usize,
    len: usize,
}

const CYCLE_PERIOD: usize = 8;
const CYCLE_REPEATS: usize = 3;
const CYCLE_AGREEMENT: f64 = 1e-8;
const CYCLE_WINDOW: usize = (CYCLE_REPEATS + 1) * CYCLE_PERIOD;

impl CycleWatch {
    pub(crate) const EMPTY: CycleWatch = CycleWatch { norms: [0.0; CYCLE_WINDOW], next: 0, len: 0 };

    /// Records the norm of a damped step; the period if the norms now
    /// cycle.
    pub(crate) fn push(&mut self, norm: f64) -> Option<usize> {
        self.norms[self.next] = norm;
        self.next = (self.next + 1) % CYCLE_WINDOW;
        self.len = (self.len + 1).min(CYCLE_WINDOW);
        // The i-th most recent norm (0: this one).
        let back = |i: usize| self.norms[(self.next + CYCLE_WINDOW - 1 - i) % CYCLE_WINDOW];
        (1..=CYCLE_PERIOD).find(|&p| {
            self.len >= (CYCLE_REPEATS + 1) * p
                && (0..CYCLE_REPEATS * p).all(|i| (back(i) - back(i + p)).abs() <= CYCLE_AGREEMENT * back(i))
        })
    }
}

/// How the contact Newton ([`newton`]) starts from the predictor in `s.v`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NewtonStart {
    /// The contact is already evaluated at the predictor with the law
    /// (forces in `s.forces`, tangent blocks in `s.blocks`, trial states
    /// set), with these totals: it is not evaluated there again.
    pub(crate) evaluated: Option<ContactTotals>,
    /// Take the stick predictor step when some point stuck at the last
    /// step (see [`newton`]): at a step's first contact solve. The
    /// finite-strain solver's later outer iterations start from the last
    /// one's contact solution, whose stick and slip are this step's.
    pub(crate) stick_predictor: bool,
}

impl NewtonStart {
    /// A step's first contact solve, from the last converged state.
    pub(crate) const STEP: NewtonStart = NewtonStart { evaluated: None, stick_predictor: true };
}

/// Semi-smooth Newton with backtracking on the condensed contact problem.
/// On entry `s.v` holds the predictor; on success `s.v`/`s.forces` hold the
/// solution and `dy` the change of the driven y (load control).
#[allow(clippy::too_many_arguments)]
pub(crate) fn newton(
    cond: &Condensed<'_>,
    contact: &mut ContactSet,
    surface: &RigidSurface,
    placement: SurfacePlacement,
    law: &ContactLaw,
    settings: &SolverSettings,
    s: &mut Scratch,
    dy: &mut f64,
    start: NewtonStart,
) -> Result<(usize, ContactTotals), StepFailure> {
    // The contact tangent starts with its geometric term (the exact
    // derivative: quadratic convergence where the surface is curved) and
    // drops it for the rest of the step at the first stall (see below).
    let mut law = *law;
    let law = &mut law;
    let m2 = cond.m2;
    let debug = std::env::var_os("HAPTEX_DEBUG").is_some();
    // The step's constant products, and S v exactly.
    cond.stiffness_times(&s.u0_s, &mut s.su0, &mut s.stiffness_half);
    if cond.load.is_some() {
        cond.stiffness_times(&s.psi_y_s, &mut s.spsi, &mut s.stiffness_half);
    } else {
        // dy stays 0 under displacement control: S psi_s is never used.
        s.spsi[..m2].fill(0.0);
    }
    cond.stiffness_times(&s.v, &mut s.sv, &mut s.stiffness_half);
    // Stick predictor: one Newton step with every contact point sticking,
    // taken when some point stuck at the last step (the pad's shear is still
    // building up, as at the start of a slide). Starting from the last state
    // instead, the linearised slip drags the whole pad past the surface and
    // the iterates flip every point's slip direction back and forth. In
    // steady sliding the last state is the better start.
    let stick_predictor = start.stick_predictor && contact.committed.iter().any(|p| p.active && !p.slipping);
    if stick_predictor {
        contact.evaluate_with(&s.v, surface, placement, law, true, &mut s.forces, &mut s.blocks);
        cond.residual(s, false, *dy);
        if newton_direction(cond, s, 0.0).is_some() {
            for r in 0..m2 {
                s.v[r] += s.dv[r];
                s.sv[r] += s.sdv[r];
            }
            *dy += s.last_ddy;
        }
    }
    let mut totals = match start.evaluated {
        Some(totals) if !stick_predictor => totals,
        _ => contact.evaluate(&s.v, surface, placement, law, &mut s.forces, &mut s.blocks),
    };
    let (mut norm, mut merit, mut scale) = cond.residual(s, false, *dy);
    let tolerance_of = |scale: f64| settings.relative_tolerance * scale.max(cond.force_floor_n);
    // The part of the last Newton correction not taken (mm): none at the
    // start (the last converged state, or the full stick-predictor step).
    let mut correction = 0.0f64;
    // Damping of pseudo-transient continuation (0: Newton's method with a
    // line search).
    let mut damping = 0.0f64;
    let mut stalls = 0usize;
    // The residual where continuation started, and the iteration limit
    // (raised when it starts).
    let mut continuation_start = 0.0f64;
    let mut cycle = CycleWatch::EMPTY;
    let mut limit = settings.max_iterations;
    let converged = |norm: f64, scale: f64, correction: f64| {
        norm <= tolerance_of(scale) && correction <= settings.increment_tolerance_mm
    };
    let mut iterations = 0;
    for iteration in 0.. {
        iterations = iteration;
        if iteration >= limit || !norm.is_finite() {
            break;
        }
        if debug {
            eprintln!(
                "it {iteration}: norm {norm:.3e} active {} slip {}",
                totals.active_points, totals.slipping_points
            );
        }
        if converged(norm, scale, correction) {
            // Confirm with S v computed afresh (no drift of the updates).
            cond.stiffness_times(&s.v, &mut s.sv, &mut s.stiffness_half);
            (norm, merit, scale) = cond.residual(s, false, *dy);
            if converged(norm, scale, correction) {
                return Ok((iteration, totals));
            }
        }
        if newton_direction(cond, s, damping).is_none() {
            // Under load control, an iterate with nothing in contact: the
            // load row has no contact force to act on. This attempt failed
            // and the step is halved. (It used to end the run as "lost
            // contact", but an iterate is not the finger: the finger rides
            // over a bump under a constant load, and the full Newton step
            // off the bump's far side may overshoot.)
            break;
        }
        let ddy = s.last_ddy;
        if damping > 0.0 {
            // Pseudo-transient continuation: the full damped step, with
            // the damping proportional to the residual relative to where
            // continuation started, capped at CONTINUATION_DAMPING and at
            // most halved per iteration: it shrinks as the residual falls
            // below that, so the iteration turns into Newton's near the
            // solution, and stays put while the residual rises. Switched evolution relaxation (Mulder & van
            // Leer 1985: the damping follows the residual's last change)
            // failed on the sharpest corners both ways: grown as the residual
            // rose, the steps became too short for the skin to snap across
            // a crest (the residual grows while it does); shrunk at each
            // fall of an oscillating residual after the snap, the iteration
            // turned into the cycling Newton's method again.
            for r in 0..m2 {
                s.v[r] += s.dv[r];
                s.sv[r] += s.sdv[r];
            }
            *dy += ddy;
            totals = contact.evaluate(&s.v, surface, placement, law, &mut s.forces, &mut s.blocks);
            (norm, merit, scale) = cond.residual(s, false, *dy);
            // The part of Newton's step the damping held back, about
            // damping |dv|.
            correction = damping * s.dv.iter().fold(ddy.abs(), |m, v| m.max(v.abs()));
            damping = if norm.is_finite() && continuation_start > 0.0 {
                (CONTINUATION_DAMPING * (norm / continuation_start).min(1.0)).max(0.5 * damping)
            } else {
                CONTINUATION_DAMPING
            };
            if damping < MIN_DAMPING {
                damping = 0.0;
            }
            if debug {
                eprintln!("  damped step, damping now {damping:.3e}");
            }
            if let Some(period) = cycle.push(norm) {
                if debug {
                    eprintln!("  continuation cycles with period {period}: attempt given up");
                }
                break;
            }
            continue;
        }
        // Backtracking line search on |S R|^2.
        let mut alpha = 1.0;
        let mut accepted = false;
        for _ in 0..8 {
            for r in 0..m2 {
                s.v_trial[r] = s.v[r] + alpha * s.dv[r];
                s.sv_trial[r] = s.sv[r] + alpha * s.sdv[r];
            }
            let trial_totals =
                contact.evaluate(&s.v_trial, surface, placement, law, &mut s.forces_trial, &mut s.blocks_trial);
            let (trial_norm, trial_merit, trial_scale) = cond.residual(s, true, *dy + alpha * ddy);
            if trial_merit.is_finite()
                && (trial_merit < (1.0 - 1e-4 * alpha) * merit || trial_norm <= tolerance_of(trial_scale))
            {
                std::mem::swap(&mut s.v, &mut s.v_trial);
                std::mem::swap(&mut s.sv, &mut s.sv_trial);
                std::mem::swap(&mut s.forces, &mut s.forces_trial);
                std::mem::swap(&mut s.blocks, &mut s.blocks_trial);
                *dy += alpha * ddy;
                totals = trial_totals;
                (norm, merit, scale) = (trial_norm, trial_merit, trial_scale);
                accepted = true;
                break;
            }
            alpha *= 0.5;
        }
        if !accepted {
            // No sufficient decrease down to 1/128 of the Newton step. The
            // residual has a kink within the step (a point entering or
            // leaving contact, or changing between stick and slip), or there
            // is no equilibrium near the iterate at all: the skin snaps off
            // a sharp crest, and the next equilibrium is on the crest's other
            // side. Newton's method with a line search cannot cross that
            // (the full step alone cycled through the same state on the
            // half-disc at penalty 1000; short steps stall on the sine at
            // r_w 0.5 mm). Switch, for the rest of the step, to
            // pseudo-transient continuation: an overdamped motion of the pad
            // towards the next stable equilibrium, which becomes Newton's
            // method again as the residual falls.
            //
            // The geometric term of the tangent is dropped with it: on a
            // crest it is a negative stiffness (a point on a hilltop), and
            // where crests are sharper than the Gauss points are apart it
            // makes the linearised problem indefinite. The residual is exact
            // either way, so the equilibrium found is the same.
            let had_geometric_term = std::mem::replace(&mut law.geometric_tangent, false);
            // Without it the tangent is no longer exact on a curved surface,
            // and Newton's method converges only linearly where the surface
            // is sharply curved: on the fine mesh, sine r_w 1, r_h 0.2 mm
            // (crest radius 0.13 mm), 10 mm/s, slide steps of 0.0125 mm, the
            // residual fell by a factor 0.9 per full step, with the active
            // and slipping sets fixed, and was at 5.8e-10 N/mm (tolerance
            // 2.3e-12) when the 100 iterations ran out, at every halving.
            // A step that loses the term here gets the continuation's budget:
            // a linear iteration that still decreases the residual is not a
            // failure. (A tangent that never had it keeps the Newton limit.)
            if had_geometric_term {
                limit = limit.max(iteration + 1 + settings.continuation_iterations);
            }
            stalls += 1;
            if stalls == 1 {
                // The first time, the full Newton step: one active-set
                // change is usually all there is (a frictionless press).
                alpha = 1.0;
                for r in 0..m2 {
                    s.v[r] += s.dv[r];
                    s.sv[r] += s.sdv[r];
                }
                *dy += ddy;
            } else {
                damping = CONTINUATION_DAMPING;
                continuation_start = norm;
                limit = limit.max(iteration + 1 + settings.continuation_iterations);
                alpha = 0.0;
            }
            totals = contact.evaluate(&s.v, surface, placement, law, &mut s.forces, &mut s.blocks);
            (norm, merit, scale) = cond.residual(s, false, *dy);
        }
        correction = (1.0 - alpha) * s.dv.iter().fold(ddy.abs(), |m, v| m.max(v.abs()));
        if debug {
            eprintln!("  alpha {}", if accepted { alpha } else { f64::NAN });
        }
    }
    // The last update may have converged: check it as the loop's head would
    // (else a converged step were cut, or reported as failed with a residual
    // below its tolerance).
    if norm.is_finite() && converged(norm, scale, correction) {
        cond.stiffness_times(&s.v, &mut s.sv, &mut s.stiffness_half);
        (norm, _, scale) = cond.residual(s, false, *dy);
        if converged(norm, scale, correction) {
            return Ok((iterations, totals));
        }
    }
    Err(StepFailure::Newton { residual: norm, tolerance: tolerance_of(scale), correction_mm: correction })
}

/// The Newton direction of the condensed problem at the current iterate
/// (residuals in `s.residual` and `s.force_residual`, tangent blocks in
/// `s.blocks`): `s.dv`, its image `s.sdv` = S dv, and `s.last_ddy` for the
/// driven y under load control. `None` when under load control nothing is
/// in contact (the load cannot be carried).
///
/// With `damping` > 0 the direction is that of pseudo-transient
/// continuation (Kelley & Keyes 1998): the system (gamma I - C D) dv = -R
/// with gamma = 1 + damping, i.e. a pseudo-time step of 1/damping with the
/// pad's own stiffness as the "mass" (in force form (gamma S - D) dv = -S R).
/// It vanishes as damping goes to 0, so a converged state is the exact
/// equilibrium either way.
fn newton_direction(cond: &Condensed<'_>, s: &mut Scratch, damping: f64) -> Option<()> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        return unsafe { newton_direction_avx2(cond, s, damping) };
    }
    newton_direction_in(cond, s, damping)
}

/// [`newton_direction`] built for AVX2: its products of the compliance
/// columns run four lanes wide instead of SSE2's two. AVX2 alone, not FMA:
/// Rust never fuses a multiply and an add it was not asked to, so every
/// operation and its rounding are those of the SSE2 build, and the
/// results the same to the bit.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn newton_direction_avx2(cond: &Condensed<'_>, s: &mut Scratch, damping: f64) -> Option<()> {
    newton_direction_in(cond, s, damping)
}

#[inline(always)]
fn newton_direction_in(cond: &Condensed<'_>, s: &mut Scratch, damping: f64) -> Option<()> {
    let gamma = 1.0 + damping;
    let m2 = cond.m2;
    // Active DOFs: those touched by a tangent block.
    s.active.clear();
    for b in &s.blocks {
        for node in [b.i, b.j] {
            for q in 0..2 {
                let dof = 2 * node + q;
                if s.position[dof] == usize::MAX {
                    s.position[dof] = s.active.len();
                    s.active.push(dof);
                }
            }
        }
    }
    let n_a = s.active.len();
    let with_load = cond.load.is_some();
    if with_load && n_a == 0 {
        for &dof in &s.active {
            s.position[dof] = usize::MAX;
        }
        return None;
    }
    // D_AA, merged from the blocks (dense n_a x n_a, column-major).
    let d = &mut s.d_active[..n_a * n_a];
    d.fill(0.0);
    for b in &s.blocks {
        for p in 0..2 {
            for q in 0..2 {
                d[s.position[2 * b.j + q] * n_a + s.position[2 * b.i + p]] += b.d[p][q];
            }
        }
    }
    // D_AA's nonzeros by column, rows ascending: the entries the blocks
    // touch (four each), counted per column, placed, sorted and merged
    // within each column, and those whose merged value is nonzero kept.
    // (The entries and their order are those of a scan of the dense D
    // skipping zeros, which cost n_a^2 a Newton iteration.)
    let (start, rows, values) = (&mut s.d_start, &mut s.d_rows, &mut s.d_values);
    start[..n_a + 2].fill(0);
    for b in &s.blocks {
        for q in 0..2 {
            start[s.position[2 * b.j + q] + 2] += 2;
        }
    }
    for col in 0..n_a {
        start[col + 2] += start[col + 1];
    }
    rows.clear();
    rows.resize(start[n_a + 1], 0);
    for b in &s.blocks {
        for q in 0..2 {
            let col = s.position[2 * b.j + q];
            for p in 0..2 {
                rows[start[col + 1]] = s.position[2 * b.i + p];
                start[col + 1] += 1;
            }
        }
    }
    // start[c + 1] is now column c's end; compact each column in place.
    values.clear();
    let mut kept = 0;
    for col in 0..n_a {
        let (from, to) = (start[col], start[col + 1]);
        start[col] = kept;
        rows[from..to].sort_unstable();
        let mut last = usize::MAX;
        for k in from..to {
            let row = rows[k];
            if row != last && d[col * n_a + row] != 0.0 {
                rows[kept] = row;
                values.push(d[col * n_a + row]);
                kept += 1;
            }
            last = row;
        }
    }
    start[n_a] = kept;
    rows.truncate(kept);
    // CD = C[:, A] D_AA (m2 x n_a, column-major), using D's sparsity.
    let cd = &mut s.cd[..m2 * n_a];
    cd.fill(0.0);
    for col in 0..n_a {
        let out = &mut cd[col * m2..(col + 1) * m2];
        for k in start[col]..start[col + 1] {
            let (dof, value) = (s.active[rows[k]], values[k]);
            let column_c = &cond.compliance[dof * m2..(dof + 1) * m2];
            for r in 0..m2 {
                out[r] += column_c[r] * value;
            }
        }
    }
    // The active system, plus the load row and dy column.
    let size = n_a + with_load as usize;
    {
        let mut j = s.lu.matrix_mut(size);
        for col in 0..n_a {
            for (row, &dof) in s.active.iter().enumerate() {
                j[(row, col)] = if row == col { gamma } else { 0.0 } - cd[col * m2 + dof];
            }
        }
        if with_load {
            for (row, &dof) in s.active.iter().enumerate() {
                j[(row, n_a)] = -s.psi_y_s[dof];
            }
            // d(sum F_y)/dv_A: the sum of D's y rows.
            for col in 0..n_a {
                j[(n_a, col)] = s
                    .active
                    .iter()
                    .enumerate()
                    .filter(|(_, dof)| *dof % 2 == 1)
                    .map(|(row, _)| d[col * n_a + row])
                    .sum();
            }
            j[(n_a, n_a)] = 0.0;
        }
    }
    let regular = s.lu.factor();
    for (row, &dof) in s.active.iter().enumerate() {
        s.rhs[row] = -s.residual[dof];
    }
    if with_load {
        let total: f64 = (0..m2 / 2).map(|i| s.forces[2 * i + 1]).sum();
        s.rhs[n_a] = -(total - cond.load.unwrap_or(0.0));
    }
    let mut ddy = 0.0;
    if regular && n_a > 0 {
        s.lu.solve(&mut s.rhs[..size]);
        if with_load {
            ddy = s.rhs[n_a];
        }
    }
    // dv = -R + CD dv_A + ddy psi, and S dv = -S R + D dv_A + ddy S psi.
    for r in 0..m2 {
        s.dv[r] = -s.residual[r] + ddy * s.psi_y_s[r];
        s.sdv[r] = -s.force_residual[r] + ddy * s.spsi[r];
    }
    if regular {
        for col in 0..n_a {
            let x = s.rhs[col];
            let column = &cd[col * m2..(col + 1) * m2];
            for r in 0..m2 {
                s.dv[r] += column[r] * x;
            }
            for k in s.d_start[col]..s.d_start[col + 1] {
                s.sdv[s.active[s.d_rows[k]]] += s.d_values[k] * x;
            }
        }
    }
    if damping != 0.0 {
        for r in 0..m2 {
            s.dv[r] /= gamma;
            s.sdv[r] /= gamma;
        }
    }
    for &dof in &s.active {
        s.position[dof] = usize::MAX;
    }
    s.last_ddy = ddy;
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2-cycle (the pad touching and not touching, in turn) is found once
    /// it has repeated three periods; converging, diverging and snapping
    /// sequences (the residual growing by 8 % a step, as while the skin
    /// crosses a crest) are not cycles.
    #[test]
    fn continuation_cycles_are_found_and_nothing_else() {
        let mut watch = CycleWatch::EMPTY;
        let two = [7.564837124566873e-3, 6.395136116528454e-1];
        let found: Vec<Option<usize>> = (0..8).map(|k| watch.push(two[k % 2] * (1.0 + 1e-13 * k as f64))).collect();
        assert_eq!(found[..7], [None; 7]);
        assert_eq!(found[7], Some(2));
        for sequence in [
            (0..200).map(|k| 0.5f64.powi(k)).collect::<Vec<_>>(),
            (0..200).map(|k| 1.08f64.powi(k)).collect(),
            (0..200).map(|k| 1e-3 * (1.0 + 1e-6 * k as f64)).collect(),
            (0..200).map(|k| if k % 2 == 0 { 1.0 } else { 2.0 } * 0.99f64.powi(k)).collect(),
        ] {
            let mut watch = CycleWatch::EMPTY;
            assert!(sequence.iter().all(|&n| watch.push(n).is_none()));
        }
        // A period-5 cycle, as on the half-disc over the sharp sine.
        let five = [1.178e-2, 3.35e-3, 5.43e-4, 2.97e-4, 9.07e-4];
        let mut watch = CycleWatch::EMPTY;
        let first = (0..40).position(|k| watch.push(five[k % 5]).is_some());
        assert_eq!(first, Some(19));
    }
}
