//! A tactile scenario (the paper's section 2.4): the finger is pressed onto
//! the rigid surface (by a displacement of bone and nail, or by a normal
//! load), then the surface slides under it at constant velocity. The
//! apparent friction Ft/Fn along the slide is the reference profile
//! mu_RS(x), with x the finger's position on the surface (in the surface
//! template's coordinates: the finger starts at x = 0 and ends at x =
//! slide).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use haptex_core::num::Num;
use haptex_core::profile::FrictionProfile;
use serde::Serialize;

use crate::body::{Body, BodyError};
use crate::contact::{ContactLaw, ContactSet};
use crate::display::Display;
use crate::element::Formulation;
use crate::finger::{FingerError, FingerModel, Resolution};
use crate::finite_solver::{FiniteSettings, FiniteSolver};
use crate::mesh::Mesh;
use crate::solver::{ContactProblem, Drive, SolveError, Solver, SolverSettings, StepReport};
use crate::surface::{RigidSurface, SurfaceShape};

/// How the finger is pressed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Loading {
    /// Bone and nail moved down by this much from first touch, then held (mm).
    Indent(f64),
    /// A constant normal load on bone and nail (N per mm of finger width).
    Load(f64),
}

/// The body's kinematics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Kinematics {
    /// Small strain, linear visco-elastic tissue (the paper's model).
    #[default]
    Small,
    /// Finite strain: total Lagrangian, neo-Hookean tissue with the same
    /// moduli and Prony series ([`crate::finite_solver`]).
    Finite,
}

/// Everything that defines a simulation.
#[derive(Debug, Clone)]
pub struct Scenario {
    pub surface: SurfaceShape,
    pub model: FingerModel,
    pub resolution: Resolution,
    pub viscoelastic: bool,
    pub kinematics: Kinematics,
    pub loading: Loading,
    /// Duration of the press (s) and its number of steps.
    pub press_time_s: f64,
    pub press_steps: usize,
    /// Slide distance (mm) and velocity (mm/s).
    pub slide_mm: f64,
    pub velocity_mm_s: f64,
    /// Slide per step (mm).
    pub step_mm: f64,
    /// Skin-surface friction coefficient (the model file's if `None`).
    pub mu_skin: Option<f64>,
    /// Normal and tangential penalty (MPa per mm).
    pub penalty_mpa_per_mm: f64,
    /// Smoothed onset of the normal penalty (mm), see `ContactLaw::pressure`.
    pub smoothing_mm: f64,
    /// The 3D finger only: each skin face's contact points on `contact_parts`
    /// x `contact_parts` equal parts of it (1 to
    /// [`crate::solid3d::contact::MAX_CONTACT_PARTS`]), for surfaces whose
    /// crests pass between the points of whole faces
    /// ([`crate::solid3d::contact::ContactSurface::with_composite_rule`]).
    pub contact_parts: usize,
    /// Keep a full-field frame every this many slide steps (0: none besides
    /// the end of the press and the step nearest the feature).
    pub frame_every: usize,
    pub settings: SolverSettings,
    /// The surface is an electrovibration display with this electrode (the
    /// surface must then be flat; its friction is `mu_skin`, mu_HD).
    pub display: Option<Display>,
    /// Set (by the progress callback, or another thread) to stop the run
    /// after the step under way: [`run`] then returns
    /// [`SimulationError::Cancelled`]. Clones of the scenario share it.
    pub stop: Option<Arc<AtomicBool>>,
}

impl Scenario {
    /// The paper's scenario on `surface`: default finger, default mesh,
    /// visco-elastic, 0.25 mm indentation pressed in 0.1 s, 10 mm slide at
    /// 20 mm/s in steps of at most 0.1 mm (finer for narrow features).
    pub fn paper(surface: SurfaceShape) -> Self {
        let step_mm = default_step_mm(&surface);
        Self {
            surface,
            model: FingerModel::default_model(),
            resolution: Resolution::Default,
            viscoelastic: true,
            kinematics: Kinematics::Small,
            loading: Loading::Indent(0.25),
            press_time_s: 0.1,
            press_steps: 10,
            slide_mm: 10.0,
            velocity_mm_s: 20.0,
            step_mm,
            mu_skin: None,
            penalty_mpa_per_mm: 200.0,
            smoothing_mm: 2e-4,
            contact_parts: 1,
            frame_every: 0,
            settings: SolverSettings::default(),
            display: None,
            stop: None,
        }
    }

