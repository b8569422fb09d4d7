//! Touch extrapolation of the real-time renderers: finger reports at
//! 60-240 Hz in, a position estimate at every output sample out.
//!
//! Between reports the position is extrapolated with the velocity of the
//! last two reports, for at most `horizon_s` past the last report (then
//! held); a pair of reports further apart than the horizon gives no
//! velocity. When a report disagrees with the extrapolation, the
//! difference is blended out linearly over `blend_s` instead of jumping.
//! Each of the `D` coordinates (x; or x and y on a map) is extrapolated
//! the same way, from the same reports.
//!
//! A report less than [`MIN_VELOCITY_DT_S`] after the last one moves the
//! reference position but gives no velocity: touch digitizers report at
//! most every 1 ms, so two reports closer than that are one report seen
//! twice or clock jitter, and their difference over microseconds would be
//! an absurd speed that the horizon then extrapolates.

/// The shortest time between two reports that gives a velocity, in s
/// (1 ms: a 1 kHz digitizer, faster than any touch screen's 60-240 Hz).
pub const MIN_VELOCITY_DT_S: f64 = 1e-3;

/// The touch state of a renderer over `D` coordinates.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TouchEstimator<const D: usize> {
    touching: bool,
    t_report: f64,
    report: [f64; D],
    velocity: [f64; D],
    offset: [f64; D],
    inv_blend: f64,
    blend: bool,
    horizon_s: f64,
}

impl<const D: usize> TouchEstimator<D> {
    /// No finger down; the held position before the first report is `rest`.
    /// `horizon_s` and `blend_s` are checked by the renderer (finite, >= 0).
    pub(crate) fn new(horizon_s: f64, blend_s: f64, rest: [f64; D]) -> Self {
        Self {
            touching: false,
            t_report: 0.0,
            report: rest,
            velocity: [0.0; D],
            offset: [0.0; D],
            inv_blend: if blend_s > 0.0 { 1.0 / blend_s } else { 1.0 },
            blend: blend_s > 0.0,
            horizon_s,
        }
    }

    /// Whether a finger is down (a report came, and no release since).
    #[inline(always)]
    pub(crate) fn is_touching(&self) -> bool {
        self.touching
    }

    /// The last reported position (held while no finger touches).
    #[inline(always)]
    pub(crate) fn last(&self) -> [f64; D] {
        self.report
    }

    /// A report: the finger is at `at` at time `t_s`. Non-finite reports
    /// are ignored. O(1), no allocation.
    pub(crate) fn touch(&mut self, t_s: f64, at: [f64; D]) {
        if !(t_s.is_finite() && at.iter().all(|v| v.is_finite())) {
            return;
        }
        if !self.touching {
            // Touch down: no velocity yet.
            (self.touching, self.t_report, self.report, self.velocity, self.offset) =
                (true, t_s, at, [0.0; D], [0.0; D]);
            return;
        }
        let estimate = self.position_at(t_s);
        let dt = t_s - self.t_report;
        if dt >= MIN_VELOCITY_DT_S {
            let fresh = dt <= self.horizon_s;
            for ((v, &a), &r) in self.velocity.iter_mut().zip(&at).zip(&self.report) {
                *v = if fresh { (a - r) / dt } else { 0.0 };
            }
            self.t_report = t_s;
        }
        // A report at, before or within MIN_VELOCITY_DT_S of the last one
        // moves the reference position only (its timestamp carries no new
        // velocity).
        self.report = at;
        // Continuity: the new estimate at t_s equals the old one.
        for ((o, &e), &a) in self.offset.iter_mut().zip(&estimate).zip(&at) {
            *o = if self.blend { e - a } else { 0.0 };
        }
    }

    /// The finger was lifted.
    pub(crate) fn release(&mut self) {
        self.touching = false;
    }

    /// The estimated position at `t_s`: the last report extrapolated with
    /// the report velocity for at most the horizon, plus what is left of
    /// the blended correction.
    #[inline(always)]
    pub(crate) fn position_at(&self, t_s: f64) -> [f64; D] {
        // Plain comparisons: the operands are finite (NaN-aware f64::min/max
        // cost extra instructions per sample).
        let age = t_s - self.t_report;
        let age = if age > 0.0 { age } else { 0.0 };
        let extrapolated = if age < self.horizon_s { age } else { self.horizon_s };
        let left = 1.0 - age * self.inv_blend;
        let left = if left > 0.0 { left } else { 0.0 };
        let mut at = self.report;
        for ((p, &v), &o) in at.iter_mut().zip(&self.velocity).zip(&self.offset) {
            *p = *p + v * extrapolated + o * left;
        }
        at
    }
}
