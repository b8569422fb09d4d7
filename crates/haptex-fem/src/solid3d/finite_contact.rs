//! The contact equilibrium of the finite-strain 3D body (issue 39): the
//! 2D model's outer iteration around the condensed contact solve
//! (crate::finite_solver, one dimension up), so that the finite-strain
//! finger keeps the small-strain slide's contact Newton, continuation and
//! step cutting ([`super::condensed`]).
//!
//! With K an SPD stiffness the condensation is factorized with and f_int
//! the finite-strain internal forces ([`FiniteBody3::internal_forces`]),
//! an outer iteration maps the iterate x to the solution u of the linear
//! body with contact under the load
//!
//! ```text
//!   K u = K x - f_int(x) + P F(u)     (free unknowns; prescribed at their values),
//! ```
//!
//! solved by [`Condensation::equilibrium`]. Its fixed point satisfies
//! f_int(u) = P F(u), the full nonlinear equilibrium on every free DOF,
//! whatever K is; K only sets the rate, |I - K^-1 K_T| where contact does
//! not dominate. K is the body's tangent stiffness ([`FiniteBody3::tangent`],
//! without the contact), taken at the first iterate of a step of a new
//! size (the caller invalidates the [`Operator`] then) and again whenever
//! an outer iteration contracts the residual by less than
//! [`REBUILD_CONTRACTION`]; where it is not positive definite, the
//! small-strain stiffness of the step. (With the small-strain K throughout
//! the shipped finger's slide converged by a factor of only 0.6-0.7 an
//! iteration, and the half-disc's slipping pad by an oscillation that grew
//! 4% an iteration without Anderson's mixing.) Anderson acceleration of
//! depth [`ANDERSON_DEPTH`] (Walker & Ni 2011), restarted when the residual
//! grows tenfold or K is rebuilt, speeds it up. Converged on the true
//! residual f_int(u) - P F(u) over the free DOFs, within the contact
//! Newton's relative tolerance of the largest nodal contact force (or its
//! floor); the contact Newton inside runs to [`INNER_FORCING`] of its
//! tolerances.

use super::condensed::{Condensation, EquilibriumError, LoadControl, NewtonSettings, PointForce, PointMode};
use super::contact::ContactSurface;
use super::finite_body::FiniteBody3;
use crate::assembly::{PRESCRIBED, Pattern, free_entries};
use crate::finite_solver::Anderson;
use crate::linalg::symmetric_matvec_add;

/// Outer iterations before the equilibrium is given up (the step is then
/// cut, as after a failed contact Newton).
pub const MAX_OUTER_ITERATIONS: usize = 60;

/// Iterates Anderson's acceleration mixes.
pub const ANDERSON_DEPTH: usize = 5;

/// An outer iteration that leaves more than this fraction of the last
/// residual rebuilds K at its iterate.
pub const REBUILD_CONTRACTION: f64 = 0.5;

/// The stiffness K the condensation holds for the outer iteration, kept
/// across calls: its values, and whether it must be rebuilt at the next
/// call's first iterate.
#[derive(Debug, Clone, Default)]
pub struct Operator {
    values: Vec<f64>,
    /// Under load control, the free unknowns' load per mm of the drive.
    per_mm: Vec<f64>,
    fresh: bool,
}

impl Operator {
    /// An operator to be built at the first call.
    pub fn new() -> Self {
        Self::default()
    }

    /// Makes the next call rebuild K (at a new step, or after the
    /// condensation was factorized with another matrix).
    pub fn invalidate(&mut self) {
        self.fresh = false;
    }
}

/// The contact Newton's tolerances inside an outer iteration, as a
/// fraction of the outer ones: the outer residual cannot fall below the
/// inner solve's (at the fixed point the true residual is the inner one).
pub const INNER_FORCING: f64 = 0.1;

