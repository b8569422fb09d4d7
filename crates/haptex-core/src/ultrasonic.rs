//! Ultrasonic friction reduction: a plate vibrating at an ultrasonic
//! resonance (tens of kHz) with peak amplitude a lowers the friction of a
//! finger sliding on it (intermittent contact and squeeze-film levitation:
//! Wiertlewski et al. 2016; Vezzoli et al. 2017; Sednaoui et al. 2017).
//!
//! The device model is the relative friction
//!
//! ```text
//! rho(a) = mu(a) / mu_HD,   rho(0) = 1,   decreasing to rho_min = rho(a_max)
//! ```
//!
//! with mu_HD the finger's friction on the plate at rest and a in um
//! (peak). It is given either by a calibration of the user's own device
//! ([`Calibration`], CSV `amplitude_um,relative_friction`, interpolated
//! linearly: monotone, and exactly invertible), or by a parametric
//! default from the literature ([`Exponential::LITERATURE`]), a placeholder
//! to replace by a calibration (docs/physics.md says what it rests on).
//!
//! [`UltrasonicDevice::amplitude_um`] is the inverse a(rho), saturating at
//! a_max below rho_min as eq. (8) saturates at U_max.

use std::io::Read;
use std::path::Path;

use serde::Serialize;

use crate::io::{Table, TableError};
use crate::num::Num;
use crate::ranges::{self, RangeError};

/// Most rows a calibration table may have: far more than any measured
/// calibration (tens of amplitudes), and a bound on the cost of each
/// interpolation (a binary search), so that mapping a profile stays
/// linear in its length.
pub const MAX_CALIBRATION_ROWS: usize = 10_000;

/// An ultrasonic device model cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UltrasonicError {
    /// A calibration file is unreadable or invalid: names file, line, column.
    #[error(transparent)]
    Table(#[from] TableError),
    /// An in-memory calibration is invalid at row `index` (0-based).
    #[error("calibration row {index}, field '{field}': {message}")]
    Invalid { index: usize, field: &'static str, message: String },
    /// A limit outside its accepted range.
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// a_max beyond what the model covers (the calibration's last amplitude,
    /// or the literature default's validity range): never extrapolated.
    #[error(
        "a_max = {} um is beyond the {what}, which reaches {} um: haptex does not extrapolate the friction \
         reduction; give a_max up to {} um{hint}",
        Num(*a_max_um),
        Num(*covered_um),
        Num(*covered_um)
    )]
    BeyondModel { a_max_um: f64, covered_um: f64, what: &'static str, hint: &'static str },
}

/// Where a problem is: row (0-based), column, message.
type Violation = (usize, &'static str, String);

/// A measured relative-friction curve: amplitudes in um (strictly
/// increasing from 0) and rho at each (strictly decreasing from 1, in
/// (0, 1]). Linear between the points.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    amplitude_um: Vec<f64>,
    relative_friction: Vec<f64>,
    source_name: String,
}

impl Calibration {
    /// A calibration from amplitudes (um) and relative friction values;
    /// `source_name` says where they came from in descriptions.
    pub fn new(
        amplitude_um: Vec<f64>,
        relative_friction: Vec<f64>,
        source_name: &str,
    ) -> Result<Self, UltrasonicError> {
        check(&amplitude_um, &relative_friction).map_err(|(index, field, message)| UltrasonicError::Invalid {
            index,
            field,
            message,
        })?;
        Ok(Self { amplitude_um, relative_friction, source_name: source_name.to_string() })
    }

    /// Reads a calibration table (`amplitude_um,relative_friction`; other
    /// columns are ignored). Errors name the file, line and column.
    pub fn from_table(table: &Table) -> Result<Self, UltrasonicError> {
        let amplitude_um = table.require("amplitude_um")?.to_vec();
        let relative_friction = table.require("relative_friction")?.to_vec();
        check(&amplitude_um, &relative_friction)
            .map_err(|(row, field, message)| table.error_at(Some(row), Some(field), message))?;
        Ok(Self { amplitude_um, relative_friction, source_name: table.source_name().to_string() })
    }

