//! The voltage curve U(x) a drive signal plays: the `x_mm,voltage_v` part
//! of a voltage profile, and what U is outside the profile's span.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::electrovibration::VoltageProfile;
use crate::io::Table;
use crate::profile::{ProfileError, validate};

/// What the voltage is where the finger is outside the profile's span
/// [x_first, x_last].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Extend {
    /// The first / last voltage is held (as `FrictionProfile::mu_at`).
    #[default]
    Hold,
    /// 0 V outside the span: no stimulus where the texture is not defined.
    Zero,
    /// The span [x_first, x_last) repeats with period x_last - x_first
    /// (a texture tile; U(x_last) should equal U(x_first)).
    Repeat,
}

impl Extend {
    /// Where a curve spanning [x0, x1] is read at `x_mm`: the position to
    /// interpolate it at (`Hold` relies on the interpolation holding its
    /// end values), or `None` where the curve is zero (`Zero`, outside the
    /// span).
    pub fn position(self, x_mm: f64, x0: f64, x1: f64) -> Option<f64> {
        match self {
            Extend::Hold => Some(x_mm),
            Extend::Zero if x_mm < x0 || x_mm > x1 => None,
            Extend::Zero => Some(x_mm),
            Extend::Repeat => Some(x0 + (x_mm - x0).rem_euclid(x1 - x0)),
        }
    }
}

/// A voltage curve U(x): positions in mm (strictly increasing, at least
/// two) and the RMS voltage in V (finite, >= 0) at each. Linear between
/// samples; outside the span as [`Extend`] says.
#[derive(Debug, Clone, PartialEq)]
pub struct VoltageCurve {
    x_mm: Vec<f64>,
    voltage_v: Vec<f64>,
}

impl VoltageCurve {
    /// A curve from positions (mm) and RMS voltages (V).
    pub fn new(x_mm: Vec<f64>, voltage_v: Vec<f64>) -> Result<Self, ProfileError> {
        let in_memory = |(index, field, message): (Option<usize>, &'static str, String)| ProfileError::Invalid {
            index: index.unwrap_or(0),
            field,
            message,
        };
        validate(&x_mm, &[("voltage_v", &voltage_v)]).map_err(in_memory)?;
        Ok(Self { x_mm, voltage_v })
    }

    /// Reads a voltage profile table: `x_mm` and `voltage_v` are required,
    /// other columns (`mu`, ...) are ignored. Errors name file, line, column.
    ///
    /// A profile designed for a combined display (an `amplitude_um`
    /// column, `haptex voltage --display combined`) is refused: its
    /// voltages assume the plate vibrates with those amplitudes, and a
    /// reader of the voltage alone would render another friction than the
    /// one designed. [`VoltageCurve::from_display_table`] reads both.
    pub fn from_table(table: &Table) -> Result<Self, ProfileError> {
        let at = |(row, field, message): (Option<usize>, &'static str, String)| {
            ProfileError::Table(table.error_at(row, Some(field), message))
        };
        if table.column("amplitude_um").is_some() {
            return Err(at((
                None,
                "amplitude_um",
                "this profile was designed for a combined display: its voltages assume the ultrasonic amplitudes \
                 beside them, which a voltage-only reader cannot apply; play it on two channels with haptex play \
                 --a-max-um, check it with haptex check --display combined, or design it with --display \
                 electrovibration"
                    .to_string(),
            )));
        }
        let x_mm = table.require("x_mm")?.to_vec();
        let voltage_v = table.require("voltage_v")?.to_vec();
        validate(&x_mm, &[("voltage_v", &voltage_v)]).map_err(at)?;
        Ok(Self { x_mm, voltage_v })
    }

