//! Iterative learning control from measured strokes: the next design of a
//! friction display from the friction a finger felt on the last one
//! (issue 36; docs/measured-compensation.md).
//!
//! A design (a voltage profile, or a combined display's voltage and
//! amplitude) is played; the user strokes the display several times at a
//! steady velocity and force, and each stroke's Ft/Fn is taken onto the
//! design's x grid ([`stroke_mean`]: the samples within each grid point's
//! cell averaged). The strokes' mean is the measured friction; the
//! standard error of that mean (the per-point standard deviation across
//! strokes over sqrt(n)) says how much of it is noise, and its RMS over
//! the renderable region is the *noise floor* (at least
//! [`MIN_STROKES`] strokes give one).
//!
//! # The update, in the command domain
//!
//! The display model (eq. 8 for electrovibration, [`crate::combined`] for
//! the combined display) turns a friction *command* m(x) into a drive:
//! m_k is what design k asks the display model for, read back from the
//! design's drive by the model itself ([`DisplayModel::command`]: mu_HD
//! rho(a) (1 + Fe(U)/Fn)), so it is m_0 = the target (within the display's
//! band) for an eq. (8) design. With the measured mean y_k, the target r,
//! and the lag d (below),
//!
//! ```text
//!   e_k(x)     = y_k(x + d) - r(x + d)
//!   m_{k+1}(x) = clip( m_k(x) - L Q[e_k](x) / P,  band )
//!   design k+1 = the display model's drive for m_{k+1}
//! ```
//!
//! - L in (0, 1] is the learning gain (default 1).
//! - P is the plant's local gain dy/dm, estimated from the strokes as the
//!   least-squares slope of y_k(x + d) against m_k(x) over the renderable
//!   points whose command is inside the band, as `haptex_fem::render::
//!   compensate` estimates its beta from each FE run; 1 (the model taken
//!   at its word) when the data cannot tell (the command hardly varies, or
//!   the slope's standard error is above a quarter of it), and held within
//!   [`PLANT_GAIN_RANGE`]. Device constants 30% off, or an air gap the
//!   model does not know, make P differ from 1; dividing by it keeps the
//!   learning rate near 1 whatever the constants.
//! - Q is a zero-phase low-pass: a Gaussian of standard deviation
//!   sigma_Q = max([`Q_SIGMA_MM`], the design's median spacing),
//!   approximated by three passes of a centred moving average of width
//!   2 sigma_Q (the central-limit construction of Wells, "Efficient
//!   synthesis of Gaussian filters by cascaded uniform filters", IEEE
//!   PAMI 8(2), 1986), in length not in samples so that an uneven grid is
//!   filtered alike. It averages only renderable points (a normalized
//!   convolution), so the error where the display cannot follow does not
//!   leak into its neighbours. Its cost is linear in the number of points
//!   whatever sigma_Q.
//! - d is the display's lag: the shift within +-[`MAX_LAG_MM`] that
//!   maximizes the correlation of y_k(x + d) with m_k(x) over the
//!   renderable region (in steps of [`MAX_LAG_MM`] / 40). It is estimated
//!   against the command, not the target: the lag is between what the
//!   display is asked and what is felt, and once the design has converged
//!   the felt profile matches the target with no lag left between them.
//!   The update then corrects m at x for the error it causes at x + d, so
//!   the design leads by the lag.
//! - Outside the renderable region (the target below the band, where the
//!   display cannot lower friction, or above it) m stays at the band's
//!   edge: no iteration changes the friction felt there, and the error
//!   there is not counted.
//! - The band clip is the anti-windup: a command beyond the band would not
//!   change the drive (clipped at U_max or a_max by the model) but would
//!   have to unwind before it could act again. The drive of a command
//!   within the band is within [0, U_max] and [0, a_max] by construction,
//!   and [`check_limits`] asserts it before anything is written.
//!
//! # Stability
//!
//! Bristow, Tharayil and Alleyne ("A survey of iterative learning
//! control", IEEE Control Systems Magazine 26(3), 2006, sec. "Stability
//! and performance") give the condition for monotone convergence of
//! u_{k+1} = Q (u_k + L e_k) in the 2-norm: |Q(e^{iw}) (1 - L(e^{iw})
//! P(e^{iw}))| < 1 at all frequencies. Here the plant is, locally, a
//! static gain P times a delay that the lag estimate removes, and the
//! learning operator is L/P-hat, so the condition is |Q| |1 - L P/P-hat|
//! < 1: with a Gaussian Q (0 < Q <= 1, zero phase) it holds whenever
//! 0 < L P/P-hat < 2, i.e. for L = 1 as long as the gain estimate is not
//! off by more than a factor of 2 on the low side. Where Q < 1 (detail
//! finer than sigma_Q) the error is not learnt: Q trades tracking of fine
//! detail for robustness to what the lag and gain estimates miss, and
//! keeps the strokes' noise (white from grid point to grid point) out of
//! the next design. The converged error is then the filtered-out detail
//! plus the noise of the mean.
//!
//! # Stopping
//!
//! When the RMS error over the renderable region is within
//! [`STOP_FACTOR`] times the noise floor, the design is not changed: a
//! further iteration would chase noise. It is not changed either once the
//! history has `max_iterations` entries.

use std::fmt;
use std::path::Path;

use crate::combined::{Allocator, DisplayError, Strategy, bias_level};
use crate::electrovibration::{Device, ElectroError, Method, force_ratio_for, map_profile};
use crate::io::{Table, TableError};
use crate::num::Num;
use crate::profile::{FrictionProfile, ProfileError, WalkingCursor};
use crate::recording::{ProcessingConfig, Recording, RecordingError, process};
use crate::ultrasonic::UltrasonicDevice;

