//! The shipped FE database (data/db): its stored leave-one-out errors,
//! which `haptex predict`, `haptex db loo` and the web app quote as the
//! typical error of a prediction, recomputed independently by brute force.
//!
//! For a template with a constant LOO-optimal width each row is left out by
//! building a new estimator from the other 179 rows and predicting the
//! held-out case; no row's removal changes an input's range (every r_w, r_h
//! and velocity value occurs in 20 or more rows), so this refit is exactly
//! the leave-one-out of eqs. (11)-(12) on the normalized database. With
//! non-constant widths (the edge of the database built 2026-11-25 at
//! commit 6f7d029: 0.097 .. 0.137) a refit would recompute the width rule
//! from 179 rows, while the LOO keeps the whole database's widths
//! (cae/loo.rs); those rows are predicted by eqs. (11)-(12) written out
//! here, with the width rule of docs/cae.md computed here too. The RMS over
//! all rows and outputs must equal the stored `loo_rmse` to 1e-9 relative
//! (floating-point summation order only), and the stored relative error
//! must be that RMS over the mean profile range. (Until that build the
//! bump and edge widths were constant and the sine's not, and the test
//! covered the bump and the edge by refits only.)

use std::path::PathBuf;

use haptex_core::cae::{Cae, ModelMatrix};
use haptex_core::database::{INPUTS, Metadata, Template};

fn shipped_db() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/db")
}

fn without_row(matrix: &ModelMatrix, row: usize) -> ModelMatrix {
    let mut b = Vec::new();
    let mut c = Vec::new();
    for n in (0..matrix.n()).filter(|&n| n != row) {
        b.extend_from_slice(matrix.input_row(n));
        c.extend_from_slice(matrix.output_row(n));
    }
    ModelMatrix::new(matrix.inputs().to_vec(), matrix.outputs().to_vec(), b, c).unwrap()
}

/// The non-constant widths w_nl = w_min + (w_max - w_min) (1 - q_nl) of
/// docs/cae.md ("Kernel widths"), written out independently of cae/widths.rs:
/// q_nl the Gaussian kernel density of input l's distinct values (each
/// counted as often as it occurs, Silverman's pilot width 1.06 s N^(-1/5))
/// at b_nl, over its largest value; inputs normalized to [0, 1].
fn non_constant_widths(bn: &[Vec<f64>], w_min: f64, w_max: f64) -> Vec<Vec<f64>> {
    let (n, d) = (bn.len(), bn[0].len());
    let mut w = vec![vec![w_min; d]; n];
    for l in 0..d {
        let v: Vec<f64> = bn.iter().map(|row| row[l]).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let sd = (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64).sqrt();
        let h = 1.06 * sd * (n as f64).powf(-0.2);
        let density = |x: f64| v.iter().map(|y| (-(x - y) * (x - y) / (2.0 * h * h)).exp()).sum::<f64>();
        let p: Vec<f64> = v.iter().map(|&x| density(x)).collect();
        let p_max = p.iter().cloned().fold(0.0, f64::max);
        for (row, p_n) in w.iter_mut().zip(&p) {
            row[l] = w_min + (w_max - w_min) * (1.0 - p_n / p_max);
        }
    }
    w
}

