//! Contact of the skin against the rigid surface: penalty normal contact
//! and Coulomb friction with a stick/slip return mapping, integrated at
//! Gauss points along the skin's boundary segments (Gauss-point-to-surface,
//! Wriggers, Computational Contact Mechanics, 2nd ed., 2006, sec. 9.1).
//!
//! At a contact point with current position x, inside the rigid body:
//!
//!   depth d = |c - x| (c the closest surface point), normal pressure
//!   p_N = eps_N d, trial tangential traction t* = t_n - eps_T (S - S_n)
//!   (S the arc coordinate of c on the surface, n the last converged step);
//!   stick if |t*| <= mu p_N, else slip with t = mu p_N sign(t*).
//!
//! The force on the finger is w (p_N n + t tau), with n the outward normal
//! of the rigid body, tau the tangent towards +x and w the integration
//! weight (reference length), so pressures are in MPa and forces in N per
//! mm of width. Its derivative with respect to x (the consistent tangent,
//! exact on the polyline's straight segments) is
//!
//!   stick: -w (k_N n n^T + eps_T tau tau^T)
//!   slip:  -w (k_N n n^T + mu k_N sign(t*) tau n^T)    (unsymmetric),
//!
//! with k_N = dp_N/dd.
//!
//! Integration points sit on the straight skin segments between nodes, so
//! a surface feature narrower than the node spacing cannot slip between
//! two nodes unnoticed, as it can with node-to-surface contact.

use crate::surface::RigidSurface;

/// Contact parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactLaw {
    /// Normal penalty eps_N in MPa per mm of penetration.
    pub penalty_normal: f64,
    /// Tangential (stick) penalty eps_T in MPa per mm of elastic slip.
    pub penalty_tangential: f64,
    /// Coulomb friction coefficient between skin and surface.
    pub mu: f64,
    /// Width of the smoothed onset of the normal penalty, mm (see
    /// [`ContactLaw::pressure`]); 0 for the plain penalty.
    pub smoothing_mm: f64,
    /// Include the curvature (geometric) term in the contact tangent: the
    /// exact derivative, but a negative stiffness on crests (see
    /// [`ContactSet::evaluate`]). Simulations start each step with it; the
    /// solver drops it at the step's first stall.
    pub geometric_tangent: bool,
    /// Electrostatic attraction towards the surface (a display under
    /// voltage), if any.
    pub electrostatic: Option<Electrostatic>,
}

impl ContactLaw {
    /// Normal pressure (MPa) and its derivative with respect to the depth d
    /// (mm): the penalty eps_N d with a C1 onset over the first
    /// `smoothing_mm` of penetration,
    ///
    ///   p = eps_N d^2 / (2 delta) for 0 < d < delta,   eps_N (d - delta/2) beyond,
    ///
    /// so that a contact point entering or leaving contact does not make
    /// the force jump in slope (the cause of active-set cycling in Newton's
    /// method). Equivalent to moving the surface by delta/2 under full
    /// pressure: with delta = 0.2 um, negligible next to the 250 um press.
    pub fn pressure(&self, depth: f64) -> (f64, f64) {
        smoothed_penalty(self.penalty_normal, self.smoothing_mm, depth)
    }
}

/// The normal pressure (MPa) of a penalty `eps_n` (MPa/mm) with a C1 onset
/// over `smoothing_mm` at a penetration `depth` (mm), and its derivative
/// with respect to the depth ([`ContactLaw::pressure`]; the 3D finger's
/// contact uses it too).
pub fn smoothed_penalty(eps_n: f64, smoothing_mm: f64, depth: f64) -> (f64, f64) {
    let (e, delta) = (eps_n, smoothing_mm);
    if depth <= 0.0 {
        (0.0, 0.0)
    } else if depth < delta {
        (e * depth * depth / (2.0 * delta), e * depth / delta)
    } else {
        (e * (depth - 0.5 * delta), e)
    }
}

