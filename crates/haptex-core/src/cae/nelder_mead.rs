//! Nelder-Mead simplex minimization with box bounds (the method of MATLAB's
//! `fminsearch`, which the paper used to choose the CAE widths).
//!
//! The standard coefficients (Lagarias, Reeds, Wright & Wright 1998, SIAM J.
//! Optim. 9:112-147): reflection 1, expansion 2, contraction 1/2, shrink
//! 1/2. Every trial point is clamped into the box before it is evaluated.
//! It stops, like `fminsearch`, when the simplex is smaller than `x_tol` in
//! every coordinate and its function values differ by at most `f_tol`
//! relative to the best (or `f_abs` absolute), or after `max_evals`
//! evaluations. A NaN
//! function value counts as +infinity.

/// Stopping rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Largest coordinate distance from the best vertex at convergence.
    pub x_tol: f64,
    /// Largest function difference from the best vertex at convergence,
    /// relative to |f_best| ...
    pub f_tol: f64,
    /// ... or absolute (either suffices).
    pub f_abs: f64,
    /// Evaluation budget.
    pub max_evals: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self { x_tol: 1e-4, f_tol: 1e-6, f_abs: 0.0, max_evals: 400 }
    }
}

/// Where the minimizer stopped.
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    pub x: Vec<f64>,
    pub f: f64,
    pub evaluations: usize,
    pub iterations: usize,
    /// True if the tolerances were met (false: budget exhausted).
    pub converged: bool,
}