/// Fewest strokes that give a noise floor (a standard deviation needs two).
pub const MIN_STROKES: usize = 2;

/// The stop rule: an RMS error within this many noise floors is noise.
pub const STOP_FACTOR: f64 = 1.5;

/// Largest lag looked for, mm: 10 ms at 20 mm/s, seven times the finger
/// pad's pre-sliding length (0.03 mm on the FE finger) and room for a force
/// sensor's filter delay; a larger shift would only align unrelated detail.
pub const MAX_LAG_MM: f64 = 0.2;

/// The Q-filter's smallest standard deviation, mm: the scale of the pad's
/// pre-sliding (0.03 mm), below which the felt friction does not follow
/// the drive point by point.
pub const Q_SIGMA_MM: f64 = 0.05;

/// The plant gain estimate is held within this range (a factor of 4 either
/// way from the model's 1).
pub const PLANT_GAIN_RANGE: [f64; 2] = [0.25, 4.0];

/// The prefix of a history comment line (after `# `).
pub const HISTORY_PREFIX: &str = "ilc iteration ";

/// An iteration cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum IlcError {
    #[error(transparent)]
    Table(#[from] TableError),
    #[error(transparent)]
    Profile(#[from] ProfileError),
    #[error(transparent)]
    Recording(#[from] RecordingError),
    #[error(transparent)]
    Electro(#[from] ElectroError),
    #[error(transparent)]
    Display(#[from] DisplayError),
    #[error(
        "{count} stroke{}: the noise floor (the standard error of the strokes' mean) needs at least {MIN_STROKES}; \
         record several strokes of the design (docs/measured-compensation.md)",
        if *count == 1 { "" } else { "s" }
    )]
    TooFewStrokes { count: usize },
    #[error(
        "{name}: the stroke covers x = {} .. {} mm, the design {} .. {} mm: each stroke must cross the design's \
         whole span",
        Num(stroke_mm[0]), Num(stroke_mm[1]), Num(design_mm[0]), Num(design_mm[1])
    )]
    NotCovered { name: String, stroke_mm: [f64; 2], design_mm: [f64; 2] },
    #[error("{source_name}: the history line \"{line}\" is not one haptex wrote: {message}")]
    History { source_name: String, line: String, message: String },
    #[error("{0}")]
    Invalid(String),
    /// A drive sample beyond its channel's limit: a bug, never written.
    #[error("internal: {channel} {} at x = {} mm is above its limit {}; nothing was written", Num(*value), Num(*x_mm), Num(*limit))]
    AboveLimit { channel: &'static str, value: f64, x_mm: f64, limit: f64 },
}

/// One measured stroke over the display: the friction Ft/Fn against the
/// finger's position (mm).
#[derive(Debug, Clone)]
pub struct Stroke {
    /// Where it came from (a file name), for messages.
    pub name: String,
    pub profile: FrictionProfile,
}

impl Stroke {
    /// Reads a stroke: a recording (`NAME.recording.json`, segmented and
    /// turned into mu(x) by the recordings pipeline with its default
    /// settings), or a CSV of `x_mm,ft_n,fn_n` (mu = Ft/Fn) or `x_mm,mu`.
    pub fn read_file(path: &Path) -> Result<Self, IlcError> {
        let name = path.display().to_string();
        let is_recording = path.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.ends_with(".recording.json"));
        let profile = if is_recording {
            process(&Recording::load(path)?, &ProcessingConfig::default())?.profile
        } else {
            FrictionProfile::read_csv_file(path)?
        };
        Ok(Self { name, profile })
    }
}

/// The strokes' mean friction on a grid, and its standard error.
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeMean {
    pub mu: Vec<f64>,
    /// Per point: the standard deviation across strokes over sqrt(n).
    pub standard_error: Vec<f64>,
    pub strokes: usize,
}

