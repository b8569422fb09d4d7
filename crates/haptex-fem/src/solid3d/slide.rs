//! The 3D finger pad's tactile scenario (the 2D model's, crate::scenario,
//! one dimension up): the layered visco-elastic fingertip
//! ([`super::fingertip`]) is pressed onto a rigid surface by moving its
//! bone down, then slides over it at constant velocity in any direction of
//! the surface's plane, with Coulomb friction in both tangential
//! directions.
//!
//! Frames: the finger's x runs across it (the 2D model's plane), y along
//! it. The surface's frame is the finger's at the start: the pad's lowest
//! point over the surface's origin, the finger pointing along the
//! surface's y (as a finger on a screen held upright). A direction theta
//! moves the finger by s = L (cos theta, sin theta) over the surface; the
//! 2D model's surfaces vary along the surface's x and are extruded along
//! its y ([`HeightField`]), so theta = 0 is the 2D model's slide, across
//! the ridges, and theta = 90 degrees runs along them.
//!
//! As in 2D the finger stays in place and the surface moves under it: a
//! skin point at x (finger frame) sits over the surface point x + s. Each
//! step is linear in the body (the Prony recursion at that step's size)
//! and non-linear in the contact, which is solved on the contact region's
//! unknowns alone ([`Condensation`]); K(dt) is factorized once per step
//! size (twice in a run: press and slide).
//!
//! The contact region is the skin whose height above the pad's lowest
//! point is at most 1.5 (indentation + the surface's relief) + 0.3 mm;
//! every step checks that no skin outside it touches the surface (an
//! error if it does, never a silent penetration).
//!
//! On a display (the scenario's [`crate::display::Display`], a flat
//! surface) the voltage at the finger's position U(x_f), x_f the distance
//! travelled, attracts the skin of the contact region with eq. (3)'s
//! traction over the gap ([`crate::contact::Electrostatic`], as in 2D):
//! on the skin in contact that is eq. (3) on the real contact area, and
//! the skin near the patch's edge is attracted across its gap. Skin
//! beyond the region, at least 0.3 mm from the display, is left out:
//! there the traction is below 3 x 10^-5 of the contact's with the
//! paper's layers. The friction law acts on the total contact pressure,
//! and the normal force Fn reported is the net force the finger applies
//! (the contact's less the attraction). A vibrating display lowers the
//! friction coefficient to mu_HD rho(a(x_f)).

use std::time::Instant;

use std::sync::Arc;

use haptex_core::height::HeightMap;
use haptex_core::profile::FrictionProfile;
use serde::Serialize;

use super::body::ViscoelasticBody;
use super::condensed::{Condensation, LoadControl, NewtonSettings, PointForce, PointMode};
use super::contact::ContactSurface;
use super::fingertip::{self, FingertipSpec};
use super::finite_body::FiniteBody3;
use super::finite_contact::{self, FiniteContactError};
use super::finite_hex8::Volumetric;
use super::friction::{Committed, FrictionLaw};
use super::hex8::Formulation;
use super::surface::{HeightField, MapSurface};
use crate::contact::Electrostatic;
use crate::material::Material;
use crate::scenario::{Kinematics, Loading, Progress, Scenario, SimulationError, Statistics};
use crate::surface::SurfaceShape;

/// One row of the 3D force history (forces in N).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Row3 {
    pub t_s: f64,
    /// Distance travelled along the slide direction (mm).
    pub slide_mm: f64,
    /// Normal force the finger applies (N).
    pub fn_n: f64,
    /// Friction force on the finger along its motion, positive opposing
    /// it (N).
    pub ft_n: f64,
    /// Tangential force on the finger across its motion, positive towards
    /// the motion's left (N).
    pub ft_lateral_n: f64,
    /// Area of skin in contact (mm^2, reference area of the contact points
    /// with pressure).
    pub contact_area_mm2: f64,
    /// The contact's extent along the motion (mm, current positions of
    /// the contact points with pressure).
    pub contact_length_mm: f64,
    /// A display's electrostatic attraction on the finger (N, > 0 pulling
    /// it onto the display; 0 on a passive surface); `fn_n` is the net
    /// normal force, the contact's less this.
    pub fe_n: f64,
    /// The part of `fe_n` on skin in contact (N): eq. (3) on the real
    /// contact area; the rest pulls skin near the patch's edge.
    pub fe_contact_n: f64,
    /// Vertical displacement of the bone (mm, negative: pressed down).
    pub drive_z_mm: f64,
    pub iterations: usize,
    /// How far the surface reaches into the skin of the contact region
    /// (mm, vertically), sampled every [`REACH_SPACING_MM`] over its faces,
    /// between and beside their contact points: the penalty's penetration
    /// where the mesh resolves the surface, more where features narrower
    /// than the contact points' spacing pass between them, which no
    /// contact point feels (see [`Simulation3::reach_limit_mm`]); 0 where
    /// the surface is nowhere above the skin.
    pub surface_reach_mm: f64,
}

/// A contact point of a [`Patch`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PatchPoint {
    /// Current position in the finger's frame (mm).
    pub position_mm: [f64; 3],
    /// Reference area (mm^2).
    pub weight_mm2: f64,
    /// Pressure and tangential traction (MPa; 0 out of contact).
    pub pressure_mpa: f64,
    pub traction_mpa: [f64; 3],
    pub sticking: bool,
}

