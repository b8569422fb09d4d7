//! Finger trajectories x(t): where the finger is on the surface at each
//! time, the input that turns a voltage profile U(x) into a drive signal.
//!
//! Files (`docs/file-formats.md`): `t_s,x_mm` CSV, times strictly
//! increasing; extra columns are allowed and ignored. Between samples the
//! position is interpolated linearly; before the first and after the last
//! sample it is held.
//!
//! Generators: [`Trajectory::constant_velocity`] (one sweep), and
//! [`Trajectory::strokes`] (back-and-forth strokes, each a minimum-jerk
//! movement: Flash & Hogan 1985).

use std::io::Write;
use std::path::Path;

use crate::io::{Table, TableError, WriteError, write_atomic, write_csv_row};
use crate::num::Num;
use crate::profile::Cursor;

/// Most samples a generated trajectory may have (1e8: 28 h at 1 kHz).
pub const MAX_GENERATED_SAMPLES: usize = 100_000_000;

/// A trajectory is invalid, or its file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum TrajectoryError {
    #[error(transparent)]
    Table(#[from] TableError),
    /// In-memory data failed validation at sample `index`.
    #[error("sample {index}, field '{field}': {message}")]
    Invalid { index: usize, field: &'static str, message: String },
    /// Generator parameters are out of range.
    #[error("{0}")]
    Generator(String),
}

/// A finger trajectory: times in s (strictly increasing) and the finger's
/// position in mm at each.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    t_s: Vec<f64>,
    x_mm: Vec<f64>,
}

impl Trajectory {
    /// A trajectory from times (s) and positions (mm).
    pub fn new(t_s: Vec<f64>, x_mm: Vec<f64>) -> Result<Self, TrajectoryError> {
        validate(&t_s, &x_mm).map_err(|(index, field, message)| TrajectoryError::Invalid {
            index: index.unwrap_or(0),
            field,
            message,
        })?;
        Ok(Self { t_s, x_mm })
    }

    /// Reads a trajectory from a parsed `t_s,x_mm` table; errors name the
    /// file, line and column.
    pub fn from_table(table: &Table) -> Result<Self, TrajectoryError> {
        let t_s = table.require("t_s")?.to_vec();
        let x_mm = table.require("x_mm")?.to_vec();
        validate(&t_s, &x_mm).map_err(|(row, field, message)| table.error_at(row, Some(field), message))?;
        Ok(Self { t_s, x_mm })
    }

    /// Reads a `t_s,x_mm` CSV from any reader; `source_name` labels errors.
    pub fn read_csv<R: std::io::Read>(reader: R, source_name: &str) -> Result<Self, TrajectoryError> {
        Self::from_table(&Table::read(reader, source_name)?)
    }

    /// Reads a `t_s,x_mm` CSV file.
    pub fn read_csv_file(path: &Path) -> Result<Self, TrajectoryError> {
        Self::from_table(&Table::read_file(path)?)
    }

