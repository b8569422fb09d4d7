#![allow(clippy::needless_range_loop)] // dense p x p algebra reads best by index
//! Robust nonlinear least squares with cluster-robust intervals: the one
//! fitting engine behind every calibration model.
//!
//! - **Fit**: an M-estimator with Huber's loss (tuning constant 1.345
//!   robust standard deviations: 95% efficiency at Gaussian noise; Huber
//!   1981, Robust Statistics), by iteratively reweighted least squares,
//!   each weighted problem solved by Levenberg-Marquardt (Marquardt 1963)
//!   with a forward-difference Jacobian and box bounds. The noise scale is
//!   the residuals' median absolute deviation times 1.4826. A measurement
//!   far from the model is down-weighted, never deleted, and reported.
//! - **Intervals**: Wald intervals from the sandwich covariance of the
//!   M-estimator, A^-1 B A^-1 with A = sum psi'(r_i) J_i J_i^T and B the sum
//!   over clusters of the outer products of sum psi(r_i) J_i (Huber 1967;
//!   the cluster-robust form of Liang and Zeger 1986), with the CR1
//!   small-sample factor G/(G - 1) (n - 1)/(n - p) and Student's t on
//!   G - 1 degrees of freedom (Cameron and Miller 2015, J. Human Resources
//!   50(2), "A practitioner's guide to cluster-robust inference"). Rows of
//!   one cluster (a finger, a stroke) may share an error; clusters are
//!   independent. With one row per cluster this is the heteroscedasticity-
//!   robust (HC1) covariance.
//!
//! The model is given as a function that fills the predictions of every
//! row for a parameter vector, so that it can share work between rows
//! (the circuit's gain is computed once per carrier, not once per row).

/// Huber's tuning constant, in robust standard deviations.
pub const HUBER_K: f64 = 1.345;

/// A fit that cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error(
        "{rows} measurement{} for {parameters} parameter{}: a fit needs more measurements than parameters",
        if *rows == 1 { "" } else { "s" },
        if *parameters == 1 { "" } else { "s" }
    )]
    TooFewRows { rows: usize, parameters: usize },
    #[error("the model is not finite at the starting parameters")]
    NotFinite,
}

/// The result of [`fit`].
#[derive(Debug, Clone)]
pub struct Fit {
    /// The estimate.
    pub theta: Vec<f64>,
    /// Its covariance, p x p row by row (infinite where a parameter is not
    /// determined by the data).
    pub covariance: Vec<f64>,
    /// Measured minus fitted, per row.
    pub residuals: Vec<f64>,
    /// Huber's weight per row (1: a full member; below 1: down-weighted).
    pub weights: Vec<f64>,
    /// Robust noise scale (MAD x 1.4826) of the residuals.
    pub scale: f64,
    /// Independent clusters, and the degrees of freedom of the intervals.
    pub clusters: usize,
    pub df: f64,
    /// Whether the iteration met its tolerance.
    pub converged: bool,
}

impl Fit {
    /// The standard error of parameter `j`.
    pub fn std_error(&self, j: usize) -> f64 {
        let p = self.theta.len();
        self.covariance[j * p + j].max(0.0).sqrt()
    }

    /// The half-width of parameter `j`'s two-sided interval at `level`.
    pub fn half_width(&self, j: usize, level: f64) -> f64 {
        super::distributions::t_quantile(level, self.df) * self.std_error(j)
    }
}

/// What [`fit`] is given.
pub struct Problem<'a> {
    /// Measured values per row.
    pub y: &'a [f64],
    /// Cluster index per row, 0 ..= max (rows of one cluster may share an
    /// error).
    pub cluster: &'a [usize],
    /// Starting parameters, and the box they stay in.
    pub start: Vec<f64>,
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
    /// Each parameter's typical magnitude (the Jacobian's step is 1e-7 of it).
    pub typical: Vec<f64>,
}