/// The contact region's state at one step.
#[derive(Debug, Clone, PartialEq)]
pub struct Patch {
    pub t_s: f64,
    pub slide_mm: f64,
    /// The contact points, [`Patch::per_face`] of each face in turn.
    pub points: Vec<PatchPoint>,
    pub per_face: usize,
    /// Each face's corners at their current place (mm).
    pub faces: Vec<[[f64; 3]; 4]>,
}

/// What a 3D simulation produces.
#[derive(Debug, Clone)]
pub struct Simulation3 {
    pub history: Vec<Row3>,
    /// Ft/Fn against the distance travelled (None for a press only).
    pub profile: Option<FrictionProfile>,
    /// The contact region after the press, where the finger's centre
    /// reaches the feature (if it does), and at the end.
    pub patches: Vec<Patch>,
    pub direction_deg: f64,
    pub statistics: Statistics,
    /// The finger's mesh (reference positions), each element's layer, the
    /// nodes the bone drives, and the skin faces of the contact region
    /// (the faces of [`Frame3`]'s per-face fields).
    pub mesh: super::mesh::Mesh3,
    pub element_layer: Vec<usize>,
    pub driven_nodes: Vec<usize>,
    pub contact_faces: Vec<[usize; 4]>,
    /// Full-field snapshots when the scenario asks for them
    /// ([`Scenario::frame_every`] > 0): after the press, every
    /// `frame_every` slide steps, where the finger reaches the feature, and
    /// at the end.
    pub frames: Vec<Frame3>,
    /// The reach of the surface into the skin ([`Row3::surface_reach_mm`])
    /// beyond which the mesh does not resolve it: half the outer skin
    /// layer (mm). A surface that reaches deeper passes between the
    /// contact points into the skin, and the forces there are the mesh's
    /// (a feature caught between points drags the skin: on a bump of 0.5
    /// by 0.5 mm the coarse mesh's Ft/Fn reaches 1.9 with mu_skin 0.5).
    pub reach_limit_mm: f64,
}

impl Simulation3 {
    /// The largest reach of the surface into the skin over the run and
    /// the distance travelled there (mm), where it is beyond
    /// [`Self::reach_limit_mm`].
    pub fn unresolved(&self) -> Option<Unresolved> {
        unresolved(&self.history, self.reach_limit_mm)
    }
}

/// Where a surface reached into the skin further than the mesh resolves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unresolved {
    /// The largest reach (mm) and the distance travelled there (mm).
    pub reach_mm: f64,
    pub x_mm: f64,
    /// The limit it passed (mm, [`Simulation3::reach_limit_mm`]).
    pub limit_mm: f64,
}

impl std::fmt::Display for Unresolved {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the surface reached {:.3} mm into the skin between its contact points at x = {:.3} mm, more than half \
             the outer skin layer ({:.3} mm): the mesh does not resolve the surface's features there (a finer \
             --mesh, or more --contact-parts, resolves narrower ones)",
            self.reach_mm, self.x_mm, self.limit_mm
        )
    }
}

/// The deepest reach of `history` if it passes `limit_mm`.
fn unresolved(history: &[Row3], limit_mm: f64) -> Option<Unresolved> {
    let deepest = history.iter().max_by(|a, b| a.surface_reach_mm.total_cmp(&b.surface_reach_mm))?;
    (deepest.surface_reach_mm > limit_mm).then_some(Unresolved {
        reach_mm: deepest.surface_reach_mm,
        x_mm: deepest.slide_mm,
        limit_mm,
    })
}

/// A full-field snapshot of a 3D run.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame3 {
    pub t_s: f64,
    pub slide_mm: f64,
    /// Displacement of every node (3 per node), mm.
    pub displacement: Vec<f64>,
    /// Per contact face (of [`Simulation3::contact_faces`]): the mean
    /// pressure and tangential traction over its contact points (MPa,
    /// traction on the finger), and the fraction of its area in contact
    /// and sticking.
    pub face_pressure_mpa: Vec<f64>,
    pub face_traction_mpa: Vec<[f64; 3]>,
    pub face_contact: Vec<f64>,
    pub face_sticking: Vec<f64>,
    /// The surface under the finger, in the finger's frame: a grid of
    /// [`SURFACE_GRID`] x [`SURFACE_GRID`] points (x fastest) over the contact
    /// region's footprint and 1 mm around it.
    pub surface: Vec<[f64; 3]>,
}

/// Points along each side of a [`Frame3`]'s surface grid.
pub const SURFACE_GRID: usize = 61;

impl Frame3 {
    fn new(t_s: f64, slide_mm: f64, u: &[f64], patch: &Patch, surface: Vec<[f64; 3]>) -> Self {
        let faces = patch.faces.len();
        let (mut pressure, mut traction) = (Vec::with_capacity(faces), Vec::with_capacity(faces));
        let (mut contact, mut sticking) = (Vec::with_capacity(faces), Vec::with_capacity(faces));
        for face in patch.points.chunks_exact(patch.per_face.max(1)) {
            let area: f64 = face.iter().map(|p| p.weight_mm2).sum::<f64>().max(f64::MIN_POSITIVE);
            let mean = |f: &dyn Fn(&PatchPoint) -> f64| face.iter().map(|p| p.weight_mm2 * f(p)).sum::<f64>() / area;
            pressure.push(mean(&|p| p.pressure_mpa));
            traction.push(std::array::from_fn(|d| mean(&|p| p.traction_mpa[d])));
            contact.push(mean(&|p| f64::from(u8::from(p.pressure_mpa > 0.0))));
            sticking.push(mean(&|p| f64::from(u8::from(p.pressure_mpa > 0.0 && p.sticking))));
        }
        Self {
            t_s,
            slide_mm,
            displacement: u.to_vec(),
            face_pressure_mpa: pressure,
            face_traction_mpa: traction,
            face_contact: contact,
            face_sticking: sticking,
            surface,
        }
    }
}

