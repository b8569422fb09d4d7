//! A structured mesher for ring-shaped domains: the region between a closed
//! outer curve and a closed inner curve, given as a map
//! (phi, t) -> (x, y) with the angular parameter phi running
//! counter-clockwise around the ring and the radial coordinate t growing
//! from the outer curve (t = 0) inwards.
//!
//! Nodes lie on rows of constant t. Between two rows the mesh is either a
//! band of regular quadrilaterals or a 3-to-1 *transition* band, which
//! coarsens the angular spacing by three over a range of the ring with the
//! 4-quad template (Schneiders, "Refining quadrilateral and hexahedral
//! element meshes", 1996):
//!
//! ```text
//!   A-----------------D      row r+1 (coarse)
//!   |\_             _/|
//!   |  p---------q    |      mid row (2 extra nodes)
//!   |  |         |    |
//!   a--b---------c----d      row r   (fine)
//! ```
//!
//! quads (a,b,p,A), (b,c,q,p), (c,d,D,q), (p,q,D,A). So the fine angular
//! spacing needed at a contact surface does not propagate to the inner
//! curve as needle-shaped elements.

use haptex_core::num::Num;

use crate::mesh::{Mesh, MeshError};

/// A 3-to-1 coarsening between row `after_row` and the next row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    /// Index of the finer row.
    pub after_row: usize,
    /// Range of the finer row's loop that is coarsened: first node index and
    /// number of segments (a multiple of 3); `None` for the whole loop (whose
    /// node count must then be a multiple of 3).
    pub range: Option<(usize, usize)>,
}

/// Everything the ring mesher needs.
pub struct RingSpec<'a> {
    /// Position of the point with angular parameter phi at radial coordinate t.
    pub map: &'a dyn Fn(f64, f64) -> [f64; 2],
    /// Angular parameters of the outer row's nodes, increasing, spanning
    /// less than one turn (the loop closes from the last back to the first).
    pub phis: Vec<f64>,
    /// Radial coordinates of the node rows, increasing; `rows[0]` is the
    /// outer curve, the last the inner curve.
    pub rows: Vec<f64>,
    pub transitions: Vec<Transition>,
    /// Subdomain of an element from its centroid's (phi, t).
    pub subdomain: &'a dyn Fn(f64, f64) -> u8,
}

/// A generated ring mesh, with each node's (phi, t).
#[derive(Debug, Clone)]
pub struct RingMesh {
    pub mesh: Mesh,
    pub params: Vec<[f64; 2]>,
}

/// Most nodes a ring mesh, and most angular nodes a contour, may have: a
/// bound on the memory a specification can ask for (the finger's finest
/// mesh has about 6000 nodes, 500 of them around the contour).
pub const MAX_NODES: usize = 1_000_000;
pub const MAX_CONTOUR_NODES: usize = 100_000;