    /// Writes `t_s,x_mm` CSV.
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        w.write_all(b"t_s,x_mm\n")?;
        for (t, x) in self.t_s.iter().zip(&self.x_mm) {
            write_csv_row(w, &[*t, *x])?;
        }
        Ok(())
    }

    /// Writes `t_s,x_mm` CSV to `path` atomically.
    pub fn write_csv_file(&self, path: &Path) -> Result<(), WriteError> {
        write_atomic(path, |w| self.write_csv(w))
    }

    /// One sweep at constant velocity from `from_mm` to `to_mm` (either
    /// direction) at `speed_mm_s` > 0, sampled at `rate_hz`, starting at
    /// t = 0. Linear interpolation between the samples is exact.
    pub fn constant_velocity(from_mm: f64, to_mm: f64, speed_mm_s: f64, rate_hz: f64) -> Result<Self, TrajectoryError> {
        let duration_s = sweep_duration(from_mm, to_mm, speed_mm_s, rate_hz)?;
        Self::sample(duration_s, rate_hz, |t| from_mm + (to_mm - from_mm) * (t / duration_s))
    }

    /// `n_strokes` strokes between `from_mm` and `to_mm`, alternating in
    /// direction (the first goes from `from_mm` to `to_mm`), sampled at
    /// `rate_hz`, starting at t = 0. Each stroke is a minimum-jerk movement
    /// (Flash & Hogan 1985, J. Neurosci. 5(7):1688-1703), the smooth profile
    /// of human point-to-point reaching:
    /// x(s) = a + (b - a)(10 s^3 - 15 s^4 + 6 s^5), s = t/T, with T =
    /// |b - a| / `mean_speed_mm_s`. Velocity and acceleration are zero at
    /// each reversal; the peak velocity is 1.875 times the mean.
    pub fn strokes(
        from_mm: f64,
        to_mm: f64,
        mean_speed_mm_s: f64,
        n_strokes: usize,
        rate_hz: f64,
    ) -> Result<Self, TrajectoryError> {
        if n_strokes == 0 {
            return Err(TrajectoryError::Generator("the number of strokes must be at least 1".into()));
        }
        let stroke_s = sweep_duration(from_mm, to_mm, mean_speed_mm_s, rate_hz)?;
        Self::sample(stroke_s * n_strokes as f64, rate_hz, |t| {
            let k = ((t / stroke_s) as usize).min(n_strokes - 1);
            let s = ((t - k as f64 * stroke_s) / stroke_s).clamp(0.0, 1.0);
            let shape = s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
            let (a, b) = if k.is_multiple_of(2) { (from_mm, to_mm) } else { (to_mm, from_mm) };
            a + (b - a) * shape
        })
    }

    /// Samples `x(t)` at `rate_hz` from 0 to `duration_s` (the last sample
    /// exactly at `duration_s`).
    fn sample(duration_s: f64, rate_hz: f64, x: impl Fn(f64) -> f64) -> Result<Self, TrajectoryError> {
        let intervals = (duration_s * rate_hz).ceil().max(1.0);
        if intervals >= MAX_GENERATED_SAMPLES as f64 {
            return Err(TrajectoryError::Generator(format!(
                "{} s at {} Hz is more than {MAX_GENERATED_SAMPLES} samples",
                Num(duration_s),
                Num(rate_hz)
            )));
        }
        let n = intervals as usize;
        let t_s: Vec<f64> = (0..=n).map(|i| if i == n { duration_s } else { i as f64 / rate_hz }).collect();
        let x_mm = t_s.iter().map(|&t| x(t)).collect();
        Self::new(t_s, x_mm)
    }

    /// Times in s, strictly increasing.
    pub fn t_s(&self) -> &[f64] {
        &self.t_s
    }

    /// Finger positions in mm.
    pub fn x_mm(&self) -> &[f64] {
        &self.x_mm
    }

    /// Number of samples (at least 2).
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Always false: a trajectory has at least two samples.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Time of the first sample in s.
    pub fn start_s(&self) -> f64 {
        self.t_s[0]
    }

    /// Time of the last sample in s.
    pub fn end_s(&self) -> f64 {
        self.t_s[self.len() - 1]
    }

    /// Duration from the first to the last sample in s.
    pub fn duration_s(&self) -> f64 {
        self.end_s() - self.start_s()
    }

    /// Smallest and largest position in mm.
    pub fn x_range_mm(&self) -> (f64, f64) {
        self.x_mm.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)))
    }

    /// Position in mm at time `t_s` (linear interpolation, held beyond the ends).
    pub fn position_at(&self, t_s: f64) -> f64 {
        crate::profile::interpolate(&self.t_s, &self.x_mm, t_s)
    }

    /// Positions at increasing times `t0_s + i * dt_s`, i = 0..out.len(),
    /// into `out` (one pass over the samples).
    pub fn positions_into(&self, t0_s: f64, dt_s: f64, out: &mut [f64]) {
        let mut cursor = Cursor::default();
        for (i, x) in out.iter_mut().enumerate() {
            *x = cursor.interpolate(&self.t_s, &self.x_mm, t0_s + i as f64 * dt_s);
        }
    }
}