    /// Reads a calibration CSV from any reader; `source_name` labels errors.
    pub fn read_csv<R: Read>(reader: R, source_name: &str) -> Result<Self, UltrasonicError> {
        Self::from_table(&Table::read(reader, source_name)?)
    }

    /// Reads a calibration CSV file.
    pub fn read_csv_file(path: &Path) -> Result<Self, UltrasonicError> {
        Self::from_table(&Table::read_file(path)?)
    }

    /// Amplitudes in um.
    pub fn amplitude_um(&self) -> &[f64] {
        &self.amplitude_um
    }

    /// Relative friction at each amplitude.
    pub fn relative_friction(&self) -> &[f64] {
        &self.relative_friction
    }

    /// Where the calibration came from (file path or label).
    pub fn source_name(&self) -> &str {
        &self.source_name
    }

    /// rho at `a_um` in [0, last amplitude], linear between the points.
    fn rho(&self, a_um: f64) -> f64 {
        let (a, r) = (&self.amplitude_um, &self.relative_friction);
        // First point beyond a_um; the segment ends there.
        let i = a.partition_point(|&ai| ai <= a_um).clamp(1, a.len() - 1);
        let t = ((a_um - a[i - 1]) / (a[i] - a[i - 1])).clamp(0.0, 1.0);
        r[i - 1] + t * (r[i] - r[i - 1])
    }

    /// The amplitude in um with relative friction `rho` in [last rho, 1]:
    /// the inverse of [`Self::rho`], linear on the same segment.
    fn amplitude(&self, rho: f64) -> f64 {
        let (a, r) = (&self.amplitude_um, &self.relative_friction);
        // First point whose rho is at or below the target (rho decreases).
        let i = r.partition_point(|&ri| ri > rho).clamp(1, r.len() - 1);
        let t = ((r[i - 1] - rho) / (r[i - 1] - r[i])).clamp(0.0, 1.0);
        a[i - 1] + t * (a[i] - a[i - 1])
    }
}

/// Checks a calibration: two to [`MAX_CALIBRATION_ROWS`] rows, each value
/// in its range, the plate at rest first (0 um, rho = 1), amplitudes
/// strictly increasing and rho strictly decreasing.
fn check(amplitude_um: &[f64], relative_friction: &[f64]) -> Result<(), Violation> {
    let n = amplitude_um.len();
    if relative_friction.len() != n {
        return Err((0, "relative_friction", format!("{} values for {n} amplitudes", relative_friction.len())));
    }
    if !(2..=MAX_CALIBRATION_ROWS).contains(&n) {
        return Err((
            n.saturating_sub(1),
            "amplitude_um",
            format!("a calibration needs 2 to {MAX_CALIBRATION_ROWS} rows, got {n}"),
        ));
    }
    for (column, values, range) in [
        ("amplitude_um", amplitude_um, ranges::AMPLITUDE_UM),
        ("relative_friction", relative_friction, ranges::RELATIVE_FRICTION),
    ] {
        if let Some(i) = range.first_outside(values) {
            return Err((i, column, range.refusal(values[i]).to_string()));
        }
    }
    if amplitude_um[0] != 0.0 {
        return Err((
            0,
            "amplitude_um",
            format!("the first row must be the plate at rest, amplitude 0, got {}", Num(amplitude_um[0])),
        ));
    }
    if relative_friction[0] != 1.0 {
        return Err((
            0,
            "relative_friction",
            format!(
                "at amplitude 0 the relative friction is 1 by definition (mu(0) = mu_HD), got {}: divide the \
                 measured friction by its value at rest",
                Num(relative_friction[0])
            ),
        ));
    }
    if let Some(i) = amplitude_um.windows(2).position(|w| w[1] <= w[0]) {
        return Err((i + 1, "amplitude_um", {
            let (next, previous) = crate::num::distinct(amplitude_um[i + 1], amplitude_um[i]);
            format!("amplitudes must increase strictly: {next} follows {previous}")
        }));
    }
    if let Some(i) = relative_friction.windows(2).position(|w| w[1] >= w[0]) {
        return Err((i + 1, "relative_friction", {
            let (next, previous) = crate::num::distinct(relative_friction[i + 1], relative_friction[i]);
            format!(
                "the relative friction must decrease strictly with amplitude: {next} follows {previous} (a \
                     flat or rising step has no unique amplitude for its friction)"
            )
        }));
    }
    Ok(())
}

