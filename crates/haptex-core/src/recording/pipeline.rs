//! The recording pipeline of paper section 2.4, step by step:
//!
//! 1. anti-alias low-pass and resample the forces to the position times
//!    ([`super::filter`]);
//! 2. finger velocity and sliding-phase detection ([`super::sliding`]);
//! 3. mu = Ft / Fn on the sliding samples, eqs. (1) and (4)
//!    ([`friction_coefficient`]), with Ft along the direction of motion;
//! 4. time-to-location resampling onto a uniform x grid per segment, and
//!    the segments combined into one profile per stroke ([`super::location`]);
//!    a node whose mean is below zero is kept as measured and counted (see
//!    [`ProcessedStroke::negative_nodes`]);
//! 5. Fn_RS = mean Fn while sliding ([`ProcessedStroke::mean_fn_n`]).
//!
//! All parameters are in [`ProcessingConfig`].

use serde::{Deserialize, Serialize};

use super::error::RecordingError;
use super::filter::{LowPassFir, resample_filtered};
use super::format::Recording;
use super::location::{GridSeries, combine_segments, to_location_grid};
use super::sliding::{Direction, DroppedRun, SlidingCriteria, SlidingSegment, detect_sliding_report, finger_velocity};
use crate::num::{Fixed, Num};
use crate::profile::FrictionProfile;

/// Most nodes of a stroke's location grid: 1e7 (1 km at 0.1 mm), checked
/// before the grid is allocated.
pub const MAX_GRID_NODES: usize = 10_000_000;

/// Which sliding directions contribute to a stroke's profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DirectionFilter {
    /// Both directions (segments over the same ground are averaged).
    Both,
    /// Only segments moving towards +x.
    Forward,
    /// Only segments moving towards -x.
    Backward,
}

impl DirectionFilter {
    fn admits(self, direction: Direction) -> bool {
        matches!(
            (self, direction),
            (DirectionFilter::Both, _)
                | (DirectionFilter::Forward, Direction::Forward)
                | (DirectionFilter::Backward, Direction::Backward)
        )
    }
}

/// Every parameter of the pipeline. `Default` gives the documented defaults
/// (docs/recordings.md explains each choice).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProcessingConfig {
    /// Anti-alias passband edge as a fraction of the position rate
    /// (default 0.375: 150 Hz for 400 Hz).
    pub passband_fraction: f64,
    /// Anti-alias stopband edge as a fraction of the position rate (default
    /// 0.625: 250 Hz for 400 Hz, the lowest frequency that folds into the
    /// passband).
    pub stopband_fraction: f64,
    /// Stopband attenuation of the anti-alias filter in dB (default 80).
    pub stopband_attenuation_db: f64,
    /// Window of the least-squares finger velocity in s (default 0.02).
    pub speed_window_s: f64,
    /// Sliding needs at least this finger speed, mm/s (default 10).
    pub min_speed_mm_s: f64,
    /// Contact needs at least this normal force, N (default 0.05).
    pub min_fn_n: f64,
    /// Sliding needs Fn within this fraction of the median sliding Fn
    /// (default 0.5: 0.5 to 1.5 times the median).
    pub fn_tolerance: f64,
    /// Cut from each end of a sliding segment, s (default 0.01).
    pub trim_s: f64,
    /// Shortest sliding segment kept, s (default 0.05).
    pub min_duration_s: f64,
    /// Shortest sliding segment kept, mm (default 1).
    pub min_length_mm: f64,
    /// Spacing of the location grid, mm (default 0.1).
    pub dx_mm: f64,
    /// Longest gap between sliding segments bridged by linear
    /// interpolation, mm (default 1: the slow-down into and out of a pause
    /// or a reversal).
    pub max_gap_mm: f64,
    /// Directions that contribute to the profile (default both).
    pub direction: DirectionFilter,
}

impl Default for ProcessingConfig {
    fn default() -> Self {
        Self {
            passband_fraction: 0.375,
            stopband_fraction: 0.625,
            stopband_attenuation_db: 80.0,
            speed_window_s: 0.02,
            min_speed_mm_s: 10.0,
            min_fn_n: 0.05,
            fn_tolerance: 0.5,
            trim_s: 0.01,
            min_duration_s: 0.05,
            min_length_mm: 1.0,
            dx_mm: 0.1,
            max_gap_mm: 1.0,
            direction: DirectionFilter::Both,
        }
    }
}