    /// Checks every setting against [`limits`] and the finger model (an
    /// indentation must stay within the pulp under the bone); the surface
    /// against its own limits. Errors name the setting.
    pub fn validate(&self) -> Result<(), SimulationError> {
        let invalid = |m: String| Err(SimulationError::Invalid(m));
        self.surface.validate().map_err(|e| SimulationError::Invalid(e.to_string()))?;
        self.model.validate_fields().map_err(|e| SimulationError::Finger(FingerError::Invalid(e)))?;
        let within = |name: &str, v: f64, (lo, hi): (f64, f64), unit: &str| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                invalid(format!(
                    "{name} = {}{unit} is outside the supported range {} .. {}{unit}",
                    Num(v),
                    Num(lo),
                    Num(hi)
                ))
            }
        };
        within("press time", self.press_time_s, limits::PRESS_TIME_S, " s")?;
        // A slide of exactly 0 is a press-only run (no friction profile).
        if self.slide_mm != 0.0 {
            within("slide", self.slide_mm, limits::SLIDE_MM, " mm")?;
        }
        within("velocity", self.velocity_mm_s, limits::VELOCITY_MM_S, " mm/s")?;
        within("penalty", self.penalty_mpa_per_mm, limits::PENALTY_MPA_PER_MM, " MPa/mm")?;
        if !(self.step_mm.is_finite() && self.step_mm > 0.0) {
            return invalid(format!("the slide step must be a positive length, got {} mm", Num(self.step_mm)));
        }
        let steps = if self.slide_mm == 0.0 { 0.0 } else { (self.slide_mm / self.step_mm).ceil() };
        if steps > limits::MAX_STEPS as f64 {
            return invalid(format!(
                "a slide of {} mm in steps of {} mm takes {} steps; at most {} are supported",
                Num(self.slide_mm),
                Num(self.step_mm),
                Num(steps),
                limits::MAX_STEPS
            ));
        }
        if self.press_steps == 0 || self.press_steps > limits::MAX_STEPS {
            return invalid(format!("the press needs 1 to {} steps, got {}", limits::MAX_STEPS, self.press_steps));
        }
        match self.loading {
            Loading::Indent(indent) => {
                let g = &self.model.geometry;
                let pulp = g.bone_center_height_mm - g.bone_half_height_mm;
                if !(indent.is_finite() && indent > 0.0 && indent < pulp) {
                    return invalid(format!(
                        "indentation = {} mm must be positive and less than the pulp under the bone ({} mm)",
                        Num(indent),
                        Num(pulp)
                    ));
                }
            }
            Loading::Load(load) => {
                if !(load.is_finite() && load > 0.0 && load <= limits::LOAD_N_PER_MM) {
                    return invalid(format!(
                        "load = {} N/mm must be positive and at most {} N/mm",
                        Num(load),
                        Num(limits::LOAD_N_PER_MM)
                    ));
                }
            }
        }
        if let Some(mu) = self.mu_skin {
            within("skin friction mu", mu, crate::finger::limits::MU_SKIN, "")?;
        }
        if self.frame_every > 0 && steps / self.frame_every as f64 > limits::MAX_FRAMES as f64 {
            return invalid(format!(
                "a frame every {} slide steps of {} keeps {} full-field frames in memory; at most {} are kept \
                 (for --vtk, a larger --vtk-every)",
                self.frame_every,
                Num(steps),
                Num((steps / self.frame_every as f64).ceil()),
                limits::MAX_FRAMES
            ));
        }
        if let Some(display) = &self.display {
            if self.surface != SurfaceShape::Flat {
                return invalid("a display is flat: the surface must be flat when a voltage is applied".into());
            }
            display.validate().map_err(|e| SimulationError::Invalid(e.to_string()))?;
            let mu = self.mu_skin.unwrap_or(self.model.contact.mu_skin);
            if let Some(vibration) = &display.vibration
                && vibration.mu_hd() != mu
            {
                return invalid(format!(
                    "the vibrating display's friction at rest, mu_HD = {}, must be the skin-display friction of the \
                     scenario, {}",
                    Num(vibration.mu_hd()),
                    Num(mu)
                ));
            }
        }
        let (x_min, x_max) = self.surface_range_mm();
        RigidSurface::template_segments(&self.surface, x_min, x_max)
            .map_err(|e| SimulationError::Invalid(e.to_string()))?;
        Ok(())
    }

    /// [`SimulationError::Cancelled`] once [`Scenario::stop`] is set.
    pub(crate) fn check_stop(&self) -> Result<(), SimulationError> {
        match &self.stop {
            Some(stop) if stop.load(Ordering::Relaxed) => Err(SimulationError::Cancelled),
            _ => Ok(()),
        }
    }

    /// The x range of the surface the finger can meet over the slide (mm).
    pub fn surface_range_mm(&self) -> (f64, f64) {
        let half = self.model.geometry.half_width_mm;
        (-half - 2.0, half + self.slide_mm + 2.0)
    }

    /// The number of equal slide steps (at most `step_mm` each); 0 for a
    /// press-only run.
    pub fn slide_steps(&self) -> Result<usize, SimulationError> {
        self.validate()?;
        if self.slide_mm == 0.0 {
            return Ok(0);
        }
        Ok((self.slide_mm / self.step_mm).ceil() as usize)
    }
}

