//! Multilinear interpolation over a model matrix whose inputs form a full
//! tensor grid (every combination of each input's values is one row, as in
//! the FE database's sweep): the estimate between the rows that is exact at
//! every row and linear along each input between neighbouring values.
//!
//! An alternative to the CAE ([`crate::cae`]) for grid databases, measured
//! against fresh FE runs on random members (`haptex db validate
//! --estimator grid`, docs/database.md): the CAE's leave-one-out width is
//! chosen by predicting each row from neighbours a whole grid step away,
//! which favours narrow kernels that, between rows, are nearly the nearest
//! row. Outside an input's range the value at its end is held.
//!
//! Profiles of a periodic feature can be blended in phase
//! ([`GridInterpolation::in_phase`]): a sine grating's profile at period P
//! is, once the contact has entered it, close to a function of xi / P, so
//! each node's profile is first resampled at the query's phase (xi P_node /
//! P_query) and only then weighted. Blended on the absolute xi axis,
//! profiles of neighbouring periods are out of step and their sum smears
//! the modulation it should interpolate (docs/database.md, "The sine in
//! phase").

use crate::cae::ModelMatrix;

/// Most inputs of a grid (2^16 corners per query).
pub const MAX_INPUTS: usize = 16;

/// The grid of a model matrix: each input's sorted distinct values and the
/// row of every node.
#[derive(Debug, Clone, PartialEq)]
pub struct GridInterpolation {
    axes: Vec<Vec<f64>>,
    /// The row at each node, the last input varying fastest.
    rows: Vec<usize>,
    /// The input that is the outputs' period, if they are blended in phase.
    phase: Option<Phase>,
}

/// Outputs sampled at positions `start + k step` (k = 0 .. M - 1) of a
/// feature whose period is input `input`, phase 0 at position 0.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Phase {
    input: usize,
    start: f64,
    step: f64,
}

/// Why a model matrix cannot have a grid estimate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// Its model vectors are not a full tensor grid.
    #[error("the model vectors are not a full grid: {0}")]
    NotAGrid(String),
    /// Its outputs cannot be blended in phase ([`GridInterpolation::in_phase`]).
    #[error("the outputs cannot be blended in phase: {0}")]
    Phase(String),
}

impl GridInterpolation {
    /// The grid of `matrix`, or why it is not one: a node without a row or
    /// a node with two. An input with a single value is set aside.
    pub fn new(matrix: &ModelMatrix) -> Result<Self, GridError> {
        let d = matrix.d();
        if d > MAX_INPUTS {
            return Err(GridError::NotAGrid(format!("{d} inputs, at most {MAX_INPUTS}")));
        }
        let axes: Vec<Vec<f64>> = (0..d)
            .map(|l| {
                let mut v: Vec<f64> = (0..matrix.n()).map(|n| matrix.input_row(n)[l]).collect();
                v.sort_by(f64::total_cmp);
                v.dedup();
                v
            })
            .collect();
        let nodes = axes.iter().try_fold(1usize, |p, a| p.checked_mul(a.len()));
        if nodes != Some(matrix.n()) {
            return Err(GridError::NotAGrid(format!(
                "{} rows for {} combinations of the inputs' values",
                matrix.n(),
                nodes.map_or_else(|| "too many".to_string(), |n| n.to_string())
            )));
        }
        let mut rows = vec![usize::MAX; matrix.n()];
        for n in 0..matrix.n() {
            let node = matrix.input_row(n).iter().zip(&axes).fold(0usize, |index, (v, axis)| {
                index * axis.len() + axis.binary_search_by(|a| a.total_cmp(v)).expect("the axis holds every value")
            });
            if rows[node] != usize::MAX {
                return Err(GridError::NotAGrid(format!("rows {} and {} have the same inputs", rows[node] + 1, n + 1)));
            }
            rows[node] = n;
        }
        Ok(Self { axes, rows, phase: None })
    }