/// Electrostatic attraction of the skin towards a flat display under a
/// voltage U: a normal traction on the skin pulling it onto the display,
/// with an air gap g between skin and display in series with the two
/// dielectric layers of eq. (3), as an air layer of permittivity 1 added
/// to both of its sums:
///
///   p_e(g) = eps0 U^2 / (2 (a + g)(b + g)),   a = d_sc/eps_sc + d_i/eps_i,   b = d_sc + d_i.
///
/// At g = 0 (skin in contact) this is eq. (3) divided by the area
/// (Kaczmarek et al. 2006), so its integral over the contact length is
/// eq. (3)'s Fe on that length; for g much larger than the layers it is
/// the force between two plates in air, eps0 U^2 / (2 g^2). (Shultz,
/// Peshkin and Colgate, "Surface haptics via electroadhesion", IEEE World
/// Haptics 2015, model the finger-display interface as such a series
/// stack.) Skin near the edge of the contact, not touching, is attracted
/// too: with the paper's layers a = 0.22 um, so the attraction halves at a
/// gap of 0.22 um and falls as a/g beyond.
///
/// The gap is the vertical distance of the skin above the display (0
/// where it penetrates) and the traction acts vertically: the law is for a
/// flat display.
///
/// A display may also keep an air gap g_0 where the skin touches it (a
/// film, the roughness of the stratum corneum's surface; Shultz et al.
/// find such a gap of the order of a micron): the traction at geometric
/// gap g is then that of the gap max(g, 0) + g_0, so that in contact
///
///   p_e = eps0 U^2 / (2 (a + g_0)(b + g_0)),
///
/// lower than eq. (3)'s by a b / ((a + g_0)(b + g_0)) (0.69 at g_0 =
/// 0.1 um with the paper's layers). Eq. (8) knows no such gap: a display
/// that has one renders less than its design (the measured compensation's
/// virtual device, docs/measured-compensation.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Electrostatic {
    /// Traction at zero gap with no air gap, MPa: eps0 U^2 / (2 a b).
    pub pressure_mpa: f64,
    /// a = d_sc/eps_sc + d_i/eps_i, mm.
    pub electric_mm: f64,
    /// b = d_sc + d_i, mm.
    pub thickness_mm: f64,
    /// The air gap g_0 in contact, mm (0: none).
    pub air_gap_mm: f64,
}

impl Electrostatic {
    /// Gaps beyond this many electric lengths a have their traction's
    /// derivative left out of the tangent (its force is kept): there
    /// |dp/dg| < p_e(0) / 900 a, so Newton's method stays quadratic where
    /// the traction matters and the active set does not grow over the
    /// whole pad.
    pub const TANGENT_GAPS: f64 = 30.0;

    /// The law for `u_v` volts (RMS) across `stack`.
    pub fn new(stack: &haptex_core::electrovibration::LayerStack, u_v: f64) -> Self {
        let electric_mm = stack.d_sc_mm / stack.eps_sc + stack.d_i_mm / stack.eps_i;
        let thickness_mm = stack.d_sc_mm + stack.d_i_mm;
        // eps0 U^2 / (2 a b) with a, b in m gives Pa; 1e-6 MPa per Pa.
        let pa =
            haptex_core::electrovibration::EPS0_F_PER_M * u_v * u_v / (2.0 * electric_mm * 1e-3 * thickness_mm * 1e-3);
        Self { pressure_mpa: pa * 1e-6, electric_mm, thickness_mm, air_gap_mm: 0.0 }
    }

    /// The same law with an air gap of `air_gap_mm` in contact (>= 0).
    pub fn with_air_gap(self, air_gap_mm: f64) -> Self {
        Self { air_gap_mm, ..self }
    }