    /// Reads a display profile for a two-channel drive: the voltage curve
    /// and, when the table has an `amplitude_um` column (`haptex voltage
    /// --display combined|ultrasonic`), the ultrasonic amplitude curve over
    /// the same positions. A profile without `voltage_v` but with
    /// `amplitude_um` (the ultrasonic display) plays 0 V on channel 1.
    /// Without `amplitude_um` this is [`VoltageCurve::from_table`].
    pub fn from_display_table(table: &Table) -> Result<(Self, Option<AmplitudeCurve>), ProfileError> {
        let Some(amplitude) = table.column("amplitude_um") else {
            return Ok((Self::from_table(table)?, None));
        };
        let at = |(row, field, message): (Option<usize>, &'static str, String)| {
            ProfileError::Table(table.error_at(row, Some(field), message))
        };
        let x_mm = table.require("x_mm")?.to_vec();
        let amplitude_um = amplitude.to_vec();
        let voltage_v = match table.column("voltage_v") {
            Some(v) => v.to_vec(),
            None => vec![0.0; x_mm.len()],
        };
        // validate checks amplitude_um against its range (0 .. 100 um).
        validate(&x_mm, &[("voltage_v", &voltage_v), ("amplitude_um", &amplitude_um)]).map_err(at)?;
        Ok((Self { x_mm: x_mm.clone(), voltage_v }, Some(AmplitudeCurve(Self { x_mm, voltage_v: amplitude_um }))))
    }

    /// Reads a voltage profile CSV from any reader; `source_name` labels errors.
    pub fn read_csv<R: std::io::Read>(reader: R, source_name: &str) -> Result<Self, ProfileError> {
        Self::from_table(&Table::read(reader, source_name)?)
    }

    /// Reads a voltage profile CSV file (`x_mm,mu,voltage_v`, as written by
    /// `haptex voltage`).
    pub fn read_csv_file(path: &Path) -> Result<Self, ProfileError> {
        Self::from_table(&Table::read_file(path)?)
    }

    /// Positions in mm.
    pub fn x_mm(&self) -> &[f64] {
        &self.x_mm
    }

    /// RMS voltages in V.
    pub fn voltage_v(&self) -> &[f64] {
        &self.voltage_v
    }

    /// First and last position in mm.
    pub fn span_mm(&self) -> (f64, f64) {
        (self.x_mm[0], self.x_mm[self.x_mm.len() - 1])
    }

    /// Largest voltage of the curve in V.
    pub fn max_v(&self) -> f64 {
        self.voltage_v.iter().fold(0.0, |m, &v| m.max(v))
    }

    /// Smallest spacing between consecutive positions in mm.
    pub fn min_spacing_mm(&self) -> f64 {
        self.x_mm.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min)
    }

    /// U in V (RMS) at `x_mm`: linear interpolation inside the span,
    /// `extend` outside it.
    pub fn voltage_at(&self, x_mm: f64, extend: Extend) -> f64 {
        let (x0, x1) = self.span_mm();
        match extend.position(x_mm, x0, x1) {
            Some(x) => crate::profile::interpolate(&self.x_mm, &self.voltage_v, x),
            None => 0.0,
        }
    }

    /// [`VoltageCurve::voltage_at`] at every position of a path (a
    /// finger's positions, sample by sample) into `out`: the same values,
    /// found by walking the table from the last position's interval
    /// instead of a binary search per position.
    pub fn voltages_along(&self, x_mm: &[f64], extend: Extend, out: &mut [f64]) {
        let (x0, x1) = self.span_mm();
        let mut cursor = crate::profile::WalkingCursor::default();
        let (xs, ys) = (&self.x_mm[..], &self.voltage_v[..]);
        for (u, &x) in out.iter_mut().zip(x_mm) {
            *u = extend.position(x, x0, x1).map_or(0.0, |x| cursor.interpolate(xs, ys, x));
        }
    }

    /// Whether `x_mm` is inside the span [x_first, x_last].
    pub fn contains(&self, x_mm: f64) -> bool {
        let (x0, x1) = self.span_mm();
        (x0..=x1).contains(&x_mm)
    }
}

