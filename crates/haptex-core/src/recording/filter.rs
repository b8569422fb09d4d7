//! Anti-aliased resampling of the force stream to the position timestamps
//! (paper section 2.4: "re-sampled from 20 kHz to 400 Hz").
//!
//! Decimating by picking every 50th sample would fold everything above the
//! new Nyquist frequency (200 Hz) into the friction signal: texture
//! vibrations, sensor noise, mains interference. Instead the forces are
//! low-pass filtered with a linear-phase FIR filter designed by the Kaiser
//! window method, evaluated only where an output sample is needed.
//!
//! Design (defaults of [`super::ProcessingConfig`], for a 400 Hz position
//! stream): passband edge 0.375 f_out = 150 Hz, stopband edge
//! 0.625 f_out = 250 Hz, stopband attenuation 80 dB. Everything at or above
//! 250 Hz is attenuated by at least 80 dB, so nothing folds into the
//! 0-150 Hz passband (a component at f >= 250 Hz lands at |f - 400 k| and,
//! for f < 400 - 150, outside the passband); 150-200 Hz is kept but may
//! carry attenuated aliases from 200-250 Hz. The filter is applied centred
//! on each output time (zero phase): no delay between forces and position.

use std::f64::consts::PI;

use super::error::RecordingError;
use crate::num::Num;

/// A linear-phase (symmetric, odd-length) FIR low-pass filter.
#[derive(Debug, Clone, PartialEq)]
pub struct LowPassFir {
    taps: Vec<f64>,
    sample_rate_hz: f64,
    passband_hz: f64,
    stopband_hz: f64,
    attenuation_db: f64,
}

impl LowPassFir {
    /// Kaiser-window design (Kaiser 1974; Oppenheim & Schafer,
    /// Discrete-Time Signal Processing, 3rd ed., section 7.6): ideal low-pass
    /// with cut-off midway between the band edges, times a Kaiser window with
    ///
    ///   beta = 0.1102 (A - 8.7)                                (A > 50 dB)
    ///   beta = 0.5842 (A - 21)^0.4 + 0.07886 (A - 21)           (21 <= A <= 50)
    ///   order M = (A - 8) / (2.285 dw),  dw = 2 pi (f_stop - f_pass) / f_s
    ///
    /// rounded up to an even order (odd length, integer delay). The taps are
    /// scaled to a DC gain of exactly 1.
    pub fn kaiser(
        sample_rate_hz: f64,
        passband_hz: f64,
        stopband_hz: f64,
        attenuation_db: f64,
    ) -> Result<Self, RecordingError> {
        let config = |name, message: String| Err(RecordingError::Config { name, message });
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return config("sample rate", format!("must be positive, got {} Hz", Num(sample_rate_hz)));
        }
        if !(passband_hz > 0.0 && stopband_hz > passband_hz && stopband_hz < sample_rate_hz / 2.0) {
            return config(
                "band edges",
                format!(
                    "need 0 < passband ({passband_hz} Hz) < stopband ({stopband_hz} Hz) < half the sample rate \
                     ({} Hz)",
                    sample_rate_hz / 2.0
                ),
            );
        }
        if !(21.0..=200.0).contains(&attenuation_db) {
            return config("stopband attenuation", format!("must be 21 to 200 dB, got {}", Num(attenuation_db)));
        }
        let a = attenuation_db;
        let beta = if a > 50.0 { 0.1102 * (a - 8.7) } else { 0.5842 * (a - 21.0).powf(0.4) + 0.07886 * (a - 21.0) };
        let dw = 2.0 * PI * (stopband_hz - passband_hz) / sample_rate_hz;
        let mut order = ((a - 8.0) / (2.285 * dw)).ceil() as usize;
        if order % 2 == 1 {
            order += 1;
        }
        let half = order / 2;
        let wc = PI * (passband_hz + stopband_hz) / sample_rate_hz; // rad/sample
        let i0_beta = bessel_i0(beta);
        let mut taps: Vec<f64> = (0..=order)
            .map(|n| {
                let k = n as f64 - half as f64;
                let ideal = if k == 0.0 { wc / PI } else { (wc * k).sin() / (PI * k) };
                let r = k / half as f64;
                ideal * bessel_i0(beta * (1.0 - r * r).max(0.0).sqrt()) / i0_beta
            })
            .collect();
        let sum: f64 = taps.iter().sum();
        taps.iter_mut().for_each(|t| *t /= sum);
        Ok(Self { taps, sample_rate_hz, passband_hz, stopband_hz, attenuation_db })
    }

    pub fn taps(&self) -> &[f64] {
        &self.taps
    }

    /// Samples on each side of the centre tap (the group delay, in samples).
    pub fn half_len(&self) -> usize {
        self.taps.len() / 2
    }

    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    pub fn passband_hz(&self) -> f64 {
        self.passband_hz
    }

    pub fn stopband_hz(&self) -> f64 {
        self.stopband_hz
    }

    pub fn attenuation_db(&self) -> f64 {
        self.attenuation_db
    }

    /// Gain |H(f)| in dB at frequency `f_hz`, from the taps (zero-phase
    /// response of the symmetric filter).
    pub fn gain_db(&self, f_hz: f64) -> f64 {
        let w = 2.0 * PI * f_hz / self.sample_rate_hz;
        let m = self.half_len();
        let mut h = self.taps[m];
        for k in 1..=m {
            h += 2.0 * self.taps[m + k] * (w * k as f64).cos();
        }
        20.0 * h.abs().max(1e-300).log10()
    }

    /// The filtered signal at sample `i`, centred (zero phase). Needs
    /// `half_len() <= i < x.len() - half_len()`.
    fn at(&self, x: &[f64], i: usize) -> f64 {
        let m = self.half_len();
        dot(&self.taps, &x[i - m..=i + m])
    }
}