/// A 3D finger as the slide needs it: the mesh, each element's layer
/// (0-3: stratum corneum to hypodermis, [`super::fingertip`]'s indices),
/// the nodes the bone drives (pressed down, held in x and y), further
/// DOFs held at zero, and the skin's faces that may touch the surface.
#[derive(Debug, Clone)]
pub struct Finger3 {
    pub mesh: super::mesh::Mesh3,
    pub element_layer: Vec<usize>,
    pub driven_nodes: Vec<usize>,
    pub held_dofs: Vec<usize>,
    pub skin_faces: Vec<[usize; 4]>,
}

impl From<fingertip::FingertipMesh> for Finger3 {
    fn from(tip: fingertip::FingertipMesh) -> Self {
        Self {
            mesh: tip.mesh,
            element_layer: tip.element_layer,
            driven_nodes: tip.driven_nodes,
            held_dofs: Vec::new(),
            skin_faces: tip.skin_faces,
        }
    }
}

/// Runs `scenario` on the 3D fingertip of its finger model
/// ([`FingertipSpec::from_model`] at its resolution), sliding in direction
/// `direction_deg` (degrees from the surface's x axis); `progress` is
/// called after every step. The scenario's settings mean what they mean
/// in 2D, with forces in N (not per mm of width; a load
/// [`Loading::Load`] is the normal force in N); a display (module docs)
/// as well. At finite strain ([`Kinematics::Finite`]) the body is the
/// total-Lagrangian one of [`super::finite_body`] with the 2D model's
/// volumetric function, balanced by [`super::finite_contact`]'s outer
/// iteration (under a load, with the drive an unknown of each contact
/// solve).
pub fn run(
    scenario: &Scenario,
    direction_deg: f64,
    progress: &mut dyn FnMut(Progress),
) -> Result<Simulation3, SimulationError> {
    run_with_volumetric(scenario, direction_deg, Volumetric::SimoTaylor, progress)
}

/// [`run`] with the volumetric function `volumetric` at finite strain
/// (CalculiX's quadratic one for comparisons with it; no effect at small
/// strain).
pub fn run_with_volumetric(
    scenario: &Scenario,
    direction_deg: f64,
    volumetric: Volumetric,
    progress: &mut dyn FnMut(Progress),
) -> Result<Simulation3, SimulationError> {
    validate(scenario)?;
    let spec = FingertipSpec::from_model(&scenario.model, scenario.resolution);
    let tip = fingertip::mesh(&spec)?;
    run_finger_on(tip.into(), scenario, None, direction_deg, volumetric, progress)
}

/// [`run`] over a height map h(x, y) (`haptex map height`'s;
/// [`MapSurface`]) instead of the scenario's surface, which must be flat.
/// The map's coordinates are the surface frame's: the finger starts with
/// its pad's lowest point over the map's (0, 0) and moves by
/// `scenario.slide_mm` in `direction_deg`. Beyond the map its edge's
/// heights continue.
pub fn run_on_map(
    scenario: &Scenario,
    map: &HeightMap,
    direction_deg: f64,
    progress: &mut dyn FnMut(Progress),
) -> Result<Simulation3, SimulationError> {
    // Its fields are public: checked again (grid, count, heights).
    let map = HeightMap::new(map.grid, map.h_mm.clone(), "the height map")
        .map_err(|e| SimulationError::Invalid(e.to_string()))?;
    run_on_surface(scenario, Arc::new(MapSurface::new(&map)), [0.0; 2], direction_deg, progress)
}

/// [`run_on_map`] on a map's surface built once (for many runs), the
/// finger starting over the map's point `start_mm`.
pub fn run_on_surface(
    scenario: &Scenario,
    surface: Arc<MapSurface>,
    start_mm: [f64; 2],
    direction_deg: f64,
    progress: &mut dyn FnMut(Progress),
) -> Result<Simulation3, SimulationError> {
    validate(scenario)?;
    if !start_mm.iter().all(|v| v.is_finite()) {
        return Err(SimulationError::Invalid(format!("the start {start_mm:?} mm must be finite")));
    }
    let spec = FingertipSpec::from_model(&scenario.model, scenario.resolution);
    let tip = fingertip::mesh(&spec)?;
    let field = HeightField::Map { surface, origin_mm: start_mm };
    run_finger_on(tip.into(), scenario, Some(field), direction_deg, Volumetric::SimoTaylor, progress)
}

/// [`run`] on the 3D finger `tip` (the scenario's finger model gives the
/// materials and the friction; its resolution is not used).
pub fn run_finger(
    tip: Finger3,
    scenario: &Scenario,
    direction_deg: f64,
    progress: &mut dyn FnMut(Progress),
) -> Result<Simulation3, SimulationError> {
    run_finger_on(tip, scenario, None, direction_deg, Volumetric::SimoTaylor, progress)
}