    /// Traction (MPa, attractive) and its derivative with respect to the
    /// gap (MPa/mm) at gap `gap_mm` (<= 0: in contact, the traction of g = 0),
    /// the air gap added.
    pub fn traction(&self, gap_mm: f64) -> (f64, f64) {
        let g = gap_mm.max(0.0) + self.air_gap_mm;
        let (a, b) = (self.electric_mm, self.thickness_mm);
        let p = self.pressure_mpa * a * b / ((a + g) * (b + g));
        let dp = if gap_mm > 0.0 { -p * (1.0 / (a + g) + 1.0 / (b + g)) } else { 0.0 };
        (p, dp)
    }

    /// Whether the traction's gap derivative enters the tangent at `gap_mm`.
    pub fn in_tangent(&self, gap_mm: f64) -> bool {
        gap_mm > 0.0 && gap_mm < Self::TANGENT_GAPS * self.electric_mm
    }
}

/// Where the rigid surface is: lab point (x, y) is at (x + slide, y - lift)
/// in the surface's own frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SurfacePlacement {
    /// How far the surface has moved towards -x (the finger's position on
    /// the surface), mm.
    pub slide_mm: f64,
    /// Vertical offset of the surface, mm.
    pub lift_mm: f64,
}

impl SurfacePlacement {
    fn to_surface(self, p: [f64; 2]) -> [f64; 2] {
        [p[0] + self.slide_mm, p[1] - self.lift_mm]
    }
}

/// The friction state of a contact point at the last converged step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PointState {
    pub active: bool,
    /// Arc coordinate on the surface of the point's closest (or, out of
    /// contact, vertically opposite) surface point, mm.
    pub arc_mm: f64,
    /// Tangential traction, MPa (along the surface tangent towards +x).
    pub traction_t: f64,
    /// Normal pressure, MPa.
    pub pressure: f64,
    /// True if sliding.
    pub slipping: bool,
}

/// A 2x2 block of the contact tangent between candidate nodes i and j.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    pub i: usize,
    pub j: usize,
    pub d: [[f64; 2]; 2],
}

/// Totals of one contact evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactTotals {
    /// Sum of the contact forces on the finger (x, y), N per mm of width.
    pub force: [f64; 2],
    /// Length of skin boundary in contact (reference), mm.
    pub contact_mm: f64,
    /// Electrostatic attraction on the finger (N per mm of width, > 0:
    /// pulling it onto the surface); its force is in the nodal forces, not
    /// in `force`.
    pub electrostatic_n: f64,
    /// The part of it on skin in contact (N per mm of width).
    pub electrostatic_contact_n: f64,
    pub active_points: usize,
    pub slipping_points: usize,
}

/// The candidate contact region: skin boundary segments and their points.
#[derive(Debug, Clone)]
pub struct ContactSet {
    /// Global node ids of the candidate nodes.
    pub nodes: Vec<usize>,
    /// Segments as pairs of candidate-node indices.
    pub segments: Vec<[usize; 2]>,
    /// Reference positions of the candidate nodes.
    reference: Vec<[f64; 2]>,
    /// For each contact point: segment, shape function values, weight (mm).
    points: Vec<(usize, [f64; 2], f64)>,
    pub committed: Vec<PointState>,
    pub trial: Vec<PointState>,
}

impl ContactSet {
    /// Contact points at `gauss_points` Gauss-Legendre points (1..=4) per
    /// segment of `segments` (pairs of global node ids along the boundary).
    pub fn new(node_positions: &[[f64; 2]], segments: &[[usize; 2]], gauss_points: usize) -> Self {
        let mut nodes: Vec<usize> = segments.iter().flatten().copied().collect();
        nodes.sort_unstable();
        nodes.dedup();
        let local = |g: usize| nodes.binary_search(&g).expect("segment node is a candidate");
        let local_segments: Vec<[usize; 2]> = segments.iter().map(|&[a, b]| [local(a), local(b)]).collect();
        let reference: Vec<[f64; 2]> = nodes.iter().map(|&g| node_positions[g]).collect();
        let (abscissae, weights) = gauss_legendre(gauss_points);
        let mut points = Vec::new();
        for (s, &[a, b]) in local_segments.iter().enumerate() {
            let length = crate::mesh::distance(reference[a], reference[b]);
            for (xi, w) in abscissae.iter().zip(&weights) {
                points.push((s, [0.5 * (1.0 - xi), 0.5 * (1.0 + xi)], 0.5 * w * length));
            }
        }
        let n = points.len();
        Self {
            nodes,
            segments: local_segments,
            reference,
            points,
            committed: vec![PointState::default(); n],
            trial: vec![PointState::default(); n],
        }
    }