/// The strokes on the grid `x` (strictly increasing, at least 2 points):
/// each stroke's samples within a grid point's cell (between the midpoints
/// to its neighbours) averaged, or the stroke interpolated there when the
/// cell holds none; then the mean and its standard error across strokes.
/// Every stroke must cover the grid's span (to half a spacing at either
/// end). Linear in the points of the grid and the strokes.
pub fn stroke_mean(x: &[f64], strokes: &[Stroke]) -> Result<StrokeMean, IlcError> {
    if strokes.len() < MIN_STROKES {
        return Err(IlcError::TooFewStrokes { count: strokes.len() });
    }
    let n = x.len();
    if n < 2 {
        return Err(IlcError::Invalid("the design has fewer than 2 points".into()));
    }
    // Cell edges: midpoints, and half a spacing beyond either end.
    let mut edges = Vec::with_capacity(n + 1);
    edges.push(x[0] - 0.5 * (x[1] - x[0]));
    edges.extend(x.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    edges.push(x[n - 1] + 0.5 * (x[n - 1] - x[n - 2]));
    let (mut sum, mut sum2) = (vec![0.0; n], vec![0.0; n]);
    for stroke in strokes {
        let (sx, smu) = (stroke.profile.x_mm(), stroke.profile.mu());
        let (first, last) = (sx[0], sx[sx.len() - 1]);
        if first > 0.5 * (x[0] + edges[1]) || last < 0.5 * (x[n - 1] + edges[n - 1]) {
            return Err(IlcError::NotCovered {
                name: stroke.name.clone(),
                stroke_mm: [first, last],
                design_mm: [x[0], x[n - 1]],
            });
        }
        let mut j = sx.partition_point(|&s| s < edges[0]);
        let mut cursor = WalkingCursor::default();
        for i in 0..n {
            let (mut total, mut count) = (0.0, 0usize);
            while j < sx.len() && sx[j] < edges[i + 1] {
                total += smu[j];
                count += 1;
                j += 1;
            }
            let value = if count > 0 { total / count as f64 } else { cursor.interpolate(sx, smu, x[i]) };
            sum[i] += value;
            sum2[i] += value * value;
        }
    }
    let count = strokes.len() as f64;
    let mu: Vec<f64> = sum.iter().map(|s| s / count).collect();
    let standard_error = (0..n)
        .map(|i| {
            let variance = ((sum2[i] - count * mu[i] * mu[i]) / (count - 1.0)).max(0.0);
            (variance / count).sqrt()
        })
        .collect();
    Ok(StrokeMean { mu, standard_error, strokes: strokes.len() })
}

/// The display a design drives, and the model that maps a friction
/// command to its drive.
#[derive(Debug, Clone, Copy)]
pub enum DisplayModel<'a> {
    /// Eq. (8) on `Device`.
    Electrovibration(Device),
    /// Voltage and vibration shared by a strategy ([`crate::combined`]).
    Combined { device: Device, ultrasonic: &'a UltrasonicDevice, strategy: Strategy },
}

impl<'a> DisplayModel<'a> {
    pub fn device(&self) -> &Device {
        match self {
            Self::Electrovibration(device) | Self::Combined { device, .. } => device,
        }
    }

    /// The highest amplitude, um (None without a plate).
    pub fn a_max_um(&self) -> Option<f64> {
        match self {
            Self::Electrovibration(_) => None,
            Self::Combined { ultrasonic, .. } => Some(ultrasonic.a_max_um()),
        }
    }

    /// The per-point allocator the combined display's mapping uses for
    /// `target` (its bias level from the target's lowest friction, as
    /// [`crate::combined::map_display`] sets it for the target).
    fn allocator(&self, target: &FrictionProfile) -> Result<Allocator<'a>, IlcError> {
        let device = self.device();
        device.validate()?;
        let (_, ratio) = force_ratio_for(target, device, None)?;
        Ok(match *self {
            Self::Electrovibration(device) => {
                Allocator::new(device.mu_hd, Some((ratio, device.u_max_v)), None, Strategy::Split, 1.0)
            }
            Self::Combined { device, ultrasonic, strategy } => {
                let mu_min = target.mu().iter().copied().fold(f64::INFINITY, f64::min);
                let rho_bias = bias_level(mu_min, device.mu_hd, ultrasonic.rho_min());
                Allocator::new(device.mu_hd, Some((ratio, device.u_max_v)), Some(ultrasonic), strategy, rho_bias)
            }
        })
    }

    /// The renderable band [low, high] of felt friction.
    pub fn band(&self, target: &FrictionProfile) -> Result<[f64; 2], IlcError> {
        Ok(self.allocator(target)?.band())
    }

    /// The command a drive asks the model for: mu_HD rho(a) (1 + Fe(U)/Fn)
    /// per point (the inverse of the mapping inside the band).
    pub fn command(
        &self,
        target: &FrictionProfile,
        voltage_v: &[f64],
        amplitude_um: Option<&[f64]>,
    ) -> Result<Vec<f64>, IlcError> {
        let allocator = self.allocator(target)?;
        let [low, high] = allocator.band();
        Ok((0..voltage_v.len())
            .map(|i| allocator.felt_mu(voltage_v[i], amplitude_um.map_or(0.0, |a| a[i])).clamp(low, high))
            .collect())
    }

    /// The drive of a command: eq. (8) ([`map_profile`]) on the
    /// electrovibration display, the strategy's allocation on the combined
    /// one; clipped at U_max and a_max by construction.
    pub fn drive(&self, target: &FrictionProfile, command: &[f64]) -> Result<Drive, IlcError> {
        let profile = FrictionProfile::new(target.x_mm().to_vec(), command.to_vec())?;
        match *self {
            Self::Electrovibration(device) => {
                let voltage_v = map_profile(&profile, &device, Method::Physical, None)?.voltage_v;
                Ok(Drive { voltage_v, amplitude_um: None })
            }
            Self::Combined { device, ultrasonic, .. } => {
                let (voltage_v, amplitude_um) = self
                    .allocator(target)?
                    .allocate_all(command, device.u_max_v, ultrasonic.a_max_um())
                    .map_err(|v| IlcError::AboveLimit {
                        channel: "drive",
                        value: v.value,
                        x_mm: target.x_mm()[v.index],
                        limit: v.limit,
                    })?;
                Ok(Drive { voltage_v, amplitude_um: Some(amplitude_um) })
            }
        }
    }
}

/// A display's drive per position.
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    /// V RMS.
    pub voltage_v: Vec<f64>,
    /// um peak (combined display).
    pub amplitude_um: Option<Vec<f64>>,
}

/// Checks that no voltage is outside 0 ..= U_max and no amplitude outside
/// 0 ..= a_max: called on every drive before it is written.
pub fn check_limits(x_mm: &[f64], drive: &Drive, model: &DisplayModel) -> Result<(), IlcError> {
    let channels = [
        ("voltage (V)", Some(&drive.voltage_v), model.device().u_max_v),
        ("amplitude (um)", drive.amplitude_um.as_ref(), model.a_max_um().unwrap_or(0.0)),
    ];
    for (channel, values, limit) in channels {
        if let Some(values) = values
            && let Some(i) = values.iter().position(|v| !(0.0..=limit).contains(v))
        {
            return Err(IlcError::AboveLimit { channel, value: values[i], x_mm: x_mm[i], limit });
        }
    }
    Ok(())
}

/// A design read back: the target, its drive and its history.
#[derive(Debug, Clone)]
pub struct Design {
    pub target: FrictionProfile,
    pub drive: Drive,
    /// The iterations that led to it, oldest first.
    pub history: Vec<HistoryEntry>,
}