/// [`run_finger`], over the height map's field `map` if given
/// ([`run_on_surface`]; the scenario's surface must then be flat).
fn run_finger_on(
    tip: Finger3,
    scenario: &Scenario,
    map: Option<HeightField>,
    direction_deg: f64,
    volumetric: Volumetric,
    progress: &mut dyn FnMut(Progress),
) -> Result<Simulation3, SimulationError> {
    let started = Instant::now();
    validate(scenario)?;
    let reach_limit_mm = REACH_LIMIT_FRACTION * scenario.model.layers.stratum_corneum_mm;
    let invalid = |m: &str| Err(SimulationError::Invalid(m.to_string()));
    if !is_direction(direction_deg) {
        return Err(SimulationError::Invalid(format!(
            "the slide direction {direction_deg} degrees must be a finite angle from -360 to 360"
        )));
    }
    // The surface's relief plus this is the depth the skin may reach (the
    // contact region's height): the indentation, or under a load a
    // generous bound of the depth it takes.
    let indent = match scenario.loading {
        Loading::Indent(indent) => indent,
        Loading::Load(load_n) => LOAD_DEPTH_MM_PER_N * load_n.max(0.5),
    };
    let finite_strain = scenario.kinematics == Kinematics::Finite;
    let display = scenario.display.as_ref();
    let theta = direction_deg.to_radians();
    let direction = [theta.cos(), theta.sin()];
    let travel = [scenario.slide_mm * direction[0], scenario.slide_mm * direction[1]];

    // The surface over the skin's footprint along the whole path. (The
    // skin's points are those of the contact, so that the first touch is
    // the contact's: with 2 x 2 points the 4 x 4 ones started up to 2 um
    // inside the surface at the default mesh.)
    let parts = scenario.contact_parts;
    let skin = ContactSurface::with_composite_rule(&tip.mesh, &tip.skin_faces, CONTACT_RULE, parts);
    let (lo, hi) = skin.points.iter().fold(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]), |(lo, hi), p| {
        ([lo[0].min(p.position[0]), lo[1].min(p.position[1])], [hi[0].max(p.position[0]), hi[1].max(p.position[1])])
    });
    let (x_min, x_max) = (lo[0] + travel[0].min(0.0) - 1.0, hi[0] + travel[0].max(0.0) + 1.0);
    let (y_min, y_max) = (lo[1] + travel[1].min(0.0) - 1.0, hi[1] + travel[1].max(0.0) + 1.0);
    let field = match map {
        Some(map) => {
            if scenario.surface != SurfaceShape::Flat {
                return invalid("a height map is the surface: the scenario's surface must be flat");
            }
            map
        }
        None => HeightField::extruded(&scenario.surface, x_min, x_max)
            .map_err(|e| SimulationError::Invalid(e.to_string()))?,
    };
    let (low, high) = field.height_range([x_min, x_max], [y_min, y_max]);
    let relief = high - low;
    // The surface just touches the undeformed skin.
    let lift = skin
        .points
        .iter()
        .map(|p| p.position[2] - field.height_gradient(p.position[0], p.position[1]).0)
        .fold(f64::INFINITY, f64::min);
    let z_cut = 1.5 * (indent + relief) + 0.3;
    let (inside, outside): (Vec<[usize; 4]>, Vec<[usize; 4]>) =
        tip.skin_faces.iter().partition(|face| face.iter().any(|&n| tip.mesh.nodes[n][2] <= z_cut));
    let candidate = ContactSurface::with_composite_rule(&tip.mesh, &inside, CONTACT_RULE, parts);
    let beyond = ContactSurface::new(&tip.mesh, &outside);
    // The lightest contact point of the CONTACT_RULE x CONTACT_RULE rule,
    // for the force floor below (the residual is the nodes': a composite
    // rule's smaller points leave it as it is).
    let lightest = ContactSurface::with_rule(&tip.mesh, &inside, CONTACT_RULE)
        .points
        .iter()
        .map(|p| p.weight)
        .fold(f64::INFINITY, f64::min);

    let soft = |m: &Material| {
        let mut m = m.clone();
        m.prony = if scenario.viscoelastic { scenario.model.viscoelasticity.prony.clone() } else { Vec::new() };
        m
    };
    let materials = &scenario.model.materials;
    let materials = vec![
        soft(&materials.stratum_corneum),
        soft(&materials.viable_epidermis),
        soft(&materials.dermis),
        soft(&materials.hypodermis),
    ];
    let mut prescribed: Vec<usize> = tip.driven_nodes.iter().flat_map(|&n| [3 * n, 3 * n + 1, 3 * n + 2]).collect();
    // The drive's vertical DOFs (an unknown under a load).
    let driven_z: Vec<usize> = tip.driven_nodes.iter().map(|&n| 3 * n + 2).collect();
    prescribed.extend_from_slice(&tip.held_dofs);
    prescribed.sort_unstable();
    prescribed.dedup();
    let n_nodes = tip.mesh.n_nodes();
    let n_elements = tip.mesh.elements.len();
    // At finite strain, the same mesh and materials as a total-Lagrangian
    // body whose internal forces the outer iteration balances
    // ([`super::finite_contact`]); the small-strain body gives K.
    let mut finite = if finite_strain {
        Some(FiniteBody3::new(tip.mesh.clone(), materials.clone(), tip.element_layer.clone(), volumetric, &prescribed)?)
    } else {
        None
    };
    let mut operator = finite_contact::Operator::new();
    // The last step's size (K is rebuilt where it changes).
    let mut last_dt: Option<f64> = None;
    let mut body = ViscoelasticBody::new(tip.mesh, Formulation::BBar, materials, tip.element_layer, &prescribed)?;
    let mut condensation = Condensation::new(body.pattern(), body.free(), &candidate)?;
    let law = FrictionLaw {
        penalty_n: scenario.penalty_mpa_per_mm,
        smoothing_mm: scenario.smoothing_mm,
        penalty_t: scenario.penalty_mpa_per_mm,
        mu: scenario.mu_skin.unwrap_or(scenario.model.contact.mu_skin),
    };
    // The 2D model's tolerances and limits; the force floor of a point's
    // penalty at the floor's depth, on the lightest point.
    let newton = NewtonSettings {
        max_iterations: scenario.settings.max_iterations,
        continuation_iterations: scenario.settings.continuation_iterations,
        relative_tolerance: scenario.settings.relative_tolerance,
        force_floor_n: law.penalty_n * scenario.settings.floor_penetration_mm * lightest,
        increment_tolerance_mm: scenario.settings.increment_tolerance_mm,
    };
    // A point's position relative to the surface (surface frame) when the
    // finger has travelled `s`.
    let relative = |x: [f64; 3], w: [f64; 3], s: [f64; 2]| [x[0] + w[0] + s[0], x[1] + w[1] + s[1], x[2] + w[2] - lift];
    let mut committed: Vec<Committed> = candidate
        .points
        .iter()
        .map(|p| Committed { position: relative(p.position, [0.0; 3], [0.0; 2]), traction: [0.0; 3] })
        .collect();

    let mut u = vec![0.0; 3 * n_nodes];
    // The nodes of the points in contact at the last step, and its slide.
    let mut in_contact: Vec<usize> = Vec::new();
    // The last step's slide, the bone's vertical displacement (mm,
    // negative down) and the normal force (N).
    let (mut last_s, mut drive_z, mut last_force) = ([0.0; 2], 0.0f64, 0.0f64);
    // Whether some point in contact stuck at the last step (Newton's
    // method then starts with the stick predictor).
    let mut some_stuck = false;
    let tip_nodes = body.mesh.nodes.clone();
    let mut region_nodes: Vec<usize> = candidate.points.iter().flat_map(|p| p.nodes).collect();
    region_nodes.sort_unstable();
    region_nodes.dedup();
    let slide_steps = scenario.slide_steps()?;
    let total_steps = scenario.press_steps + slide_steps;
    // The steps: under a load, an instant touch first (as in 2D: by a
    // micrometre, unrecorded), then the press and the slide.
    let mut plan = Vec::with_capacity(total_steps + 1);
    let target = |fraction: f64| match scenario.loading {
        Loading::Indent(indent) => Target::Depth(indent * fraction),
        Loading::Load(load_n) => Target::Force(load_n * fraction),
    };
    if matches!(scenario.loading, Loading::Load(_)) {
        plan.push((0.0, Target::Depth(TOUCH_MM), 0.0, 0));
    }
    let dt_press = scenario.press_time_s / scenario.press_steps as f64;
    for k in 1..=scenario.press_steps {
        plan.push((dt_press, target(k as f64 / scenario.press_steps as f64), 0.0, k));
    }
    for j in 1..=slide_steps {
        let step = scenario.slide_mm / slide_steps as f64;
        let distance = scenario.slide_mm * j as f64 / slide_steps as f64;
        plan.push((step / scenario.velocity_mm_s, target(1.0), distance, scenario.press_steps + j));
    }
    let mut history = Vec::with_capacity(total_steps);
    let mut patches = Vec::new();
    let mut frames = Vec::new();
    // The surface under the contact region (and 1 mm around it) in the
    // finger's frame with the finger at `s`.
    let (lo, hi) = inside.iter().flatten().fold(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]), |(lo, hi), &n| {
        let x = tip_nodes[n];
        ([lo[0].min(x[0]), lo[1].min(x[1])], [hi[0].max(x[0]), hi[1].max(x[1])])
    });
    let surface_grid = |s: [f64; 2]| -> Vec<[f64; 3]> {
        let last = (SURFACE_GRID - 1) as f64;
        let mut grid = Vec::with_capacity(SURFACE_GRID * SURFACE_GRID);
        for j in 0..SURFACE_GRID {
            for i in 0..SURFACE_GRID {
                let x = lo[0] - 1.0 + (hi[0] - lo[0] + 2.0) * i as f64 / last;
                let y = lo[1] - 1.0 + (hi[1] - lo[1] + 2.0) * j as f64 / last;
                grid.push([x, y, field.height_gradient(x + s[0], y + s[1]).0 + lift]);
            }
        }
        grid
    };
    let mut newton_iterations = 0;
    let mut t_s = 0.0;
    let feature = feature_distance(&scenario.surface, direction);
    let mut feature_reached = false;
    let (mut x, mut ft, mut fn_n) = (Vec::new(), Vec::new(), Vec::new());
    // Under a load, the free unknowns' load per mm of the drive at the
    // step size last prepared.
    let mut per_mm: Vec<f64> = Vec::new();
    for &(dt, goal, distance, k) in &plan {
        let pressing = k <= scenario.press_steps;
        t_s += dt;
        let s = [distance * direction[0], distance * direction[1]];
        // A display's attraction and friction with the finger at x_f =
        // the distance travelled (held over the step's pieces).
        let electrostatic = display.map(|d| d.electrostatic_at(distance)).filter(|e| e.pressure_mpa > 0.0);
        let law = FrictionLaw { mu: display.and_then(|d| d.friction_at(distance)).unwrap_or(law.mu), ..law };
        let sticking = FrictionLaw { mu: f64::INFINITY, ..law };
        if let Some(finite) = finite.as_mut() {
            finite.begin_step(dt);
            // K is kept from step to step (rebuilt within one where the
            // outer iteration slows) and taken afresh at a step of a new
            // size, as in 2D: rebuilt at every step's first iterate, the
            // coarse bump took 18.3-20.0 s instead of 13.7 s, its profile
            // the same to 3e-10.
            if last_dt != Some(dt) {
                operator.invalidate();
            }
        }
        last_dt = Some(dt);
        // The small-strain K(dt): the small-strain solve's operator, and at
        // finite strain the fallback where the tangent is not positive
        // definite (the outer iteration factorizes its own operator).
        if body.prepare(dt)? {
            if finite.is_none() {
                condensation.factorize(body.stiffness_values())?;
            }
            if matches!(scenario.loading, Loading::Load(_)) {
                // The load per mm of the drive: the step's load is affine
                // in it, with a slope of K(dt) alone.
                let mut moved = u.clone();
                let base = body.step_load(&moved);
                for &n in &tip.driven_nodes {
                    moved[3 * n + 2] += 1.0;
                }
                per_mm = body.step_load(&moved).iter().zip(&base).map(|(a, b)| a - b).collect();
            }
        }
        // Continuation: the step's surface move and press in `pieces`
        // equal parts, each solved from the last. The friction's reference
        // is the last step's commit throughout, so the solution is the
        // whole step's; only Newton's start is nearer. One piece first,
        // doubled while Newton fails (at a slide's first step, where the
        // pad goes from sticking to slipping, and on features finer than
        // the mesh).
        let start = u.clone();
        let mut pieces = 1;
        let iterations = loop {
            u.copy_from_slice(&start);
            let mut from = last_s;
            let mut total = 0;
            let mut failure = None;
            let mut z = drive_z;
            for j in 1..=pieces {
                let lambda = j as f64 / pieces as f64;
                let to = [last_s[0] + lambda * (s[0] - last_s[0]), last_s[1] + lambda * (s[1] - last_s[1])];
                if let Target::Depth(depth) = goal {
                    z = drive_z + lambda * (-depth - drive_z);
                }
                for &n in &tip.driven_nodes {
                    u[3 * n + 2] = z;
                }
                // At finite strain the skin is not moved ahead of the body:
                // the iterate is also where f_int and its tangent are
                // taken, and a skin shifted against the tissue under it is
                // a distorted state to linearize at (on the shipped
                // finger's bump slide, coarse mesh, 115 s with the shift
                // and 17 s without it; the profiles agree to 4e-10).
                if finite.is_none() {
                    follow_surface(&mut u, &region_nodes, &in_contact, body.free(), &tip_nodes, &field, lift, from, to);
                }
                let mut control = match goal {
                    Target::Depth(_) => None,
                    Target::Force(force) => Some(LoadControl {
                        per_mm: &per_mm,
                        normal_force_n: last_force + lambda * (force - last_force),
                        change_mm: 0.0,
                    }),
                };
                let point = |q: usize, w: [f64; 3], mode: PointMode| {
                    let r = relative(candidate.points[q].position, w, to);
                    let contact = match mode {
                        PointMode::Exact => law.evaluate(&field.at(r), r, &committed[q]),
                        PointMode::NoCurvature => law.evaluate(&field.at(r).without_curvature(), r, &committed[q]),
                        PointMode::Stick => sticking.evaluate(&field.at(r), r, &committed[q]),
                    };
                    attracted(contact.map(|c| (c.force, c.tangent)), electrostatic.as_ref(), r[2])
                };
                let solved = match finite.as_mut() {
                    None => condensation
                        .equilibrium(
                            &body.step_load(&u),
                            body.free(),
                            &mut u,
                            &candidate,
                            &mut |q, w, mode| point(q, w, mode),
                            some_stuck,
                            &newton,
                            control.as_mut(),
                        )
                        .map(|e| e.iterations)
                        .map_err(FiniteContactError::from),
                    Some(finite) => finite_contact::equilibrium(
                        finite,
                        body.pattern(),
                        body.stiffness_values(),
                        body.free(),
                        &mut condensation,
                        &mut operator,
                        &mut u,
                        &candidate,
                        &mut |q, w, mode| point(q, w, mode),
                        some_stuck,
                        &newton,
                        control.as_mut().map(|c| (&driven_z[..], c)),
                    ),
                };
                match solved {
                    Ok(iterations) => {
                        total += iterations;
                        if let Some(c) = &control {
                            z += c.change_mm;
                            for &n in &tip.driven_nodes {
                                u[3 * n + 2] = z;
                            }
                        }
                    }
                    Err(e) => {
                        total += MAX_ITERATIONS_COUNTED;
                        failure = Some(e);
                        break;
                    }
                }
                from = to;
            }
            newton_iterations += total;
            match failure {
                None => {
                    drive_z = z;
                    break total;
                }
                Some(source) if pieces >= MAX_PIECES => {
                    return Err(SimulationError::Equilibrium3 {
                        x_mm: distance,
                        t_s,
                        source,
                        unresolved: unresolved(&history, reach_limit_mm),
                    });
                }
                Some(_) => pieces *= 2,
            }
        };
        let point = |q: usize, w: [f64; 3]| {
            let r = relative(candidate.points[q].position, w, s);
            law.evaluate(&field.at(r), r, &committed[q])
        };
        // Forces, the patch, and the commit.
        let mut force = [0.0; 3];
        let mut area = 0.0;
        let (mut fe_n, mut fe_contact_n) = (0.0, 0.0);
        let (mut ahead, mut behind) = (f64::NEG_INFINITY, f64::INFINITY);
        let mut points = Vec::with_capacity(candidate.points.len());
        let mut next = Vec::with_capacity(candidate.points.len());
        for (q, p) in candidate.points.iter().enumerate() {
            let w = p.displacement(&u);
            let r = relative(p.position, w, s);
            let response = point(q, w);
            let (pressure, traction, sticking) = response.map_or((0.0, [0.0; 3], false), |r| {
                for d in 0..3 {
                    force[d] += p.weight * r.force[d];
                }
                (r.pressure, r.traction, r.sticking)
            });
            if pressure > 0.0 {
                area += p.weight;
                let along = (p.position[0] + w[0]) * direction[0] + (p.position[1] + w[1]) * direction[1];
                (ahead, behind) = (ahead.max(along), behind.min(along));
            }
            if let Some(e) = &electrostatic {
                let attraction = p.weight * e.traction(r[2]).0;
                fe_n += attraction;
                if pressure > 0.0 {
                    fe_contact_n += attraction;
                }
            }
            next.push(Committed { position: r, traction });
            points.push(PatchPoint {
                position_mm: std::array::from_fn(|d| p.position[d] + w[d]),
                weight_mm2: p.weight,
                pressure_mpa: pressure,
                traction_mpa: traction,
                sticking,
            });
        }
        committed = next;
        in_contact.clear();
        for (p, point) in candidate.points.iter().zip(&points) {
            if point.pressure_mpa > 0.0 {
                in_contact.extend(p.nodes);
            }
        }
        in_contact.sort_unstable();
        in_contact.dedup();
        some_stuck = points.iter().any(|p| p.pressure_mpa > 0.0 && p.sticking);
        (last_s, last_force) = (s, force[2] - fe_n);
        // The history of the body that was solved.
        match finite.as_mut() {
            Some(finite) => finite.commit(&u),
            None => body.commit(&u),
        }
        let surface_reach_mm = candidate
            .face_samples(&tip_nodes, &u, REACH_SPACING_MM, |x| x.iter().any(|p| p[2] - lift <= high))
            .map(|x| field.height_gradient(x[0] + s[0], x[1] + s[1]).0 - (x[2] - lift))
            .fold(0.0, f64::max);
        for p in &beyond.points {
            if field.at(relative(p.position, p.displacement(&u), s)).depth > 0.0 {
                return Err(SimulationError::ContactBeyondRegion { x_mm: distance, t_s, z_cut_mm: z_cut });
            }
        }
        let row = Row3 {
            t_s,
            slide_mm: distance,
            fn_n: force[2] - fe_n,
            ft_n: -(force[0] * direction[0] + force[1] * direction[1]),
            ft_lateral_n: -(-force[0] * direction[1] + force[1] * direction[0]),
            contact_area_mm2: area,
            contact_length_mm: (ahead - behind).max(0.0),
            fe_n,
            fe_contact_n,
            drive_z_mm: drive_z,
            surface_reach_mm,
            iterations,
        };
        if k == 0 {
            // The touch is not a step of the run.
            continue;
        }
        history.push(row);
        let faces =
            inside.iter().map(|face| face.map(|n| std::array::from_fn(|d| tip_nodes[n][d] + u[3 * n + d]))).collect();
        let patch = Patch { t_s, slide_mm: distance, points, per_face: candidate.per_face, faces };
        let slide_step = k.saturating_sub(scenario.press_steps);
        let at_feature = !pressing && !feature_reached && feature.is_some_and(|f| distance >= f);
        if scenario.frame_every > 0
            && (k == scenario.press_steps
                || at_feature
                || k == total_steps
                || (!pressing && slide_step % scenario.frame_every == 0))
        {
            frames.push(Frame3::new(t_s, distance, &u, &patch, surface_grid(s)));
        }
        if k == scenario.press_steps {
            patches.push(patch);
        } else if !pressing {
            if row.fn_n.is_nan() || row.fn_n <= 1e-12 {
                return Err(SimulationError::NoContact { x_mm: distance, t_s });
            }
            x.push(distance);
            ft.push(row.ft_n);
            fn_n.push(row.fn_n);
            if at_feature || k == total_steps {
                feature_reached |= at_feature;
                patches.push(patch);
            }
        }
        progress(Progress { step: k, total_steps, t_s, slide_mm: distance });
        scenario.check_stop()?;
    }
    let profile = crate::scenario::slide_profile(x, &ft, fn_n)?;
    let statistics = Statistics {
        nodes: n_nodes,
        elements: n_elements,
        free_dofs: body.n_free(),
        contact_dofs: condensation.unknowns(),
        factor_nnz: condensation.factor_nnz(),
        steps: total_steps,
        newton_iterations,
        step_cuts: 0,
        wall_time_s: started.elapsed().as_secs_f64(),
    };
    Ok(Simulation3 {
        history,
        profile,
        patches,
        direction_deg,
        statistics,
        mesh: body.mesh,
        element_layer: body.element_material,
        driven_nodes: tip.driven_nodes,
        contact_faces: inside,
        frames,
        reach_limit_mm,
    })
}

