//! Finger speed and sliding-phase detection (paper section 2.4: "only the
//! sliding parts of the experiments were used, where the assumption about
//! constant normal force ... is valid").
//!
//! A sample (at the position rate) is *sliding* when all hold:
//!
//! 1. contact: Fn >= `min_fn_n`;
//! 2. motion: |v| >= `min_speed_mm_s`, v from a least-squares slope of x(t)
//!    over a centred window of `speed_window_s`;
//! 3. steady load: |Fn - Fn_ref| <= `fn_tolerance` Fn_ref, with Fn_ref the
//!    median Fn over the samples that pass 1 and 2.
//!
//! Sliding samples are grouped into segments: maximal runs with one
//! direction of motion (sign of v) and no gap in the position stream longer
//! than 1.5 nominal intervals. `trim_s` is cut from both ends of each
//! segment (the stick-slip transition at the start and the deceleration at
//! the end), and segments shorter than `min_duration_s` or `min_length_mm`
//! are dropped. Pauses and reversals therefore end a segment.

use serde::{Deserialize, Serialize};

use crate::num::{Fixed, Num};

/// Direction of a sliding segment along x.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Towards +x.
    Forward,
    /// Towards -x.
    Backward,
}

impl Direction {
    /// +1 for forward, -1 for backward.
    pub fn sign(self) -> f64 {
        match self {
            Direction::Forward => 1.0,
            Direction::Backward => -1.0,
        }
    }
}

/// Thresholds of the sliding detection (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SlidingCriteria {
    pub speed_window_s: f64,
    pub min_speed_mm_s: f64,
    pub min_fn_n: f64,
    pub fn_tolerance: f64,
    pub trim_s: f64,
    pub min_duration_s: f64,
    pub min_length_mm: f64,
}

/// One sliding phase: samples `start..end` of the position-rate series.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SlidingSegment {
    pub start: usize,
    pub end: usize,
    pub direction: Direction,
    pub t_start_s: f64,
    pub t_end_s: f64,
    pub x_start_mm: f64,
    pub x_end_mm: f64,
    pub mean_speed_mm_s: f64,
    pub mean_fn_n: f64,
}

impl SlidingSegment {
    pub fn duration_s(&self) -> f64 {
        self.t_end_s - self.t_start_s
    }

    pub fn length_mm(&self) -> f64 {
        (self.x_end_mm - self.x_start_mm).abs()
    }
}

/// Finger velocity in mm/s: the least-squares slope of x(t) over the
/// `2 half + 1` samples centred on each sample (fewer at the ends). Uses
/// the actual sample times, so occasional gaps are handled.
pub fn finger_velocity(t_s: &[f64], x_mm: &[f64], half: usize) -> Vec<f64> {
    let n = t_s.len();
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(half);
            let hi = (i + half + 1).min(n);
            let k = (hi - lo) as f64;
            let tm = t_s[lo..hi].iter().sum::<f64>() / k;
            let xm = x_mm[lo..hi].iter().sum::<f64>() / k;
            let (mut sxy, mut sxx) = (0.0, 0.0);
            for j in lo..hi {
                let dt = t_s[j] - tm;
                sxy += dt * (x_mm[j] - xm);
                sxx += dt * dt;
            }
            if sxx > 0.0 { sxy / sxx } else { 0.0 }
        })
        .collect()
}

/// A run of sliding samples that was not kept as a segment, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DroppedRun {
    pub direction: Direction,
    /// The run before trimming.
    pub t_start_s: f64,
    pub t_end_s: f64,
    pub x_start_mm: f64,
    pub x_end_mm: f64,
    /// Why it was dropped, e.g. "lasts 0.030 s after trimming, less than
    /// min_duration_s = 0.05 s".
    pub reason: String,
}

/// The segments kept and the runs dropped by [`detect_sliding_report`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SlidingReport {
    pub segments: Vec<SlidingSegment>,
    pub dropped: Vec<DroppedRun>,
}

