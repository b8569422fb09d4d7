//! The ultrasonic plate's relative friction rho(a) = mu(a) / mu_HD from
//! measurements at 0 V under several vibration amplitudes.
//!
//! Two forms (`crate::ultrasonic`): the parametric literature form
//! rho(a) = rho_inf + (1 - rho_inf) exp(-a / a_c) (Vezzoli et al. 2017's
//! decay with amplitude, fitted by [`least_squares`] with its
//! cluster-robust intervals), and a monotone table: the mean friction per
//! amplitude made non-increasing by the pool-adjacent-violators algorithm
//! (isotonic regression; Barlow et al. 1972, Statistical Inference under
//! Order Restrictions), divided by the mean at rest. A pooled block keeps
//! its first amplitude, so the table decreases strictly (as
//! `ultrasonic::Calibration` requires), and a flat tail ends the table
//! at its first amplitude (beyond it the friction fell no further). rho_min
//! is rho at a_max (the largest amplitude measured, or the table's last),
//! with its interval.
//!
//! `Auto` takes the parametric form when the data identify both of its
//! constants and the lack-of-fit test does not reject it (p >= 0.01),
//! else the table.

use crate::calibration::least_squares::{self, Problem};
use crate::calibration::measurements::Measurements;
use crate::calibration::{Estimate, Goodness, LEVEL, Outlier, Posterior, distributions, goodness, outliers};
use crate::frequency::round3;
use crate::num::Num;

/// Which form of rho(a).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Choice {
    Auto,
    Exponential,
    Table,
}

/// The parametric form's constants.
#[derive(Debug, Clone, PartialEq)]
pub struct ExponentialFit {
    pub mu_hd: Estimate,
    pub rho_inf: Estimate,
    pub a_c_um: Estimate,
    /// theta = [mu_HD, rho_inf, ln a_c].
    pub posterior: Posterior,
    pub goodness: Goodness,
    pub outliers: Vec<Outlier>,
}

/// One amplitude of the monotone table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TablePoint {
    pub amplitude_um: f64,
    pub rho: f64,
    /// Pointwise 95% interval (from the spread at this amplitude and at
    /// rest; delta method for the ratio).
    pub interval: [f64; 2],
}

/// rho(a) as measured.
#[derive(Debug, Clone, PartialEq)]
pub struct UltrasonicFit {
    pub exponential: Option<ExponentialFit>,
    pub table: Vec<TablePoint>,
    /// The form the device file will use (`Exponential` or `Table`).
    pub chosen: Choice,
    /// The largest amplitude measured, um, and rho there.
    pub a_max_um: f64,
    pub rho_min: Estimate,
    pub verdicts: Vec<String>,
}

