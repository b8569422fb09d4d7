//! Friction profiles mu(x): the location-domain friction coefficient of a
//! reference surface, the input of the electrovibration mapping.
//!
//! Files (`docs/file-formats.md`): `x_mm,mu`, or `x_mm,ft_n,fn_n` from which
//! mu = ft/fn (paper eq. 4). Extra columns are allowed and ignored, so a
//! voltage profile (`x_mm,mu,voltage_v`) reads back as a friction profile.

use std::io::Write;
use std::path::Path;

use crate::io::{Table, TableError, WriteError, write_atomic, write_csv_row};
use crate::num::Num;

/// A friction profile is invalid, or its file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error(transparent)]
    Table(#[from] TableError),
    /// In-memory data failed validation at sample `index`.
    #[error("sample {index}, field '{field}': {message}")]
    Invalid { index: usize, field: &'static str, message: String },
    #[error("{0}")]
    Resample(String),
}

/// Where a validation problem is: sample index (0-based), field, message.
pub(crate) type Violation = (Option<usize>, &'static str, String);

/// A friction profile: positions in mm (strictly increasing) and the
/// friction coefficient at each, with the normal force in N when known.
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionProfile {
    x_mm: Vec<f64>,
    mu: Vec<f64>,
    fn_n: Option<Vec<f64>>,
}

impl FrictionProfile {
    /// A profile from positions (mm) and friction coefficients.
    pub fn new(x_mm: Vec<f64>, mu: Vec<f64>) -> Result<Self, ProfileError> {
        validate(&x_mm, &[("mu", &mu)]).map_err(in_memory)?;
        Ok(Self { x_mm, mu, fn_n: None })
    }

    /// A profile from positions (mm), tangential and normal forces (N):
    /// mu = ft / fn (paper eq. 4); fn must be positive.
    pub fn from_forces(x_mm: Vec<f64>, ft_n: &[f64], fn_n: Vec<f64>) -> Result<Self, ProfileError> {
        validate(&x_mm, &[("ft_n", ft_n), ("fn_n", &fn_n)]).map_err(in_memory)?;
        let mu = mu_from_forces(ft_n, &fn_n).map_err(in_memory)?;
        Ok(Self { x_mm, mu, fn_n: Some(fn_n) })
    }

    /// The same profile with the normal force in N at each position
    /// (finite, positive, one value per position), e.g. the location-domain
    /// Fn of a recorded stroke.
    pub fn with_normal_force(mut self, fn_n: Vec<f64>) -> Result<Self, ProfileError> {
        validate(&self.x_mm, &[("fn_n", &fn_n)]).map_err(in_memory)?;
        self.fn_n = Some(fn_n);
        Ok(self)
    }

    /// Reads a profile from a parsed table: `x_mm` plus `mu`, or `x_mm` plus
    /// `ft_n` and `fn_n`. If `mu` is present it is used as is, and an
    /// `fn_n` column, if any, is kept as the normal force.
    pub fn from_table(table: &Table) -> Result<Self, ProfileError> {
        let at = |v: Violation| ProfileError::Table(table.error_at(v.0, Some(v.1), v.2));
        let x_mm = table.require("x_mm")?.to_vec();
        let fn_col = table.column("fn_n").map(<[f64]>::to_vec);
        let mu = match table.column("mu") {
            Some(mu) => {
                validate(&x_mm, &[("mu", mu)]).map_err(at)?;
                mu.to_vec()
            }
            None => {
                let (ft, fnn) = match (table.column("ft_n"), fn_col.as_deref()) {
                    (Some(ft), Some(fnn)) => (ft, fnn),
                    _ => {
                        let missing = if table.column("ft_n").is_none() { "mu (or ft_n and fn_n)" } else { "fn_n" };
                        return Err(table.missing(missing).into());
                    }
                };
                validate(&x_mm, &[("ft_n", ft), ("fn_n", fnn)]).map_err(at)?;
                mu_from_forces(ft, fnn).map_err(at)?
            }
        };
        if let Some(fnn) = &fn_col {
            validate(&x_mm, &[("fn_n", fnn)]).map_err(at)?;
        }
        Ok(Self { x_mm, mu, fn_n: fn_col })
    }

    /// Reads a profile CSV from any reader; `source_name` labels errors.
    pub fn read_csv<R: std::io::Read>(reader: R, source_name: &str) -> Result<Self, ProfileError> {
        Self::from_table(&Table::read(reader, source_name)?)
    }

    /// Reads a profile CSV file.
    pub fn read_csv_file(path: &Path) -> Result<Self, ProfileError> {
        Self::from_table(&Table::read_file(path)?)
    }

    /// Writes `x_mm,mu` CSV.
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        w.write_all(b"x_mm,mu\n")?;
        for (x, mu) in self.x_mm.iter().zip(&self.mu) {
            write_csv_row(w, &[*x, *mu])?;
        }
        Ok(())
    }

    /// Writes `#` comment lines (one per entry; newlines become spaces),
    /// then `x_mm,mu`, or `x_mm,mu,fn_n` when the normal force is known.
    pub fn write_csv_commented(&self, w: &mut dyn Write, comments: &[String]) -> std::io::Result<()> {
        for line in comments {
            writeln!(w, "# {}", line.replace('\n', " "))?;
        }
        match &self.fn_n {
            Some(fn_n) => {
                w.write_all(b"x_mm,mu,fn_n\n")?;
                for ((x, mu), f) in self.x_mm.iter().zip(&self.mu).zip(fn_n) {
                    write_csv_row(w, &[*x, *mu, *f])?;
                }
                Ok(())
            }
            None => self.write_csv(w),
        }
    }

    /// Writes `x_mm,mu` CSV to `path` atomically.
    pub fn write_csv_file(&self, path: &Path) -> Result<(), WriteError> {
        write_atomic(path, |w| self.write_csv(w))
    }

    /// Positions in mm, strictly increasing.
    pub fn x_mm(&self) -> &[f64] {
        &self.x_mm
    }

    /// Friction coefficient at each position.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    /// Normal force in N at each position, when the source gave it.
    pub fn fn_n(&self) -> Option<&[f64]> {
        self.fn_n.as_deref()
    }

    /// Mean normal force in N (paper section 2.4: "for Fn^RS a mean value
    /// ... during sliding was used"), when the source gave it.
    pub fn mean_fn_n(&self) -> Option<f64> {
        self.fn_n.as_ref().map(|f| f.iter().sum::<f64>() / f.len() as f64)
    }

    /// The median of the friction values (the mean of the middle two for an
    /// even count): the typical level of the profile, unmoved by its
    /// features as long as they cover less than half of it
    /// ([`crate::relative`] uses it as the default flat-surface friction).
    pub fn median_mu(&self) -> f64 {
        let mut values = self.mu.clone();
        let n = values.len();
        let (below, middle, _) = values.select_nth_unstable_by(n / 2, f64::total_cmp);
        let middle = *middle;
        if n % 2 == 1 {
            middle
        } else {
            // The largest of the lower half is the other middle value.
            let lower = below.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            0.5 * (lower + middle)
        }
    }

    /// The same positions and normal force with the friction values `mu`,
    /// which the caller has checked: one per position, finite and within
    /// [`crate::ranges::MU`].
    pub(crate) fn with_checked_mu(&self, mu: Vec<f64>) -> Self {
        debug_assert!(mu.len() == self.mu.len() && crate::ranges::MU.first_outside(&mu).is_none());
        Self { x_mm: self.x_mm.clone(), mu, fn_n: self.fn_n.clone() }
    }

    /// Number of samples (at least 2).
    pub fn len(&self) -> usize {
        self.x_mm.len()
    }

    /// Always false: a profile has at least two samples.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Length covered, x_last - x_first, in mm.
    pub fn span_mm(&self) -> f64 {
        self.x_mm[self.len() - 1] - self.x_mm[0]
    }

    /// mu at `x_mm` by linear interpolation, held constant beyond the ends.
    pub fn mu_at(&self, x_mm: f64) -> f64 {
        interpolate(&self.x_mm, &self.mu, x_mm)
    }

    /// The profile resampled by linear interpolation onto `n` uniformly
    /// spaced positions from the first to the last sample (n >= 2).
    pub fn resample_uniform(&self, n: usize) -> Result<Self, ProfileError> {
        if n < 2 {
            return Err(ProfileError::Resample(format!("cannot resample onto {n} points: need at least 2")));
        }
        let (x0, x1) = (self.x_mm[0], self.x_mm[self.len() - 1]);
        let step = (x1 - x0) / (n - 1) as f64;
        self.resample_at(n, |i| if i + 1 == n { x1 } else { x0 + step * i as f64 })
    }

    /// The profile resampled onto a uniform grid of spacing `dx_mm` starting
    /// at the first sample; the last point may fall short of the end.
    pub fn resample_step(&self, dx_mm: f64) -> Result<Self, ProfileError> {
        if !(dx_mm.is_finite() && dx_mm > 0.0) {
            return Err(ProfileError::Resample(format!("grid spacing must be positive, got {} mm", Num(dx_mm))));
        }
        let intervals = (self.span_mm() / dx_mm).floor();
        if intervals < 1.0 {
            return Err(ProfileError::Resample(format!(
                "spacing {} mm is longer than the profile ({} mm)",
                Num(dx_mm),
                Num(self.span_mm())
            )));
        }
        if intervals > 1e9 {
            return Err(ProfileError::Resample(format!("spacing {} mm gives more than 1e9 points", Num(dx_mm))));
        }
        let x0 = self.x_mm[0];
        self.resample_at(intervals as usize + 1, |i| x0 + dx_mm * i as f64)
    }

    /// Linear interpolation of every column at the `n` increasing positions
    /// `x(0), x(1), ...`; the buffers (sized by the caller's n) allocated
    /// fallibly, so that a grid the memory cannot hold is an error.
    fn resample_at(&self, n: usize, x: impl Fn(usize) -> f64) -> Result<Self, ProfileError> {
        let buffer = || {
            crate::buffer::try_with_capacity::<f64>(n, || format!("a profile of {n} points"))
                .map_err(|e| ProfileError::Resample(e.to_string()))
        };
        let mut x_mm = buffer()?;
        x_mm.extend((0..n).map(x));
        let resample = |values: &[f64]| -> Result<Vec<f64>, ProfileError> {
            let mut out = buffer()?;
            let mut cursor = Cursor::default();
            out.extend(x_mm.iter().map(|&x| cursor.interpolate(&self.x_mm, values, x)));
            Ok(out)
        };
        let mu = resample(&self.mu)?;
        let fn_n = self.fn_n.as_deref().map(resample).transpose()?;
        // A grid over a valid span is strictly increasing unless the span is
        // so small that consecutive points round to the same value.
        validate(&x_mm, &[("mu", &mu)]).map_err(|(_, _, m)| {
            ProfileError::Resample(format!(
                "cannot resample a {} mm span onto {} points: {m}",
                Num(self.span_mm()),
                x_mm.len()
            ))
        })?;
        Ok(Self { x_mm, mu, fn_n })
    }
}

/// Linear interpolation in a strictly increasing table, clamped at the ends.
pub fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let i = xs.partition_point(|&v| v <= x);
    if i == 0 {
        return ys[0];
    }
    if i >= xs.len() {
        return ys[xs.len() - 1];
    }
    lerp(xs, ys, i - 1, x)
}

