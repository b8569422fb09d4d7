//! Time-to-location resampling (paper section 2.4: "the friction profiles
//! were re-sampled to location domain").
//!
//! Every sliding segment is a set of samples (x_i, y_i) at the position
//! rate. Within a segment the samples are ordered by x (a backward segment
//! is simply read the other way; position noise can swap neighbours, so
//! they are sorted), samples at the same x are merged, and the piecewise
//! linear curve y(x) through them is averaged over the cells of a uniform
//! grid: node j at x_j = j dx stands for the cell [x_j - dx/2, x_j + dx/2],
//! and its value is the exact mean of the piecewise linear curve over that
//! cell. Where samples are denser than the grid (slow sliding) this averages
//! them (a box anti-alias filter in space); where they are sparser (fast
//! sliding) it interpolates. Only cells that lie wholly inside the segment's
//! x range get a value.
//!
//! The segments of one recording share the grid (nodes at multiples of dx),
//! so a stroke interrupted by a pause continues on the same nodes, and where
//! segments overlap (a reversal goes back over the same ground) their values
//! are averaged. Short gaps between segments (the few tenths of a mm where
//! the finger slows into and out of a pause or a reversal, no longer
//! sliding) are bridged by linear interpolation between the nodes on either
//! side, up to a maximum gap. The stroke's profile is the longest run of
//! consecutive nodes covered by a segment or a bridge.

/// Values on grid nodes `first_node, first_node + 1, ...` (x = node * dx).
#[derive(Debug, Clone, PartialEq)]
pub struct GridSeries {
    pub first_node: i64,
    /// One column per resampled quantity, all of the same length.
    pub columns: Vec<Vec<f64>>,
}

impl GridSeries {
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Node positions in mm, node * dx rounded to 1e-9 mm (so that a 0.1 mm
    /// grid reads 41.8, not 41.800000000000004).
    pub fn x_mm(&self, dx_mm: f64) -> Vec<f64> {
        (0..self.len() as i64).map(|k| ((self.first_node + k) as f64 * dx_mm * 1e9).round() / 1e9).collect()
    }
}

/// Cell averages on the grid x_j = j dx of the piecewise linear curves
/// through (x_mm[i], columns[c][i]), for one segment (see the module
/// documentation). Returns `None` when no whole cell fits in the range.
pub fn to_location_grid(x_mm: &[f64], columns: &[&[f64]], dx_mm: f64) -> Option<GridSeries> {
    let mut order: Vec<usize> = (0..x_mm.len()).collect();
    order.sort_by(|&a, &b| x_mm[a].total_cmp(&x_mm[b]));
    // Merge samples with equal x (mean of their values).
    let mut xs: Vec<f64> = Vec::with_capacity(order.len());
    let mut ys: Vec<Vec<f64>> = vec![Vec::with_capacity(order.len()); columns.len()];
    let mut count: Vec<f64> = Vec::with_capacity(order.len());
    for &i in &order {
        if xs.last() == Some(&x_mm[i]) {
            let k = xs.len() - 1;
            for (y, c) in ys.iter_mut().zip(columns) {
                y[k] += c[i];
            }
            count[k] += 1.0;
        } else {
            xs.push(x_mm[i]);
            for (y, c) in ys.iter_mut().zip(columns) {
                y.push(c[i]);
            }
            count.push(1.0);
        }
    }
    for y in &mut ys {
        for (v, c) in y.iter_mut().zip(&count) {
            *v /= c;
        }
    }
    if xs.len() < 2 {
        return None;
    }
    let (x_first, x_last) = (xs[0], xs[xs.len() - 1]);
    let first_node = ((x_first / dx_mm) + 0.5).ceil() as i64;
    let last_node = ((x_last / dx_mm) - 0.5).floor() as i64;
    if last_node < first_node {
        return None;
    }
    let out = ys
        .iter()
        .map(|y| {
            let cumulative = Cumulative::new(&xs, y);
            let mut cursor = 0;
            let mut lower = cumulative.at((first_node as f64 - 0.5) * dx_mm, &mut cursor);
            (first_node..=last_node)
                .map(|j| {
                    let upper = cumulative.at((j as f64 + 0.5) * dx_mm, &mut cursor);
                    let mean = (upper - lower) / dx_mm;
                    lower = upper;
                    mean
                })
                .collect()
        })
        .collect();
    Some(GridSeries { first_node, columns: out })
}

/// The integral from xs[0] of the piecewise linear curve through (xs, ys).
struct Cumulative<'a> {
    xs: &'a [f64],
    ys: &'a [f64],
    at_knots: Vec<f64>,
}