/// An ultrasonic amplitude curve a(x): positions in mm and the plate's
/// vibration amplitude in um (peak, finite, >= 0), linear between samples
/// and extended outside the span as the voltage curve is. A distinct type
/// from [`VoltageCurve`] so that an amplitude is never played as a voltage.
#[derive(Debug, Clone, PartialEq)]
pub struct AmplitudeCurve(VoltageCurve);

impl AmplitudeCurve {
    /// A curve from positions (mm) and amplitudes (um).
    pub fn new(x_mm: Vec<f64>, amplitude_um: Vec<f64>) -> Result<Self, ProfileError> {
        validate(&x_mm, &[("amplitude_um", &amplitude_um)])
            .map_err(|(index, field, message)| ProfileError::Invalid { index: index.unwrap_or(0), field, message })?;
        Ok(Self(VoltageCurve { x_mm, voltage_v: amplitude_um }))
    }

    /// The curve's positions (mm) and amplitudes (um) as a [`VoltageCurve`]
    /// for the crate's interpolation code (never played as a voltage).
    pub(crate) fn curve(&self) -> &VoltageCurve {
        &self.0
    }

    /// Positions in mm.
    pub fn x_mm(&self) -> &[f64] {
        self.0.x_mm()
    }

    /// Amplitudes in um (peak).
    pub fn amplitude_um(&self) -> &[f64] {
        self.0.voltage_v()
    }

    /// Largest amplitude of the curve in um.
    pub fn max_um(&self) -> f64 {
        self.0.max_v()
    }

    /// a in um at every position of a path into `out` (as
    /// [`VoltageCurve::voltages_along`]).
    pub fn amplitudes_along(&self, x_mm: &[f64], extend: Extend, out: &mut [f64]) {
        self.0.voltages_along(x_mm, extend, out)
    }
}