/// The accepted ranges of the scenario's settings (see
/// [`Scenario::validate`]): beyond any experiment, and bounding the time,
/// the memory and the magnitudes a run can reach.
pub mod limits {
    /// Most press or slide steps.
    pub const MAX_STEPS: usize = 1_000_000;
    /// Most full-field frames kept (~0.3 MB each at the finest mesh).
    pub const MAX_FRAMES: usize = 1000;
    pub const PRESS_TIME_S: (f64, f64) = (1e-6, 1e6);
    pub const SLIDE_MM: (f64, f64) = (1e-3, 1e4);
    pub const VELOCITY_MM_S: (f64, f64) = (1e-3, 1e6);
    pub const PENALTY_MPA_PER_MM: (f64, f64) = (1e-3, 1e6);
    /// Largest normal load, N per mm of finger width.
    pub const LOAD_N_PER_MM: f64 = 100.0;
}

/// The default slide step: 0.1 mm, or a tenth of the feature width if
/// narrower. (On the bump x0 = 5, r_w = 1.5, r_h = 0.3 the profile with
/// 0.1 mm steps differs from the one with 0.025 mm steps by 0.18% RMS;
/// docs/fem.md, "Convergence".)
pub fn default_step_mm(surface: &SurfaceShape) -> f64 {
    match surface {
        SurfaceShape::Bump { width, .. } | SurfaceShape::Edge { width, .. } | SurfaceShape::Sine { width, .. } => {
            (0.1 * width).min(0.1)
        }
        _ => 0.1,
    }
}

