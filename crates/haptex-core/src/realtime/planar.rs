//! Real-time rendering over a voltage map (issue 19): finger reports
//! (x, y) in, drive samples out, as [`super::RealtimeRenderer`] does on a
//! line.
//!
//! The position is extrapolated in both coordinates from the same reports
//! ([`super::touch`]), the envelope is the map's voltage there, bilinear
//! with the edge held beyond the map ([`crate::map::MapGrid::sample`], what
//! the offline [`crate::signal::render_map`] reads), and the carrier,
//! limits, full scale and clock are the line renderer's. O(1) and
//! allocation-free per sample; the map is the lookup table.
//!
//! ```
//! use haptex_core::map::{MapGrid, VoltageMap};
//! use haptex_core::realtime::{PlanarRenderer, RealtimeConfig};
//!
//! // 3 x 2 cells, 1 mm apart: 0 .. 80 V along x, the same on both rows.
//! let grid = MapGrid { nx: 3, ny: 2, dx_mm: 1.0, dy_mm: 1.0, x0_mm: 0.0, y0_mm: 0.0 };
//! let map = VoltageMap {
//!     grid,
//!     voltage_v: vec![0.0, 40.0, 80.0, 0.0, 40.0, 80.0],
//!     u_max_v: 100.0,
//!     not_renderable_fraction: 0.0,
//!     clipped_fraction: 0.0,
//! };
//! let mut renderer = PlanarRenderer::new(&map, &RealtimeConfig::default())?;
//! renderer.touch(renderer.now_s(), 1.5, 0.5);
//! let mut buffer = [0.0f32; 480];
//! renderer.fill(&mut buffer);
//! assert_eq!(renderer.voltage_at(1.5, 0.5), 60.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::touch::TouchEstimator;
use super::{NONE, Output, RealtimeConfig, RealtimeRenderer, SINE, SQUARE};
use crate::map::VoltageMap;
use crate::signal::{CarrierShape, SignalError};

/// One output sample of a [`PlanarRenderer`] with the quantities behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarSample {
    /// Time on the renderer's clock in s.
    pub t_s: f64,
    /// Estimated finger position in mm.
    pub x_mm: f64,
    pub y_mm: f64,
    /// Envelope after the limits, V RMS (0 when no finger touches).
    pub envelope_v: f64,
    /// Drive voltage in V.
    pub signal_v: f64,
}

impl PlanarSample {
    /// All zero.
    pub const ZERO: Self = Self { t_s: 0.0, x_mm: 0.0, y_mm: 0.0, envelope_v: 0.0, signal_v: 0.0 };
}

/// Streams the drive of a voltage map from (x, y) touch reports; see the
/// module documentation.
#[derive(Debug, Clone)]
pub struct PlanarRenderer {
    map: VoltageMap,
    out: Output,
    touch: TouchEstimator<2>,
}

impl PlanarRenderer {
    /// Builds the renderer for `map` with `config`'s rate, carrier, limits,
    /// full scale and touch extrapolation. Beyond the map its edge is held,
    /// as the offline render does, so `config.extend` must be
    /// [`Extend::Hold`]; `config.table_points` is not used (the map's grid
    /// is the table). Refuses a map whose peak (carrier peak/RMS times its
    /// largest voltage or U_max, whichever is lower) exceeds the amplifier
    /// range or the full scale, and a map with a voltage that is not a
    /// finite number >= 0.
    pub fn new(map: &VoltageMap, config: &RealtimeConfig) -> Result<Self, SignalError> {
        crate::signal::check_map_extend(config.extend)?;
        let g = &map.grid;
        g.validate("the voltage map").map_err(|e| SignalError::Settings(e.to_string()))?;
        if map.voltage_v.len() != g.nx * g.ny {
            return Err(SignalError::Settings(format!(
                "the map has {} voltages for a {} x {} grid",
                map.voltage_v.len(),
                g.nx,
                g.ny
            )));
        }
        let mut max_v = 0.0f64;
        for (k, &u) in map.voltage_v.iter().enumerate() {
            if !(u.is_finite() && u >= 0.0) {
                return Err(SignalError::Settings(format!(
                    "the map's voltage at cell {k} (column {}, row {}) is {u}: voltages are finite numbers >= 0",
                    k % g.nx,
                    k / g.nx
                )));
            }
            max_v = max_v.max(u);
        }
        let out = Output::new(config, max_v)?;
        let touch = TouchEstimator::new(config.horizon_s, config.blend_s, [g.x0_mm, g.y0_mm]);
        Ok(Self { map: map.clone(), out, touch })
    }