    /// Number of candidate nodes (the condensed system has twice as many DOFs).
    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    pub fn n_points(&self) -> usize {
        self.points.len()
    }

    /// Current position of contact point `k` for candidate displacements `u`.
    fn position(&self, k: usize, u: &[f64]) -> [f64; 2] {
        let (s, n, _) = self.points[k];
        let [a, b] = self.segments[s];
        let mut p = [0.0; 2];
        for (node, w) in [(a, n[0]), (b, n[1])] {
            p[0] += w * (self.reference[node][0] + u[2 * node]);
            p[1] += w * (self.reference[node][1] + u[2 * node + 1]);
        }
        p
    }

    /// Reference-configuration positions of the contact points (lab frame).
    pub fn point_positions(&self, u: &[f64]) -> Vec<[f64; 2]> {
        (0..self.points.len()).map(|k| self.position(k, u)).collect()
    }

    /// Evaluates the contact at candidate displacements `u` (2 per candidate
    /// node): nodal forces on the finger into `forces`, tangent blocks into
    /// `blocks` (cleared first), trial states updated.
    pub fn evaluate(
        &mut self,
        u: &[f64],
        surface: &RigidSurface,
        placement: SurfacePlacement,
        law: &ContactLaw,
        forces: &mut [f64],
        blocks: &mut Vec<Block>,
    ) -> ContactTotals {
        self.evaluate_with(u, surface, placement, law, false, forces, blocks)
    }