/// A parametric relative-friction curve,
/// rho(a) = rho_inf + (1 - rho_inf) exp(-a / a_c), valid up to `a_valid_um`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Exponential {
    /// The asymptote rho_inf for large amplitudes, in (0, 1).
    pub rho_inf: f64,
    /// The decay amplitude a_c in um.
    pub a_c_um: f64,
    /// The largest amplitude the curve stands for, in um.
    pub a_valid_um: f64,
}

impl Exponential {
    /// The literature default, a placeholder until the device is
    /// calibrated (docs/physics.md, "Ultrasonic friction reduction"):
    ///
    /// - the exponential decay with amplitude is the shape Vezzoli et al.
    ///   (2017, IEEE ToH 10(2)) report for the computed friction of
    ///   intermittent contact, as a function of a dimensionless group that
    ///   holds the amplitude (with frequency, the intrinsic friction and
    ///   the inverse of the sliding speed, fixed here);
    /// - rho_inf = 0.05: friction reduced by up to 95% (Wiertlewski et al.
    ///   2016, PNAS 113(33));
    /// - a_c = 1 um and a_valid = 2.3 um: plates of 27 to 60 kHz vibrating
    ///   up to 1 to 2.3 um (Sednaoui et al. 2015, 2017). a_c is not a
    ///   published fit: it puts rho(1 um) = 0.399 and rho(2.3 um) = 0.145.
    pub const LITERATURE: Self = Self { rho_inf: 0.05, a_c_um: 1.0, a_valid_um: 2.3 };

    /// Whether this is the literature default (a placeholder), not a fit.
    pub fn is_literature(&self) -> bool {
        self.rho_inf == Self::LITERATURE.rho_inf && self.a_c_um == Self::LITERATURE.a_c_um
    }

    fn rho(&self, a_um: f64) -> f64 {
        self.rho_inf + (1.0 - self.rho_inf) * (-a_um / self.a_c_um).exp()
    }

    /// The inverse, a = -a_c ln(1 - (1 - rho)/(1 - rho_inf)), for rho in
    /// (rho_inf, 1] (ln_1p: accurate near rho = 1).
    fn amplitude(&self, rho: f64) -> f64 {
        -self.a_c_um * (-(1.0 - rho) / (1.0 - self.rho_inf)).ln_1p()
    }
}

/// Where an ultrasonic device's rho(a) comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum ReductionCurve {
    /// A measured calibration of the device.
    Calibrated(Calibration),
    /// The parametric literature default.
    Parametric(Exponential),
}

/// An ultrasonic friction-reduction display: its rho(a) and the highest
/// amplitude a_max its plate and driver reach.
#[derive(Debug, Clone, PartialEq)]
pub struct UltrasonicDevice {
    curve: ReductionCurve,
    a_max_um: f64,
    rho_min: f64,
}

impl UltrasonicDevice {
    /// The literature default ([`Exponential::LITERATURE`]) with a_max =
    /// `a_max_um` (default: its validity limit, 2.3 um).
    pub fn literature_default(a_max_um: Option<f64>) -> Result<Self, UltrasonicError> {
        Self::new(ReductionCurve::Parametric(Exponential::LITERATURE), a_max_um)
    }