/// Whether `direction_deg` is a slide direction the 3D finger takes: a
/// finite angle from -360 to 360 degrees (the callers name the flag or
/// argument in their error).
pub fn is_direction(direction_deg: f64) -> bool {
    direction_deg.is_finite() && direction_deg.abs() <= 360.0
}

/// The scenario's checks ([`Scenario::validate`]), a load first in the 3D
/// finger's unit: N on the whole finger, not N per mm of width (the
/// bound's number is the 2D model's).
pub fn validate(scenario: &Scenario) -> Result<(), SimulationError> {
    if let Loading::Load(load) = scenario.loading {
        let most = crate::scenario::limits::LOAD_N_PER_MM;
        if !(load.is_finite() && load > 0.0 && load <= most) {
            return Err(SimulationError::Invalid(format!(
                "load = {} N must be positive and at most {} N",
                haptex_core::num::Num(load),
                haptex_core::num::Num(most)
            )));
        }
    }
    if !(1..=MAX_CONTACT_PARTS).contains(&scenario.contact_parts) {
        return Err(SimulationError::Invalid(format!(
            "contact parts = {} must be from 1 to {MAX_CONTACT_PARTS}",
            scenario.contact_parts
        )));
    }
    scenario.validate()
}

pub use super::contact::MAX_CONTACT_PARTS;