    /// Time of the next output sample on the renderer's clock, in s.
    pub fn now_s(&self) -> f64 {
        self.out.now_s()
    }

    /// Output sample rate in Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.out.sample_rate_hz
    }

    /// Samples rendered so far (the index of the next one).
    pub fn samples_rendered(&self) -> u64 {
        self.out.n
    }

    /// Whether a finger is down.
    pub fn is_touching(&self) -> bool {
        self.touch.is_touching()
    }

    /// A touch report: the finger is at (`x_mm`, `y_mm`) at time `t_s`
    /// (renderer clock). Non-finite reports are ignored. O(1), no
    /// allocation.
    pub fn touch(&mut self, t_s: f64, x_mm: f64, y_mm: f64) {
        self.touch.touch(t_s, [x_mm, y_mm]);
    }

    /// A touch report stamped at [`now_s`](Self::now_s).
    pub fn touch_now(&mut self, x_mm: f64, y_mm: f64) {
        self.touch(self.now_s(), x_mm, y_mm);
    }

    /// The finger was lifted: the envelope goes to 0 V (through the slew
    /// limit, if any) until the next report.
    pub fn release(&mut self) {
        self.touch.release();
    }

    /// The estimated position (x, y) in mm at `t_s`.
    pub fn position_at(&self, t_s: f64) -> (f64, f64) {
        let [x, y] = self.touch.position_at(t_s);
        (x, y)
    }

    /// U in V RMS at (x, y), before the U_max clamp the limiter applies.
    pub fn voltage_at(&self, x_mm: f64, y_mm: f64) -> f64 {
        self.map.sample(x_mm, y_mm)
    }

    /// Upper bound of |drive| in V.
    pub fn peak_bound_v(&self) -> f64 {
        self.out.peak_bound_v
    }

    /// Volts at the amplifier output for a full-scale sample.
    pub fn volts_per_full_scale(&self) -> f64 {
        1.0 / self.out.output_scale
    }

    #[inline(always)]
    fn render<const S: u8>(&mut self, n: usize, mut write: impl FnMut(usize, PlanarSample)) {
        let dt = self.out.dt_s;
        let t0 = self.out.n as f64 * dt;
        let (mut phase, phase_step, mut limiter) = (self.out.phase, self.out.phase_step, self.out.limiter);
        let mut k = 0.0;
        for i in 0..n {
            let t_s = t0 + k * dt;
            k += 1.0;
            let ([x_mm, y_mm], requested) = if self.touch.is_touching() {
                let [x, y] = self.touch.position_at(t_s);
                ([x, y], self.map.sample(x, y))
            } else {
                (self.touch.last(), 0.0)
            };
            let envelope_v = limiter.apply(requested);
            let signal_v = envelope_v * RealtimeRenderer::carrier_at::<S>(phase);
            phase = phase.wrapping_add(phase_step);
            write(i, PlanarSample { t_s, x_mm, y_mm, envelope_v, signal_v });
        }
        self.out.phase = phase;
        self.out.limiter = limiter;
        self.out.n += n as u64;
    }

    /// Renders the next `n` samples, handing each with its index to
    /// `write`. O(1) per sample, no allocation.
    pub fn render_with(&mut self, n: usize, write: impl FnMut(usize, PlanarSample)) {
        match self.out.shape {
            CarrierShape::Sine => self.render::<SINE>(n, write),
            CarrierShape::Square => self.render::<SQUARE>(n, write),
            CarrierShape::None => self.render::<NONE>(n, write),
        }
    }

    /// Fills `out` with the next samples as fractions of full scale
    /// (volts / volts_per_full_scale, within [-1, 1]).
    pub fn fill(&mut self, out: &mut [f32]) {
        let scale = self.out.output_scale;
        self.render_with(out.len(), |i, s| out[i] = (s.signal_v * scale) as f32);
    }

    /// Fills `out` with the next samples in volts.
    pub fn fill_volts(&mut self, out: &mut [f64]) {
        self.render_with(out.len(), |i, s| out[i] = s.signal_v);
    }

    /// Fills `out` with the next samples, each with its time, position and
    /// envelope (for inspection and tests).
    pub fn fill_samples(&mut self, out: &mut [PlanarSample]) {
        self.render_with(out.len(), |i, s| out[i] = s);
    }
}