impl ProcessingConfig {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<(), RecordingError> {
        let positive = [
            ("passband_fraction", self.passband_fraction),
            ("stopband_fraction", self.stopband_fraction),
            ("stopband_attenuation_db", self.stopband_attenuation_db),
            ("speed_window_s", self.speed_window_s),
            ("min_speed_mm_s", self.min_speed_mm_s),
            ("min_fn_n", self.min_fn_n),
            ("fn_tolerance", self.fn_tolerance),
            ("dx_mm", self.dx_mm),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(RecordingError::Config { name, message: format!("must be positive, got {}", Num(value)) });
            }
        }
        let non_negative = [
            ("trim_s", self.trim_s),
            ("min_duration_s", self.min_duration_s),
            ("min_length_mm", self.min_length_mm),
            ("max_gap_mm", self.max_gap_mm),
        ];
        for (name, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(RecordingError::Config {
                    name,
                    message: format!("must be zero or positive, got {}", Num(value)),
                });
            }
        }
        if self.passband_fraction >= self.stopband_fraction || self.stopband_fraction > 1.0 {
            return Err(RecordingError::Config {
                name: "stopband_fraction",
                message: format!(
                    "need passband_fraction ({}) < stopband_fraction ({}) <= 1 (beyond 1 aliases reach the passband)",
                    Num(self.passband_fraction),
                    Num(self.stopband_fraction)
                ),
            });
        }
        Ok(())
    }

    /// The anti-alias filter for a force rate and a position (output) rate.
    pub fn anti_alias_filter(&self, force_rate_hz: f64, position_rate_hz: f64) -> Result<LowPassFir, RecordingError> {
        LowPassFir::kaiser(
            force_rate_hz,
            self.passband_fraction * position_rate_hz,
            self.stopband_fraction * position_rate_hz,
            self.stopband_attenuation_db,
        )
    }

    fn criteria(&self) -> SlidingCriteria {
        SlidingCriteria {
            speed_window_s: self.speed_window_s,
            min_speed_mm_s: self.min_speed_mm_s,
            min_fn_n: self.min_fn_n,
            fn_tolerance: self.fn_tolerance,
            trim_s: self.trim_s,
            min_duration_s: self.min_duration_s,
            min_length_mm: self.min_length_mm,
        }
    }
}

/// The signals at the position rate, after step 1 and 2 (for inspection).
#[derive(Debug, Clone, PartialEq)]
pub struct PositionRateSeries {
    pub t_s: Vec<f64>,
    pub x_mm: Vec<f64>,
    pub v_mm_s: Vec<f64>,
    pub fn_n: Vec<f64>,
    pub ft_n: Vec<f64>,
}

/// The result of processing one recording.
#[derive(Debug, Clone, PartialEq)]
pub struct ProcessedStroke {
    /// mu(x) with the location-domain Fn(x), on the uniform grid.
    pub profile: FrictionProfile,
    /// The sliding segments found (all directions; see `used`).
    pub segments: Vec<SlidingSegment>,
    /// Whether each segment contributed (direction filter).
    pub used: Vec<bool>,
    /// Runs of sliding samples not kept as segments (too short once
    /// trimmed), with the reason: the processing report.
    pub dropped: Vec<DroppedRun>,
    /// Fn_RS: mean normal force over the profile, N (paper section 2.4).
    pub mean_fn_n: f64,
    /// Mean friction coefficient over the profile.
    pub mean_mu: f64,
    /// Total duration of the contributing segments, s.
    pub sliding_s: f64,
    /// Length of the profile bridged between segments, mm.
    pub bridged_mm: f64,
    /// Length of the anti-alias filter, taps.
    pub filter_taps: usize,
    /// The resampled signals and velocity at the position rate.
    pub series: PositionRateSeries,
}

impl ProcessedStroke {
    /// Nodes of the profile where the mean friction along the motion came
    /// out below zero: the surface pushed the finger along (a downslope
    /// steeper than the skin's friction, [`crate::ranges::MU`]), or sensor
    /// noise or a force offset where the friction is near zero. Kept as
    /// measured and counted, so that `library process` can say so; a
    /// segment whose force opposes the motion on average is refused
    /// instead (a converter's flipped sign).
    pub fn negative_nodes(&self) -> usize {
        self.profile.mu().iter().filter(|m| **m < 0.0).count()
    }
}

/// mu = Ft / Fn (paper eqs. 1 and 4), with Ft taken along the direction of
/// motion: ft_n is the force the finger exerts on the surface along +x
/// (positive while it slides towards +x, negative towards -x), so
/// mu = sign(direction) ft_n / fn_n, positive while the friction opposes
/// the motion whichever way the finger slides. The sign of ft_n is thus
/// the sliding direction's, and stays here: the profile that leaves the
/// pipeline holds the friction along the motion (negative only where the
/// surface pushed the finger along).
pub fn friction_coefficient(ft_n: &[f64], fn_n: &[f64], direction: Direction) -> Vec<f64> {
    let s = direction.sign();
    ft_n.iter().zip(fn_n).map(|(t, n)| s * t / n).collect()
}