impl<'a> Cumulative<'a> {
    fn new(xs: &'a [f64], ys: &'a [f64]) -> Self {
        let mut at_knots = Vec::with_capacity(xs.len());
        let mut sum = 0.0;
        at_knots.push(0.0);
        for i in 1..xs.len() {
            sum += 0.5 * (ys[i] + ys[i - 1]) * (xs[i] - xs[i - 1]);
            at_knots.push(sum);
        }
        Self { xs, ys, at_knots }
    }

    /// Integral up to `x` (inside [xs[0], xs[last]], up to rounding) for
    /// increasing `x` across calls sharing `cursor`.
    fn at(&self, x: f64, cursor: &mut usize) -> f64 {
        let last = self.xs.len() - 1;
        while *cursor + 1 < last && self.xs[*cursor + 1] <= x {
            *cursor += 1;
        }
        let i = *cursor;
        let h = (x - self.xs[i]).clamp(0.0, self.xs[i + 1] - self.xs[i]);
        let slope = (self.ys[i + 1] - self.ys[i]) / (self.xs[i + 1] - self.xs[i]);
        self.at_knots[i] + h * (self.ys[i] + 0.5 * slope * h)
    }
}

/// The segments of one stroke combined on their shared grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Combined {
    pub series: GridSeries,
    /// Nodes of `series` filled by bridging gaps.
    pub bridged_nodes: usize,
}