fn lerp(xs: &[f64], ys: &[f64], i: usize, x: f64) -> f64 {
    let t = (x - xs[i]) / (xs[i + 1] - xs[i]);
    ys[i] + t * (ys[i + 1] - ys[i])
}

/// Interpolation along a path that moves a little between queries (a
/// finger's positions, sample by sample): walks from the last interval up
/// or down instead of a binary search, with the same convention and
/// therefore the same results, bit for bit, as [`interpolate`].
#[derive(Debug, Clone, Copy, Default)]
pub struct WalkingCursor {
    /// The interval [xs[i], xs[i + 1]) of the last query.
    i: usize,
}

impl WalkingCursor {
    /// [`interpolate`]`(xs, ys, x)`; `xs` increasing with at least two
    /// values, the same table at every call.
    #[inline]
    pub fn interpolate(&mut self, xs: &[f64], ys: &[f64], x: f64) -> f64 {
        let last = xs.len() - 1;
        // x below the first knot (or NaN) and at or beyond the last: the
        // end values, as the binary search gives them.
        if x < xs[0] || x.is_nan() {
            return ys[0];
        }
        if x >= xs[last] {
            return ys[last];
        }
        // Now xs[0] <= x < xs[last]: find xs[i] <= x < xs[i + 1].
        let mut i = self.i.min(last - 1);
        while xs[i + 1] <= x {
            i += 1;
        }
        while xs[i] > x {
            i -= 1;
        }
        self.i = i;
        lerp(xs, ys, i, x)
    }
}