/// Why the finite-strain equilibrium was not found.
#[derive(Debug, thiserror::Error)]
pub enum FiniteContactError {
    #[error(transparent)]
    Contact(#[from] EquilibriumError),
    #[error("element {element} of the finite-strain body is {source}")]
    Inverted { element: usize, source: crate::finite_element::Inverted },
    #[error(
        "the finite-strain equilibrium was not reached in {iterations} outer iterations (largest residual {residual_n:.3e} N)"
    )]
    NoConvergence { iterations: usize, residual_n: f64 },
    #[error("the stiffness could not be factorized: {0}")]
    Factor(#[from] crate::linalg::FactorError),
}

/// The equilibrium of `finite` with the contact of `surface` (points as
/// [`Condensation::equilibrium`] takes them); `condensation` is factorized
/// with `operator`'s K (built here), or with the small-strain stiffness
/// `small_k` on `pattern` over the free unknowns `free` where the tangent
/// is not positive definite. `u` holds the prescribed values and a start
/// on entry, the solution on return. No external forces besides the
/// contact's. Under load control (`load`: the drive's global DOFs, which
/// move together, and the control with the small-strain stiffness's load
/// per mm of the drive) the drive is an unknown of each contact solve, with
/// the operator's load per mm of it (the tangent's, -K_fp e); its total
/// change is returned in the control's `change_mm`. Returns the contact
/// Newton iterations over all outer iterations.
#[allow(clippy::too_many_arguments)]
pub fn equilibrium(
    finite: &mut FiniteBody3,
    pattern: &Pattern,
    small_k: &[f64],
    free: &[usize],
    condensation: &mut Condensation,
    operator: &mut Operator,
    u: &mut [f64],
    surface: &ContactSurface,
    point: &mut dyn FnMut(usize, [f64; 3], PointMode) -> PointForce,
    stick_predictor: bool,
    settings: &NewtonSettings,
    mut load: Option<(&[usize], &mut LoadControl<'_>)>,
) -> Result<usize, FiniteContactError> {
    let n_free = pattern.n;
    // A unit move of the drive (global), for the tangent's load per mm.
    let unit_drive = load.as_ref().map(|(driven, _)| {
        let mut e = vec![0.0; u.len()];
        driven.iter().for_each(|&d| e[d] = 1.0);
        e
    });
    let small_per_mm: Vec<f64> = load.as_ref().map_or(Vec::new(), |(_, c)| c.per_mm.to_vec());
    let free_values = |x: &[f64]| free_entries(free, n_free, |g| x[g]);
    let inverted = |(element, source)| FiniteContactError::Inverted { element, source };
    // K at x: the tangent, or the small-strain stiffness where the
    // tangent is not positive definite; under load control, its load per
    // mm of the drive.
    let rebuild = |finite: &mut FiniteBody3,
                   condensation: &mut Condensation,
                   x: &[f64],
                   operator: &mut Operator|
     -> Result<(), FiniteContactError> {
        // Not fresh until built: a rebuild that fails (an element inverted
        // at x) leaves the operator to be rebuilt at the next call, which
        // would otherwise find its values cleared.
        operator.fresh = false;
        operator.values.clear();
        operator.per_mm.clear();
        match &unit_drive {
            Some(e) => {
                let (k, per_mm) = finite.tangent_and_drive_load(x, e).map_err(inverted)?;
                operator.values.extend_from_slice(k);
                operator.per_mm = per_mm;
            }
            None => operator.values.extend_from_slice(finite.tangent(x).map_err(inverted)?),
        }
        if condensation.factorize(&operator.values).is_err() {
            operator.values.clear();
            operator.values.extend_from_slice(small_k);
            operator.per_mm.clone_from(&small_per_mm);
            condensation.factorize(&operator.values)?;
        }
        operator.fresh = true;
        Ok(())
    };
    let inner_settings = NewtonSettings {
        relative_tolerance: INNER_FORCING * settings.relative_tolerance,
        increment_tolerance_mm: INNER_FORCING * settings.increment_tolerance_mm,
        ..*settings
    };
    let mut newton_iterations = 0;
    let mut x = u.to_vec();
    let mut anderson = Anderson::new(ANDERSON_DEPTH, n_free);
    let mut last_residual = f64::INFINITY;
    if !operator.fresh || (load.is_some() && operator.per_mm.len() != n_free) {
        rebuild(finite, condensation, &x, operator)?;
    }
    // The internal forces at the last inner solution.
    let mut last_forces: Option<(Vec<f64>, Vec<f64>)> = None;
    for outer in 0..MAX_OUTER_ITERATIONS {
        // The load K x - f_int(x) on the free unknowns (f_int(x) from the
        // last residual's where x is that iterate: Anderson's first step
        // after a restart).
        let f = match last_forces.take() {
            Some((at, f)) if at == x => f,
            _ => finite.internal_forces(&x).map_err(inverted)?,
        };
        let mut rhs = vec![0.0; n_free];
        symmetric_matvec_add(pattern, &operator.values, &free_values(&x), &mut rhs);
        for (g, &d) in free.iter().enumerate() {
            if d != PRESCRIBED {
                rhs[d] -= f[g];
            }
        }
        let mut next = x.clone();
        let mut control = load.as_ref().map(|(_, c)| LoadControl {
            per_mm: &operator.per_mm,
            normal_force_n: c.normal_force_n,
            change_mm: 0.0,
        });
        let inner = condensation.equilibrium(
            &rhs,
            free,
            &mut next,
            surface,
            point,
            stick_predictor && outer == 0,
            &inner_settings,
            control.as_mut(),
        )?;
        newton_iterations += inner.iterations;
        if let (Some(c), Some((driven, _))) = (control, load.as_ref()) {
            driven.iter().for_each(|&d| next[d] += c.change_mm);
        }
        // The true residual at the new iterate.
        let f = finite.internal_forces(&next).map_err(inverted)?;
        let mut contact = vec![0.0; x.len()];
        for (q, p) in surface.points.iter().enumerate() {
            if let Some((force, _)) = point(q, p.displacement(&next), PointMode::Exact) {
                for a in 0..4 {
                    for d in 0..3 {
                        contact[3 * p.nodes[a] + d] += p.weight * p.shape[a] * force[d];
                    }
                }
            }
        }
        let scale = contact.iter().fold(settings.force_floor_n, |m, v| m.max(v.abs()));
        let residual = free
            .iter()
            .enumerate()
            .filter(|&(_, &d)| d != PRESCRIBED)
            .fold(0.0f64, |m, (g, _)| m.max((contact[g] - f[g]).abs()));
        if std::env::var_os("HAPTEX_DEBUG").is_some() {
            eprintln!("outer {outer}: residual {residual:.3e} N of {scale:.3e}, inner {}", inner.iterations);
        }
        last_forces = Some((next.clone(), f));
        if residual <= settings.relative_tolerance * scale {
            if let Some((driven, c)) = load.as_mut() {
                c.change_mm = driven.first().map_or(0.0, |&d| next[d] - u[d]);
            }
            u.copy_from_slice(&next);
            return Ok(newton_iterations);
        }
        // Anderson's mix of the map G(x) = next on the free unknowns.
        if residual > 10.0 * last_residual {
            anderson.reset();
        }
        let slow = residual > REBUILD_CONTRACTION * last_residual;
        last_residual = residual;
        let mut mixed = free_values(&x);
        anderson.step(&mut mixed, &free_values(&next));
        for (g, &d) in free.iter().enumerate() {
            x[g] = if d == PRESCRIBED { next[g] } else { mixed[d] };
        }
        if slow && outer > 0 {
            rebuild(finite, condensation, &x, operator)?;
            anderson.reset();
        }
    }
    Err(FiniteContactError::NoConvergence { iterations: MAX_OUTER_ITERATIONS, residual_n: last_residual })
}