/// Builds the mesh of a ring.
pub fn mesh_ring(spec: &RingSpec<'_>) -> Result<RingMesh, MeshError> {
    let fail = |m: String| Err(MeshError::Generation(m));
    if spec.phis.len() < 3 || spec.rows.len() < 2 {
        return fail("a ring needs at least 3 angular nodes and 2 rows".into());
    }
    if spec.phis.iter().chain(&spec.rows).any(|v| !v.is_finite()) {
        return fail("angular parameters and rows must be finite numbers".into());
    }
    let n_nodes = spec.phis.len() as f64 * spec.rows.len() as f64;
    if n_nodes > MAX_NODES as f64 {
        return fail(format!(
            "{} angular nodes x {} rows is more than {MAX_NODES} nodes",
            spec.phis.len(),
            spec.rows.len()
        ));
    }
    if spec.phis.windows(2).any(|w| w[1] <= w[0]) || spec.rows.windows(2).any(|w| w[1] <= w[0]) {
        return fail("angular parameters and rows must be increasing".into());
    }
    let turn = spec.phis[spec.phis.len() - 1] - spec.phis[0];
    if turn >= std::f64::consts::TAU {
        return fail("angular parameters span a full turn or more".into());
    }

    let mut builder = Builder { spec, mesh: Mesh::default(), params: Vec::new() };
    // Each row: the loop of (phi, node) pairs.
    let mut row: Vec<(f64, usize)> = spec.phis.iter().map(|&phi| (phi, builder.node(phi, spec.rows[0]))).collect();
    builder.mesh.outer = row.iter().map(|&(_, n)| n).collect();

    for r in 0..spec.rows.len() - 1 {
        let (t0, t1) = (spec.rows[r], spec.rows[r + 1]);
        let transition = spec.transitions.iter().find(|tr| tr.after_row == r);
        row = match transition {
            None => builder.regular_band(&row, t1),
            Some(tr) => {
                let (start, count) = tr.range.unwrap_or((0, row.len()));
                if count % 3 != 0 || count > row.len() || start >= row.len() {
                    return fail(format!(
                        "transition after row {r}: {count} segments from node {start} of a {}-node loop \
                         (need a multiple of 3 within the loop)",
                        row.len()
                    ));
                }
                builder.transition_band(&row, t0, t1, start, count)
            }
        };
    }
    builder.mesh.inner = row.iter().map(|&(_, n)| n).collect();
    // Check every element once here, so a bad spec fails at generation
    // (saying where).
    if let Err(e) = builder.mesh.geometry() {
        return Err(match e {
            MeshError::Jacobian { element, cause } => {
                let x = builder.mesh.element_coords(element);
                let at = [0, 1].map(|k| x.iter().map(|p| 1000.0 * p[k] / 4.0).sum::<f64>().round() / 1000.0);
                MeshError::Inverted { element, at, cause }
            }
            other => other,
        });
    }
    Ok(RingMesh { mesh: builder.mesh, params: builder.params })
}

struct Builder<'s, 'a> {
    spec: &'s RingSpec<'a>,
    mesh: Mesh,
    params: Vec<[f64; 2]>,
}

impl Builder<'_, '_> {
    fn node(&mut self, phi: f64, t: f64) -> usize {
        self.mesh.nodes.push((self.spec.map)(phi, t));
        self.params.push([phi, t]);
        self.mesh.nodes.len() - 1
    }

    fn element(&mut self, nodes: [usize; 4]) {
        let (mut phi, mut t) = (0.0, 0.0);
        for &n in &nodes {
            phi += self.params[n][0] / 4.0;
            t += self.params[n][1] / 4.0;
        }
        // The loop's last segment wraps around: unwrap before averaging.
        let phis = nodes.map(|n| self.params[n][0]);
        let lo = phis.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = phis.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if hi - lo > std::f64::consts::PI {
            phi = phis
                .iter()
                .map(|&p| if p < lo + std::f64::consts::PI { p + std::f64::consts::TAU } else { p })
                .sum::<f64>()
                / 4.0;
        }
        self.mesh.subdomain.push((self.spec.subdomain)(phi, t));
        self.mesh.elements.push(nodes);
    }

    fn regular_band(&mut self, row: &[(f64, usize)], t1: f64) -> Vec<(f64, usize)> {
        let next: Vec<(f64, usize)> = row.iter().map(|&(phi, _)| (phi, self.node(phi, t1))).collect();
        let n = row.len();
        for k in 0..n {
            let k1 = (k + 1) % n;
            self.element([row[k].1, row[k1].1, next[k1].1, next[k].1]);
        }
        next
    }

    fn transition_band(
        &mut self,
        row: &[(f64, usize)],
        t0: f64,
        t1: f64,
        start: usize,
        count: usize,
    ) -> Vec<(f64, usize)> {
        let n = row.len();
        let offset = |k: usize| (k + n - start) % n;
        let in_range = |k: usize| offset(k) < count;
        // The coarse row keeps every node except the two middle nodes of
        // each coarsened triple (offsets 3j+1 and 3j+2 within the range).
        let mut next_index = vec![usize::MAX; n];
        let mut next = Vec::with_capacity(n);
        for k in 0..n {
            if !(in_range(k) && offset(k) % 3 != 0) {
                next_index[k] = next.len();
                let phi = row[k].0;
                next.push((phi, self.node(phi, t1)));
            }
        }
        let tm = 0.5 * (t0 + t1);
        let mut k = start;
        let mut done = 0;
        while done < n {
            let k1 = (k + 1) % n;
            if in_range(k) {
                let (k2, k3) = ((k + 2) % n, (k + 3) % n);
                let (a, b, c, d) = (row[k].1, row[k1].1, row[k2].1, row[k3].1);
                let big_a = next[next_index[k]].1;
                let big_d = next[next_index[k3]].1;
                let p = self.node(row[k1].0 + wrap(row[k1].0, row[k].0), tm);
                let q = self.node(row[k2].0 + wrap(row[k2].0, row[k].0), tm);
                self.element([a, b, p, big_a]);
                self.element([b, c, q, p]);
                self.element([c, d, big_d, q]);
                self.element([p, q, big_d, big_a]);
                k = k3;
                done += 3;
            } else {
                self.element([row[k].1, row[k1].1, next[next_index[k1]].1, next[next_index[k]].1]);
                k = k1;
                done += 1;
            }
        }
        next
    }
}