impl From<&VoltageProfile> for VoltageCurve {
    /// The curve of a mapped profile (already validated by the mapping).
    fn from(profile: &VoltageProfile) -> Self {
        Self { x_mm: profile.x_mm.clone(), voltage_v: profile.voltage_v.clone() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extend_modes() {
        let c = VoltageCurve::new(vec![0.0, 1.0, 2.0], vec![0.0, 10.0, 0.0]).unwrap();
        assert_eq!(c.voltage_at(0.5, Extend::Hold), 5.0);
        assert_eq!(c.voltage_at(-1.0, Extend::Hold), 0.0);
        assert_eq!(c.voltage_at(1.0, Extend::Zero), 10.0);
        assert_eq!(c.voltage_at(2.5, Extend::Zero), 0.0);
        assert_eq!(c.voltage_at(3.0, Extend::Repeat), 10.0);
        assert_eq!(c.voltage_at(-1.5, Extend::Repeat), 5.0);
        let c = VoltageCurve::new(vec![0.0, 1.0], vec![3.0, 4.0]).unwrap();
        assert_eq!(c.voltage_at(5.0, Extend::Hold), 4.0);
        assert_eq!(c.voltage_at(5.0, Extend::Zero), 0.0);
    }

    /// The walking lookup gives voltage_at's values bit for bit, along a
    /// back-and-forth path that crosses every knot, lands on knots and
    /// leaves the span on both sides, in every extension mode.
    #[test]
    fn voltages_along_equals_voltage_at() {
        let xs: Vec<f64> = (0..41).map(|i| i as f64 * 0.25 + if i % 3 == 0 { 0.01 } else { 0.0 }).collect();
        let ys: Vec<f64> = xs.iter().map(|x| 50.0 + 40.0 * (1.3 * x).sin()).collect();
        let c = VoltageCurve::new(xs.clone(), ys).unwrap();
        let mut path: Vec<f64> = (0..4000).map(|i| 5.0 + 7.0 * (i as f64 * 0.003).sin()).collect();
        path.extend(&xs);
        path.extend(xs.iter().rev());
        path.extend([f64::NAN, -1.0, 0.0, 10.01, 10.0, 3.0]);
        for extend in [Extend::Hold, Extend::Zero, Extend::Repeat] {
            let mut out = vec![0.0; path.len()];
            c.voltages_along(&path, extend, &mut out);
            for (x, u) in path.iter().zip(&out) {
                let want = c.voltage_at(*x, extend);
                assert!(
                    u.to_bits() == want.to_bits() || (u.is_nan() && want.is_nan()),
                    "{extend:?} at {x}: {u} vs {want}"
                );
            }
        }
    }

    #[test]
    fn reads_voltage_profiles_and_names_bad_lines() {
        let c = VoltageCurve::read_csv("# c\nx_mm,mu,voltage_v\n0,1.1,70\n1,1.2,99\n".as_bytes(), "u.csv").unwrap();
        assert_eq!(c.voltage_v(), [70.0, 99.0]);
        let c = VoltageCurve::read_csv("x_mm,voltage_v\n0,1\n1,2\n".as_bytes(), "u.csv").unwrap();
        assert_eq!(c.max_v(), 2.0);
        let e = VoltageCurve::read_csv("x_mm,voltage_v\n0,1\n1,-2\n".as_bytes(), "u.csv").unwrap_err();
        assert_eq!(e.to_string(), "u.csv, line 3, column 'voltage_v': voltage_v must be from 0 to 1000000 V, got -2");
        let e = VoltageCurve::read_csv("x_mm,mu\n0,1\n1,2\n".as_bytes(), "u.csv").unwrap_err();
        assert!(e.to_string().starts_with("u.csv, line 1, column 'voltage_v': required column is missing"), "{e}");
        let e = VoltageCurve::read_csv("x_mm,voltage_v\n0,1\n0,2\n".as_bytes(), "u.csv").unwrap_err();
        assert!(e.to_string().starts_with("u.csv, line 3, column 'x_mm'"), "{e}");
    }

    /// A combined display's profile is not played as if the voltage were
    /// all of it.
    #[test]
    fn combined_display_profiles_are_refused() {
        let text = "# c\nx_mm,mu,voltage_v,amplitude_um\n0,0.9,0,0.3\n1,1.1,70,0\n";
        let e = VoltageCurve::read_csv(text.as_bytes(), "d.csv").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("d.csv, line 2, column 'amplitude_um': this profile was designed for a combined display"),
            "{e}"
        );
    }

    /// A display profile reads as voltage and amplitude over the same
    /// positions; bad amplitudes are refused at their line and column.
    #[test]
    fn display_profiles_read_both_channels() {
        let text = "# c\nx_mm,mu,voltage_v,amplitude_um\n0,0.9,0,0.3\n1,1.1,70,0\n";
        let table = Table::read(text.as_bytes(), "d.csv").unwrap();
        let (u, a) = VoltageCurve::from_display_table(&table).unwrap();
        assert_eq!(u.voltage_v(), &[0.0, 70.0]);
        let mut out = [0.0; 2];
        a.unwrap().amplitudes_along(&[0.5, 2.0], Extend::Hold, &mut out);
        assert_eq!(out, [0.15, 0.0]);
        // An ultrasonic display's profile: 0 V on channel 1.
        let table = Table::read("x_mm,mu,amplitude_um\n0,0.5,1\n1,0.6,0.8\n".as_bytes(), "a.csv").unwrap();
        let (u, a) = VoltageCurve::from_display_table(&table).unwrap();
        assert_eq!((u.max_v(), a.unwrap().max_um()), (0.0, 1.0));
        let table = Table::read("x_mm,voltage_v,amplitude_um\n0,1,0.3\n1,2,-0.1\n".as_bytes(), "b.csv").unwrap();
        let e = VoltageCurve::from_display_table(&table).unwrap_err().to_string();
        assert!(e.starts_with("b.csv, line 3, column 'amplitude_um'"), "{e}");
        // Without amplitude_um: the voltage profile, as from_table.
        let table = Table::read("x_mm,voltage_v\n0,1\n1,2\n".as_bytes(), "v.csv").unwrap();
        assert!(VoltageCurve::from_display_table(&table).unwrap().1.is_none());
    }
}