    /// This grid with the outputs blended in phase: they are a profile
    /// sampled at positions `start + k step` (k = 0 .. M - 1, M the
    /// outputs of the matrix it is used with) of a periodic feature whose
    /// period is input `input` and whose phase is 0 at position 0. A node's
    /// profile enters the estimate at the query's phase, read at xi P_node
    /// / P_query by linear interpolation between its samples; a position
    /// that falls beyond the samples is read a whole number of the node's
    /// periods back inside them (the profile is periodic there, the
    /// feature extending past the samples), or, for a period longer than
    /// the samples, at their end. At a node's own period it is its row.
    /// The query's period is held at the axis's ends, as every input is.
    pub fn in_phase(mut self, input: usize, start: f64, step: f64) -> Result<Self, GridError> {
        let axis = self.axes.get(input).ok_or_else(|| {
            GridError::Phase(format!("no input {} of {} to take as the period", input + 1, self.axes.len()))
        })?;
        if let Some(p) = axis.iter().find(|p| !(p.is_finite() && **p > 0.0)) {
            return Err(GridError::Phase(format!("a period of {p}: the periods must be positive")));
        }
        if !(start.is_finite() && step.is_finite() && step > 0.0) {
            return Err(GridError::Phase(format!(
                "positions from {start} in steps of {step}: need a finite start and a positive step"
            )));
        }
        self.phase = Some(Phase { input, start, step });
        Ok(self)
    }

    /// Whether the outputs are blended in phase ([`Self::in_phase`]).
    pub fn is_in_phase(&self) -> bool {
        self.phase.is_some()
    }

    /// Each input's grid values.
    pub fn axes(&self) -> &[Vec<f64>] {
        &self.axes
    }

    /// The multilinear interpolant of `matrix`'s outputs at `query` (D
    /// finite values, checked by the caller) into `out` (M values), without
    /// allocation: the 2^D nodes around the query, weighted by the products
    /// of the linear weights along each input; at a node, its row exactly.
    pub fn predict_into(&self, matrix: &ModelMatrix, query: &[f64], out: &mut [f64]) {
        let d = self.axes.len();
        debug_assert!(query.len() == d && out.len() == matrix.m());
        // Per input: the lower node of the bracket and the weight of the upper.
        let mut lower = [0usize; MAX_INPUTS];
        let mut t = [0.0f64; MAX_INPUTS];
        for (l, (axis, &q)) in self.axes.iter().zip(query).enumerate() {
            if axis.len() == 1 {
                // A constant input (one value in the sweep): set aside, as the CAE does.
                (lower[l], t[l]) = (0, 0.0);
                continue;
            }
            let j = axis.partition_point(|&a| a <= q).clamp(1, axis.len() - 1) - 1;
            lower[l] = j;
            t[l] = ((q - axis[j]) / (axis[j + 1] - axis[j])).clamp(0.0, 1.0);
        }
        // The query's period, held at the axis's ends.
        let period = self.phase.map(|p| {
            let axis = &self.axes[p.input];
            query[p.input].clamp(axis[0], axis[axis.len() - 1])
        });
        out.fill(0.0);
        // The corner's row and weight.
        let corner_node = |corner: usize| {
            let (mut node, mut weight) = (0usize, 1.0f64);
            for (l, axis) in self.axes.iter().enumerate() {
                let upper = corner >> (d - 1 - l) & 1 == 1;
                // (An upper node beyond a constant input's one value has weight 0.)
                node = node * axis.len() + (lower[l] + usize::from(upper)).min(axis.len() - 1);
                weight *= if upper { t[l] } else { 1.0 - t[l] };
            }
            (self.rows[node], weight)
        };
        let (Some(phase), Some(period)) = (self.phase, period) else {
            for corner in 0..(1usize << d) {
                let (row, weight) = corner_node(corner);
                if weight != 0.0 {
                    for (o, &c) in out.iter_mut().zip(matrix.output_row(row)) {
                        *o += weight * c;
                    }
                }
            }
            return;
        };
        // In phase: the corners on each side of the period's bracket share
        // one reading position per output, found once for all of them.
        let bit = d - 1 - phase.input;
        let axis = &self.axes[phase.input];
        for side in 0..2 {
            let node_period = axis[(lower[phase.input] + side).min(axis.len() - 1)];
            let reading = Reading::new(phase.start, phase.step, node_period, period, out.len());
            let mut group: [(&[f64], f64); GROUP] = [(&[], 0.0); GROUP];
            let mut count = 0;
            for corner in (0..(1usize << d)).filter(|c| c >> bit & 1 == side) {
                let (row, weight) = corner_node(corner);
                if weight != 0.0 {
                    group[count] = (matrix.output_row(row), weight);
                    count += 1;
                }
                if count == GROUP {
                    reading.add(&group, out);
                    count = 0;
                }
            }
            reading.add(&group[..count], out);
        }
    }
}