/// A step's aim: the bone's depth below first touch (mm), or the normal
/// force (N).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Target {
    Depth(f64),
    Force(f64),
}

/// The touch before a load is applied (mm): a micrometre.
const TOUCH_MM: f64 = 1e-3;

/// The contact region under a load is sized for a depth of this much per
/// N (at least 0.5 N's): the default fingertip carries 0.4 N at 0.5 mm and
/// 1.5 N at 0.8 mm (instantaneous moduli), less deep than this bound; skin
/// beyond the region that touches is an error all the same.
const LOAD_DEPTH_MM_PER_N: f64 = 1.0;

/// Gauss points along each side of a skin face: 4 x 4, as the 2D model
/// has 4 per segment. On the default mesh over the default bump the
/// profile moved by up to 0.04 in Ft/Fn between 2 x 2 and 3 x 3 points,
/// and less from 3 x 3 to 4 x 4; the points cost little next to the
/// dense solve on the nodes in contact (the run took 52 s with 2 x 2 and
/// 54 s with 4 x 4).
const CONTACT_RULE: usize = 4;

/// The spacing of the samples of [`Row3::surface_reach_mm`] on the skin
/// faces (mm; about half the contact points' spacing at the pad on the
/// coarse mesh, 0.1-0.2 mm), on the faces that reach below the surface's
/// highest point on the path (a bilinear face is nowhere lower than its
/// lowest node). A crest between samples is missed by at most its drop
/// over 0.05 mm, 0.02 mm on the 0.06 mm crest of the narrowest bump, a
/// fifth of the limit. The sampling costs 3-5% of a coarse run (0.05 mm
/// 10%, 16 x 16 per face on all faces of the region 2-4% of the coarse
/// and 5% of the default mesh's run), about 1% of a default one.
pub const REACH_SPACING_MM: f64 = 0.07;

