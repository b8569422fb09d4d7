//! The shipped FE database (data/db): its stored leave-one-out errors,
//! which `haptex predict`, `haptex db loo` and the web app quote as the
//! typical error of a prediction, recomputed independently by brute force.
//!
//! For the bump and edge templates (constant LOO-optimal widths) each row
//! is left out by building a new estimator from the other 179 rows and
//! predicting the held-out case; no row's removal changes an input's range
//! (every r_w, r_h and velocity value occurs in 20 or more rows), so this
//! refit is exactly the leave-one-out of eqs. (11)-(12) on the normalized
//! database. The RMS over all rows and outputs must equal the stored
//! `loo_rmse` to 1e-9 relative (floating-point summation order only), and
//! the stored relative error must be that RMS over the mean profile range.

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

#[test]
fn stored_loo_errors_equal_a_brute_force_leave_one_out() {
    let dir = shipped_db();
    let metadata = Metadata::read(&dir).unwrap();
    for template in [Template::Bump, Template::Edge] {
        let entry = metadata.entry(template).unwrap();
        assert_eq!(entry.widths.w_min, entry.widths.w_max, "{}: widths are not constant", template.name());
        let matrix = ModelMatrix::read_csv_file(&dir.join(&entry.file), &INPUTS).unwrap();
        let (n, m) = (matrix.n(), matrix.m());
        let mut sum_sq = 0.0;
        let mut range_sum = 0.0;
        for row in 0..n {
            let others = without_row(&matrix, row);
            for l in 0..matrix.d() {
                let column = |mm: &ModelMatrix| {
                    (0..mm.n())
                        .map(|k| mm.input_row(k)[l])
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)))
                };
                assert_eq!(column(&others), column(&matrix), "row {row} sets the range of input {l}");
            }
            let (predicted, _) = Cae::new(others, entry.widths).unwrap().predict(matrix.input_row(row)).unwrap();
            let actual = matrix.output_row(row);
            sum_sq += predicted.iter().zip(actual).map(|(p, a)| (p - a) * (p - a)).sum::<f64>();
            let (lo, hi) = actual.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
            range_sum += hi - lo;
        }
        let rmse = (sum_sq / (n * m) as f64).sqrt();
        let relative = rmse / (range_sum / n as f64);
        eprintln!(
            "{}: brute-force LOO RMS {rmse:.6} (stored {:.6}), {:.2}% of the mean range (stored {:.2}%)",
            template.name(),
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