    /// A device with a parametric curve (a calibration's fit, valid up to
    /// its `a_valid_um`) and a_max = `a_max_um` (default: that limit).
    pub fn parametric(curve: Exponential, a_max_um: Option<f64>) -> Result<Self, UltrasonicError> {
        Self::new(ReductionCurve::Parametric(curve), a_max_um)
    }

    /// A calibrated device with a_max = `a_max_um` (default: the
    /// calibration's last amplitude).
    pub fn calibrated(calibration: Calibration, a_max_um: Option<f64>) -> Result<Self, UltrasonicError> {
        Self::new(ReductionCurve::Calibrated(calibration), a_max_um)
    }

    fn new(curve: ReductionCurve, a_max_um: Option<f64>) -> Result<Self, UltrasonicError> {
        let (covered_um, what, hint) = match &curve {
            ReductionCurve::Calibrated(c) => (
                c.amplitude_um[c.amplitude_um.len() - 1],
                "calibration's last amplitude",
                ", or calibrate higher amplitudes",
            ),
            ReductionCurve::Parametric(e) => (
                e.a_valid_um,
                "literature default's validity range",
                ", or give a calibration of the device (--ultrasonic-calibration)",
            ),
        };
        let a_max_um = match a_max_um {
            Some(a) => ranges::A_MAX_UM.check(a)?,
            None => ranges::A_MAX_UM.check(covered_um)?,
        };
        if a_max_um > covered_um {
            return Err(UltrasonicError::BeyondModel { a_max_um, covered_um, what, hint });
        }
        let mut device = Self { curve, a_max_um, rho_min: 1.0 };
        device.rho_min = device.curve_rho(a_max_um);
        Ok(device)
    }

    fn curve_rho(&self, a_um: f64) -> f64 {
        match &self.curve {
            ReductionCurve::Calibrated(c) => c.rho(a_um),
            ReductionCurve::Parametric(e) => e.rho(a_um),
        }
    }

    /// rho(a): the relative friction mu(a)/mu_HD at amplitude `a_um` (um,
    /// peak), with a held within [0, a_max].
    #[inline]
    pub fn relative_friction(&self, a_um: f64) -> f64 {
        self.curve_rho(a_um.clamp(0.0, self.a_max_um))
    }

    /// The inverse a(rho) in um: the amplitude at which the relative
    /// friction is `rho`. Saturates: 0 for rho >= 1 (friction at or above
    /// mu_HD: no vibration), a_max for rho <= rho_min (the plate cannot
    /// lower friction further). Monotone and continuous.
    #[inline]
    pub fn amplitude_um(&self, rho: f64) -> f64 {
        if rho >= 1.0 {
            return 0.0;
        }
        if rho <= self.rho_min {
            return self.a_max_um;
        }
        let a = match &self.curve {
            ReductionCurve::Calibrated(c) => c.amplitude(rho),
            ReductionCurve::Parametric(e) => e.amplitude(rho),
        };
        a.clamp(0.0, self.a_max_um)
    }

    /// The highest amplitude, a_max in um (peak).
    pub fn a_max_um(&self) -> f64 {
        self.a_max_um
    }

    /// The lowest relative friction, rho_min = rho(a_max).
    pub fn rho_min(&self) -> f64 {
        self.rho_min
    }

    /// The curve rho(a).
    pub fn curve(&self) -> &ReductionCurve {
        &self.curve
    }

    /// The model for summaries (JSON).
    pub fn model(&self) -> UltrasonicModel {
        let (source, calibration_file, parameters) = match &self.curve {
            ReductionCurve::Calibrated(c) => (ModelSource::Calibration, Some(c.source_name.clone()), None),
            ReductionCurve::Parametric(e) if e.is_literature() => (ModelSource::LiteratureDefault, None, Some(*e)),
            // An exponential fitted to the plate's own measurements (a device file).
            ReductionCurve::Parametric(e) => (ModelSource::Calibration, Some("fitted exponential".into()), Some(*e)),
        };
        UltrasonicModel {
            source,
            calibration_file,
            parameters,
            a_max_um: self.a_max_um,
            relative_friction_min: self.rho_min,
            description: self.describe(),
        }
    }