    /// As [`ContactSet::evaluate`]; with `force_stick` every point in contact
    /// sticks (the elastic predictor of the return mapping, used to start
    /// Newton's iteration from the stick solution).
    #[allow(clippy::too_many_arguments)]
    pub fn evaluate_with(
        &mut self,
        u: &[f64],
        surface: &RigidSurface,
        placement: SurfacePlacement,
        law: &ContactLaw,
        force_stick: bool,
        forces: &mut [f64],
        blocks: &mut Vec<Block>,
    ) -> ContactTotals {
        forces.fill(0.0);
        blocks.clear();
        let mut totals = ContactTotals::default();
        for k in 0..self.points.len() {
            let (s, shape, w) = self.points[k];
            let previous = self.committed[k];
            let x = placement.to_surface(self.position(k, u));
            if let Some(e) = law.electrostatic.filter(|e| e.pressure_mpa > 0.0) {
                // The vertical gap above the (flat) display; <= 0 in contact.
                let gap = x[1] - surface.height(x[0]);
                let (p, dp) = e.traction(gap);
                let nodes = self.segments[s];
                for (a, &na) in nodes.iter().zip(&shape) {
                    forces[2 * a + 1] -= na * w * p;
                }
                if e.in_tangent(gap) {
                    // d f_y / d y = -w dp/dg (> 0: the attraction grows as
                    // the skin approaches).
                    for (a, &na) in nodes.iter().zip(&shape) {
                        for (b, &nb) in nodes.iter().zip(&shape) {
                            blocks.push(Block { i: *a, j: *b, d: [[0.0, 0.0], [0.0, -na * nb * w * dp]] });
                        }
                    }
                }
                totals.electrostatic_n += w * p;
                if gap < 0.0 {
                    totals.electrostatic_contact_n += w * p;
                }
            }
            let Some(projection) = surface.project(x) else {
                self.trial[k] = PointState { arc_mm: surface.arc_at(x[0]), ..PointState::default() };
                continue;
            };
            let (n, tau) = (projection.normal, projection.tangent);
            let (pressure, stiffness) = law.pressure(projection.depth);
            // A point that was not in contact starts sticking where it touched.
            let (arc_n, t_n) =
                if previous.active { (previous.arc_mm, previous.traction_t) } else { (previous.arc_mm, 0.0) };
            let trial = t_n - law.penalty_tangential * (projection.arc_mm - arc_n);
            let limit = law.mu * pressure;
            let slipping = !force_stick && trial.abs() > limit;
            let traction = if slipping { limit * trial.signum() } else { trial };
            self.trial[k] =
                PointState { active: true, arc_mm: projection.arc_mm, traction_t: traction, pressure, slipping };

            let f = [w * (pressure * n[0] + traction * tau[0]), w * (pressure * n[1] + traction * tau[1])];
            // The tangent D = df/dx of f = w (p n + t tau) on a curved
            // surface (Wriggers, Computational Contact Mechanics, 2006, sec.
            // 4.3, for a rigid master): with the closest point moving by
            // ds = tau.dx / (1 + kappa d), dn = -kappa tau ds and dtau =
            // kappa n ds, dd = -n.dx,
            //   D = -p' n n + kappa/(1 + kappa d) (t n - p tau) tau   [geometric]
            //       - eps_T r/(1 + kappa d) tau tau       (stick)
            //       - mu p' sign(t) tau n                 (slip)
            // with r = d arc / ds of the arc coordinate. The geometric term
            // (the normal turning as the point moves) is included with
            // `law.geometric_tangent`; the solver starts each step with it
            // and drops it where Newton's method stalls (see solver.rs: on a
            // crest it is a negative stiffness, a point on a hilltop).
            let kappa = if law.geometric_tangent { projection.curvature } else { 0.0 };
            let along = 1.0 / (1.0 + projection.curvature * projection.depth);
            let geometric = [
                kappa * along * (traction * n[0] - pressure * tau[0]),
                kappa * along * (traction * n[1] - pressure * tau[1]),
            ];
            let mut d = [[0.0; 2]; 2];
            for p in 0..2 {
                for q in 0..2 {
                    let tangential = if slipping {
                        law.mu * stiffness * trial.signum() * tau[p] * n[q]
                    } else {
                        law.penalty_tangential * projection.arc_rate * along * tau[p] * tau[q]
                    };
                    d[p][q] = -w * (stiffness * n[p] * n[q] + tangential) + w * geometric[p] * tau[q];
                }
            }
            let nodes = self.segments[s];
            for (a, &na) in nodes.iter().zip(&shape) {
                forces[2 * a] += na * f[0];
                forces[2 * a + 1] += na * f[1];
                for (b, &nb) in nodes.iter().zip(&shape) {
                    let scale = na * nb;
                    blocks.push(Block {
                        i: *a,
                        j: *b,
                        d: [[scale * d[0][0], scale * d[0][1]], [scale * d[1][0], scale * d[1][1]]],
                    });
                }
            }
            totals.force[0] += f[0];
            totals.force[1] += f[1];
            totals.contact_mm += w;
            totals.active_points += 1;
            totals.slipping_points += slipping as usize;
        }
        totals
    }

    /// Accepts the trial states as converged.
    pub fn commit(&mut self) {
        self.committed.copy_from_slice(&self.trial);
    }

    /// Sets the committed arc coordinates of points out of contact from the
    /// displacement `u` (before the first step, or after a reset).
    pub fn initialize(&mut self, u: &[f64], surface: &RigidSurface, placement: SurfacePlacement) {
        for k in 0..self.points.len() {
            let x = placement.to_surface(self.position(k, u));
            self.committed[k] = PointState { arc_mm: surface.arc_at(x[0]), ..PointState::default() };
        }
        self.trial.copy_from_slice(&self.committed);
    }

    /// Integration weight (reference length, mm) of each contact point.
    pub fn point_weights(&self) -> Vec<f64> {
        self.points.iter().map(|p| p.2).collect()
    }