/// Averages overlapping segments node by node, bridges gaps of at most
/// `max_gap_nodes` uncovered nodes by linear interpolation, and keeps the
/// longest run of covered nodes. All series must have the same number of
/// columns.
pub fn combine_segments(series: &[GridSeries], max_gap_nodes: usize) -> Option<Combined> {
    let first = series.iter().map(|s| s.first_node).min()?;
    let last = series.iter().map(|s| s.first_node + s.len() as i64 - 1).max()?;
    let n_columns = series[0].columns.len();
    let n = (last - first + 1) as usize;
    let mut sums = vec![vec![0.0; n]; n_columns];
    let mut counts = vec![0u32; n];
    for s in series {
        let offset = (s.first_node - first) as usize;
        for (sum, column) in sums.iter_mut().zip(&s.columns) {
            for (k, v) in column.iter().enumerate() {
                sum[offset + k] += v;
            }
        }
        for k in 0..s.len() {
            counts[offset + k] += 1;
        }
    }
    let mut values: Vec<Vec<f64>> = sums
        .iter()
        .map(|sum| sum.iter().zip(&counts).map(|(s, &c)| if c > 0 { s / f64::from(c) } else { 0.0 }).collect())
        .collect();
    let mut covered: Vec<bool> = counts.iter().map(|&c| c > 0).collect();
    // Bridge short gaps between covered nodes a and b.
    let mut previous: Option<usize> = None;
    for b in 0..n {
        if !covered[b] {
            continue;
        }
        if let Some(a) = previous
            && b - a > 1
            && b - a - 1 <= max_gap_nodes
        {
            for column in &mut values {
                for k in a + 1..b {
                    let t = (k - a) as f64 / (b - a) as f64;
                    column[k] = column[a] + t * (column[b] - column[a]);
                }
            }
            covered[a + 1..b].iter_mut().for_each(|c| *c = true);
        }
        previous = Some(b);
    }
    // Longest run of covered nodes.
    let (mut best, mut run_start) = ((0, 0), None);
    for (k, covered) in covered.iter().copied().chain([false]).enumerate() {
        match (covered, run_start) {
            (true, None) => run_start = Some(k),
            (false, Some(s)) => {
                if k - s > best.1 - best.0 {
                    best = (s, k);
                }
                run_start = None;
            }
            _ => {}
        }
    }
    let (a, b) = best;
    if b == a {
        return None;
    }
    let bridged_nodes = counts[a..b].iter().filter(|&&c| c == 0).count();
    let columns = values.iter().map(|v| v[a..b].to_vec()).collect();
    Some(Combined { series: GridSeries { first_node: first + a as i64, columns }, bridged_nodes })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_averages_of_a_line_are_its_values_at_the_nodes() {
        // The mean of a linear function over a cell is its value at the centre.
        let x: Vec<f64> = (0..40).map(|i| 0.037 + i as f64 * 0.173).collect();
        let y: Vec<f64> = x.iter().map(|x| 0.5 + 0.01 * x).collect();
        let g = to_location_grid(&x, &[&y], 0.1).unwrap();
        assert_eq!(g.first_node, 1); // cell [0.05, 0.15] is the first inside [0.037, ..]
        for (x, mu) in g.x_mm(0.1).iter().zip(&g.columns[0]) {
            assert!((mu - (0.5 + 0.01 * x)).abs() < 1e-12);
        }
        let x_last = 0.037 + 39.0 * 0.173;
        assert!(*g.x_mm(0.1).last().unwrap() + 0.05 <= x_last + 1e-12);
    }

    #[test]
    fn backward_and_unsorted_samples_give_the_same_grid() {
        let x: Vec<f64> = (0..30).map(|i| i as f64 * 0.25).collect();
        let y: Vec<f64> = x.iter().map(|x| (x * 0.7).sin()).collect();
        let forward = to_location_grid(&x, &[&y], 0.1).unwrap();
        let mut xr = x.clone();
        let mut yr = y.clone();
        xr.reverse();
        yr.reverse();
        xr.swap(3, 4);
        yr.swap(3, 4);
        assert_eq!(to_location_grid(&xr, &[&yr], 0.1).unwrap(), forward);
    }

    #[test]
    fn dense_samples_are_averaged_per_cell() {
        // A square wave sampled densely: each cell averages the samples' curve.
        let x: Vec<f64> = (0..=1000).map(|i| i as f64 * 0.001).collect();
        let y: Vec<f64> = x.iter().map(|&x| if ((x / 0.01) as i64) % 2 == 0 { 1.0 } else { 0.0 }).collect();
        let g = to_location_grid(&x, &[&y], 0.1).unwrap();
        for v in &g.columns[0] {
            assert!((v - 0.5).abs() < 0.02, "{v}");
        }
    }

    #[test]
    fn overlapping_segments_average_and_gaps_keep_the_longest_run() {
        let a = GridSeries { first_node: 0, columns: vec![vec![1.0; 5]] };
        let b = GridSeries { first_node: 3, columns: vec![vec![3.0; 4]] };
        let c = GridSeries { first_node: 20, columns: vec![vec![9.0; 2]] };
        let combined = combine_segments(&[a, b, c], 3).unwrap();
        assert_eq!(combined.series.first_node, 0);
        assert_eq!(combined.series.columns[0], [1.0, 1.0, 1.0, 2.0, 2.0, 3.0, 3.0]);
        assert_eq!(combined.bridged_nodes, 0);
    }

    #[test]
    fn short_gaps_are_bridged_linearly_long_ones_are_not() {
        let a = GridSeries { first_node: 0, columns: vec![vec![1.0; 3]] };
        let b = GridSeries { first_node: 6, columns: vec![vec![5.0; 2]] };
        let c = GridSeries { first_node: 20, columns: vec![vec![9.0; 2]] };
        let combined = combine_segments(&[a, b, c], 3).unwrap();
        assert_eq!(combined.series.first_node, 0);
        assert_eq!(combined.series.columns[0], [1.0, 1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 5.0]);
        assert_eq!(combined.bridged_nodes, 3);
    }
}
