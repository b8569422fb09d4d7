//! One case of the FE database against the CAE (`haptex db loo --surface`):
//! the FE profile, the estimate that never saw the case (the database
//! without its row) and the estimate over the whole database.

use std::path::Path;

use haptex_core::cae::Cae;
use haptex_core::database::{Metadata, TemplateModel};
use haptex_core::num::Num;

use crate::sweep::{DatabaseSpec, Run, SweepError};

/// A case's profiles on the database's grid of xi = x - x0 (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct LooCase {
    pub run: Run,
    pub xi_mm: Vec<f64>,
    /// The surface height at each xi, mm.
    pub h_mm: Vec<f64>,
    /// Ft/Fn of the FE model: the database's row, or a run simulated now
    /// with the database's FE settings when the case is not a row.
    pub mu_fe: Vec<f64>,
    /// The CAE over the other rows (the whole database for a case that is
    /// not a row).
    pub mu_cae_loo: Vec<f64>,
    /// The CAE over the whole database.
    pub mu_cae_full: Vec<f64>,
    /// The database row (0-based) the case is, if it is one.
    pub row: Option<usize>,
    /// Where the FE profile comes from, in words.
    pub source: String,
    /// RMS differences to the FE profile.
    pub rms_loo: f64,
    pub rms_full: f64,
    /// The CAE's widths (w_min, w_max), normalized units.
    pub widths: (f64, f64),
}

impl LooCase {
    /// The case `run` of the database in `dir` (whose metadata and template
    /// model are given): for a row, the CAE renormalized without it (the
    /// metadata's widths); otherwise the case is simulated (about half a
    /// second).
    pub fn compute(dir: &Path, metadata: &Metadata, model: &TemplateModel, run: Run) -> Result<Self, SweepError> {
        let query = [run.width_mm, run.height_mm, run.velocity_mm_s];
        let matrix = model.cae.matrix();
        let widths = model.cae.widths();
        let full = model.cae.predict(&query)?.0;
        let row = model.exact_row(&query);
        let (fe, left_out, source) = match row {
            Some(row) => {
                let left_out = Cae::new(matrix.without_row(row)?, widths)?.predict(&query)?.0;
                let source = format!("row {} of {}", row + 1, dir.join(run.template.file_name()).display());
                (matrix.output_row(row).to_vec(), left_out, source)
            }
            None => {
                let spec = DatabaseSpec::from_metadata(metadata)?;
                let fe = spec.simulate(&run)?;
                (fe, full.clone(), "not in the database, FE simulated now".to_string())
            }
        };
        let xi_mm = model.positions().to_vec();
        let shape = run.surface(0.0);
        let h_mm = xi_mm.iter().map(|&x| shape.height(x)).collect();
        let rms = |a: &[f64]| (a.iter().zip(&fe).map(|(p, f)| (p - f) * (p - f)).sum::<f64>() / fe.len() as f64).sqrt();
        Ok(Self {
            rms_loo: rms(&left_out),
            rms_full: rms(&full),
            run,
            xi_mm,
            h_mm,
            mu_fe: fe,
            mu_cae_loo: left_out,
            mu_cae_full: full,
            row,
            source,
            widths: (widths.w_min, widths.w_max),
        })
    }

    /// Writes `xi_mm,h_mm,mu_fe,mu_cae_loo,mu_cae_full` after two comments
    /// (the case and its RMS differences), as `haptex db loo -o` does.
    pub fn write_csv(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let run = &self.run;
        writeln!(
            w,
            "# haptex db loo: {} r_w={} mm r_h={} mm v={} mm/s ({}); widths {} .. {}",
            run.template.name(),
            Num(run.width_mm),
            Num(run.height_mm),
            Num(run.velocity_mm_s),
            self.source,
            Num(self.widths.0),
            Num(self.widths.1)
        )?;
        writeln!(
            w,
            "# RMS difference to FE: CAE leaving the case out {:.6}, CAE full {:.6}",
            self.rms_loo, self.rms_full
        )?;
        writeln!(w, "xi_mm,h_mm,mu_fe,mu_cae_loo,mu_cae_full")?;
        for i in 0..self.xi_mm.len() {
            haptex_core::io::write_csv_row(
                w,
                &[self.xi_mm[i], self.h_mm[i], self.mu_fe[i], self.mu_cae_loo[i], self.mu_cae_full[i]],
            )?;
        }
        Ok(())
    }
}