/// [`Simulation3::reach_limit_mm`] as a fraction of the outer skin
/// layer's thickness.
pub const REACH_LIMIT_FRACTION: f64 = 0.5;

/// Most parts a step is cut into when Newton's method fails on it.
const MAX_PIECES: usize = 16;
/// The Newton iterations a failed attempt counts for in the statistics.
const MAX_ITERATIONS_COUNTED: usize = 100;

/// A point's contact force and tangent (MPa, MPa/mm; [`PointForce`]) with
/// a display's attraction at the point's gap `gap_mm` above the flat
/// display added: F_z = -p_e(g), whose tangent -dF_z/dz = dp_e/dg enters
/// where [`Electrostatic::in_tangent`] says it matters (the 2D model's
/// rule; beyond, the force is kept and the point is no unknown of the
/// step's dense system).
fn attracted(contact: PointForce, electrostatic: Option<&Electrostatic>, gap_mm: f64) -> PointForce {
    let Some(e) = electrostatic else {
        return contact;
    };
    let (p, dp) = e.traction(gap_mm);
    let (mut force, mut tangent) = contact.unwrap_or(([0.0; 3], [[0.0; 3]; 3]));
    force[2] -= p;
    if e.in_tangent(gap_mm) {
        tangent[2][2] += dp;
    }
    Some((force, tangent))
}