/// Fits `model` (fills the prediction of every row for a parameter
/// vector) to the problem's measurements (module docs).
pub fn fit(problem: &Problem<'_>, model: &dyn Fn(&[f64], &mut [f64])) -> Result<Fit, FitError> {
    let n = problem.y.len();
    let p = problem.start.len();
    if n <= p {
        return Err(FitError::TooFewRows { rows: n, parameters: p });
    }
    let clamp = |theta: &mut [f64]| {
        for j in 0..p {
            theta[j] = theta[j].clamp(problem.lower[j], problem.upper[j]);
        }
    };
    let mut theta = problem.start.clone();
    clamp(&mut theta);
    let mut pred = vec![0.0; n];
    model(&theta, &mut pred);
    if pred.iter().any(|v| !v.is_finite()) {
        return Err(FitError::NotFinite);
    }
    let residuals_of = |pred: &[f64]| -> Vec<f64> { problem.y.iter().zip(pred).map(|(y, f)| y - f).collect() };
    let mut r = residuals_of(&pred);
    let mut weights = vec![1.0; n];
    let mut jac = vec![0.0; n * p];
    let mut converged = false;
    let mut lambda = 1e-3;
    // Outer loop: Huber weights from the current residuals; inner: LM on
    // the weighted sum of squares.
    let mut scale = robust_scale(&r);
    for outer in 0..30 {
        if outer > 0 {
            scale = robust_scale(&r);
        }
        let cut = HUBER_K * scale;
        for (w, ri) in weights.iter_mut().zip(&r) {
            *w = if ri.abs() <= cut { 1.0 } else { cut / ri.abs() };
        }
        let theta_before = theta.clone();
        let mut cost = weighted_cost(&r, &weights);
        for _ in 0..50 {
            jacobian(&theta, &pred, problem, model, &mut jac);
            let (a, g) = normal_equations(&jac, &r, &weights, p, |_| 1.0);
            let mut improved = false;
            while lambda < 1e12 {
                let mut damped = a.clone();
                for j in 0..p {
                    damped[j * p + j] += lambda * a[j * p + j].max(1e-300);
                }
                let Some(step) = solve(&damped, &g, p) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut trial: Vec<f64> = theta.iter().zip(&step).map(|(t, s)| t + s).collect();
                clamp(&mut trial);
                let mut trial_pred = vec![0.0; n];
                model(&trial, &mut trial_pred);
                let trial_r = residuals_of(&trial_pred);
                let trial_cost = weighted_cost(&trial_r, &weights);
                if trial_cost.is_finite() && trial_cost <= cost {
                    let change = theta
                        .iter()
                        .zip(&trial)
                        .zip(&problem.typical)
                        .map(|((a, b), t)| ((a - b) / t).abs())
                        .fold(0.0, f64::max);
                    let relative_drop = (cost - trial_cost) / cost.max(f64::MIN_POSITIVE);
                    (theta, pred, r, cost) = (trial, trial_pred, trial_r, trial_cost);
                    lambda = (lambda * 0.3).max(1e-12);
                    improved = change > 1e-12 && relative_drop > 1e-15;
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        let change = theta
            .iter()
            .zip(&theta_before)
            .zip(&problem.typical)
            .map(|((a, b), t)| ((a - b) / t).abs())
            .fold(0.0, f64::max);
        if outer > 0 && change < 1e-9 {
            converged = true;
            break;
        }
    }
    // The sandwich at the estimate.
    jacobian(&theta, &pred, problem, model, &mut jac);
    let cut = HUBER_K * scale;
    let (bread, _) = normal_equations(&jac, &r, &weights, p, |i| if r[i].abs() <= cut { 1.0 } else { 0.0 });
    let g_count = problem.cluster.iter().copied().max().map_or(0, |m| m + 1);
    let mut score = vec![0.0; g_count * p];
    for i in 0..n {
        let psi = weights[i] * r[i];
        let c = problem.cluster[i];
        for j in 0..p {
            score[c * p + j] += psi * jac[i * p + j];
        }
    }
    let mut meat = vec![0.0; p * p];
    let mut present = vec![false; g_count];
    for &c in problem.cluster {
        present[c] = true;
    }
    let clusters = present.iter().filter(|&&p| p).count();
    for c in 0..g_count {
        let u = &score[c * p..(c + 1) * p];
        for a in 0..p {
            for b in 0..p {
                meat[a * p + b] += u[a] * u[b];
            }
        }
    }
    let clusters = clusters.max(1);
    let covariance = match inverse(&bread, p) {
        Some(inv) => {
            let correction = if clusters > 1 {
                clusters as f64 / (clusters - 1) as f64 * (n - 1) as f64 / (n - p) as f64
            } else {
                f64::INFINITY
            };
            let cov = multiply(&multiply(&inv, &meat, p), &inv, p);
            cov.iter().map(|v| v * correction).collect()
        }
        None => vec![f64::INFINITY; p * p],
    };
    let df = if clusters < n { (clusters as f64 - 1.0).max(1.0) } else { (n - p) as f64 };
    Ok(Fit { theta, covariance, residuals: r, weights, scale, clusters, df, converged })
}

/// MAD x 1.4826 of the residuals about their median; falls back to their
/// RMS (and then to the smallest positive double) when more than half of
/// them are equal.
fn robust_scale(r: &[f64]) -> f64 {
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let m = v.len() / 2;
        if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
    };
    let mut v = r.to_vec();
    let center = median(&mut v);
    let mut dev: Vec<f64> = r.iter().map(|x| (x - center).abs()).collect();
    let mad = 1.4826 * median(&mut dev);
    if mad > 0.0 {
        return mad;
    }
    let rms = (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt();
    if rms > 0.0 { rms } else { f64::MIN_POSITIVE }
}

fn weighted_cost(r: &[f64], w: &[f64]) -> f64 {
    r.iter().zip(w).map(|(r, w)| w * r * r).sum()
}

/// Forward differences, stepping inward at an upper bound.
fn jacobian(theta: &[f64], pred: &[f64], problem: &Problem<'_>, model: &dyn Fn(&[f64], &mut [f64]), jac: &mut [f64]) {
    let n = pred.len();
    let p = theta.len();
    let mut shifted = theta.to_vec();
    let mut moved = vec![0.0; n];
    for j in 0..p {
        let mut h = 1e-7 * problem.typical[j].abs().max(theta[j].abs());
        if theta[j] + h > problem.upper[j] {
            h = -h;
        }
        shifted[j] = theta[j] + h;
        model(&shifted, &mut moved);
        for i in 0..n {
            jac[i * p + j] = (moved[i] - pred[i]) / h;
        }
        shifted[j] = theta[j];
    }
}

/// sum c_i w_i J_i J_i^T and the gradient sum w_i r_i J_i.
fn normal_equations(
    jac: &[f64],
    r: &[f64],
    w: &[f64],
    p: usize,
    curvature: impl Fn(usize) -> f64,
) -> (Vec<f64>, Vec<f64>) {
    let mut a = vec![0.0; p * p];
    let mut g = vec![0.0; p];
    for (i, (&ri, &wi)) in r.iter().zip(w).enumerate() {
        let row = &jac[i * p..(i + 1) * p];
        let c = curvature(i) * wi;
        for x in 0..p {
            g[x] += wi * ri * row[x];
            for y in 0..p {
                a[x * p + y] += c * row[x] * row[y];
            }
        }
    }
    (a, g)
}

/// Solves a x = b by Gaussian elimination with partial pivoting; `None`
/// when a is singular to working precision.
fn solve(a: &[f64], b: &[f64], p: usize) -> Option<Vec<f64>> {
    let mut m = a.to_vec();
    let mut x = b.to_vec();
    let norm = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    for col in 0..p {
        let pivot = (col..p).max_by(|&i, &j| m[i * p + col].abs().total_cmp(&m[j * p + col].abs()))?;
        let size = m[pivot * p + col].abs();
        if size.is_nan() || size <= 1e-14 * norm {
            return None;
        }
        if pivot != col {
            for k in 0..p {
                m.swap(col * p + k, pivot * p + k);
            }
            x.swap(col, pivot);
        }
        for row in col + 1..p {
            let f = m[row * p + col] / m[col * p + col];
            for k in col..p {
                m[row * p + k] -= f * m[col * p + k];
            }
            x[row] -= f * x[col];
        }
    }
    for col in (0..p).rev() {
        let mut s = x[col];
        for k in col + 1..p {
            s -= m[col * p + k] * x[k];
        }
        x[col] = s / m[col * p + col];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The inverse of a p x p matrix, column by column.
fn inverse(a: &[f64], p: usize) -> Option<Vec<f64>> {
    let mut inv = vec![0.0; p * p];
    for c in 0..p {
        let mut e = vec![0.0; p];
        e[c] = 1.0;
        let col = solve(a, &e, p)?;
        for r in 0..p {
            inv[r * p + c] = col[r];
        }
    }
    Some(inv)
}

fn multiply(a: &[f64], b: &[f64], p: usize) -> Vec<f64> {
    let mut c = vec![0.0; p * p];
    for i in 0..p {
        for k in 0..p {
            let aik = a[i * p + k];
            for j in 0..p {
                c[i * p + j] += aik * b[k * p + j];
            }
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fits y = a + b x from `start`, every row its own cluster, within
    /// +-10.
    fn fit_line(x: &[f64], y: &[f64], start: [f64; 2]) -> Fit {
        let cluster: Vec<usize> = (0..y.len()).collect();
        let problem = Problem {
            y,
            cluster: &cluster,
            start: start.to_vec(),
            lower: vec![-10.0, -10.0],
            upper: vec![10.0, 10.0],
            typical: vec![1.0, 1.0],
        };
        fit(&problem, &|t, out| {
            for (o, x) in out.iter_mut().zip(x) {
                *o = t[0] + t[1] * x;
            }
        })
        .unwrap()
    }

    /// A straight line without noise is found exactly, and its intervals
    /// shrink to nothing.
    #[test]
    fn an_exact_line_is_recovered() {
        let x: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let y: Vec<f64> = x.iter().map(|x| 0.5 + 0.25 * x).collect();
        let f = fit_line(&x, &y, [1.0, 1.0]);
        assert!((f.theta[0] - 0.5).abs() < 1e-9 && (f.theta[1] - 0.25).abs() < 1e-9, "{:?}", f.theta);
        assert!(f.converged);
        assert!(f.std_error(0) < 1e-6);
    }

    /// A line with 0.01 Gaussian noise and one point 5 off: the robust fit
    /// down-weights the point instead of following it, and its noise scale
    /// is the noise's.
    #[test]
    fn an_outlier_is_down_weighted_not_followed() {
        let x: Vec<f64> = (0..50).map(|i| i as f64 / 10.0).collect();
        let mut rng = crate::recording::rng::SplitMix64::new(7);
        let mut y: Vec<f64> = x.iter().map(|x| 1.0 + 2.0 * x + 0.01 * rng.normal()).collect();
        y[10] += 5.0;
        let f = fit_line(&x, &y, [0.0, 0.0]);
        // The outlier moves an OLS intercept by 5/50 = 0.1; the robust fit
        // stays within its noise (0.01 / sqrt(50) ~ 0.0014, 5 sigma).
        assert!((f.theta[0] - 1.0).abs() < 0.01, "{:?}", f.theta);
        assert!(f.weights[10] < 0.01, "{}", f.weights[10]);
        assert!((f.scale - 0.01).abs() < 0.004, "{}", f.scale);
    }
}