/// Fits rho(a); `None` when no row has vibration at 0 V.
pub fn fit(m: &Measurements, choice: Choice) -> Option<UltrasonicFit> {
    let data = m.rows();
    let rows: Vec<usize> = (0..data.len()).filter(|&i| data[i].voltage_v == 0.0).collect();
    if !rows.iter().any(|&i| data[i].amplitude_um > 0.0) {
        return None;
    }
    let mut verdicts = Vec::new();
    let a: Vec<f64> = rows.iter().map(|&i| data[i].amplitude_um).collect();
    let y: Vec<f64> = rows.iter().map(|&i| data[i].mu).collect();
    // Per amplitude: mean, variance and count.
    let mut levels: Vec<f64> = a.clone();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let a_max_um = levels[levels.len() - 1];
    if levels[0] != 0.0 {
        verdicts.push(
            "rho(a) cannot be measured without the plate at rest: measure at amplitude 0 as well (rho is the \
             friction relative to it)"
                .to_string(),
        );
        return Some(UltrasonicFit {
            exponential: None,
            table: Vec::new(),
            chosen: Choice::Table,
            a_max_um,
            rho_min: Estimate::unidentified(f64::NAN),
            verdicts,
        });
    }
    let (mut sum, mut sum2, mut count) = (vec![0.0; levels.len()], vec![0.0; levels.len()], vec![0usize; levels.len()]);
    for (k, &ak) in a.iter().enumerate() {
        let l = levels.partition_point(|&x| x < ak);
        sum[l] += y[k];
        sum2[l] += y[k] * y[k];
        count[l] += 1;
    }
    let means: Vec<f64> = (0..levels.len()).map(|l| sum[l] / count[l] as f64).collect();
    let se: Vec<f64> = (0..levels.len())
        .map(|l| {
            let n = count[l] as f64;
            if count[l] < 2 { f64::INFINITY } else { ((sum2[l] - sum[l] * sum[l] / n).max(0.0) / (n - 1.0) / n).sqrt() }
        })
        .collect();
    let table = isotonic_table(&levels, &means, &se, &count);
    if table.len() < 2 {
        verdicts.push(format!(
            "the friction does not fall with the vibration amplitude (up to {} um): check that the plate vibrates \
             at resonance, or measure at higher amplitudes",
            Num(a_max_um)
        ));
    }
    // The parametric form.
    let (cluster, level) = m.clusters(&rows);
    let exponential = if levels.len() >= 4 {
        let mu0 = means[0];
        let rho_end = (means[means.len() - 1] / mu0).clamp(0.01, 0.99);
        // a_c where the mean first falls halfway.
        let half = mu0 * (1.0 + rho_end) / 2.0;
        let a_half = levels.iter().zip(&means).find(|(_, m)| **m <= half).map_or(a_max_um, |(a, _)| *a);
        let problem = Problem {
            y: &y,
            cluster: &cluster,
            start: vec![mu0, (rho_end * 0.8).clamp(0.0, 0.95), (a_half.max(1e-3) / std::f64::consts::LN_2).ln()],
            lower: vec![1e-4, 0.0, (1e-3f64).ln()],
            upper: vec![100.0, 0.999, (1e3f64).ln()],
            typical: vec![mu0, 0.1, 1.0],
        };
        let model = |t: &[f64], out: &mut [f64]| {
            let a_c = t[2].exp();
            for (o, &ak) in out.iter_mut().zip(&a) {
                *o = t[0] * (t[1] + (1.0 - t[1]) * (-ak / a_c).exp());
            }
        };
        match least_squares::fit(&problem, &model) {
            Ok(f) => {
                let keys = crate::calibration::force_fit::settings_key(&rows, m);
                let g = goodness(&f, &y, &keys, level, 3);
                let mu_hd = Estimate::linear(&f, 0, true);
                let mut rho_inf = Estimate::linear(&f, 1, true);
                rho_inf.interval = [rho_inf.interval[0].max(0.0), rho_inf.interval[1].min(1.0)];
                let mut a_c = Estimate::log_natural(&f, 2, true);
                let (width, ratio) = (rho_inf.interval[1] - rho_inf.interval[0], a_c.interval[1] / a_c.interval[0]);
                if width.is_nan() || width > 0.3 || ratio.is_nan() || ratio > 4.0 {
                    rho_inf.identified = false;
                    a_c.identified = false;
                    verdicts.push(format!(
                        "the exponential rho(a) is not identifiable (rho_inf {} .. {}, a_c {} .. {} um): measure \
                         to amplitudes where the friction levels off (two to three times a_c), with more \
                         repetitions; the monotone table is used",
                        Num(round3(rho_inf.interval[0])),
                        Num(round3(rho_inf.interval[1])),
                        Num(round3(a_c.interval[0])),
                        Num(round3(a_c.interval[1]))
                    ));
                }
                // rho_min = rho(a_max) with the delta method.
                let rho_at = |t: &[f64]| t[1] + (1.0 - t[1]) * (-a_max_um / t[2].exp()).exp();
                let value = rho_at(&f.theta);
                let p = 3;
                let mut grad = [0.0; 3];
                for (j, gj) in grad.iter_mut().enumerate() {
                    let mut t = f.theta.clone();
                    let h = 1e-6 * t[j].abs().max(1e-3);
                    t[j] += h;
                    *gj = (rho_at(&t) - value) / h;
                }
                let var: f64 = (0..p)
                    .flat_map(|x| (0..p).map(move |z| (x, z)))
                    .map(|(x, z)| grad[x] * grad[z] * f.covariance[x * p + z])
                    .sum();
                let hw = distributions::t_quantile(LEVEL, f.df) * var.max(0.0).sqrt();
                let rho_min = Estimate { value, interval: [value - hw, value + hw], identified: rho_inf.identified };
                Some((
                    ExponentialFit {
                        mu_hd,
                        rho_inf,
                        a_c_um: a_c,
                        posterior: Posterior::of(&f),
                        goodness: g,
                        outliers: outliers(&f, &y, &rows, m),
                    },
                    rho_min,
                ))
            }
            Err(e) => {
                verdicts.push(format!("the exponential rho(a) cannot be fitted: {e}"));
                None
            }
        }
    } else {
        verdicts.push(format!(
            "the exponential rho(a) needs four or more amplitudes (rest included), got {}: the monotone table is \
             used",
            levels.len()
        ));
        None
    };
    let parametric_ok = exponential
        .as_ref()
        .is_some_and(|(e, _)| e.rho_inf.identified && e.goodness.lack_of_fit.is_none_or(|l| l.p >= 0.01));
    let chosen = match choice {
        Choice::Auto if parametric_ok => Choice::Exponential,
        Choice::Auto => Choice::Table,
        Choice::Exponential if exponential.is_some() => Choice::Exponential,
        Choice::Exponential => {
            verdicts.push("the exponential form was asked for but cannot be fitted: the table is used".into());
            Choice::Table
        }
        Choice::Table => Choice::Table,
    };
    // The table ends where the friction last fell: a pooled (flat) tail
    // lowers it no further, so a_max is the tail's first amplitude.
    let a_max_um = match (chosen, table.last()) {
        (Choice::Table, Some(last)) if table.len() >= 2 => last.amplitude_um,
        _ => a_max_um,
    };
    let rho_min = match (&exponential, chosen) {
        (Some((_, r)), Choice::Exponential) => *r,
        _ => table.last().map_or(Estimate::unidentified(f64::NAN), |p| Estimate {
            value: p.rho,
            interval: p.interval,
            identified: table.len() >= 2,
        }),
    };
    Some(UltrasonicFit { exponential: exponential.map(|(e, _)| e), table, chosen, a_max_um, rho_min, verdicts })
}