/// Corners of the multilinear estimate read together on one side of the
/// period's bracket (2^(D-1) of them: 4 for the database's 3 inputs).
const GROUP: usize = 64;

/// Where output k of a profile sampled at xi_k = start + k step, of a
/// feature of period `row_period` (phase 0 at xi = 0), is read to put it
/// at the phase of period `period`: at xi_k row_period / period, moved back
/// inside the samples by whole periods `row_period` (or held at the end
/// when one period is longer than the samples), as sample j and the
/// fraction f of the way to sample j + 1. In units of the samples that
/// position is u_k = u_0 + k ratio, with no division per output.
struct Reading {
    u0: f64,
    ratio: f64,
    /// The row's period in samples.
    period: f64,
    last: f64,
    m: usize,
}

impl Reading {
    fn new(start: f64, step: f64, row_period: f64, period: f64, m: usize) -> Self {
        let ratio = row_period / period;
        Self { u0: start * (ratio - 1.0) / step, ratio, period: row_period / step, last: m.saturating_sub(1) as f64, m }
    }

    #[inline(always)]
    fn at(&self, k: usize) -> (usize, f64) {
        let mut u = self.u0 + k as f64 * self.ratio;
        if u > self.last {
            u -= ((u - self.last) / self.period).ceil() * self.period;
        } else if u < 0.0 {
            u += (-u / self.period).ceil() * self.period;
        }
        let u = u.clamp(0.0, self.last);
        let j = (u as usize).min(self.m - 2);
        (j, u - j as f64)
    }

    /// out_k += sum over `group` of weight row(reading k): rows (M samples
    /// each) of the same period, read at one position per output. At a
    /// ratio of 1, or with fewer than two samples, the rows as they are.
    fn add(&self, group: &[(&[f64], f64)], out: &mut [f64]) {
        if self.ratio == 1.0 || self.m < 2 {
            for &(row, weight) in group {
                for (o, &c) in out.iter_mut().zip(row) {
                    *o += weight * c;
                }
            }
            return;
        }
        for (k, o) in out.iter_mut().enumerate().take(self.m) {
            let (j, f) = self.at(k);
            let (mut a, mut b) = (0.0, 0.0);
            for &(c, weight) in group {
                a += weight * c[j];
                b += weight * c[j + 1];
            }
            *o += a + f * (b - a);
        }
    }
}

