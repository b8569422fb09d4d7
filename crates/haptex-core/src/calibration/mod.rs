//! Calibration: haptex's device models fitted to measurements made on the
//! user's own display (docs/calibration.md).
//!
//! - [`measurements`]: the measurements format (constant drive, steady
//!   sliding: friction per segment or sample);
//! - [`from_recordings`]: measurements from recorded strokes (the
//!   recording format) and a manifest of the drive each was made under;
//! - [`force_fit`]: eq. (3)/(8) per carrier (mu_HD and c) and the circuit
//!   model across carriers (rho_sc, the air gap g, c);
//! - [`ultrasonic_fit`]: the ultrasonic plate's rho(a), parametric or a
//!   monotone (isotonic) table, and rho_min;
//! - [`least_squares`] and [`distributions`]: the robust fit, its
//!   cluster-robust intervals and the t and F distributions they use;
//! - [`curves`]: the data and fitted curves with their bands, to plot;
//! - [`device_file`]: the device file (TOML) every design command takes
//!   with `--device`;
//! - [`virtual_device`]: synthetic measurements from known constants, the
//!   test bench that stands in for hardware.

pub mod curves;
pub mod design_device;
pub mod device_file;
pub mod distributions;
pub mod force_fit;
pub mod from_recordings;
pub mod least_squares;
pub mod measurements;
pub mod ultrasonic_fit;
pub mod virtual_device;

use crate::electrovibration::LayerStack;
use least_squares::Fit;
use measurements::{ClusterLevel, Measurements};

/// The confidence level of every interval.
pub const LEVEL: f64 = 0.95;

/// A fitted constant: its estimate, its 95% interval, and whether the
/// measurements identify it (when not, the number is not to be used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub value: f64,
    pub interval: [f64; 2],
    pub identified: bool,
}

impl Estimate {
    pub(crate) fn unidentified(value: f64) -> Self {
        Self { value, interval: [f64::NEG_INFINITY, f64::INFINITY], identified: false }
    }

    /// Whether `truth` lies in the interval.
    pub fn covers(&self, truth: f64) -> bool {
        self.interval[0] <= truth && truth <= self.interval[1]
    }
}

/// A fit's estimate and covariance, kept to draw the model's band.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Posterior {
    pub theta: Vec<f64>,
    /// p x p, row by row.
    pub covariance: Vec<f64>,
    /// Degrees of freedom of the t quantile.
    pub df: f64,
}

impl Posterior {
    pub(crate) fn of(fit: &Fit) -> Self {
        Self { theta: fit.theta.clone(), covariance: fit.covariance.clone(), df: fit.df }
    }

    /// A function of the parameters with its 95% interval by the delta
    /// method (forward-difference gradient): [value, low, high].
    pub fn band(&self, f: &dyn Fn(&[f64]) -> f64) -> [f64; 3] {
        let p = self.theta.len();
        let value = f(&self.theta);
        let mut grad = vec![0.0; p];
        let mut t = self.theta.clone();
        for j in 0..p {
            let h = 1e-6 * self.theta[j].abs().max(1e-6);
            t[j] = self.theta[j] + h;
            grad[j] = (f(&t) - value) / h;
            t[j] = self.theta[j];
        }
        let mut var = 0.0;
        for a in 0..p {
            for b in 0..p {
                var += grad[a] * grad[b] * self.covariance[a * p + b];
            }
        }
        let hw = distributions::t_quantile(LEVEL, self.df) * var.max(0.0).sqrt();
        [value, value - hw, value + hw]
    }
}

/// How well a model fits.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Goodness {
    /// Rows fitted.
    pub rows: usize,
    /// RMS residual, and the robust noise scale (MAD), in units of mu.
    pub rms: f64,
    pub scale: f64,
    /// Fraction of the variance of mu the model explains.
    pub r2: f64,
    /// Independent clusters the intervals rest on, and what they are.
    pub clusters: usize,
    pub cluster_level: Option<ClusterLevel>,
    /// The lack-of-fit F test against the replicates' pure error, when
    /// there are replicates and more settings than parameters.
    pub lack_of_fit: Option<LackOfFit>,
    /// Whether the iteration converged.
    pub converged: bool,
}

