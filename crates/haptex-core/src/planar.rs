//! A finger path over a map: times and (x, y) positions, as a touch panel
//! reports them (`t_s,x_mm,y_mm`), sampled from a [`crate::map`] map.

use std::io::Write;

use crate::io::{Table, write_csv_row};
use crate::map::MapGrid;
use crate::num::Num;
use crate::profile::WalkingCursor;
use crate::trajectory::TrajectoryError;

/// A finger path in the plane: strictly increasing times (s) and the
/// position (mm) at each.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarTrajectory {
    t_s: Vec<f64>,
    x_mm: Vec<f64>,
    y_mm: Vec<f64>,
}

impl PlanarTrajectory {
    /// A path from its columns, checked.
    pub fn new(t_s: Vec<f64>, x_mm: Vec<f64>, y_mm: Vec<f64>) -> Result<Self, TrajectoryError> {
        validate(&t_s, &x_mm, &y_mm).map_err(|(index, field, message)| TrajectoryError::Invalid {
            index: index.unwrap_or(0),
            field,
            message,
        })?;
        Ok(Self { t_s, x_mm, y_mm })
    }

    /// Reads a `t_s,x_mm,y_mm` CSV; errors name the file, line and column.
    pub fn read_csv<R: std::io::Read>(reader: R, source_name: &str) -> Result<Self, TrajectoryError> {
        let table = Table::read(reader, source_name)?;
        let t_s = table.require("t_s")?.to_vec();
        let x_mm = table.require("x_mm")?.to_vec();
        let y_mm = table.require("y_mm")?.to_vec();
        validate(&t_s, &x_mm, &y_mm).map_err(|(row, field, message)| table.error_at(row, Some(field), message))?;
        Ok(Self { t_s, x_mm, y_mm })
    }

    pub fn t_s(&self) -> &[f64] {
        &self.t_s
    }

    pub fn x_mm(&self) -> &[f64] {
        &self.x_mm
    }

    pub fn y_mm(&self) -> &[f64] {
        &self.y_mm
    }

    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Positions at increasing times `t0_s + i * dt_s`, i = 0..x_out.len(),
    /// into `x_out` and `y_out` (linear between the samples, held beyond
    /// the ends; one pass, as [`crate::trajectory::Trajectory::positions_into`]).
    pub fn positions_into(&self, t0_s: f64, dt_s: f64, x_out: &mut [f64], y_out: &mut [f64]) {
        let (mut cx, mut cy) = (WalkingCursor::default(), WalkingCursor::default());
        for (i, (x, y)) in x_out.iter_mut().zip(y_out.iter_mut()).enumerate() {
            let t = t0_s + i as f64 * dt_s;
            *x = cx.interpolate(&self.t_s, &self.x_mm, t);
            *y = cy.interpolate(&self.t_s, &self.y_mm, t);
        }
    }

    /// The values of a map (one per cell of `grid`) at each sample of the
    /// path, bilinear, the map's edge held beyond it.
    pub fn sample(&self, grid: &MapGrid, values: &[f64]) -> Vec<f64> {
        self.x_mm.iter().zip(&self.y_mm).map(|(&x, &y)| grid.sample(values, x, y)).collect()
    }

    /// Writes `t_s,x_mm,y_mm,NAME` with `values` one per sample.
    pub fn write_csv_with(&self, w: &mut dyn Write, name: &str, values: &[f64]) -> std::io::Result<()> {
        writeln!(w, "t_s,x_mm,y_mm,{name}")?;
        for (i, v) in values.iter().enumerate().take(self.len()) {
            write_csv_row(w, &[self.t_s[i], self.x_mm[i], self.y_mm[i], *v])?;
        }
        Ok(())
    }

    /// What `haptex map sample-path` writes: a comment naming the voltage
    /// map and the path, then `t_s,x_mm,y_mm,voltage_v` (`voltage_v` the
    /// map sampled at each sample, V RMS).
    pub fn write_sampled_voltage_csv(
        &self,
        w: &mut dyn Write,
        map_name: &str,
        path_name: &str,
        voltage_v: &[f64],
    ) -> std::io::Result<()> {
        writeln!(w, "# haptex map sample-path: voltage (V RMS) of {map_name} along {path_name}")?;
        self.write_csv_with(w, "voltage_v", voltage_v)
    }

    /// The line `haptex map sample-path` prints about the voltages
    /// sampled along the path.
    pub fn sampled_voltage_summary(&self, voltage_v: &[f64]) -> String {
        let (lo, hi) = crate::map::min_max(voltage_v);
        format!(
            "path: {} samples, {} s; voltage {:.3} .. {:.3} V RMS",
            self.len(),
            Num(self.t_s[self.len() - 1] - self.t_s[0]),
            lo,
            hi
        )
    }
}

fn validate(t_s: &[f64], x_mm: &[f64], y_mm: &[f64]) -> Result<(), crate::profile::Violation> {
    // Times and x as a 1-D trajectory's, then y.
    crate::trajectory::validate(t_s, x_mm)?;
    if y_mm.len() != t_s.len() {
        return Err((None, "y_mm", format!("{} values for {} times", y_mm.len(), t_s.len())));
    }
    crate::profile::check_values("y_mm", y_mm)?;
    // y has the positions' range, under its own name.
    if let Some(i) = crate::ranges::POSITION_MM.first_outside(y_mm) {
        return Err((
            Some(i),
            "y_mm",
            format!("y_mm must be {}, got {}", crate::ranges::POSITION_MM.describe(), Num(y_mm[i])),
        ));
    }
    Ok(())
}