impl Design {
    /// A design from a table of `x_mm,mu,voltage_v` (and `amplitude_um` on
    /// a combined display) with its `# ilc iteration` history lines: every
    /// voltage within 0 ..= U_max and amplitude within 0 ..= a_max of
    /// `model`, each error at its line and column.
    pub fn from_table(table: &Table, model: &DisplayModel) -> Result<Self, IlcError> {
        let target = FrictionProfile::from_table(table)?;
        let voltage_v = table.require("voltage_v")?.to_vec();
        let amplitude_um = table.column("amplitude_um").map(<[f64]>::to_vec);
        match (model, &amplitude_um) {
            (DisplayModel::Electrovibration(_), Some(_)) => {
                return Err(table
                    .error_at(
                        None,
                        Some("amplitude_um"),
                        "the design has an amplitude: it is a combined display's (give --display combined)",
                    )
                    .into());
            }
            (DisplayModel::Combined { .. }, None) => return Err(table.missing("amplitude_um").into()),
            _ => {}
        }
        let u_max = model.device().u_max_v;
        if let Some(i) = voltage_v.iter().position(|u| !(0.0..=u_max).contains(u)) {
            return Err(table
                .error_at(
                    Some(i),
                    Some("voltage_v"),
                    format!(
                        "{} V is outside 0 .. U_max = {} V: this design was not made for this display (--u-max)",
                        Num(voltage_v[i]),
                        Num(u_max)
                    ),
                )
                .into());
        }
        if let (Some(a), Some(a_max)) = (&amplitude_um, model.a_max_um())
            && let Some(i) = a.iter().position(|a| !(0.0..=a_max).contains(a))
        {
            return Err(table
                .error_at(
                    Some(i),
                    Some("amplitude_um"),
                    format!("{} um is outside 0 .. a_max = {} um", Num(a[i]), Num(a_max)),
                )
                .into());
        }
        let mut history = Vec::new();
        for line in table.comments() {
            let text = line.trim_start_matches('#').trim();
            if let Some(rest) = text.strip_prefix(HISTORY_PREFIX) {
                let entry = HistoryEntry::parse(rest).map_err(|message| IlcError::History {
                    source_name: table.source_name().to_string(),
                    line: line.clone(),
                    message,
                })?;
                if entry.iteration != history.len() {
                    return Err(IlcError::History {
                        source_name: table.source_name().to_string(),
                        line: line.clone(),
                        message: format!("iteration {} follows {} earlier ones", entry.iteration, history.len()),
                    });
                }
                history.push(entry);
            }
        }
        Ok(Self { target, drive: Drive { voltage_v, amplitude_um }, history })
    }
}

/// What limits the design after an iteration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Limit {
    /// The error is within [`STOP_FACTOR`] noise floors.
    NoiseFloor,
    /// At the noise floor where the display can render the target; the
    /// rest of the target is outside its band.
    NotRenderable,
    /// The update asks for more than the band (U_max, a_max) somewhere.
    UMax,
    /// More iterations would lower the error (or the iteration limit is
    /// reached).
    Iterations,
}

impl Limit {
    /// The name in the history and the report.
    pub fn name(self) -> &'static str {
        match self {
            Limit::NoiseFloor => "noise_floor",
            Limit::NotRenderable => "not_renderable",
            Limit::UMax => "u_max",
            Limit::Iterations => "iterations",
        }
    }

    fn from_name(name: &str) -> Option<Self> {
        [Limit::NoiseFloor, Limit::NotRenderable, Limit::UMax, Limit::Iterations].into_iter().find(|l| l.name() == name)
    }
}

impl fmt::Display for Limit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One iteration as the history keeps it: the measurement of design k.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HistoryEntry {
    /// k: the design measured (0: the first design, e.g. eq. 8's).
    pub iteration: usize,
    /// RMS and largest |measured mean - target| over the renderable region.
    pub rms_error: f64,
    pub max_error: f64,
    /// RMS of the standard error of the mean over the renderable region.
    pub noise_floor: f64,
    /// The display's lag, mm (> 0: the friction is felt after the drive).
    pub lag_mm: f64,
    /// The plant's local gain P used (1: the model's own).
    pub plant_gain: f64,
    pub strokes: usize,
    pub limited_by: Limit,
}

impl HistoryEntry {
    /// The comment line's text (after `# `).
    pub fn comment(&self) -> String {
        format!(
            "{HISTORY_PREFIX}{}: RMS error {:.4e}, noise floor {:.4e}, max error {:.4e}, lag {:.4} mm, plant gain \
             {:.4}, {} strokes, limited by {}",
            self.iteration,
            self.rms_error,
            self.noise_floor,
            self.max_error,
            self.lag_mm,
            self.plant_gain,
            self.strokes,
            self.limited_by
        )
    }

    /// Parses what follows [`HISTORY_PREFIX`] in [`HistoryEntry::comment`].
    pub fn parse(rest: &str) -> Result<Self, String> {
        let (k, fields) = rest.split_once(": ").ok_or("no ': ' after the iteration number")?;
        let iteration = k.trim().parse().map_err(|_| format!("iteration '{k}' is not a whole number"))?;
        let fields: Vec<&str> = fields.split(", ").collect();
        if fields.len() != 7 {
            return Err(format!("{} fields, 7 expected", fields.len()));
        }
        let number = |i: usize, prefix: &str, suffix: &str| -> Result<f64, String> {
            let text = fields[i]
                .strip_prefix(prefix)
                .and_then(|t| t.strip_suffix(suffix))
                .ok_or_else(|| format!("'{}' does not read '{prefix}...{suffix}'", fields[i]))?;
            text.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("'{text}' is not a finite number"))
        };
        let strokes = fields[5]
            .strip_suffix(" strokes")
            .and_then(|n| n.parse().ok())
            .ok_or_else(|| format!("'{}' does not read 'N strokes'", fields[5]))?;
        let limited_by = fields[6]
            .strip_prefix("limited by ")
            .and_then(Limit::from_name)
            .ok_or_else(|| format!("'{}' does not name a limit", fields[6]))?;
        Ok(Self {
            iteration,
            rms_error: number(0, "RMS error ", "")?,
            noise_floor: number(1, "noise floor ", "")?,
            max_error: number(2, "max error ", "")?,
            lag_mm: number(3, "lag ", " mm")?,
            plant_gain: number(4, "plant gain ", "")?,
            strokes,
            limited_by,
        })
    }
}