#[test]
fn stored_loo_errors_equal_a_brute_force_leave_one_out() {
    let dir = shipped_db();
    let metadata = Metadata::read(&dir).unwrap();
    for template in [Template::Bump, Template::Edge, Template::Sine] {
        let entry = metadata.entry(template).unwrap();
        let matrix = ModelMatrix::read_csv_file(&dir.join(&entry.file), &INPUTS).unwrap();
        let (n, m, d) = (matrix.n(), matrix.m(), matrix.d());
        let constant = entry.widths.w_min == entry.widths.w_max;
        // Normalized inputs and the widths of the whole database (used by
        // the non-constant case only).
        let range: Vec<(f64, f64)> = (0..d)
            .map(|l| {
                (0..n)
                    .map(|k| matrix.input_row(k)[l])
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)))
            })
            .collect();
        let bn: Vec<Vec<f64>> = (0..n)
            .map(|k| matrix.input_row(k).iter().zip(&range).map(|(v, (lo, hi))| (v - lo) / (hi - lo)).collect())
            .collect();
        let w = non_constant_widths(&bn, entry.widths.w_min, entry.widths.w_max);
        let mut sum_sq = 0.0;
        let mut range_sum = 0.0;
        for row in 0..n {
            let predicted = if constant {
                let others = without_row(&matrix, row);
                for l in 0..d {
                    let column = |mm: &ModelMatrix| {
                        (0..mm.n())
                            .map(|k| mm.input_row(k)[l])
                            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)))
                    };
                    assert_eq!(column(&others), column(&matrix), "row {row} sets the range of input {l}");
                }
                Cae::new(others, entry.widths).unwrap().predict(matrix.input_row(row)).unwrap().0
            } else {
                // Eqs. (11)-(12) with the whole database's widths, row `row`
                // left out: ln a_k = -sum_l ln w_kl - sum_l (b_l - b_kl)^2 / (2 w_kl^2).
                let log_a: Vec<f64> = (0..n)
                    .map(|k| {
                        if k == row {
                            return f64::NEG_INFINITY;
                        }
                        (0..d)
                            .map(|l| {
                                let z = bn[row][l] - bn[k][l];
                                -w[k][l].ln() - z * z / (2.0 * w[k][l] * w[k][l])
                            })
                            .sum()
                    })
                    .collect();
                let top = log_a.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let a: Vec<f64> = log_a.iter().map(|x| (x - top).exp()).collect();
                let total: f64 = a.iter().sum();
                (0..m).map(|j| (0..n).map(|k| a[k] * matrix.output_row(k)[j]).sum::<f64>() / total).collect()
            };
            let actual = matrix.output_row(row);
            sum_sq += predicted.iter().zip(actual).map(|(p, a)| (p - a) * (p - a)).sum::<f64>();
            let (lo, hi) = actual.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
            range_sum += hi - lo;
        }
        let rmse = (sum_sq / (n * m) as f64).sqrt();
        let relative = rmse / (range_sum / n as f64);
        eprintln!(
            "{} ({} widths): brute-force LOO RMS {rmse:.6} (stored {:.6}), {:.2}% of the mean range (stored {:.2}%)",
            template.name(),
            if constant { "constant" } else { "non-constant" },
            entry.loo_rmse,
            100.0 * relative,
            100.0 * entry.loo_rmse_relative_to_range
        );
        assert!((rmse / entry.loo_rmse - 1.0).abs() < 1e-9, "{}: {rmse} vs stored {}", template.name(), entry.loo_rmse);
        assert!((relative / entry.loo_rmse_relative_to_range - 1.0).abs() < 1e-9);
    }
}

/// The flat-surface friction of the database's profiles (the mu_flat of a
/// relative mapping, paper Fig. 2a) is the FE skin friction mu_skin of its
/// metadata: every bump and edge row starts at xi = -5 mm, before the
/// feature reaches the contact, with Ft/Fn equal to it within 1e-4
/// (measured: 1.1e-5; the tolerance of steady sliding on a flat is 1e-9,
/// docs/fem.md, and the rows hold 6 decimals). With the paper's device
/// (mu_HD = 1) eq. (8) gives 0 V everywhere on these raw profiles (issue
/// 15), and on every bump made relative a voltage above 0 where the
/// profile rises above flat.
#[test]
fn fe_profiles_start_at_the_skin_friction_and_map_relative_to_it() {
    use haptex_core::electrovibration::{Device, Method, map_profile, map_profile_relative};
    use haptex_core::profile::FrictionProfile;
    use haptex_core::relative::FlatMu;

    let dir = shipped_db();
    let metadata = Metadata::read(&dir).unwrap();
    let flat = metadata.fe.flat_mu();
    assert_eq!(flat, metadata.fe.mu_skin);
    let x = metadata.grid.positions();
    for template in [Template::Bump, Template::Edge] {
        let entry = metadata.entry(template).unwrap();
        let matrix = ModelMatrix::read_csv_file(&dir.join(&entry.file), &INPUTS).unwrap();
        for row in 0..matrix.n() {
            let mu = matrix.output_row(row);
            assert!((mu[0] - flat).abs() < 1e-4, "{} row {row}: Ft/Fn at xi = -5 mm is {}", template.name(), mu[0]);
            if template != Template::Bump {
                continue;
            }
            let p = FrictionProfile::new(x.clone(), mu.to_vec()).unwrap();
            let raw = map_profile(&p, &Device::PAPER, Method::Physical, None).unwrap();
            assert_eq!(raw.summary.voltage_max_v, 0.0, "bump row {row}");
            let v = map_profile_relative(&p, &Device::PAPER, Method::Physical, None, FlatMu::Given(flat)).unwrap();
            let peak = mu.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            // Eq. (8) at the profile's peak, clipped at U_max = 100 V.
            let expected = ((peak / flat - 1.0) / Device::PAPER.force_ratio_per_v2(1.0)).sqrt().min(100.0);
            assert!(peak > flat && v.summary.voltage_max_v > 0.0, "bump row {row}");
            assert!((v.summary.voltage_max_v - expected).abs() < 1e-9 * expected, "bump row {row}");
        }
    }
}