/// The classical lack-of-fit test (Draper and Smith, Applied Regression
/// Analysis, 3rd ed., section 2.1): the residual sum of squares split into
/// pure error (within replicates of one setting) and lack of fit (the
/// settings' means against the model), F = (SS_lof / (m - p)) / (SS_pe /
/// (n - m)). Rows of one stroke share errors, so p is approximate: read a
/// very small p as "the model misses a trend", not as a probability.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LackOfFit {
    pub f: f64,
    pub df1: usize,
    pub df2: usize,
    pub p: f64,
}

/// A measurement the robust fit down-weighted: more than 3 robust
/// standard deviations from the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outlier {
    /// The line of the measurements file.
    pub line: u64,
    pub measured: f64,
    pub fitted: f64,
    /// Huber's weight the fit gave it.
    pub weight: f64,
}

pub(crate) fn goodness(fit: &Fit, y: &[f64], settings: &[usize], level: ClusterLevel, p: usize) -> Goodness {
    let n = y.len();
    let mean = y.iter().sum::<f64>() / n as f64;
    let ss_total: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let sse: f64 = fit.residuals.iter().map(|r| r * r).sum();
    let m = settings.iter().copied().max().map_or(0, |x| x + 1);
    let lack_of_fit = (m > p && n > m).then(|| {
        let mut sum = vec![0.0; m];
        let mut count = vec![0usize; m];
        for (i, &s) in settings.iter().enumerate() {
            sum[s] += fit.residuals[i];
            count[s] += 1;
        }
        let mut ss_pe = 0.0;
        for (i, &s) in settings.iter().enumerate() {
            ss_pe += (fit.residuals[i] - sum[s] / count[s] as f64).powi(2);
        }
        let ss_lof = (sse - ss_pe).max(0.0);
        let (df1, df2) = (m - p, n - m);
        let f = if ss_pe > 0.0 { (ss_lof / df1 as f64) / (ss_pe / df2 as f64) } else { f64::INFINITY };
        LackOfFit { f, df1, df2, p: distributions::f_upper_p(f, df1 as f64, df2 as f64) }
    });
    Goodness {
        rows: n,
        rms: (sse / n as f64).sqrt(),
        scale: fit.scale,
        r2: if ss_total > 0.0 { 1.0 - sse / ss_total } else { 1.0 },
        clusters: fit.clusters,
        cluster_level: Some(level),
        lack_of_fit: lack_of_fit.filter(|l| l.f.is_finite()),
        converged: fit.converged,
    }
}

/// The rows more than 3 robust standard deviations from the fit.
pub(crate) fn outliers(fit: &Fit, y: &[f64], rows: &[usize], m: &Measurements) -> Vec<Outlier> {
    (0..y.len())
        .filter(|&k| fit.residuals[k].abs() > 3.0 * fit.scale)
        .map(|k| Outlier {
            line: m.line(rows[k]),
            measured: y[k],
            fitted: y[k] - fit.residuals[k],
            weight: fit.weights[k],
        })
        .collect()
}

/// How the fits are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// The layer stack assumed (friction data cannot separate it from k).
    pub stack: LayerStack,
    /// The ultrasonic model wanted.
    pub ultrasonic: ultrasonic_fit::Choice,
}

impl Default for Settings {
    fn default() -> Self {
        Self { stack: LayerStack::PAPER, ultrasonic: ultrasonic_fit::Choice::Auto }
    }
}

/// Every fit the measurements allow.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    pub force: Option<force_fit::ForceFit>,
    pub ultrasonic: Option<ultrasonic_fit::UltrasonicFit>,
    /// What could not be identified and what to measure next, every
    /// model's together.
    pub verdicts: Vec<String>,
    pub settings: Settings,
}

/// Fits every model the measurements hold data for.
pub fn calibrate(m: &Measurements, settings: Settings) -> Calibration {
    let force = force_fit::fit(m, &settings.stack);
    let ultrasonic = ultrasonic_fit::fit(m, settings.ultrasonic);
    let mut verdicts = Vec::new();
    if let Some(f) = &force {
        verdicts.extend(f.verdicts.iter().cloned());
    }
    if let Some(u) = &ultrasonic {
        verdicts.extend(u.verdicts.iter().cloned());
    }
    Calibration { force, ultrasonic, verdicts, settings }
}