/// How an iteration is done.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// The learning gain L, in (0, 1].
    pub gain: f64,
    /// The Q-filter's standard deviation, mm (None: max([`Q_SIGMA_MM`],
    /// the design's median spacing)).
    pub q_sigma_mm: Option<f64>,
    /// Most designs measured: at this many history entries the design is
    /// kept.
    pub max_iterations: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self { gain: 1.0, q_sigma_mm: None, max_iterations: 10 }
    }
}

/// Why the design was kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kept {
    /// At the noise floor: a further iteration would chase noise.
    AtNoiseFloor,
    /// The history has reached the iteration limit.
    IterationLimit,
}

/// The outcome of one iteration.
#[derive(Debug, Clone)]
pub struct Step {
    /// This iteration's measurement of the design.
    pub entry: HistoryEntry,
    pub mean: StrokeMean,
    /// m_k and m_{k+1} (equal when the design is kept).
    pub command: Vec<f64>,
    pub next_command: Vec<f64>,
    /// The next design's drive (the design's own when kept).
    pub next: Drive,
    /// Why the design was kept, if it was.
    pub kept: Option<Kept>,
    /// The renderable band, and the fraction of the target's length outside
    /// it.
    pub band: [f64; 2],
    pub not_renderable_fraction: f64,
    /// Fraction of the renderable length where the update asked for more
    /// than the band (the command held at its edge).
    pub saturated_fraction: f64,
    pub q_sigma_mm: f64,
    /// What the summary should say beside the numbers.
    pub warnings: Vec<String>,
}

/// One iteration: the design, what was measured on it, and the next design.
pub fn iterate(
    design: &Design,
    model: &DisplayModel,
    strokes: &[Stroke],
    settings: &Settings,
) -> Result<Step, IlcError> {
    if !(settings.gain > 0.0 && settings.gain <= 1.0) {
        return Err(IlcError::Invalid(format!("the learning gain must be in (0, 1], got {}", Num(settings.gain))));
    }
    let target = &design.target;
    let (x, r) = (target.x_mm(), target.mu());
    let n = x.len();
    if design.drive.voltage_v.len() != n || design.drive.amplitude_um.as_ref().is_some_and(|a| a.len() != n) {
        return Err(IlcError::Invalid("the design's drive and target differ in length".into()));
    }
    let mean = stroke_mean(x, strokes)?;
    let band = model.band(target)?;
    let inside = |m: f64| m >= band[0] && m <= band[1];
    let renderable: Vec<bool> = r.iter().map(|&m| inside(m)).collect();
    let weight = trapezoid_weights(x);
    let span = (x[n - 1] - x[0]).max(f64::MIN_POSITIVE);
    let length_where = |f: &dyn Fn(usize) -> bool| (0..n).filter(|&i| f(i)).map(|i| weight[i]).sum::<f64>();
    let renderable_length = length_where(&|i| renderable[i]);
    if renderable_length <= 0.0 {
        return Err(IlcError::Invalid(format!(
            "no part of the target is within the display's band {} .. {}: there is nothing to compensate",
            Num(band[0]),
            Num(band[1])
        )));
    }
    let not_renderable_fraction = 1.0 - renderable_length / span;
    let rms_over = |values: &dyn Fn(usize) -> f64| {
        (length_where(&|i| renderable[i]).recip()
            * (0..n).filter(|&i| renderable[i]).map(|i| weight[i] * values(i).powi(2)).sum::<f64>())
        .sqrt()
    };
    let rms_error = rms_over(&|i| mean.mu[i] - r[i]);
    let noise_floor = rms_over(&|i| mean.standard_error[i]);
    let max_error = (0..n).filter(|&i| renderable[i]).map(|i| (mean.mu[i] - r[i]).abs()).fold(0.0, f64::max);

    let command = model.command(target, &design.drive.voltage_v, design.drive.amplitude_um.as_deref())?;
    let lag_mm = estimate_lag(x, &mean.mu, &command, &renderable);
    // The measured mean and the target where the command at x acts.
    let shifted = |values: &[f64]| -> Vec<f64> {
        let mut cursor = WalkingCursor::default();
        x.iter().map(|&xi| cursor.interpolate(x, values, (xi + lag_mm).clamp(x[0], x[n - 1]))).collect()
    };
    let (y, r_at) = (shifted(&mean.mu), shifted(r));
    let acts: Vec<bool> = r_at.iter().map(|&m| inside(m)).collect();
    let plant_gain = estimate_plant_gain(&y, &command, &acts, band);
    let q_sigma_mm = settings.q_sigma_mm.unwrap_or_else(|| Q_SIGMA_MM.max(median_spacing(x)));
    let error: Vec<f64> = (0..n).map(|i| y[i] - r_at[i]).collect();
    let filtered = low_pass(x, &error, &acts, q_sigma_mm);
    let mut next_command = command.clone();
    let mut saturated_length = 0.0;
    for i in (0..n).filter(|&i| acts[i]) {
        let wanted = command[i] - settings.gain * filtered[i] / plant_gain;
        if wanted > band[1] || wanted < band[0] {
            saturated_length += weight[i];
        }
        next_command[i] = wanted.clamp(band[0], band[1]);
    }
    let saturated_fraction = saturated_length / renderable_length;

    let iteration = design.history.len();
    let mut warnings = Vec::new();
    if let Some(previous) = design.history.last()
        && rms_error > 1.1 * previous.rms_error
    {
        warnings.push(format!(
            "the RMS error rose from {:.3e} (iteration {}) to {rms_error:.3e}: check that the strokes were made as \
             before (velocity, force), or lower --gain",
            previous.rms_error, previous.iteration
        ));
    }
    if noise_floor == 0.0 {
        warnings.push(
            "the strokes agree exactly (the same stroke given twice?): the noise floor is 0, so the stop rule \
             cannot tell noise from error"
                .to_string(),
        );
    }
    let at_floor = rms_error <= STOP_FACTOR * noise_floor;
    let kept = if at_floor {
        Some(Kept::AtNoiseFloor)
    } else if iteration + 1 >= settings.max_iterations {
        Some(Kept::IterationLimit)
    } else {
        None
    };
    let limited_by = match () {
        _ if at_floor && not_renderable_fraction > 1e-9 => Limit::NotRenderable,
        _ if at_floor => Limit::NoiseFloor,
        _ if saturated_fraction > 0.01 => Limit::UMax,
        _ => Limit::Iterations,
    };
    let entry = HistoryEntry {
        iteration,
        rms_error,
        max_error,
        noise_floor,
        lag_mm,
        plant_gain,
        strokes: mean.strokes,
        limited_by,
    };
    let (next_command, next) = match kept {
        Some(_) => (command.clone(), design.drive.clone()),
        None => {
            let next = model.drive(target, &next_command)?;
            (next_command, next)
        }
    };
    check_limits(x, &next, model)?;
    Ok(Step {
        entry,
        mean,
        command,
        next_command,
        next,
        kept,
        band,
        not_renderable_fraction,
        saturated_fraction,
        q_sigma_mm,
        warnings,
    })
}

