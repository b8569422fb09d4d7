//! Safety limits of a drive signal: the hard U_max clamp, the optional slew
//! limit of the envelope, and the amplifier range a signal must fit.
//!
//! Both renderers (offline [`super::render`] and
//! [`crate::realtime::RealtimeRenderer`]) pass every envelope sample through
//! the same [`EnvelopeLimiter`].

use serde::{Deserialize, Serialize};

use crate::ranges;

/// The limits a drive signal must respect.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Hard ceiling of the RMS envelope in V: higher requests are clamped.
    pub u_max_v: f64,
    /// Largest rate of change of the RMS envelope in V/s (`None`: no limit).
    /// The envelope starts from 0 V, so a limited signal also fades in.
    pub slew_v_per_s: Option<f64>,
    /// Peak output the amplifier can deliver, in V: a signal whose peak
    /// (carrier amplitude) exceeds it is refused, never clipped (`None`: no
    /// check here; a WAV still refuses to exceed its full scale).
    pub amplifier_range_v: Option<f64>,
}

impl Limits {
    /// U_max = 100 V (the paper's Fig. 2), no slew limit, no amplifier range.
    pub const DEFAULT: Self = Self { u_max_v: 100.0, slew_v_per_s: None, amplifier_range_v: None };

    /// Checks every limit against its accepted range ([`crate::ranges`]).
    pub fn check(&self) -> Result<(), String> {
        let check = |range: ranges::Range, v: f64| range.check(v).map(|_| ()).map_err(|e| e.to_string());
        check(ranges::U_MAX_V, self.u_max_v)?;
        if let Some(s) = self.slew_v_per_s {
            check(ranges::SLEW_V_PER_S, s)?;
        }
        if let Some(r) = self.amplifier_range_v {
            check(ranges::AMPLIFIER_RANGE_V, r)?;
        }
        Ok(())
    }
}

impl Default for Limits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Clamps the envelope at U_max, then limits its change per sample to
/// slew / sample rate. O(1), no allocation.
#[derive(Debug, Clone, Copy)]
pub struct EnvelopeLimiter {
    u_max_v: f64,
    max_step_v: f64,
    previous_v: f64,
}

impl EnvelopeLimiter {
    /// A limiter for `limits` at `sample_rate_hz`, starting from 0 V.
    pub fn new(limits: &Limits, sample_rate_hz: f64) -> Self {
        let max_step_v = limits.slew_v_per_s.map_or(f64::INFINITY, |s| s / sample_rate_hz);
        Self { u_max_v: limits.u_max_v, max_step_v, previous_v: 0.0 }
    }

    /// The limited envelope for a requested RMS voltage `requested_v` (>= 0,
    /// not NaN).
    #[inline]
    pub fn apply(&mut self, requested_v: f64) -> f64 {
        // Plain comparisons (not f64::min/max, whose NaN handling lengthens
        // this loop-carried dependency chain in the real-time renderer).
        let clamped = if requested_v < self.u_max_v { requested_v } else { self.u_max_v };
        if self.max_step_v == f64::INFINITY {
            // No slew limit: no dependency on the previous sample.
            self.previous_v = clamped;
            return clamped;
        }
        let lo = self.previous_v - self.max_step_v;
        let hi = self.previous_v + self.max_step_v;
        let out = if clamped > hi {
            hi
        } else if clamped < lo {
            lo
        } else {
            clamped
        };
        self.previous_v = out;
        out
    }

    /// The last envelope value returned, in V.
    pub fn previous_v(&self) -> f64 {
        self.previous_v
    }
}

/// What the limits did to a signal.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ClipReport {
    /// Samples whose requested envelope exceeded U_max and were clamped.
    pub clamped_samples: usize,
    /// The same as a fraction of all samples, 0..=1.
    pub clamped_fraction: f64,
    /// Largest requested envelope in V (before the clamp).
    pub requested_max_v: f64,
    /// Samples changed by the slew limit.
    pub slew_limited_samples: usize,
    /// The same as a fraction of all samples, 0..=1.
    pub slew_limited_fraction: f64,
    /// Largest difference between the clamped and the slew-limited envelope, in V.
    pub slew_max_deviation_v: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamps_then_limits_the_rate() {
        let limits = Limits { u_max_v: 10.0, slew_v_per_s: Some(1000.0), amplifier_range_v: None };
        let mut l = EnvelopeLimiter::new(&limits, 100.0); // 10 V per sample at most
        let out: Vec<f64> = [25.0, 25.0, 25.0, 3.0, 0.0].iter().map(|&u| l.apply(u)).collect();
        assert_eq!(out, [10.0, 10.0, 10.0, 3.0, 0.0]);
        let mut l = EnvelopeLimiter::new(&Limits { slew_v_per_s: Some(200.0), ..limits }, 100.0);
        let out: Vec<f64> = [10.0, 10.0, 10.0, 10.0, 10.0, 10.0, 0.0, 0.0].iter().map(|&u| l.apply(u)).collect();
        assert_eq!(out, [2.0, 4.0, 6.0, 8.0, 10.0, 10.0, 8.0, 6.0]);
        assert!(Limits { u_max_v: 0.0, ..Limits::DEFAULT }.check().is_err());
        assert!(Limits { slew_v_per_s: Some(f64::NAN), ..Limits::DEFAULT }.check().is_err());
    }
}