/// A simulation could not be run.
#[derive(Debug, thiserror::Error)]
pub enum SimulationError {
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Finger(#[from] FingerError),
    #[error(transparent)]
    Body(#[from] BodyError),
    #[error(transparent)]
    Solve(#[from] SolveError),
    /// The run was stopped through [`Scenario::stop`].
    #[error("the simulation was cancelled")]
    Cancelled,
    #[error("the finger lost contact with the surface at x = {x_mm:.3} mm (t = {t_s:.4} s): Ft/Fn is undefined there")]
    NoContact { x_mm: f64, t_s: f64 },
    /// The 3D finger's mesh.
    #[error("the 3D fingertip cannot be meshed: {0}")]
    Fingertip(#[from] crate::solid3d::fingertip::FingertipError),
    #[error("the 3D finger: {0}")]
    Body3(#[from] crate::solid3d::body::BodyError),
    #[error("the 3D finger's stiffness could not be factorized: {0}")]
    Factor(#[from] crate::linalg::FactorError),
    #[error("the 3D finger at finite strain: {0}")]
    Finite3(#[from] crate::solid3d::finite_body::FiniteBodyError),
    #[error("the 3D finger at x = {x_mm:.3} mm (t = {t_s:.4} s): {source}{}", unresolved.map_or(String::new(), |u| format!("; {u}")))]
    Equilibrium3 {
        x_mm: f64,
        t_s: f64,
        source: crate::solid3d::finite_contact::FiniteContactError,
        /// Where the surface had reached into the skin further than the
        /// mesh resolves before the step failed (the likely cause).
        unresolved: Option<crate::solid3d::slide::Unresolved>,
    },
    #[error(
        "the 3D finger touches the surface beyond its contact region (skin up to {z_cut_mm:.2} mm above the pad) at \
         x = {x_mm:.3} mm (t = {t_s:.4} s): the surface's relief or the indentation is too large for the 3D model"
    )]
    ContactBeyondRegion { x_mm: f64, t_s: f64, z_cut_mm: f64 },
}

/// One row of the force history (forces per mm of finger width).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HistoryRow {
    pub t_s: f64,
    pub slide_mm: f64,
    /// Normal force the finger applies (N/mm): the contact force on it (up)
    /// less the electrostatic attraction, which in equilibrium is the bone
    /// and nail reaction, what a force plate under the surface measures.
    pub fn_n: f64,
    /// Friction force on the finger, opposing its motion over the surface, N/mm.
    pub ft_n: f64,
    /// Length of skin in contact, mm.
    pub contact_mm: f64,
    /// Display voltage at this step (V RMS; 0 on a passive surface).
    pub voltage_v: f64,
    /// Electrostatic attraction on the finger (N/mm; 0 on a passive surface).
    pub fe_n: f64,
    /// The part of `fe_n` on skin in contact (N/mm): eq. (3) on the contact
    /// length; the rest pulls skin near the contact's edges.
    pub fe_contact_n: f64,
    /// Vertical displacement of bone and nail, mm (negative: pressed down).
    pub drive_y_mm: f64,
    /// Reaction on bone and nail from the tissue's stresses, N/mm (x, y).
    pub reaction_n: [f64; 2],
    pub iterations: usize,
    pub cuts: u32,
}

/// A full-field snapshot.
#[derive(Debug, Clone)]
pub struct Frame {
    pub t_s: f64,
    pub slide_mm: f64,
    /// Global displacement vector (2 per node), mm.
    pub displacement: Vec<f64>,
    /// Element stress (xx, yy, zz, xy), MPa, averaged over Gauss points.
    pub stress: Vec<[f64; 4]>,
    /// The contact points of the skin (every Gauss point of the candidate
    /// region, in contact or not).
    pub contact: Vec<ContactPoint>,
}

/// A contact point of a [`Frame`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ContactPoint {
    /// Current position (lab frame), mm.
    pub position_mm: [f64; 2],
    /// Integration weight (reference length), mm.
    pub weight_mm: f64,
    /// Normal pressure and tangential traction, MPa (0 out of contact).
    pub pressure_mpa: f64,
    pub traction_mpa: f64,
}

impl Frame {
    /// The contact half-width (mm) as the CalculiX reference measures it
    /// (validation/calculix/extract.py): twice the square root of the
    /// pressure-weighted second moment of x about the pressure centroid,
    /// which is the half-width a for Hertz's elliptical pressure (whose
    /// second moment is a^2/4). `None` without contact.
    pub fn contact_half_width_mm(&self) -> Option<f64> {
        let forces: Vec<(f64, f64)> =
            self.contact.iter().map(|c| (c.position_mm[0], c.pressure_mpa * c.weight_mm)).collect();
        let total: f64 = forces.iter().map(|(_, f)| f).sum();
        if total <= 0.0 {
            return None;
        }
        let centre = forces.iter().map(|(x, f)| x * f).sum::<f64>() / total;
        Some(2.0 * (forces.iter().map(|(x, f)| (x - centre).powi(2) * f).sum::<f64>() / total).sqrt())
    }
}

/// Size and effort of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Statistics {
    pub nodes: usize,
    pub elements: usize,
    pub free_dofs: usize,
    pub contact_dofs: usize,
    pub factor_nnz: usize,
    pub steps: usize,
    pub newton_iterations: usize,
    pub step_cuts: u32,
    pub wall_time_s: f64,
}

/// What a simulation produces.
#[derive(Debug, Clone)]
pub struct SimulationResult {
    pub history: Vec<HistoryRow>,
    /// Ft/Fn against the finger's position on the surface, over the slide
    /// (`None` for a press-only run, `slide_mm` = 0: the press is in
    /// `history`).
    pub profile: Option<FrictionProfile>,
    /// Snapshots: after the press first, then every `frame_every` steps and
    /// the step where the finger reaches the feature.
    pub frames: Vec<Frame>,
    /// Index in `frames` of the snapshot at the feature, if any.
    pub feature_frame: Option<usize>,
    pub statistics: Statistics,
    pub mesh: Mesh,
    /// The surface's vertical placement (mm) and polyline for drawing.
    pub lift_mm: f64,
    pub surface: RigidSurface,
}

/// Progress of a running simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    pub step: usize,
    pub total_steps: usize,
    pub t_s: f64,
    pub slide_mm: f64,
}

/// Builds the contact problem of a scenario.
pub fn build_problem(scenario: &Scenario) -> Result<(ContactProblem, f64), SimulationError> {
    scenario.validate()?;
    let finger = scenario.model.mesh(scenario.resolution)?;
    let (x_min, x_max) = scenario.surface_range_mm();
    let surface =
        RigidSurface::new(&scenario.surface, x_min, x_max).map_err(|e| SimulationError::Invalid(e.to_string()))?;
    let contact = ContactSet::new(&finger.mesh.nodes, &finger.contact_segments, 4);
    // Lift the surface so that it just touches the undeformed finger.
    let lift_mm = contact
        .point_positions(&vec![0.0; 2 * contact.n_nodes()])
        .iter()
        .map(|p| p[1] - surface.height(p[0]))
        .fold(f64::INFINITY, f64::min);
    let mu = scenario.mu_skin.unwrap_or(scenario.model.contact.mu_skin);
    let law = ContactLaw {
        penalty_normal: scenario.penalty_mpa_per_mm,
        penalty_tangential: scenario.penalty_mpa_per_mm,
        mu,
        smoothing_mm: scenario.smoothing_mm,
        geometric_tangent: true,
        electrostatic: None,
    };
    let body = Body::new(finger.mesh, scenario.model.subdomain_models(scenario.viscoelastic), Formulation::BBar)?;
    let problem = ContactProblem {
        body,
        driven_nodes: finger.driven_nodes,
        contact,
        other_surface_nodes: finger.other_surface_nodes,
        surface,
        law,
        display: scenario.display.clone(),
    };
    Ok((problem, lift_mm))
}

/// Runs a scenario; `progress` is called after every step.
pub fn run(scenario: &Scenario, progress: &mut dyn FnMut(Progress)) -> Result<SimulationResult, SimulationError> {
    let started = Instant::now();
    let (problem, lift_mm) = build_problem(scenario)?;
    let small = Solver::new(problem, scenario.settings, lift_mm)?;
    let mut solver = match scenario.kinematics {
        Kinematics::Small => AnySolver::Small(small),
        Kinematics::Finite => AnySolver::Finite(Box::new(FiniteSolver::new(small, FiniteSettings::default()))),
    };
    let slide_steps = scenario.slide_steps()?;
    // Equal steps that end exactly at the slide length (so every step has
    // the same time step and shares one set of operators).
    let step_mm = if slide_steps == 0 { 0.0 } else { scenario.slide_mm / slide_steps as f64 };
    let total_steps = scenario.press_steps + slide_steps;
    let mut history = Vec::with_capacity(total_steps + 1);
    let mut frames = Vec::new();
    let dt_press = scenario.press_time_s / scenario.press_steps as f64;
    let record = |solver: &mut AnySolver, report: &StepReport| HistoryRow {
        t_s: report.t_s,
        slide_mm: report.slide_mm,
        fn_n: report.totals.force[1] - report.totals.electrostatic_n,
        ft_n: -report.totals.force[0],
        contact_mm: report.totals.contact_mm,
        voltage_v: solver.state().problem.display.as_ref().map_or(0.0, |d| d.voltage_at(report.slide_mm)),
        fe_n: report.totals.electrostatic_n,
        fe_contact_n: report.totals.electrostatic_contact_n,
        drive_y_mm: report.drive_mm[1],
        reaction_n: solver.driven_reaction(),
        iterations: report.iterations,
        cuts: report.cuts,
    };
    // Press. Under load control the finger is first brought into contact
    // by a small displacement (1% of the pad spacing), then the load ramps.
    match scenario.loading {
        Loading::Indent(indent) => {
            for k in 1..=scenario.press_steps {
                let y = -indent * k as f64 / scenario.press_steps as f64;
                let report = solver.advance(dt_press, 0.0, Drive::Displacement([0.0, y]))?;
                history.push(record(&mut solver, &report));
                progress(Progress { step: k, total_steps, t_s: report.t_s, slide_mm: 0.0 });
                scenario.check_stop()?;
            }
        }
        Loading::Load(load) => {
            let touch = 0.01 * scenario.resolution.parameters().pad_spacing_mm;
            solver.advance(0.0, 0.0, Drive::Displacement([0.0, -touch]))?;
            for k in 1..=scenario.press_steps {
                let fy = load * k as f64 / scenario.press_steps as f64;
                let report = solver.advance(dt_press, 0.0, Drive::Load { x_mm: 0.0, fy_n: fy })?;
                history.push(record(&mut solver, &report));
                progress(Progress { step: k, total_steps, t_s: report.t_s, slide_mm: 0.0 });
                scenario.check_stop()?;
            }
        }
    }
    frames.push(frame(&solver));
    // Slide.
    let dt_slide = step_mm / scenario.velocity_mm_s;
    let feature_x = feature_position(&scenario.surface);
    let mut x = Vec::with_capacity(slide_steps);
    let mut ft = Vec::with_capacity(slide_steps);
    let mut fn_n = Vec::with_capacity(slide_steps);
    let mut feature_frame = None;
    for k in 1..=slide_steps {
        let slide = scenario.slide_mm * k as f64 / slide_steps as f64;
        let dt = dt_slide;
        let drive = match scenario.loading {
            Loading::Indent(indent) => Drive::Displacement([0.0, -indent]),
            Loading::Load(load) => Drive::Load { x_mm: 0.0, fy_n: load },
        };
        let report = solver.advance(dt, slide, drive)?;
        let row = record(&mut solver, &report);
        if row.fn_n.is_nan() || row.fn_n <= 1e-12 {
            return Err(SimulationError::NoContact { x_mm: slide, t_s: row.t_s });
        }
        x.push(slide);
        ft.push(row.ft_n);
        fn_n.push(row.fn_n);
        history.push(row);
        let at_feature = feature_frame.is_none() && feature_x.is_some_and(|f| slide >= f);
        if at_feature || (scenario.frame_every > 0 && k % scenario.frame_every == 0) {
            if at_feature {
                feature_frame = Some(frames.len());
            }
            frames.push(frame(&solver));
        }
        progress(Progress { step: scenario.press_steps + k, total_steps, t_s: report.t_s, slide_mm: slide });
        scenario.check_stop()?;
    }
    if frames.last().is_some_and(|f| f.slide_mm != solver.state().slide_mm) {
        frames.push(frame(&solver));
    }
    let profile = slide_profile(x, &ft, fn_n)?;
    if let AnySolver::Finite(f) = &solver
        && std::env::var_os("HAPTEX_PROFILE").is_some()
    {
        eprintln!("finite-strain profile: {} outer iterations; {}", f.outer_iterations, f.profile);
    }
    let solver = solver.state();
    let (free_dofs, factor_nnz) = solver.sizes();
    let statistics = Statistics {
        nodes: solver.problem.body.mesh.n_nodes(),
        elements: solver.problem.body.mesh.n_elements(),
        free_dofs,
        contact_dofs: 2 * solver.problem.contact.n_nodes(),
        factor_nnz,
        steps: solver.steps,
        newton_iterations: solver.total_iterations,
        step_cuts: history.iter().map(|r| r.cuts).sum(),
        wall_time_s: started.elapsed().as_secs_f64(),
    };
    Ok(SimulationResult {
        history,
        profile,
        frames,
        feature_frame,
        statistics,
        mesh: solver.problem.body.mesh.clone(),
        lift_mm,
        surface: solver.problem.surface.clone(),
    })
}

/// The profile of a slide's positions and forces (`None` for a press
/// only, no positions).
pub(crate) fn slide_profile(
    x: Vec<f64>,
    ft: &[f64],
    fn_n: Vec<f64>,
) -> Result<Option<FrictionProfile>, SimulationError> {
    if x.is_empty() {
        return Ok(None);
    }
    FrictionProfile::from_forces(x, ft, fn_n)
        .map(Some)
        .map_err(|e| SimulationError::Invalid(format!("the computed profile is invalid: {e}")))
}

fn frame(solver: &AnySolver) -> Frame {
    let state = solver.state();
    let body = &state.problem.body;
    let stress = (0..body.mesh.n_elements())
        .map(|e| {
            if body.deformable_elements().binary_search(&e).is_ok() {
                match solver {
                    AnySolver::Small(_) => body.element_stress(e, &state.u),
                    AnySolver::Finite(f) => f.body_state.element_stress(body, e, &state.u),
                }
            } else {
                [0.0; 4]
            }
        })
        .collect();
    let contact_set = &state.problem.contact;
    let u_s: Vec<f64> = contact_set.nodes.iter().flat_map(|&n| [state.u[2 * n], state.u[2 * n + 1]]).collect();
    let contact = contact_set
        .pressure_profile(&u_s)
        .into_iter()
        .zip(contact_set.point_weights())
        .map(|((position_mm, pressure_mpa, traction_mpa), weight_mm)| ContactPoint {
            position_mm,
            weight_mm,
            pressure_mpa,
            traction_mpa,
        })
        .collect();
    Frame { t_s: state.t_s, slide_mm: state.slide_mm, displacement: state.u.clone(), stress, contact }
}

/// The solver of the scenario's kinematics (one per run: the size of the
/// unboxed variant does not matter).
#[allow(clippy::large_enum_variant)]
enum AnySolver {
    Small(Solver),
    Finite(Box<FiniteSolver>),
}

impl AnySolver {
    fn advance(&mut self, dt_s: f64, slide_mm: f64, drive: Drive) -> Result<StepReport, SolveError> {
        match self {
            Self::Small(s) => s.advance(dt_s, slide_mm, drive),
            Self::Finite(s) => s.advance(dt_s, slide_mm, drive),
        }
    }