/// Finds the sliding segments. `nominal_dt_s` is the position stream's
/// nominal sample interval (gaps longer than 1.5 of it split segments).
/// The error explains why nothing qualified.
pub fn detect_sliding(
    t_s: &[f64],
    x_mm: &[f64],
    v_mm_s: &[f64],
    fn_n: &[f64],
    nominal_dt_s: f64,
    criteria: &SlidingCriteria,
) -> Result<Vec<SlidingSegment>, String> {
    detect_sliding_report(t_s, x_mm, v_mm_s, fn_n, nominal_dt_s, criteria).map(|r| r.segments)
}

/// [`detect_sliding`], also reporting the runs of sliding samples that
/// were dropped (too short once trimmed) with the reason.
pub fn detect_sliding_report(
    t_s: &[f64],
    x_mm: &[f64],
    v_mm_s: &[f64],
    fn_n: &[f64],
    nominal_dt_s: f64,
    criteria: &SlidingCriteria,
) -> Result<SlidingReport, String> {
    let n = t_s.len();
    let moving: Vec<bool> =
        (0..n).map(|i| fn_n[i] >= criteria.min_fn_n && v_mm_s[i].abs() >= criteria.min_speed_mm_s).collect();
    let mut candidate_fn: Vec<f64> = (0..n).filter(|&i| moving[i]).map(|i| fn_n[i]).collect();
    if candidate_fn.is_empty() {
        let max_speed = v_mm_s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let max_speed_in_contact =
            (0..n).filter(|&i| fn_n[i] >= criteria.min_fn_n).fold(0.0f64, |m, i| m.max(v_mm_s[i].abs()));
        let max_fn = fn_n.iter().fold(f64::NEG_INFINITY, |m, &f| m.max(f));
        return Err(format!(
            "the finger never moved at >= {} mm/s while pressing with Fn >= {} N (largest speed {} mm/s, largest \
             speed in contact {} mm/s, largest Fn {} N)",
            Num(criteria.min_speed_mm_s),
            Num(criteria.min_fn_n),
            Fixed(max_speed, 3),
            Fixed(max_speed_in_contact, 3),
            Fixed(max_fn, 4)
        ));
    }
    let mid = candidate_fn.len() / 2;
    let fn_ref = *candidate_fn.select_nth_unstable_by(mid, f64::total_cmp).1;
    let sliding: Vec<bool> =
        (0..n).map(|i| moving[i] && (fn_n[i] - fn_ref).abs() <= criteria.fn_tolerance * fn_ref).collect();

    let mut segments = Vec::new();
    let mut dropped = Vec::new();
    let mut i = 0;
    while i < n {
        if !sliding[i] {
            i += 1;
            continue;
        }
        let sign = v_mm_s[i] > 0.0;
        let mut j = i + 1;
        while j < n && sliding[j] && (v_mm_s[j] > 0.0) == sign && t_s[j] - t_s[j - 1] <= 1.5 * nominal_dt_s {
            j += 1;
        }
        // Trim both ends by trim_s.
        let (t0, t1) = (t_s[i] + criteria.trim_s, t_s[j - 1] - criteria.trim_s);
        let start = i + t_s[i..j].partition_point(|&t| t < t0);
        let end = i + t_s[i..j].partition_point(|&t| t <= t1);
        let direction = if sign { Direction::Forward } else { Direction::Backward };
        let drop = |reason: String| DroppedRun {
            direction,
            t_start_s: t_s[i],
            t_end_s: t_s[j - 1],
            x_start_mm: x_mm[i],
            x_end_mm: x_mm[j - 1],
            reason,
        };
        if end <= start + 1 {
            dropped.push(drop(format!(
                "lasts {} s, too short to keep anything after trimming trim_s = {} s at each end",
                Fixed(t_s[j - 1] - t_s[i], 3),
                Num(criteria.trim_s)
            )));
        } else {
            let segment = SlidingSegment {
                start,
                end,
                direction,
                t_start_s: t_s[start],
                t_end_s: t_s[end - 1],
                x_start_mm: x_mm[start],
                x_end_mm: x_mm[end - 1],
                mean_speed_mm_s: v_mm_s[start..end].iter().map(|v| v.abs()).sum::<f64>() / (end - start) as f64,
                mean_fn_n: fn_n[start..end].iter().sum::<f64>() / (end - start) as f64,
            };
            if segment.duration_s() < criteria.min_duration_s {
                dropped.push(drop(format!(
                    "lasts {} s after trimming, less than min_duration_s = {} s",
                    Fixed(segment.duration_s(), 3),
                    Num(criteria.min_duration_s)
                )));
            } else if segment.length_mm() < criteria.min_length_mm {
                dropped.push(drop(format!(
                    "covers {} mm after trimming, less than min_length_mm = {} mm",
                    Fixed(segment.length_mm(), 3),
                    Num(criteria.min_length_mm)
                )));
            } else {
                segments.push(segment);
            }
        }
        i = j;
    }
    if segments.is_empty() {
        let steady = sliding.iter().filter(|&&s| s).count();
        return Err(format!(
            "{steady} samples move at >= {} mm/s with a steady normal force (Fn within {}% of {} N), but no run of \
             them lasts {} s and covers {} mm after trimming {} s at each end",
            Num(criteria.min_speed_mm_s),
            Num(criteria.fn_tolerance * 100.0),
            Fixed(fn_ref, 4),
            Num(criteria.min_duration_s),
            Num(criteria.min_length_mm),
            Num(criteria.trim_s)
        ));
    }
    Ok(SlidingReport { segments, dropped })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A long run is kept; a short one (0.04 s of sliding) is dropped with
    /// the reason, and so is one too short to survive the trimming.
    #[test]
    fn short_runs_are_reported_with_the_reason() {
        let dt = 0.0025;
        let n = 400;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        // Moving forward at 50 mm/s on samples 20..200 (0.45 s), 250..266
        // (0.04 s) and 300..306 (0.015 s); still elsewhere.
        let moving = |i: usize| (20..200).contains(&i) || (250..266).contains(&i) || (300..306).contains(&i);
        let v: Vec<f64> = (0..n).map(|i| if moving(i) { 50.0 } else { 0.0 }).collect();
        let mut x = vec![0.0; n];
        for i in 1..n {
            x[i] = x[i - 1] + v[i] * dt;
        }
        let fn_n = vec![0.5; n];
        let criteria = SlidingCriteria {
            speed_window_s: 0.02,
            min_speed_mm_s: 10.0,
            min_fn_n: 0.05,
            fn_tolerance: 0.5,
            trim_s: 0.01,
            min_duration_s: 0.05,
            min_length_mm: 1.0,
        };
        let report = detect_sliding_report(&t, &x, &v, &fn_n, dt, &criteria).unwrap();
        assert_eq!(report.segments.len(), 1);
        assert_eq!(report.dropped.len(), 2, "{:?}", report.dropped);
        assert!(report.dropped[0].reason.contains("less than min_duration_s = 0.05 s"), "{:?}", report.dropped[0]);
        assert!((report.dropped[0].t_start_s - 250.0 * dt).abs() < 1e-12);
        assert!(
            report.dropped[1].reason.contains("too short to keep anything after trimming"),
            "{:?}",
            report.dropped[1]
        );
        assert_eq!(detect_sliding(&t, &x, &v, &fn_n, dt, &criteria).unwrap(), report.segments);
    }

    #[test]
    fn velocity_of_a_quadratic_is_exact_at_the_centre() {
        // x = t^2: a centred least-squares line has the exact slope 2t at a
        // symmetric window's centre.
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.0025).collect();
        let x: Vec<f64> = t.iter().map(|t| t * t * 1000.0).collect();
        let v = finger_velocity(&t, &x, 4);
        for i in 4..46 {
            assert!((v[i] - 2000.0 * t[i]).abs() < 1e-9, "{i}: {}", v[i]);
        }
    }
}