/// Minimizes `f` from `x0` with an initial simplex of `x0` plus `step[i]`
/// along each axis, within `lower <= x <= upper`.
pub fn minimize<F>(mut f: F, x0: &[f64], step: &[f64], lower: &[f64], upper: &[f64], options: Options) -> Minimum
where
    F: FnMut(&[f64]) -> f64,
{
    let dim = x0.len();
    assert!(dim > 0 && step.len() == dim && lower.len() == dim && upper.len() == dim);
    let clamp = |x: &mut Vec<f64>| {
        for i in 0..dim {
            x[i] = x[i].clamp(lower[i], upper[i]);
        }
    };
    let mut evaluations = 0;
    let mut eval = |x: &[f64], evaluations: &mut usize| {
        *evaluations += 1;
        let v = f(x);
        if v.is_nan() { f64::INFINITY } else { v }
    };

    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(dim + 1);
    let mut start = x0.to_vec();
    clamp(&mut start);
    let f0 = eval(&start, &mut evaluations);
    simplex.push((start.clone(), f0));
    for i in 0..dim {
        let mut x = start.clone();
        x[i] += step[i];
        clamp(&mut x);
        if x[i] == start[i] {
            // The step ran into a bound: go the other way.
            x[i] = (start[i] - step[i]).clamp(lower[i], upper[i]);
        }
        let fx = eval(&x, &mut evaluations);
        simplex.push((x, fx));
    }

    let mut iterations = 0;
    let mut converged = false;
    loop {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best_x, best_f) = (&simplex[0].0, simplex[0].1);
        let x_spread =
            simplex[1..].iter().flat_map(|(x, _)| x.iter().zip(best_x).map(|(a, b)| (a - b).abs())).fold(0.0, f64::max);
        let f_spread = simplex[1..].iter().map(|(_, v)| (v - best_f).abs()).fold(0.0, f64::max);
        let f_close = f_spread <= options.f_tol * best_f.abs() || f_spread <= options.f_abs;
        if x_spread <= options.x_tol && f_close {
            converged = true;
            break;
        }
        if evaluations >= options.max_evals {
            break;
        }
        iterations += 1;

        let centroid: Vec<f64> =
            (0..dim).map(|i| simplex[..dim].iter().map(|(x, _)| x[i]).sum::<f64>() / dim as f64).collect();
        let worst = simplex[dim].clone();
        let along = |t: f64| -> Vec<f64> {
            let mut x: Vec<f64> = (0..dim).map(|i| centroid[i] + t * (worst.0[i] - centroid[i])).collect();
            clamp(&mut x);
            x
        };
        let reflected = along(-1.0);
        let f_reflected = eval(&reflected, &mut evaluations);
        if f_reflected < simplex[0].1 {
            let expanded = along(-2.0);
            let f_expanded = eval(&expanded, &mut evaluations);
            simplex[dim] = if f_expanded < f_reflected { (expanded, f_expanded) } else { (reflected, f_reflected) };
            continue;
        }
        if f_reflected < simplex[dim - 1].1 {
            simplex[dim] = (reflected, f_reflected);
            continue;
        }
        // Contract: outside if the reflection improved on the worst vertex,
        // inside otherwise.
        let (contracted, limit) =
            if f_reflected < worst.1 { (along(-0.5), f_reflected) } else { (along(0.5), worst.1) };
        let f_contracted = eval(&contracted, &mut evaluations);
        if f_contracted <= limit {
            simplex[dim] = (contracted, f_contracted);
            continue;
        }
        // Shrink towards the best vertex.
        let best = simplex[0].0.clone();
        for vertex in simplex.iter_mut().skip(1) {
            let mut x: Vec<f64> = (0..dim).map(|i| best[i] + 0.5 * (vertex.0[i] - best[i])).collect();
            clamp(&mut x);
            let fx = eval(&x, &mut evaluations);
            *vertex = (x, fx);
        }
    }
    let (x, f) = simplex.swap_remove(0);
    Minimum { x, f, evaluations, iterations, converged }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WIDE: [f64; 2] = [-10.0, 10.0];

    #[test]
    fn quadratic_minimum_to_tolerance() {
        let f = |x: &[f64]| (x[0] - 1.5).powi(2) + 3.0 * (x[1] + 0.5).powi(2) + 2.0;
        let options = Options { x_tol: 1e-6, f_tol: 1e-12, f_abs: 0.0, max_evals: 2000 };
        let r = minimize(f, &[0.0, 0.0], &[0.5, 0.5], &[WIDE[0]; 2], &[WIDE[1]; 2], options);
        assert!(r.converged, "{r:?}");
        assert!((r.x[0] - 1.5).abs() < 2e-6 && (r.x[1] + 0.5).abs() < 2e-6, "{r:?}");
        assert!((r.f - 2.0).abs() < 1e-12);
    }

    /// Rosenbrock's banana, the classic test of fminsearch: minimum at (1, 1).
    #[test]
    fn rosenbrock_from_the_standard_start() {
        let f = |x: &[f64]| 100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2);
        let options = Options { x_tol: 1e-8, f_tol: 1e-12, f_abs: 1e-20, max_evals: 5000 };
        let r = minimize(f, &[-1.2, 1.0], &[0.05 * 1.2, 0.05], &[WIDE[0]; 2], &[WIDE[1]; 2], options);
        assert!(r.converged, "{r:?}");
        assert!((r.x[0] - 1.0).abs() < 1e-5 && (r.x[1] - 1.0).abs() < 1e-5, "{r:?}");
    }

    #[test]
    fn one_dimension_and_a_bound() {
        let f = |x: &[f64]| (x[0] - 3.0).powi(2);
        let r = minimize(f, &[0.0], &[0.3], &[-1.0], &[2.0], Options::default());
        assert_eq!(r.x[0], 2.0, "{r:?}");
        let r = minimize(f, &[0.0], &[0.3], &[-1.0], &[5.0], Options::default());
        assert!((r.x[0] - 3.0).abs() < 1e-3, "{r:?}");
    }

    #[test]
    fn nan_is_treated_as_infinity_and_the_budget_is_respected() {
        let f = |x: &[f64]| if x[0] < 0.0 { f64::NAN } else { (x[0] - 1.0).powi(2) };
        let r = minimize(f, &[0.5], &[0.2], &[-5.0], &[5.0], Options::default());
        assert!((r.x[0] - 1.0).abs() < 1e-3);
        let r = minimize(f, &[0.5], &[0.2], &[-5.0], &[5.0], Options { max_evals: 5, ..Options::default() });
        assert!(!r.converged && r.evaluations <= 7, "{r:?}");
    }
}