/// 0, or the turn to add so that `phi` is not behind `reference` (for the
/// segment that wraps around the loop's end).
fn wrap(phi: f64, reference: f64) -> f64 {
    if phi < reference { std::f64::consts::TAU } else { 0.0 }
}

/// Angular parameters for a ring whose outer curve is `contour(phi)`
/// (phi in [0, 2 pi), phi = 0 the middle of the pad): `n_fine` segments of
/// at most `pad_spacing` (arc length) over the pad (arc +-`half_arc` around
/// phi = 0, starting at index 0; a multiple of 18, so that two 3-to-1
/// transitions fit and a node sits at phi = 0), then a spacing growing
/// linearly (rate 0.25) with the distance from the pad up to
/// `coarse_spacing`. The total count is a multiple of 3. Returns the
/// parameters (increasing from -phi_pad) and `n_fine`. The pad must leave
/// at least a fifth of the perimeter to the coarse part, and the count is
/// at most [`MAX_CONTOUR_NODES`].
pub fn contour_parameters(
    contour: &dyn Fn(f64) -> [f64; 2],
    half_arc: f64,
    pad_spacing: f64,
    coarse_spacing: f64,
) -> Result<(Vec<f64>, usize), MeshError> {
    let fail = |m: String| Err(MeshError::Generation(m));
    if !(half_arc.is_finite() && half_arc > 0.0) {
        return fail(format!("the pad's half-arc must be a positive length, got {} mm", Num(half_arc)));
    }
    if !(pad_spacing.is_finite() && pad_spacing > 0.0 && coarse_spacing.is_finite() && coarse_spacing > 0.0) {
        return fail(format!(
            "node spacings must be positive lengths, got {} and {} mm",
            Num(pad_spacing),
            Num(coarse_spacing)
        ));
    }
    // Arc length of the contour as a function of phi, tabulated.
    let table_n = 20_000;
    let mut phis = Vec::with_capacity(table_n + 1);
    let mut arcs = Vec::with_capacity(table_n + 1);
    let mut s = 0.0;
    let mut prev = contour(0.0);
    for i in 0..=table_n {
        let phi = std::f64::consts::TAU * i as f64 / table_n as f64;
        let p = contour(phi);
        s += (p[0] - prev[0]).hypot(p[1] - prev[1]);
        prev = p;
        phis.push(phi);
        arcs.push(s);
    }
    let perimeter = s;
    if !(perimeter.is_finite() && perimeter > 0.0) {
        return fail(format!("the contour's perimeter is {} mm", Num(perimeter)));
    }
    let phi_at = |arc: f64| haptex_core::profile::interpolate(&arcs, &phis, arc.rem_euclid(perimeter));
    let half = half_arc;
    if half > 0.4 * perimeter {
        return fail(format!(
            "the pad's half-arc {} mm is more than 0.4 of the contour's perimeter ({} mm)",
            Num(half),
            Num(perimeter)
        ));
    }
    let fine_count = (18.0 * (2.0 * half / (18.0 * pad_spacing)).ceil()).max(18.0);
    let coarse_length = perimeter - 2.0 * half;
    // At least the count of the coarse part at the coarse spacing.
    if fine_count + coarse_length / coarse_spacing > MAX_CONTOUR_NODES as f64 {
        return fail(format!(
            "a contour of {} mm at a pad spacing of {} mm over +-{} mm needs more than {MAX_CONTOUR_NODES} nodes",
            Num(perimeter),
            Num(pad_spacing),
            Num(half)
        ));
    }
    let n_fine = fine_count as usize;
    let h = |u: f64| (pad_spacing + 0.25 * u.min(coarse_length - u)).min(coarse_spacing);
    let steps = 10_000;
    let mut cumulative = vec![0.0; steps + 1];
    for i in 0..steps {
        let u = coarse_length * (i as f64 + 0.5) / steps as f64;
        cumulative[i + 1] = cumulative[i] + coarse_length / steps as f64 / h(u);
    }
    if cumulative[steps] + n_fine as f64 > MAX_CONTOUR_NODES as f64 {
        return fail(format!(
            "a contour of {} mm with {} mm nodes growing to {} mm needs more than {MAX_CONTOUR_NODES} nodes",
            Num(perimeter),
            Num(pad_spacing),
            Num(coarse_spacing)
        ));
    }
    let mut n_coarse = cumulative[steps].round().max(3.0) as usize;
    while !(n_fine + n_coarse).is_multiple_of(3) {
        n_coarse += 1;
    }
    let us: Vec<f64> = (0..=steps).map(|i| coarse_length * i as f64 / steps as f64).collect();
    let total = cumulative[steps];
    let mut params = Vec::with_capacity(n_fine + n_coarse);
    for k in 0..n_fine {
        let arc = -half + 2.0 * half * k as f64 / n_fine as f64;
        let phi = phi_at(arc);
        params.push(if arc < 0.0 { phi - std::f64::consts::TAU } else { phi });
    }
    for k in 0..n_coarse {
        let u = haptex_core::profile::interpolate(&cumulative, &us, total * k as f64 / n_coarse as f64);
        params.push(phi_at(half + u));
    }
    Ok((params, n_fine))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn annulus(n: usize, rows: Vec<f64>, transitions: Vec<Transition>) -> RingMesh {
        let map = |phi: f64, t: f64| {
            let r = 2.0 - t;
            [r * phi.cos(), r * phi.sin()]
        };
        let phis: Vec<f64> = (0..n).map(|i| std::f64::consts::TAU * i as f64 / n as f64).collect();
        mesh_ring(&RingSpec { map: &map, phis, rows, transitions, subdomain: &|_, _| 0 }).unwrap()
    }

    fn total_area(m: &Mesh) -> f64 {
        m.geometry().unwrap().iter().map(|q| q.area).sum()
    }

    #[test]
    fn regular_annulus_counts_and_area() {
        let m = annulus(24, vec![0.0, 0.5, 1.0], vec![]).mesh;
        assert_eq!((m.n_nodes(), m.n_elements()), (72, 48));
        assert_eq!((m.outer.len(), m.inner.len()), (24, 24));
        // Polygonal annulus area: (n/2) sin(2 pi/n) (R^2 - r^2).
        let exact = 12.0 * (std::f64::consts::TAU / 24.0).sin() * (4.0 - 1.0);
        assert!((total_area(&m) - exact).abs() < 1e-12);
    }

    #[test]
    fn global_and_partial_transitions_are_conforming() {
        let full = annulus(
            27,
            vec![0.0, 0.3, 0.6, 1.0],
            vec![Transition { after_row: 0, range: None }, Transition { after_row: 1, range: Some((0, 3)) }],
        );
        let m = &full.mesh;
        assert_eq!(m.outer.len(), 27);
        assert_eq!(m.inner.len(), 7);
        // Conformity: every interior edge is shared by exactly two elements,
        // boundary edges (outer + inner loops) by one.
        let mut edges = std::collections::HashMap::new();
        for el in &m.elements {
            for i in 0..4 {
                let (a, b) = (el[i], el[(i + 1) % 4]);
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        let boundary = edges.values().filter(|&&c| c == 1).count();
        assert!(edges.values().all(|&c| c == 1 || c == 2));
        assert_eq!(boundary, m.outer.len() + m.inner.len());
        // The area is that of the polygon between the two loops.
        let polygon = |loop_: &[usize]| -> f64 {
            (0..loop_.len())
                .map(|i| {
                    let (p, q) = (m.nodes[loop_[i]], m.nodes[loop_[(i + 1) % loop_.len()]]);
                    p[0] * q[1] - q[0] * p[1]
                })
                .sum::<f64>()
                / 2.0
        };
        assert!((total_area(m) - (polygon(&m.outer) - polygon(&m.inner))).abs() < 1e-12);
    }
}