/// Duration of a sweep from `from_mm` to `to_mm` at `speed_mm_s`, after
/// checking the generator parameters.
fn sweep_duration(from_mm: f64, to_mm: f64, speed_mm_s: f64, rate_hz: f64) -> Result<f64, TrajectoryError> {
    let bad = |m: String| Err(TrajectoryError::Generator(m));
    if crate::profile::check_values("x_mm", &[from_mm, to_mm]).is_err() {
        return bad(format!(
            "stroke ends must be finite positions within 1e6 mm, got {} and {} mm",
            Num(from_mm),
            Num(to_mm)
        ));
    }
    if from_mm == to_mm {
        return bad(format!("stroke ends are equal ({} mm): the finger would not move", Num(from_mm)));
    }
    if !(speed_mm_s.is_finite() && speed_mm_s > 0.0) {
        return bad(format!("speed must be a positive finite number, got {} mm/s", Num(speed_mm_s)));
    }
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return bad(format!("sample rate must be a positive finite number, got {} Hz", Num(rate_hz)));
    }
    Ok((to_mm - from_mm).abs() / speed_mm_s)
}

/// Checks at least two samples, equal lengths, finite values and strictly
/// increasing times; the error names the 0-based sample and the field.
pub(crate) fn validate(t_s: &[f64], x_mm: &[f64]) -> Result<(), crate::profile::Violation> {
    if t_s.len() < 2 {
        return Err((None, "t_s", format!("a trajectory needs at least 2 samples, got {}", t_s.len())));
    }
    if x_mm.len() != t_s.len() {
        return Err((None, "x_mm", format!("{} positions for {} times", x_mm.len(), t_s.len())));
    }
    crate::profile::check_values("t_s", t_s)?;
    crate::profile::check_values("x_mm", x_mm)?;
    if let Some(i) = t_s.windows(2).position(|w| w[1] <= w[0]) {
        return Err((Some(i + 1), "t_s", {
            let (next, previous) = crate::num::distinct(t_s[i + 1], t_s[i]);
            format!("times must be strictly increasing: {next} follows {previous}")
        }));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_velocity_is_linear_and_ends_exactly() {
        let t = Trajectory::constant_velocity(10.0, 0.0, 20.0, 1000.0).unwrap();
        assert_eq!(t.end_s(), 0.5);
        assert_eq!(t.len(), 501);
        assert_eq!(t.x_mm()[0], 10.0);
        assert_eq!(t.x_mm()[500], 0.0);
        assert!((t.position_at(0.123) - (10.0 - 20.0 * 0.123)).abs() < 1e-12);
        assert!(Trajectory::constant_velocity(0.0, 0.0, 20.0, 1000.0).is_err());
        assert!(Trajectory::constant_velocity(0.0, 1.0, -2.0, 1000.0).is_err());
    }

    /// Minimum-jerk strokes (Flash & Hogan 1985): mean speed as asked, peak
    /// speed 1.875 x mean at mid-stroke, at rest at each reversal.
    #[test]
    fn minimum_jerk_strokes_reverse_at_rest() {
        let rate = 10_000.0;
        let t = Trajectory::strokes(0.0, 10.0, 50.0, 3, rate).unwrap();
        assert!((t.end_s() - 0.6).abs() < 1e-12);
        assert_eq!(t.x_range_mm(), (0.0, 10.0));
        let v = |time: f64| (t.position_at(time + 0.5 / rate) - t.position_at(time - 0.5 / rate)) * rate;
        // Mid-stroke peak: 1.875 * 50 mm/s, within the finite-difference error.
        assert!((v(0.1) - 93.75).abs() < 1e-3, "{}", v(0.1));
        assert!((v(0.3) + 93.75).abs() < 1e-3, "{}", v(0.3));
        assert!(v(0.2).abs() < 1e-3, "{}", v(0.2));
        assert!((t.position_at(0.2) - 10.0).abs() < 1e-12 && (t.position_at(0.4)).abs() < 1e-12);
    }

    #[test]
    fn positions_into_matches_position_at() {
        let t = Trajectory::new(vec![0.0, 1.0, 3.0], vec![0.0, 2.0, -2.0]).unwrap();
        let mut out = [0.0; 9];
        t.positions_into(-0.5, 0.5, &mut out);
        let expected: Vec<f64> = (0..9).map(|i| t.position_at(-0.5 + 0.5 * i as f64)).collect();
        assert_eq!(out.to_vec(), expected);
        assert_eq!(out, [0.0, 0.0, 1.0, 2.0, 1.0, 0.0, -1.0, -2.0, -2.0]);
    }
}