    fn driven_reaction(&mut self) -> [f64; 2] {
        match self {
            Self::Small(s) => s.driven_reaction(),
            Self::Finite(s) => s.driven_reaction(),
        }
    }

    /// The committed state (displacement, time, slide, problem).
    fn state(&self) -> &Solver {
        match self {
            Self::Small(s) => s,
            Self::Finite(s) => &s.inner,
        }
    }
}

/// Where the finger is over the feature's characteristic point.
fn feature_position(surface: &SurfaceShape) -> Option<f64> {
    match surface {
        SurfaceShape::Bump { x0, .. } | SurfaceShape::Edge { x0, .. } | SurfaceShape::Sine { x0, .. } => Some(*x0),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stop flag set by the progress callback ends the run after that
    /// step, with `Cancelled`; a clone of the scenario shares the flag.
    #[test]
    fn stop_flag_cancels_after_the_step() {
        let stop = Arc::new(AtomicBool::new(false));
        let mut scenario = Scenario::paper(SurfaceShape::Flat);
        scenario.slide_mm = 0.0;
        scenario.stop = Some(stop.clone());
        let scenario = scenario.clone();
        let mut steps = Vec::new();
        let result = run(&scenario, &mut |p| {
            steps.push(p.step);
            if p.step == 3 {
                stop.store(true, Ordering::Relaxed);
            }
        });
        assert!(matches!(result, Err(SimulationError::Cancelled)), "{result:?}");
        assert_eq!(steps, [1, 2, 3]);
    }
}