    /// One line for summaries and CSV comments.
    pub fn describe(&self) -> String {
        let limits = format!("a_max = {} um, rho_min = rho(a_max) = {:.4}", Num(self.a_max_um), self.rho_min);
        match &self.curve {
            ReductionCurve::Calibrated(c) => format!(
                "calibration {:?} ({} points up to {} um, linear between them); {limits}",
                c.source_name,
                c.amplitude_um.len(),
                Num(c.amplitude_um[c.amplitude_um.len() - 1])
            ),
            ReductionCurve::Parametric(e) if !e.is_literature() => format!(
                "exponential fitted to this plate's measurements: rho(a) = {} + {} exp(-a / {} um), valid up to {} \
                 um; {limits}",
                Num(e.rho_inf),
                Num(1.0 - e.rho_inf),
                Num(e.a_c_um),
                Num(e.a_valid_um)
            ),
            ReductionCurve::Parametric(e) => format!(
                "literature default, not a calibration of this device: rho(a) = {} + {} exp(-a / {} um), valid up \
                 to {} um; {limits}",
                Num(e.rho_inf),
                Num(1.0 - e.rho_inf),
                Num(e.a_c_um),
                Num(e.a_valid_um)
            ),
        }
    }
}

/// Where a device's rho(a) came from, for summaries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelSource {
    Calibration,
    LiteratureDefault,
}