/// The next design as CSV, as `haptex compensate` writes it: the history
/// lines (`# ilc iteration k: ...`, oldest first; `history` ends with this
/// step's entry), then the design as `haptex voltage` writes it (the
/// target, its summary, the next drive). Every sample is checked against
/// U_max and a_max first ([`check_limits`]): nothing above them is written.
pub fn next_design_csv(
    design: &Design,
    step: &Step,
    history: &[HistoryEntry],
    model: &DisplayModel,
) -> Result<Vec<u8>, IlcError> {
    use std::io::Write;
    let x = design.target.x_mm();
    check_limits(x, &step.next, model)?;
    let io = |e: std::io::Error| IlcError::Invalid(format!("cannot write the design: {e}"));
    let mut out: Vec<u8> = Vec::new();
    for entry in history {
        writeln!(out, "# {}", entry.comment()).map_err(io)?;
    }
    let device = model.device();
    match *model {
        DisplayModel::Combined { ultrasonic, strategy, .. } => {
            let mut profile = crate::combined::map_display(
                &design.target,
                device,
                crate::combined::Channels::Combined(ultrasonic, strategy),
                None,
                None,
            )?;
            let Drive { voltage_v, amplitude_um } = step.next.clone();
            let min_max =
                |v: &[f64]| v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
            if let Some(ev) = &mut profile.summary.electrovibration {
                (ev.voltage_min_v, ev.voltage_max_v) = min_max(&voltage_v);
            }
            if let (Some(us), Some(a)) = (&mut profile.summary.ultrasonic, &amplitude_um) {
                (us.amplitude_min_um, us.amplitude_max_um) = min_max(a);
            }
            profile.voltage_v = Some(voltage_v);
            profile.amplitude_um = amplitude_um;
            profile.write_csv(&mut out).map_err(io)?;
        }
        DisplayModel::Electrovibration(_) => {
            let profile = map_profile(&design.target, device, Method::Physical, None)?
                .with_voltages(step.next.voltage_v.clone())?;
            profile.write_csv(&mut out).map_err(io)?;
        }
    }
    Ok(out)
}

/// The history as the report CSV of `haptex compensate --report`:
/// `iteration,rms_error,noise_floor,max_error,lag_mm,strokes,limited_by`.
pub fn report_csv(history: &[HistoryEntry]) -> String {
    let mut out = String::from("iteration,rms_error,noise_floor,max_error,lag_mm,strokes,limited_by\n");
    for e in history {
        out += &format!(
            "{},{},{},{},{},{},{}\n",
            e.iteration, e.rms_error, e.noise_floor, e.max_error, e.lag_mm, e.strokes, e.limited_by
        );
    }
    out
}

/// The length each sample stands for (trapezoid weights).
fn trapezoid_weights(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n).map(|i| 0.5 * (x[(i + 1).min(n - 1)] - x[i.saturating_sub(1)])).collect()
}

