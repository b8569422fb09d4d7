//! The friction of one line of a sine grating (`haptex_core::map::Grating`):
//! an FE run of the 1-D sine the line cuts, or the FE database's CAE
//! estimate, and the flat-surface friction of the same source. What
//! `haptex map grating` and `haptex.map_grating` both call.

use std::path::{Path, PathBuf};

use haptex_core::database::{DatabaseError, Metadata, Template, TemplateModel};
use haptex_core::map::Grating;
use haptex_core::num::Num;

use crate::scenario::{self, Scenario, SimulationError};
use crate::surface::SurfaceShape;

/// Where a grating line's friction comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LineSource {
    /// One FE run of the line's sine (10 mm of slide, the paper's scenario).
    Fe,
    /// The FE database's CAE estimate.
    Cae,
}

/// A line's friction profile: positions (mm), Ft/Fn, and the sine's phase
/// x0 (mm).
pub type LineProfile = (Vec<f64>, Vec<f64>, f64);

/// Why a line's friction could not be had.
#[derive(Debug, thiserror::Error)]
pub enum LineError {
    #[error("the FE run of the line's sine (period {period_mm:.4} mm) failed")]
    Fe {
        period_mm: f64,
        #[source]
        source: Box<SimulationError>,
    },
    #[error("the FE run gave no profile")]
    NoProfile,
    #[error("no FE database in {}", dir.display())]
    NoDatabase {
        dir: PathBuf,
        #[source]
        source: Box<DatabaseError>,
    },
    #[error(transparent)]
    Database(Box<DatabaseError>),
    /// The line's sine is outside what the database covers (the caller
    /// says which source to use instead).
    #[error(
        "the line's sine (period {period_mm:.4} mm, amplitude {} mm) is outside the database's sine periods {} .. {} \
         mm and heights {} .. {} mm",
        Num(*amplitude_mm), Num(periods_mm.0), Num(periods_mm.1), Num(heights_mm.0), Num(heights_mm.1)
    )]
    OutsideDatabase { period_mm: f64, amplitude_mm: f64, periods_mm: (f64, f64), heights_mm: (f64, f64) },
}

impl From<DatabaseError> for LineError {
    fn from(e: DatabaseError) -> Self {
        LineError::Database(Box::new(e))
    }
}

/// The flat-surface friction of `source`: the FE model's skin friction,
/// or the database's flat friction.
pub fn flat_mu(source: LineSource, db: &Path) -> Result<f64, LineError> {
    Ok(match source {
        LineSource::Fe => crate::finger::FingerModel::default_model().contact.mu_skin,
        LineSource::Cae => read_metadata(db)?.fe.flat_mu(),
    })
}

fn read_metadata(db: &Path) -> Result<Metadata, LineError> {
    Metadata::read(db).map_err(|source| LineError::NoDatabase { dir: db.to_path_buf(), source: Box::new(source) })
}

/// The friction profile of the 1-D sine a line of the grating cuts, and
/// its phase x0 (None where the line is flat).
pub fn line_friction(g: &Grating, source: LineSource, db: &Path) -> Result<Option<LineProfile>, LineError> {
    let p = g.line_period_mm();
    if !p.is_finite() {
        return Ok(None);
    }
    match source {
        LineSource::Fe => {
            let x0 = 5.0;
            let mut scenario = Scenario::paper(SurfaceShape::Sine { x0, width: p, height: g.amplitude_mm });
            scenario.velocity_mm_s = g.velocity_mm_s;
            let result = scenario::run(&scenario, &mut |_| {})
                .map_err(|source| LineError::Fe { period_mm: p, source: Box::new(source) })?;
            let profile = result.profile.ok_or(LineError::NoProfile)?;
            Ok(Some((profile.x_mm().to_vec(), profile.mu().to_vec(), x0)))
        }
        LineSource::Cae => {
            let metadata = read_metadata(db)?;
            let model = TemplateModel::load_with(db, &metadata, Template::Sine)?;
            let [(w_lo, w_hi), (h_lo, h_hi), _] = model.input_ranges();
            if p < w_lo || p > w_hi || g.amplitude_mm < h_lo || g.amplitude_mm > h_hi {
                return Err(LineError::OutsideDatabase {
                    period_mm: p,
                    amplitude_mm: g.amplitude_mm,
                    periods_mm: (w_lo, w_hi),
                    heights_mm: (h_lo, h_hi),
                });
            }
            let prediction = model.predict(0.0, p, g.amplitude_mm, g.velocity_mm_s)?;
            Ok(Some((prediction.x_mm, prediction.mu, 0.0)))
        }
    }
}