/// An ultrasonic device as summaries report it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UltrasonicModel {
    pub source: ModelSource,
    /// The calibration's file (or label), for a calibrated device.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration_file: Option<String>,
    /// The parametric curve, for the literature default.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub parameters: Option<Exponential>,
    /// a_max in um (peak): no amplitude written exceeds it.
    pub a_max_um: f64,
    /// rho_min = rho(a_max).
    pub relative_friction_min: f64,
    pub description: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Calibration, UltrasonicError> {
        Calibration::read_csv(text.as_bytes(), "cal.csv")
    }

    #[test]
    fn calibration_is_linear_between_points_and_its_inverse_exact() {
        let c = read("amplitude_um,relative_friction\n0,1\n1,0.6\n2,0.3\n").unwrap();
        let d = UltrasonicDevice::calibrated(c, None).unwrap();
        assert_eq!((d.a_max_um(), d.rho_min()), (2.0, 0.3));
        let close = |a: f64, b: f64| (a - b).abs() < 1e-15;
        assert!(close(d.relative_friction(0.5), 0.8));
        assert_eq!(d.relative_friction(1.0), 0.6);
        assert!(close(d.relative_friction(1.5), 0.45));
        assert!(close(d.amplitude_um(0.8), 0.5));
        assert_eq!(d.amplitude_um(0.6), 1.0);
        assert!(close(d.amplitude_um(0.45), 1.5));
        // Saturation: no vibration at or above mu_HD, a_max at or below rho_min.
        assert_eq!((d.amplitude_um(1.0), d.amplitude_um(1.7)), (0.0, 0.0));
        assert_eq!((d.amplitude_um(0.3), d.amplitude_um(0.01)), (2.0, 2.0));
        // Beyond a_max rho is held at rho_min.
        assert_eq!(d.relative_friction(5.0), 0.3);
    }

    #[test]
    fn a_lower_a_max_cuts_the_curve_and_a_higher_one_is_refused() {
        let c = read("amplitude_um,relative_friction\n0,1\n1,0.6\n2,0.3\n").unwrap();
        let d = UltrasonicDevice::calibrated(c.clone(), Some(1.5)).unwrap();
        assert!((d.rho_min() - 0.45).abs() < 1e-15);
        assert_eq!(d.amplitude_um(0.3), 1.5);
        let e = UltrasonicDevice::calibrated(c, Some(2.5)).unwrap_err();
        assert!(e.to_string().contains("does not extrapolate"), "{e}");
        let e = UltrasonicDevice::literature_default(Some(3.0)).unwrap_err();
        assert!(e.to_string().contains("--ultrasonic-calibration"), "{e}");
        let e = UltrasonicDevice::literature_default(Some(f64::NAN)).unwrap_err();
        assert!(e.to_string().starts_with("a_max_um must be"), "{e}");
    }

    /// The literature default's stated values: rho(1 um) = 0.05 + 0.95/e =
    /// 0.399485, rho(2.3 um) = 0.145246 (docs/physics.md).
    #[test]
    fn literature_default_values() {
        let d = UltrasonicDevice::literature_default(None).unwrap();
        assert_eq!(d.a_max_um(), 2.3);
        assert!((d.relative_friction(1.0) - 0.399_485).abs() < 1e-6);
        assert!((d.rho_min() - 0.145_246).abs() < 1e-6);
        assert_eq!(d.relative_friction(0.0), 1.0);
        for a in [1e-9, 0.1, 1.0, 2.0, 2.29] {
            let back = d.amplitude_um(d.relative_friction(a));
            assert!((back - a).abs() < 1e-9, "{a} -> {back}");
        }
    }

    #[test]
    fn bad_calibrations_name_line_and_column() {
        for (text, expected) in [
            (
                "amplitude_um,relative_friction\n0,1\n1,0.6\n2,0.7\n",
                "cal.csv, line 4, column 'relative_friction': the relative friction must decrease strictly",
            ),
            (
                "amplitude_um,relative_friction\n0,1\n1,0.6\n1,0.5\n",
                "cal.csv, line 4, column 'amplitude_um': amplitudes must increase strictly",
            ),
            ("amplitude_um,relative_friction\n0,1\n1,0.6\n2,0.6\n", "cal.csv, line 4, column 'relative_friction'"),
            (
                "amplitude_um,relative_friction\n0,1\n# c\n1,0\n",
                "cal.csv, line 4, column 'relative_friction': relative_friction must be from 1e-6 to 1",
            ),
            (
                "amplitude_um,relative_friction\n0,1\n1,1.2\n",
                "cal.csv, line 3, column 'relative_friction': relative_friction must be",
            ),
            (
                "amplitude_um,relative_friction\n0,1\n-1,0.5\n",
                "cal.csv, line 3, column 'amplitude_um': amplitude_um must be from 0 to 100 um",
            ),
            (
                "amplitude_um,relative_friction\n0.5,1\n1,0.5\n",
                "cal.csv, line 2, column 'amplitude_um': the first row must be the plate at rest",
            ),
            (
                "amplitude_um,relative_friction\n0,0.9\n1,0.5\n",
                "cal.csv, line 2, column 'relative_friction': at amplitude 0 the relative friction is 1",
            ),
            (
                "amplitude_um,relative_friction\n0,1\n",
                "cal.csv, line 2, column 'amplitude_um': a calibration needs 2 to",
            ),
            (
                "amplitude_um,relative_friction\n0,1\n1,abc\n",
                "cal.csv, line 3, column 'relative_friction': not a number",
            ),
            (
                "amplitude_um,mu\n0,1\n1,0.5\n",
                "cal.csv, line 1, column 'relative_friction': required column is missing",
            ),
        ] {
            let e = read(text).unwrap_err().to_string();
            assert!(e.starts_with(expected), "{text:?}\n{e}");
        }
    }

    #[test]
    fn in_memory_calibration_names_its_row() {
        let e = Calibration::new(vec![0.0, 1.0], vec![1.0, 1.0], "api").unwrap_err();
        assert!(matches!(e, UltrasonicError::Invalid { index: 1, field: "relative_friction", .. }), "{e}");
        let e = Calibration::new(vec![0.0; MAX_CALIBRATION_ROWS + 1], vec![1.0; MAX_CALIBRATION_ROWS + 1], "api")
            .unwrap_err();
        assert!(e.to_string().contains("2 to 10000 rows"), "{e}");
    }
}