impl ExponentialFit {
    /// The fitted rho(a) at `a_um`, with its 95% band.
    pub fn curve(&self, a_um: f64) -> [f64; 3] {
        self.posterior.band(&|t| t[1] + (1.0 - t[1]) * (-a_um / t[2].exp()).exp())
    }
}

/// The table from the means per amplitude: pool adjacent violators of a
/// non-increasing order (weights: counts), keep each block's first
/// amplitude, divide by the block at rest.
fn isotonic_table(levels: &[f64], means: &[f64], se: &[f64], count: &[usize]) -> Vec<TablePoint> {
    // Blocks: (first level, weighted sum, weight, sum of se^2 w^2).
    let mut blocks: Vec<(usize, f64, f64, f64)> = Vec::new();
    for l in 0..levels.len() {
        let w = count[l] as f64;
        blocks.push((l, means[l] * w, w, (se[l] * w).powi(2)));
        while blocks.len() >= 2 {
            let (b, a) = (blocks[blocks.len() - 1], blocks[blocks.len() - 2]);
            if b.1 / b.2 >= a.1 / a.2 {
                blocks.pop();
                let last = blocks.len() - 1;
                blocks[last] = (a.0, a.1 + b.1, a.2 + b.2, a.3 + b.3);
            } else {
                break;
            }
        }
    }
    let (m0, se0) = (blocks[0].1 / blocks[0].2, blocks[0].3.sqrt() / blocks[0].2);
    let z = 1.959963984540054;
    blocks
        .iter()
        .enumerate()
        .map(|(k, &(l, s, w, v))| {
            let (mean, se) = (s / w, v.sqrt() / w);
            let rho = mean / m0;
            let half = if k == 0 { 0.0 } else { z * rho * ((se / mean).powi(2) + (se0 / m0).powi(2)).sqrt() };
            TablePoint { amplitude_um: levels[l], rho, interval: [rho - half, rho + half] }
        })
        .collect()
}