/// Interpolation for increasing query positions: walks the table once.
#[derive(Default)]
pub(crate) struct Cursor {
    i: usize,
}

impl Cursor {
    #[inline]
    pub(crate) fn interpolate(&mut self, xs: &[f64], ys: &[f64], x: f64) -> f64 {
        let last = xs.len() - 1;
        if x <= xs[0] {
            return ys[0];
        }
        if x >= xs[last] {
            return ys[last];
        }
        while xs[self.i + 1] < x {
            self.i += 1;
        }
        lerp(xs, ys, self.i, x)
    }
}

/// Checks that every value of column `name` is finite and, when the
/// column is a quantity with an accepted range ([`crate::ranges`]: x_mm,
/// mu, ft_n, fn_n, t_s, voltage_v), within it, so that no span, ratio or
/// difference computed from the values can overflow.
pub(crate) fn check_values(name: &'static str, values: &[f64]) -> Result<(), Violation> {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err((Some(i), name, format!("not a finite number: {}", Num(values[i]))));
    }
    if let Some(range) = crate::ranges::of(name)
        && let Some(i) = range.first_outside(values)
    {
        return Err((Some(i), name, range.refusal(values[i]).to_string()));
    }
    Ok(())
}

/// Checks positions (finite, in range, strictly increasing, at least two)
/// and that each value column is finite, in range and as long as the
/// positions.
pub(crate) fn validate(x_mm: &[f64], columns: &[(&'static str, &[f64])]) -> Result<(), Violation> {
    if x_mm.len() < 2 {
        return Err((None, "x_mm", format!("a profile needs at least 2 points, got {}", x_mm.len())));
    }
    for (name, values) in columns {
        if values.len() != x_mm.len() {
            return Err((None, name, format!("{} values for {} positions", values.len(), x_mm.len())));
        }
        check_values(name, values)?;
    }
    check_values("x_mm", x_mm)?;
    if let Some(i) = x_mm.windows(2).position(|w| w[1] <= w[0]) {
        return Err((Some(i + 1), "x_mm", {
            let (next, previous) = crate::num::distinct(x_mm[i + 1], x_mm[i]);
            format!("positions must be strictly increasing: {next} follows {previous}")
        }));
    }
    Ok(())
}

/// mu = ft / fn (paper eq. 4) from checked forces, itself checked: a tiny
/// fn (5e-324 N) makes an infinite or absurd mu, refused at its row and
/// blamed on fn_n. A negative ft (the surface pushing the finger along, on
/// a steep downslope) gives a negative mu, kept ([`crate::ranges::MU`]).
fn mu_from_forces(ft_n: &[f64], fn_n: &[f64]) -> Result<Vec<f64>, Violation> {
    let mu: Vec<f64> = ft_n.iter().zip(fn_n).map(|(t, n)| t / n).collect();
    check_values("mu", &mu).map_err(|(i, _, _)| {
        let i = i.unwrap_or(0);
        (
            Some(i),
            "fn_n",
            format!(
                "mu = ft_n / fn_n = {} / {} = {} is not a friction coefficient (mu must be {}): is fn_n in newtons?",
                Num(ft_n[i]),
                Num(fn_n[i]),
                Num(mu[i]),
                crate::ranges::MU.describe()
            ),
        )
    })?;
    Ok(mu)
}

fn in_memory((index, field, message): Violation) -> ProfileError {
    ProfileError::Invalid { index: index.unwrap_or(0), field, message }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_clamps() {
        let p = FrictionProfile::new(vec![0.0, 1.0, 3.0], vec![1.0, 2.0, 0.0]).unwrap();
        assert_eq!(p.mu_at(-1.0), 1.0);
        assert_eq!(p.mu_at(0.5), 1.5);
        assert_eq!(p.mu_at(2.0), 1.0);
        assert_eq!(p.mu_at(9.0), 0.0);
    }

    #[test]
    fn resample_uniform_hits_both_ends_and_is_linear() {
        let p = FrictionProfile::new(vec![0.0, 1.0, 3.0], vec![1.0, 2.0, 0.0]).unwrap();
        let r = p.resample_uniform(7).unwrap();
        assert_eq!(r.x_mm(), [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0]);
        assert_eq!(r.mu(), [1.0, 1.5, 2.0, 1.5, 1.0, 0.5, 0.0]);
        assert!(p.resample_uniform(1).is_err());
    }

    /// A grid the memory cannot hold is an error naming it, not an abort.
    #[test]
    fn a_grid_the_memory_cannot_hold_is_an_error() {
        let p = FrictionProfile::new(vec![0.0, 1.0], vec![0.0, 1.0]).unwrap();
        let e = p.resample_uniform(usize::MAX / 4).unwrap_err().to_string();
        assert!(e.starts_with("cannot allocate a profile of"), "{e}");
    }

    #[test]
    fn resample_step_keeps_spacing() {
        let p = FrictionProfile::new(vec![0.0, 1.0], vec![0.0, 1.0]).unwrap();
        let r = p.resample_step(0.3).unwrap();
        assert_eq!(r.len(), 4);
        assert!((r.mu()[3] - 0.9).abs() < 1e-15);
        assert!(p.resample_step(2.0).is_err());
        assert!(p.resample_step(0.0).is_err());
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        let odd = FrictionProfile::new(vec![0.0, 1.0, 2.0, 3.0, 4.0], vec![0.9, 0.5, 0.5, 2.0, 0.4]).unwrap();
        assert_eq!(odd.median_mu(), 0.5);
        let even = FrictionProfile::new(vec![0.0, 1.0, 2.0, 3.0], vec![0.7, 0.1, 0.3, 5.0]).unwrap();
        assert_eq!(even.median_mu(), 0.5);
        // The profile itself is not reordered.
        assert_eq!(even.mu(), [0.7, 0.1, 0.3, 5.0]);
    }

    #[test]
    fn forces_give_mu_and_mean_normal_force() {
        let p = FrictionProfile::from_forces(vec![0.0, 1.0], &[0.1, 0.3], vec![0.2, 0.6]).unwrap();
        assert_eq!(p.mu(), [0.5, 0.5]);
        assert!((p.mean_fn_n().unwrap() - 0.4).abs() < 1e-15);
        assert!(FrictionProfile::from_forces(vec![0.0, 1.0], &[0.1, 0.3], vec![0.2, 0.0]).is_err());
    }
}