    /// Pressure at each contact point (committed) with its current x.
    pub fn pressure_profile(&self, u: &[f64]) -> Vec<([f64; 2], f64, f64)> {
        (0..self.points.len())
            .map(|k| (self.position(k, u), self.committed[k].pressure, self.committed[k].traction_t))
            .collect()
    }
}

/// Gauss-Legendre abscissae and weights on [-1, 1] for 1 to 4 points.
pub(crate) fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    match n {
        1 => (vec![0.0], vec![2.0]),
        2 => {
            let a = 1.0 / 3f64.sqrt();
            (vec![-a, a], vec![1.0, 1.0])
        }
        3 => {
            let a = 0.6f64.sqrt();
            (vec![-a, 0.0, a], vec![5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])
        }
        _ => {
            let a = (3.0 / 7.0 - 2.0 / 7.0 * 1.2f64.sqrt()).sqrt();
            let b = (3.0 / 7.0 + 2.0 / 7.0 * 1.2f64.sqrt()).sqrt();
            let wa = (18.0 + 30f64.sqrt()) / 36.0;
            let wb = (18.0 - 30f64.sqrt()) / 36.0;
            (vec![-b, -a, a, b], vec![wb, wa, wa, wb])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::SurfaceShape;

    fn setup() -> (ContactSet, RigidSurface, ContactLaw) {
        // One horizontal segment of length 1 at y = 0.
        let nodes = [[0.0, 0.0], [1.0, 0.0]];
        let set = ContactSet::new(&nodes, &[[0, 1]], 4);
        let surface = RigidSurface::new(&SurfaceShape::Flat, -10.0, 10.0).unwrap();
        (
            set,
            surface,
            ContactLaw {
                penalty_normal: 100.0,
                penalty_tangential: 50.0,
                mu: 0.5,
                smoothing_mm: 0.0,
                geometric_tangent: false,
                electrostatic: None,
            },
        )
    }

    #[test]
    fn uniform_penetration_gives_penalty_pressure_times_length() {
        let (mut set, surface, law) = setup();
        set.initialize(&[0.0; 4], &surface, SurfacePlacement::default());
        let u = [0.0, -0.01, 0.0, -0.01];
        let mut f = [0.0; 4];
        let mut blocks = Vec::new();
        let totals = set.evaluate(&u, &surface, SurfacePlacement::default(), &law, &mut f, &mut blocks);
        // p = 100 MPa/mm * 0.01 mm = 1 MPa over 1 mm: 1 N/mm, half per node.
        assert!((totals.force[1] - 1.0).abs() < 1e-12 && totals.force[0].abs() < 1e-15);
        assert!((f[1] - 0.5).abs() < 1e-12 && (f[3] - 0.5).abs() < 1e-12);
        assert!((totals.contact_mm - 1.0).abs() < 1e-12);
    }

    /// The tangent blocks are the derivative of the forces (finite
    /// differences, 1e-6 relative), in stick and in slip.
    /// The tangent blocks of one segment's two nodes as a 4 x 4 matrix.
    fn assembled(blocks: &[Block]) -> [[f64; 4]; 4] {
        let mut k = [[0.0; 4]; 4];
        for b in blocks {
            for p in 0..2 {
                for q in 0..2 {
                    k[2 * b.i + p][2 * b.j + q] += b.d[p][q];
                }
            }
        }
        k
    }

    #[test]
    fn tangent_matches_finite_differences() {
        for slide in [0.0001, 0.05] {
            let (mut set, surface, law) = setup();
            set.initialize(&[0.0; 4], &surface, SurfacePlacement::default());
            let placement = SurfacePlacement { slide_mm: slide, lift_mm: 0.0 };
            let u = [0.0, -0.01, 0.0, -0.012];
            let mut f0 = [0.0; 4];
            let mut blocks = Vec::new();
            set.evaluate(&u, &surface, placement, &law, &mut f0, &mut blocks);
            let k = assembled(&blocks);
            let h = 1e-7;
            for j in 0..4 {
                let mut up = u;
                up[j] += h;
                let mut f1 = [0.0; 4];
                let mut scratch = Vec::new();
                set.evaluate(&up, &surface, placement, &law, &mut f1, &mut scratch);
                for i in 0..4 {
                    let fd = (f1[i] - f0[i]) / h;
                    assert!(
                        (fd - k[i][j]).abs() < 1e-5 * (1.0 + k[i][j].abs()),
                        "slide {slide}: K[{i}][{j}] = {} vs fd {fd}",
                        k[i][j]
                    );
                }
            }
        }
    }

    /// The same on a curved surface, where the normal and the tangent turn
    /// with the closest point (the tangent with its geometric term is the
    /// exact derivative): a segment pressed into the flank and into the
    /// crest of a bump, in stick and in slip (finite differences, 1e-5 of
    /// the largest entry).
    #[test]
    fn tangent_matches_finite_differences_on_a_curved_surface() {
        let surface = RigidSurface::new(&SurfaceShape::Bump { x0: 0.0, width: 1.5, height: 0.3 }, -5.0, 5.0).unwrap();
        let law = ContactLaw {
            penalty_normal: 200.0,
            penalty_tangential: 100.0,
            mu: 0.5,
            smoothing_mm: 2e-4,
            geometric_tangent: true,
            electrostatic: None,
        };
        for (a, b) in [(0.2, 0.45), (-0.1, 0.12)] {
            let bump = SurfaceShape::Bump { x0: 0.0, width: 1.5, height: 0.3 };
            let nodes = [[a, bump.height(a)], [b, bump.height(b)]];
            // The surface moving towards +x keeps the flank's points in contact.
            for slide in [-0.00001, -0.02] {
                let mut set = ContactSet::new(&nodes, &[[0, 1]], 4);
                set.initialize(&[0.0; 4], &surface, SurfacePlacement::default());
                let placement = SurfacePlacement { slide_mm: slide, lift_mm: 0.0 };
                let u = [0.001, -0.004, -0.0005, -0.006];
                let mut f0 = [0.0; 4];
                let mut blocks = Vec::new();
                let totals = set.evaluate(&u, &surface, placement, &law, &mut f0, &mut blocks);
                assert_eq!(totals.active_points, 4);
                assert_eq!(totals.slipping_points, if slide < -0.01 { 4 } else { 0 }, "slide {slide}");
                let k = assembled(&blocks);
                let h = 1e-8;
                for j in 0..4 {
                    let (mut up, mut down) = (u, u);
                    up[j] += h;
                    down[j] -= h;
                    let (mut f1, mut f2) = ([0.0; 4], [0.0; 4]);
                    let mut scratch = Vec::new();
                    set.evaluate(&up, &surface, placement, &law, &mut f1, &mut scratch);
                    set.evaluate(&down, &surface, placement, &law, &mut f2, &mut scratch);
                    let scale = k.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
                    for i in 0..4 {
                        let fd = (f1[i] - f2[i]) / (2.0 * h);
                        assert!(
                            (fd - k[i][j]).abs() < 1e-5 * scale,
                            "segment {a}..{b}, slide {slide}: K[{i}][{j}] = {} vs fd {fd}",
                            k[i][j]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn sliding_saturates_at_coulomb() {
        let (mut set, surface, law) = setup();
        set.initialize(&[0.0; 4], &surface, SurfacePlacement::default());
        let u = [0.0, -0.01, 0.0, -0.01];
        let mut f = [0.0; 4];
        let mut blocks = Vec::new();
        // The surface moves 0.1 mm towards -x under the fixed points: they slip.
        let totals =
            set.evaluate(&u, &surface, SurfacePlacement { slide_mm: 0.1, lift_mm: 0.0 }, &law, &mut f, &mut blocks);
        assert_eq!(totals.slipping_points, 4);
        assert!((totals.force[0] / totals.force[1] + 0.5).abs() < 1e-12, "{:?}", totals.force);
    }
}