/// out_k += weight row(xi_k P_row / P), xi_k = start + k step: a profile
/// `row` of a periodic feature of period `row_period` (phase 0 at xi = 0),
/// sampled at the xi_k, added at the phase of period `period`
/// ([`GridInterpolation::in_phase`]). Read between its samples linearly; a
/// position beyond them is moved back by whole periods `row_period` (or
/// held at the end when one period is longer than the samples).
pub fn add_in_phase(row: &[f64], start: f64, step: f64, row_period: f64, period: f64, weight: f64, out: &mut [f64]) {
    Reading::new(start, step, row_period, period, row.len()).add(&[(row, weight)], out);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn matrix(rows: &[[f64; 2]], f: impl Fn(f64, f64) -> [f64; 2]) -> ModelMatrix {
        let b: Vec<f64> = rows.iter().flatten().copied().collect();
        let c: Vec<f64> = rows.iter().flat_map(|r| f(r[0], r[1])).collect();
        ModelMatrix::new(vec!["a".into(), "b".into()], vec!["y".into(), "z".into()], b, c).unwrap()
    }

    /// Rows in any order; a function linear in each input separately
    /// (bilinear) is reproduced exactly inside the grid; nodes give their
    /// rows; outside, the end value is held.
    #[test]
    fn bilinear_functions_are_reproduced_and_ends_held() {
        let f = |a: f64, b: f64| [1.0 + 2.0 * a - 3.0 * b + 0.5 * a * b, -a];
        let rows = [[1.0, 10.0], [0.0, 20.0], [2.5, 10.0], [0.0, 10.0], [1.0, 20.0], [2.5, 20.0]];
        let m = matrix(&rows, f);
        let g = GridInterpolation::new(&m).unwrap();
        assert_eq!(g.axes(), &[vec![0.0, 1.0, 2.5], vec![10.0, 20.0]]);
        let mut out = [0.0; 2];
        for (a, b) in [(0.3, 12.0), (1.0, 10.0), (2.2, 19.9), (0.0, 20.0), (1.7, 15.0)] {
            g.predict_into(&m, &[a, b], &mut out);
            let want = f(a, b);
            assert!((out[0] - want[0]).abs() < 1e-12 && (out[1] - want[1]).abs() < 1e-12, "{a} {b}: {out:?}");
        }
        g.predict_into(&m, &[-4.0, 25.0], &mut out);
        assert_eq!(out, f(0.0, 20.0));
    }

    #[test]
    fn incomplete_and_repeated_grids_are_refused() {
        let f = |a: f64, b: f64| [a, b];
        let missing = matrix(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], f);
        assert!(GridInterpolation::new(&missing).unwrap_err().to_string().contains("3 rows for 4 combinations"));
        let twice = matrix(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 1.0]], f);
        assert!(GridInterpolation::new(&twice).is_err());
        // A constant input is set aside: linear along the other.
        let flat = matrix(&[[0.0, 0.0], [1.0, 0.0]], f);
        let g = GridInterpolation::new(&flat).unwrap();
        let mut out = [0.0; 2];
        g.predict_into(&flat, &[0.25, 3.0], &mut out);
        assert_eq!(out, [0.25, 0.0]);
    }

    /// A sine of period P sampled at xi from -5 to 5 mm, rows at the
    /// periods 1.0, 1.25 and 1.5 mm and two amplitudes: in phase, the
    /// estimate at a period between rows is that period's sine to the
    /// error of reading between samples (h^2 k^2 / 8 of the amplitude, k
    /// = 2 pi / P, h the step: 2.5e-4 here), at the ends too (the
    /// positions read a period back); on the absolute axis, the rows'
    /// sines are out of step and the estimate misses by a large fraction
    /// of the amplitude. At a row's period the row is returned.
    #[test]
    fn a_sine_between_periods_is_that_periods_sine_in_phase() {
        let (start, step, m) = (-5.0, 0.02, 501);
        let xi: Vec<f64> = (0..m).map(|k| start + k as f64 * step).collect();
        let profile = |p: f64, a: f64| -> Vec<f64> {
            xi.iter().map(|x| 0.5 + a * (std::f64::consts::TAU * x / p).sin()).collect()
        };
        let (mut b, mut c) = (Vec::new(), Vec::new());
        for p in [1.0, 1.25, 1.5] {
            for a in [0.05, 0.1] {
                b.extend([p, a]);
                c.extend(profile(p, a));
            }
        }
        let names = (0..m).map(|k| format!("y{k}")).collect();
        let matrix = ModelMatrix::new(vec!["p".into(), "a".into()], names, b, c).unwrap();
        let plain = GridInterpolation::new(&matrix).unwrap();
        let phased = plain.clone().in_phase(0, start, step).unwrap();
        assert!(phased.is_in_phase() && !plain.is_in_phase());
        let mut out = vec![0.0; m];
        for (p, a) in [(1.1, 0.07), (1.37, 0.1), (1.25, 0.06), (1.49, 0.05)] {
            let want = profile(p, a);
            phased.predict_into(&matrix, &[p, a], &mut out);
            let bound = a * (step * std::f64::consts::TAU / 1.0).powi(2) / 8.0 + 1e-15;
            let worst = out.iter().zip(&want).map(|(o, w)| (o - w).abs()).fold(0.0, f64::max);
            assert!(worst <= bound, "P {p}, A {a}: {worst:e} > {bound:e}");
            plain.predict_into(&matrix, &[p, a], &mut out);
            let worst = out.iter().zip(&want).map(|(o, w)| (o - w).abs()).fold(0.0, f64::max);
            if [1.1, 1.37].contains(&p) {
                assert!(worst > 0.3 * a, "P {p}: the absolute axis missed by only {worst}");
            }
        }
        phased.predict_into(&matrix, &[1.25, 0.1], &mut out);
        assert_eq!(out, profile(1.25, 0.1));
        // Beyond the axis the period is held: the end row.
        phased.predict_into(&matrix, &[2.0, 0.1], &mut out);
        assert_eq!(out, profile(1.5, 0.1));
    }

    /// Eight inputs (128 corners on each side of the period's bracket,
    /// read in groups of 64): the period's sine plus a function linear in
    /// the seven others, to the same bound.
    #[test]
    fn many_inputs_are_read_in_groups_in_phase() {
        let (start, step, m) = (-5.0, 0.02, 501);
        let d = 8;
        let mut b = Vec::new();
        let mut c = Vec::new();
        let value = |p: f64, rest: &[f64], x: f64| {
            0.5 + 0.1 * (std::f64::consts::TAU * x / p).sin() + rest.iter().map(|v| 0.01 * v).sum::<f64>()
        };
        for n in 0..(1usize << d) {
            let inputs: Vec<f64> = (0..d).map(|l| if n >> l & 1 == 1 { 1.5 } else { 1.0 }).collect();
            c.extend((0..m).map(|k| value(inputs[0], &inputs[1..], start + k as f64 * step)));
            b.extend(inputs);
        }
        let inputs = (0..d).map(|l| format!("i{l}")).collect();
        let outputs = (0..m).map(|k| format!("y{k}")).collect();
        let matrix = ModelMatrix::new(inputs, outputs, b, c).unwrap();
        let g = GridInterpolation::new(&matrix).unwrap().in_phase(0, start, step).unwrap();
        let query = [1.2, 1.1, 1.3, 1.25, 1.05, 1.45, 1.4, 1.15];
        let mut out = vec![0.0; m];
        g.predict_into(&matrix, &query, &mut out);
        let bound = 0.1 * (step * std::f64::consts::TAU / 1.0).powi(2) / 8.0 + 1e-14;
        for (k, o) in out.iter().enumerate() {
            let want = value(query[0], &query[1..], start + k as f64 * step);
            assert!((o - want).abs() <= bound, "output {k}: {o} against {want}");
        }
    }

    #[test]
    fn a_period_must_be_a_positive_input() {
        let matrix = ModelMatrix::new(
            vec!["p".into(), "a".into()],
            vec!["y".into()],
            vec![0.0, 1.0, 1.0, 1.0, 0.0, 2.0, 1.0, 2.0],
            vec![1.0, 2.0, 3.0, 4.0],
        )
        .unwrap();
        let g = GridInterpolation::new(&matrix).unwrap();
        let error = g.clone().in_phase(2, 0.0, 1.0).unwrap_err().to_string();
        assert!(error.starts_with("the outputs cannot be blended in phase: no input 3 of 2"), "{error}");
        assert!(g.clone().in_phase(0, 0.0, 1.0).unwrap_err().to_string().contains("must be positive"));
        assert!(g.clone().in_phase(1, 0.0, 0.0).unwrap_err().to_string().contains("positive step"));
        assert!(g.in_phase(1, 0.0, 1.0).is_ok());
    }
}