fn median_spacing(x: &[f64]) -> f64 {
    let mut d: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The shift d within +-[`MAX_LAG_MM`] (steps of a 40th of it) that
/// maximizes the correlation of y(x + d) with the command m(x) over the
/// renderable points with x + d on the grid; 0 when the command does not
/// vary there. Ties go to the smaller shift. Linear in the points.
pub fn estimate_lag(x: &[f64], y: &[f64], command: &[f64], renderable: &[bool]) -> f64 {
    let n = x.len();
    let (lo, hi) = (x[0], x[n - 1]);
    let mut best = (f64::NEG_INFINITY, 0.0);
    let shifts = std::iter::once(0).chain((1..=40).flat_map(|k| [k, -k]));
    for k in shifts {
        // k / 200 (not k 0.2 / 40): the shift of k steps to rounding.
        let d = f64::from(k) / (40.0 / MAX_LAG_MM);
        let mut cursor = WalkingCursor::default();
        let (mut s, mut sy, mut sm, mut syy, mut smm, mut sym) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for i in (0..n).filter(|&i| renderable[i]) {
            let at = x[i] + d;
            if at < lo || at > hi {
                continue;
            }
            let (a, b) = (cursor.interpolate(x, y, at), command[i]);
            s += 1.0;
            sy += a;
            sm += b;
            syy += a * a;
            smm += b * b;
            sym += a * b;
        }
        if s < 3.0 {
            continue;
        }
        let (vy, vm) = (syy - sy * sy / s, smm - sm * sm / s);
        if !(vm > 1e-18 * s && vy > 0.0) {
            continue;
        }
        let correlation = (sym - sy * sm / s) / (vy * vm).sqrt();
        if correlation > best.0 + 1e-12 {
            best = (correlation, d);
        }
    }
    best.1
}

/// The least-squares slope (with an intercept) of y against the command
/// over the points where `acts` and the command is strictly inside the
/// band; 1 when the data cannot tell (fewer than 3 points, no spread, or a
/// standard error above a quarter of the slope), else held within
/// [`PLANT_GAIN_RANGE`].
pub fn estimate_plant_gain(y: &[f64], command: &[f64], acts: &[bool], band: [f64; 2]) -> f64 {
    let margin = 1e-9 * (band[1] - band[0]).abs().max(1e-12);
    let points: Vec<usize> =
        (0..y.len()).filter(|&i| acts[i] && command[i] > band[0] + margin && command[i] < band[1] - margin).collect();
    let s = points.len() as f64;
    if s < 3.0 {
        return 1.0;
    }
    let (my, mm) = (points.iter().map(|&i| y[i]).sum::<f64>() / s, points.iter().map(|&i| command[i]).sum::<f64>() / s);
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for &i in &points {
        sxx += (command[i] - mm).powi(2);
        sxy += (command[i] - mm) * (y[i] - my);
    }
    if sxx <= 1e-18 * s {
        return 1.0;
    }
    let slope = sxy / sxx;
    let residual = points.iter().map(|&i| (y[i] - my - slope * (command[i] - mm)).powi(2)).sum::<f64>() / (s - 2.0);
    let slope_se = (residual / sxx).sqrt();
    if !(slope > 0.0 && slope_se < 0.25 * slope) {
        return 1.0;
    }
    slope.clamp(PLANT_GAIN_RANGE[0], PLANT_GAIN_RANGE[1])
}

/// The Q-filter: a zero-phase Gaussian low-pass of standard deviation
/// `sigma_mm` (three passes of a centred moving average of width 2 sigma,
/// in x), averaging only the points where `mask` holds (a normalized
/// convolution, weighted by the length each point stands for). Where no
/// masked point is within reach, 0. Linear in the points.
pub fn low_pass(x: &[f64], values: &[f64], mask: &[bool], sigma_mm: f64) -> Vec<f64> {
    let n = x.len();
    let weight = trapezoid_weights(x);
    let mut num: Vec<f64> = (0..n).map(|i| if mask[i] { weight[i] * values[i] } else { 0.0 }).collect();
    let mut den: Vec<f64> = (0..n).map(|i| if mask[i] { weight[i] } else { 0.0 }).collect();
    if sigma_mm > 0.0 && sigma_mm.is_finite() {
        for _ in 0..3 {
            num = moving_average(x, &num, sigma_mm);
            den = moving_average(x, &den, sigma_mm);
        }
    }
    (0..n).map(|i| if den[i] > 0.0 { num[i] / den[i] } else { 0.0 }).collect()
}

/// The sum of `values` over the points within +-h of each point (the
/// common factor of a moving average cancels in the normalized
/// convolution), by prefix sums and two pointers.
fn moving_average(x: &[f64], values: &[f64], h: f64) -> Vec<f64> {
    let n = x.len();
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    for v in values {
        prefix.push(prefix[prefix.len() - 1] + v);
    }
    // A hair beyond h, so that rounding does not make the window of a
    // uniform grid lopsided (a lopsided window shifts the phase).
    let reach = h * (1.0 + 1e-9);
    let (mut lo, mut hi) = (0, 0);
    (0..n)
        .map(|i| {
            while x[lo] < x[i] - reach {
                lo += 1;
            }
            while hi < n && x[hi] <= x[i] + reach {
                hi += 1;
            }
            prefix[hi] - prefix[lo]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::interpolate;
    use crate::recording::rng::SplitMix64;

    fn grid(n: usize, dx: f64) -> Vec<f64> {
        (0..n).map(|i| i as f64 * dx).collect()
    }

    fn stroke(name: &str, x: Vec<f64>, mu: Vec<f64>) -> Stroke {
        Stroke { name: name.into(), profile: FrictionProfile::new(x, mu).unwrap() }
    }

    fn device() -> Device {
        Device { mu_hd: 0.5, ..Device::PAPER }
    }

    #[test]
    fn stroke_mean_bins_dense_strokes_and_gives_the_standard_error_of_the_mean() {
        // Two strokes, constant 0.5 and 0.6, sampled 10x finer than the
        // grid: mean 0.55, standard deviation 0.0707, SE 0.05 (exact).
        let x = grid(11, 0.1);
        let fine = grid(111, 0.01);
        let strokes =
            [stroke("a", fine.clone(), vec![0.5; fine.len()]), stroke("b", fine.clone(), vec![0.6; fine.len()])];
        let mean = stroke_mean(&x, &strokes).unwrap();
        for i in 0..x.len() {
            assert!((mean.mu[i] - 0.55).abs() < 1e-12);
            assert!((mean.standard_error[i] - 0.05).abs() < 1e-12);
        }
    }

    #[test]
    fn one_stroke_has_no_noise_floor() {
        let x = grid(11, 0.1);
        let err = stroke_mean(&x, &[stroke("a", x.clone(), vec![0.5; 11])]).unwrap_err();
        assert!(matches!(err, IlcError::TooFewStrokes { count: 1 }), "{err}");
        assert!(err.to_string().contains("at least 2"), "{err}");
    }

    #[test]
    fn a_stroke_short_of_the_design_span_is_named() {
        let x = grid(11, 0.1);
        let short = grid(6, 0.1);
        let err = stroke_mean(&x, &[stroke("a.csv", x.clone(), vec![0.5; 11]), stroke("b.csv", short, vec![0.5; 6])])
            .unwrap_err();
        assert!(err.to_string().starts_with("b.csv: the stroke covers x = 0 .. 0.5 mm"), "{err}");
    }

    #[test]
    fn low_pass_keeps_a_constant_and_a_line_and_smooths_white_noise() {
        // A normalized convolution with a symmetric kernel reproduces a
        // constant exactly and a line away from the ends; white noise of
        // unit variance comes out with variance about dx / (2 sqrt(pi)
        // sigma) = 0.028 at sigma = 10 dx (here below 0.05).
        let x = grid(2001, 0.01);
        let mask = vec![true; x.len()];
        let constant = low_pass(&x, &vec![0.3; x.len()], &mask, 0.1);
        assert!(constant.iter().all(|v| (v - 0.3).abs() < 1e-12));
        let line: Vec<f64> = x.iter().map(|x| 2.0 * x).collect();
        let smooth = low_pass(&x, &line, &mask, 0.1);
        for i in 100..1900 {
            assert!((smooth[i] - line[i]).abs() < 1e-9, "{i}");
        }
        let mut rng = SplitMix64::new(7);
        let noise: Vec<f64> = x.iter().map(|_| rng.normal()).collect();
        let smooth = low_pass(&x, &noise, &mask, 0.1);
        let variance = smooth[100..1900].iter().map(|v| v * v).sum::<f64>() / 1800.0;
        assert!(variance < 0.05, "{variance}");
    }

    #[test]
    fn lag_estimate_finds_a_shift_of_the_measured_profile() {
        // y(x) = m(x - 0.03): felt 0.03 mm after the command; found to the
        // search step (0.005 mm).
        let x = grid(401, 0.01);
        let bump = |x: f64| 0.5 + 0.05 * (-((x - 2.0) / 0.3f64).powi(2)).exp();
        let command: Vec<f64> = x.iter().map(|&x| bump(x)).collect();
        let y: Vec<f64> = x.iter().map(|&x| bump(x - 0.03)).collect();
        let lag = estimate_lag(&x, &y, &command, &vec![true; x.len()]);
        assert!((lag - 0.03).abs() < 0.0026, "{lag}");
    }

    #[test]
    fn history_line_reads_back() {
        let entry = HistoryEntry {
            iteration: 3,
            rms_error: 0.0123,
            max_error: 0.05,
            noise_floor: 0.004,
            lag_mm: 0.015,
            plant_gain: 0.74,
            strokes: 8,
            limited_by: Limit::UMax,
        };
        let comment = entry.comment();
        let parsed = HistoryEntry::parse(comment.strip_prefix(HISTORY_PREFIX).unwrap()).unwrap();
        assert_eq!(parsed.comment(), comment);
        assert_eq!(parsed.limited_by, Limit::UMax);
        assert!(HistoryEntry::parse("3: RMS error x").is_err());
    }

    /// A virtual display in the command domain: felt = P m(x - lag) + c,
    /// the model's constants off (P = 1.5, c = -0.26), plus noise.
    fn measure(x: &[f64], command: &[f64], seed: u64, strokes: usize) -> Vec<Stroke> {
        let mut rng = SplitMix64::new(seed);
        (0..strokes)
            .map(|s| {
                let mu = x
                    .iter()
                    .map(|&xi| {
                        let m = interpolate(x, command, (xi - 0.02).max(x[0]));
                        1.5 * m - 0.26 + 0.003 * rng.normal()
                    })
                    .collect();
                stroke(&format!("s{s}"), x.to_vec(), mu)
            })
            .collect()
    }

    #[test]
    fn iterations_reach_the_noise_floor_on_a_display_whose_gain_is_off() {
        // A smooth bump within the band of the paper's device at mu_HD =
        // 0.5 (0.5 .. 0.6): with P = 1.5 and an offset, eq. (8)'s design
        // is far off; the estimated gain and lag bring the error within
        // 1.5 noise floors (the stop rule) in at most 4 iterations.
        let x = grid(301, 0.02);
        let mu: Vec<f64> = x.iter().map(|&x| 0.52 + 0.06 * (-((x - 3.0) / 0.8f64).powi(2)).exp()).collect();
        let target = FrictionProfile::new(x.clone(), mu).unwrap();
        let model = DisplayModel::Electrovibration(device());
        let first = model.drive(&target, target.mu()).unwrap();
        let mut design = Design { target: target.clone(), drive: first, history: Vec::new() };
        let settings = Settings::default();
        let mut errors = Vec::new();
        for k in 0..6 {
            let command = model.command(&target, &design.drive.voltage_v, None).unwrap();
            let strokes = measure(&x, &command, 100 + k, 6);
            let step = iterate(&design, &model, &strokes, &settings).unwrap();
            assert!(step.next.voltage_v.iter().all(|&u| (0.0..=100.0).contains(&u)));
            errors.push(step.entry.rms_error / step.entry.noise_floor);
            if step.kept.is_some() {
                break;
            }
            design.history.push(step.entry);
            design.drive = step.next;
        }
        assert!(errors[0] > 5.0, "{errors:?}");
        assert!(errors.len() <= 5 && *errors.last().unwrap() <= STOP_FACTOR, "{errors:?}");
    }
}