/// The predictor of a step that moves the surface from `from` to `to`:
/// the skin in contact at the last step follows the surface's rise or
/// fall under it, and the skin that was not in contact and would now be
/// inside the surface is put on it (from the last state, the surface's
/// move alone pushes skin tens of micrometres deep at the penalty's
/// stiffness on a feature's flank, and Newton's first steps overshoot).
#[allow(clippy::too_many_arguments)]
fn follow_surface(
    u: &mut [f64],
    region_nodes: &[usize],
    in_contact: &[usize],
    free: &[usize],
    nodes: &[[f64; 3]],
    field: &HeightField,
    lift: f64,
    from: [f64; 2],
    to: [f64; 2],
) {
    if from == to {
        return;
    }
    for &n in region_nodes {
        if free[3 * n + 2] == crate::assembly::PRESCRIBED {
            continue;
        }
        let x = nodes[n];
        let (ux, uy) = (u[3 * n], u[3 * n + 1]);
        let at = |shift: [f64; 2]| field.height_gradient(x[0] + ux + shift[0], x[1] + uy + shift[1]).0 + lift;
        if in_contact.binary_search(&n).is_ok() {
            u[3 * n + 2] += at(to) - at(from);
        } else {
            u[3 * n + 2] = u[3 * n + 2].max(at(to) - x[2]);
        }
    }
}

/// The distance along the path at which the finger's centre is over the
/// feature's characteristic point x0 (None if it never is).
fn feature_distance(surface: &SurfaceShape, direction: [f64; 2]) -> Option<f64> {
    match surface {
        SurfaceShape::Bump { x0, .. } | SurfaceShape::Edge { x0, .. } | SurfaceShape::Sine { x0, .. } => {
            let d = x0 / direction[0];
            (d.is_finite() && d >= 0.0).then_some(d)
        }
        _ => None,
    }
}