/// Dot product with four independent accumulators (vectorizes).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (a4, a_rest) = a.split_at(a.len() / 4 * 4);
    let (b4, b_rest) = b.split_at(a4.len());
    for (x, y) in a4.chunks_exact(4).zip(b4.chunks_exact(4)) {
        for j in 0..4 {
            acc[j] += x[j] * y[j];
        }
    }
    let tail: f64 = a_rest.iter().zip(b_rest).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Modified Bessel function of the first kind, order 0 (power series).
fn bessel_i0(x: f64) -> f64 {
    let q = x * x / 4.0;
    let (mut term, mut sum, mut k) = (1.0, 1.0, 1.0);
    while term > sum * 1e-17 {
        term *= q / (k * k);
        sum += term;
        k += 1.0;
    }
    sum
}

/// Signals low-pass filtered and resampled at new times.
#[derive(Debug, Clone, PartialEq)]
pub struct Resampled {
    /// Index range of the requested times that could be computed: those
    /// whose filter window lies inside the input (the first and last
    /// `half_len()` input samples are only used as context).
    pub valid: std::ops::Range<usize>,
    /// One output column per input signal, for the times in `valid`.
    pub columns: Vec<Vec<f64>>,
}

/// Anti-aliased resampling: low-pass filters the uniformly sampled
/// `signals` (times `t_s`) with `filter` and evaluates them at `times_s`
/// (increasing): the filter output at the two input samples around each
/// time, linearly interpolated. After the low-pass the input is heavily
/// oversampled (20 kHz for a 250 Hz band), so the interpolation error is
/// below 1e-4 of the signal.
pub fn resample_filtered(t_s: &[f64], signals: &[&[f64]], times_s: &[f64], filter: &LowPassFir) -> Resampled {
    let m = filter.half_len();
    let n = t_s.len();
    let mut columns = vec![Vec::new(); signals.len()];
    if n < 2 * m + 2 {
        return Resampled { valid: 0..0, columns };
    }
    // Times whose neighbouring samples i, i+1 both have full filter windows.
    let (t_lo, t_hi) = (t_s[m], t_s[n - 1 - m - 1]);
    let start = times_s.partition_point(|&t| t < t_lo);
    let end = times_s.partition_point(|&t| t <= t_hi).max(start);
    let mut i = m;
    for &t in &times_s[start..end] {
        while t_s[i + 1] <= t {
            i += 1;
        }
        let frac = (t - t_s[i]) / (t_s[i + 1] - t_s[i]);
        for (out, x) in columns.iter_mut().zip(signals) {
            let y0 = filter.at(x, i);
            out.push(if frac == 0.0 { y0 } else { y0 + frac * (filter.at(x, i + 1) - y0) });
        }
    }
    Resampled { valid: start..end, columns }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bessel_i0_matches_tables() {
        // Abramowitz & Stegun table 9.8: I0(1) = 1.266065878, I0(5) = 27.23987182.
        assert!((bessel_i0(1.0) - 1.266_065_878).abs() < 1e-8);
        assert!((bessel_i0(5.0) - 27.239_871_82).abs() < 1e-6);
    }

    #[test]
    fn default_design_is_odd_symmetric_with_unit_dc_gain() {
        let f = LowPassFir::kaiser(20_000.0, 150.0, 250.0, 80.0).unwrap();
        assert_eq!(f.taps().len() % 2, 1);
        let n = f.taps().len();
        for k in 0..n / 2 {
            assert_eq!(f.taps()[k], f.taps()[n - 1 - k]);
        }
        assert!(f.gain_db(0.0).abs() < 1e-12);
    }

    #[test]
    fn rejects_bad_band_edges() {
        assert!(LowPassFir::kaiser(20_000.0, 250.0, 150.0, 80.0).is_err());
        assert!(LowPassFir::kaiser(400.0, 150.0, 250.0, 80.0).is_err());
        assert!(LowPassFir::kaiser(20_000.0, 150.0, 250.0, 10.0).is_err());
    }
}