/// Runs the whole pipeline on one recording.
pub fn process(recording: &Recording, config: &ProcessingConfig) -> Result<ProcessedStroke, RecordingError> {
    config.validate()?;
    let file = recording.name.clone();
    let (force, position) = (&recording.force, &recording.position);
    let filter = config.anti_alias_filter(force.rate_hz, position.rate_hz)?;

    // Step 1: anti-aliased forces at the position times.
    let resampled = resample_filtered(&force.t_s, &[&force.fn_n, &force.ft_n], &position.t_s, &filter);
    if resampled.valid.len() < 3 {
        return Err(RecordingError::Processing {
            file,
            message: format!(
                "too short: the anti-alias filter ({} taps, {} s) needs {} s of force data on each side of a position \
                 sample",
                filter.taps().len(),
                Fixed(filter.taps().len() as f64 / force.rate_hz, 4),
                Fixed(filter.half_len() as f64 / force.rate_hz, 4)
            ),
        });
    }
    let [fn_n, ft_n]: [Vec<f64>; 2] = resampled.columns.try_into().expect("two resampled columns");
    let t_s = position.t_s[resampled.valid.clone()].to_vec();
    let x_mm = position.x_mm[resampled.valid].to_vec();

    // Step 2: velocity and sliding segments.
    let half = ((0.5 * config.speed_window_s * position.rate_hz).round() as usize).max(1);
    let v_mm_s = finger_velocity(&t_s, &x_mm, half);
    let detected = detect_sliding_report(&t_s, &x_mm, &v_mm_s, &fn_n, 1.0 / position.rate_hz, &config.criteria())
        .map_err(|message| RecordingError::NoSliding { file: file.clone(), message })?;
    let (segments, dropped) = (detected.segments, detected.dropped);
    let used: Vec<bool> = segments.iter().map(|s| config.direction.admits(s.direction)).collect();
    if !used.iter().any(|&u| u) {
        return Err(RecordingError::NoSliding {
            file,
            message: format!(
                "{} sliding segments, none in the selected direction ({:?})",
                segments.len(),
                config.direction
            ),
        });
    }

    // Steps 3 and 4: mu per segment, onto the location grid, combined.
    // The grid spans the used segments' x range: checked before any node
    // is allocated (a dx of 1e-12 mm would ask for 1e17 of them).
    let (x_low, x_high) = segments
        .iter()
        .zip(&used)
        .filter(|(_, u)| **u)
        .flat_map(|(s, _)| [s.x_start_mm, s.x_end_mm])
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
    let nodes = (x_high - x_low) / config.dx_mm;
    if !nodes.is_finite() || nodes > MAX_GRID_NODES as f64 {
        return Err(RecordingError::Config {
            name: "dx_mm",
            message: format!(
                "{} mm over the sliding segments' {} mm is {} grid nodes, more than the {MAX_GRID_NODES} a profile \
                 may have",
                Num(config.dx_mm),
                Num(x_high - x_low),
                Num(nodes.ceil())
            ),
        });
    }
    let mut grids: Vec<GridSeries> = Vec::new();
    for (segment, _) in segments.iter().zip(&used).filter(|(_, u)| **u) {
        let range = segment.start..segment.end;
        let mu = friction_coefficient(&ft_n[range.clone()], &fn_n[range.clone()], segment.direction);
        let mean = mu.iter().sum::<f64>() / mu.len() as f64;
        if mean < 0.0 {
            return Err(RecordingError::Processing {
                file,
                message: format!(
                    "the tangential force opposes the motion in the segment at t = {} .. {} s (mean Ft/Fn = {}): \
                     ft_n must be the force the finger exerts on the surface along +x; flip its sign in the converter",
                    Fixed(segment.t_start_s, 3),
                    Fixed(segment.t_end_s, 3),
                    Fixed(mean, 3)
                ),
            });
        }
        if let Some(grid) = to_location_grid(&x_mm[range.clone()], &[&mu, &fn_n[range]], config.dx_mm) {
            grids.push(grid);
        }
    }
    let max_gap_nodes = (config.max_gap_mm / config.dx_mm + 1e-9).floor() as usize;
    let combined = combine_segments(&grids, max_gap_nodes).filter(|c| c.series.len() >= 2).ok_or_else(|| {
        RecordingError::Processing {
            file: file.clone(),
            message: format!("the sliding segments cover less than two {} mm grid cells", Num(config.dx_mm)),
        }
    })?;
    let bridged_mm = combined.bridged_nodes as f64 * config.dx_mm;
    let x_grid = combined.series.x_mm(config.dx_mm);
    let [mu, fn_grid]: [Vec<f64>; 2] = combined.series.columns.try_into().expect("two grid columns");
    // A node whose mean came out below zero is kept as measured (see
    // `ProcessedStroke::negative_nodes`); a segment whose force opposes the
    // motion on average was refused above.
    // Step 5: Fn_RS = mean Fn while sliding, over the location domain.
    let mean_fn_n = fn_grid.iter().sum::<f64>() / fn_grid.len() as f64;
    let mean_mu = mu.iter().sum::<f64>() / mu.len() as f64;
    let profile = FrictionProfile::new(x_grid, mu)
        .and_then(|p| p.with_normal_force(fn_grid))
        .map_err(|e| RecordingError::Processing { file: file.clone(), message: format!("invalid profile: {e}") })?;
    let sliding_s = segments.iter().zip(&used).filter(|(_, u)| **u).map(|(s, _)| s.duration_s()).sum();
    Ok(ProcessedStroke {
        profile,
        segments,
        used,
        dropped,
        mean_fn_n,
        mean_mu,
        sliding_s,
        bridged_mm,
        filter_taps: filter.taps().len(),
        series: PositionRateSeries { t_s, x_mm, v_mm_s, fn_n, ft_n },
    })
}
