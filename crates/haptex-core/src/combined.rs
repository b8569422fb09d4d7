//! The combined display: electrovibration and ultrasonic friction
//! reduction on one plate, and the allocation of a target friction profile
//! to the two channels (docs/physics.md, "The combined display").
//!
//! The two effects act independently (Vezzoli et al. 2015, IEEE ToH 8(2)):
//! the vibration lowers the friction coefficient, the voltage adds normal
//! force, so the finger feels
//!
//! ```text
//! mu(U, a) = mu_HD rho(a) (1 + Fe(U)/Fn)
//! ```
//!
//! with rho(a) the plate's relative friction ([`crate::ultrasonic`]) and
//! Fe/Fn = ratio U^2 from eq. (3). The renderable band is
//! [mu_HD rho_min, mu_HD (1 + ratio U_max^2)] (its top at a = 0).
//!
//! A target m = mu/mu_HD inside the band is met by every pair with
//! rho(a) in [max(rho_min, m / (1 + ratio U_max^2)), min(1, m)] and
//! U^2 = (m/rho(a) - 1)/ratio. A [`Strategy`] picks rho in that interval;
//! the amplitude is a(rho), and the voltage is computed from rho(a) as the
//! amplitude actually gives it, so the pair renders m to rounding.

use std::fmt;
use std::io::Write;

use serde::Serialize;

use crate::electrovibration::{
    Device, ElectroError, Regions, force_ratio_for, format_ranges, min_max, write_profile_line,
};
use crate::num::Num;
use crate::profile::FrictionProfile;
use crate::ranges::{self, RangeError};
use crate::relative::{FlatMu, Relative, RelativeError};
use crate::ultrasonic::{ModelSource, UltrasonicDevice, UltrasonicModel};

/// How a target is shared between the two channels of a combined display.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Strategy {
    /// Ultrasonic only below mu_HD, electrovibration only above: the least
    /// drive (any cost that grows with both U and a is least here, since
    /// each channel works against the other).
    Split,
    /// A constant ultrasonic level lowering the baseline to the profile's
    /// lowest friction, so that electrovibration renders the whole profile
    /// from there (one smooth voltage signal for the detail); the amplitude
    /// drops below that level only where electrovibration alone would pass
    /// U_max.
    Bias,
    /// Per point, the pair minimizing
    /// J = (U/U_max)^2 + weight ((rho(a) - rho_bias) / (1 - rho_bias))^2:
    /// the voltage's share of its range against how far the vibration has
    /// left the bias level towards rest, both 0 to 1 (weight 1 weighs full
    /// voltage against the vibration fully off). weight = 0 is `Split`; a
    /// large weight approaches `Bias`.
    Weighted { weight: f64 },
}

impl Strategy {
    pub fn kind(self) -> StrategyKind {
        match self {
            Strategy::Split => StrategyKind::Split,
            Strategy::Bias => StrategyKind::Bias,
            Strategy::Weighted { .. } => StrategyKind::Weighted,
        }
    }
}

/// The name of a [`Strategy`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StrategyKind {
    Split,
    Bias,
    Weighted,
}

impl fmt::Display for StrategyKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StrategyKind::Split => "split",
            StrategyKind::Bias => "bias",
            StrategyKind::Weighted => "weighted",
        })
    }
}

/// Which friction display renders the profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Channels<'a> {
    /// Electrovibration alone: eq. (8).
    Electrovibration,
    /// Ultrasonic friction reduction alone.
    Ultrasonic(&'a UltrasonicDevice),
    /// Both, allocated by the strategy.
    Combined(&'a UltrasonicDevice, Strategy),
}

/// The name of a display.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DisplayKind {
    Electrovibration,
    Ultrasonic,
    Combined,
}

impl fmt::Display for DisplayKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DisplayKind::Electrovibration => "electrovibration",
            DisplayKind::Ultrasonic => "ultrasonic",
            DisplayKind::Combined => "combined (electrovibration + ultrasonic)",
        })
    }
}

/// A display mapping cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DisplayError {
    #[error(transparent)]
    Electro(#[from] ElectroError),
    #[error(transparent)]
    Relative(#[from] RelativeError),
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// A designed value is not finite or beyond its channel's limit: never
    /// written (a guard; the allocation keeps within the limits).
    #[error(
        "profile sample {index} (x = {} mm, mu = {}): {quantity} = {} is not within 0 ..= {}; nothing is \
         written",
        Num(*x_mm),
        Num(*mu),
        Num(*value),
        Num(*limit)
    )]
    Limit { index: usize, x_mm: f64, mu: f64, quantity: &'static str, value: f64, limit: f64 },
}

/// The allocation rule, with its constants folded.
#[derive(Debug, Clone, Copy)]
enum Rule {
    Split,
    Bias {
        rho_bias: f64,
    },
    /// `k` = 2 weight / (1 - rho_bias)^2, the curvature of the ultrasonic
    /// term (0 when rho_bias = 1: no bias level, the split pair).
    Weighted {
        rho_bias: f64,
        k: f64,
    },
}

/// The per-point allocation of a target friction to (U, a): the inverse
/// of [`Allocator::felt_mu`] inside the band, saturating outside it.
#[derive(Debug, Clone, Copy)]
pub struct Allocator<'a> {
    mu_hd: f64,
    inv_mu_hd: f64,
    /// Fe/Fn per V^2 (0 without electrovibration).
    ratio: f64,
    inv_ratio: f64,
    u_max_v: f64,
    /// ratio U_max^2: the largest relative friction increase.
    s_max: f64,
    inv_one_plus_s_max: f64,
    ultrasonic: Option<&'a UltrasonicDevice>,
    rho_min: f64,
    rule: Rule,
}

impl<'a> Allocator<'a> {
    /// An allocator for a display of friction `mu_hd` with electrovibration
    /// `(Fe/Fn per V^2, U_max in V)` if any, ultrasonic device if any, and
    /// strategy (used only with both channels). `rho_bias` is the bias
    /// level of `Bias` and `Weighted`, in [rho_min, 1] (see [`bias_level`]).
    pub fn new(
        mu_hd: f64,
        electrovibration: Option<(f64, f64)>,
        ultrasonic: Option<&'a UltrasonicDevice>,
        strategy: Strategy,
        rho_bias: f64,
    ) -> Self {
        let (ratio, u_max_v) = electrovibration.unwrap_or((0.0, 0.0));
        let s_max = ratio * u_max_v * u_max_v;
        let rho_min = ultrasonic.map_or(1.0, UltrasonicDevice::rho_min);
        let rule = match (electrovibration.is_some() && ultrasonic.is_some(), strategy) {
            (false, _) | (true, Strategy::Split) => Rule::Split,
            (true, Strategy::Bias) => Rule::Bias { rho_bias },
            (true, Strategy::Weighted { weight }) => {
                let span = 1.0 - rho_bias;
                Rule::Weighted { rho_bias, k: if span > 0.0 { 2.0 * weight / (span * span) } else { 0.0 } }
            }
        };
        Self {
            mu_hd,
            inv_mu_hd: 1.0 / mu_hd,
            ratio,
            inv_ratio: if ratio > 0.0 { 1.0 / ratio } else { 0.0 },
            u_max_v,
            s_max,
            inv_one_plus_s_max: 1.0 / (1.0 + s_max),
            ultrasonic,
            rho_min,
            rule,
        }
    }

    /// The renderable band [mu_HD rho_min, mu_HD (1 + ratio U_max^2)].
    pub fn band(&self) -> [f64; 2] {
        [self.mu_hd * self.rho_min, self.mu_hd * (1.0 + self.s_max)]
    }

    /// The model: the friction felt with voltage `u_v` (V RMS) and
    /// amplitude `a_um` (um, peak), mu_HD rho(a) (1 + Fe/Fn).
    pub fn felt_mu(&self, u_v: f64, a_um: f64) -> f64 {
        let rho = self.ultrasonic.map_or(1.0, |d| d.relative_friction(a_um));
        self.mu_hd * rho * (1.0 + self.ratio * u_v * u_v)
    }

    /// The relative friction rho the strategy gives the target `mu`
    /// (before the amplitude is found): within [rho_lo, rho_hi] inside the
    /// band; rho_min below it; 1 above it.
    #[inline]
    fn rho_for(&self, m: f64) -> f64 {
        let rho_hi = m.min(1.0);
        let rho_lo = self.rho_min.max(m * self.inv_one_plus_s_max);
        if rho_lo > rho_hi {
            // Outside the band: below it the plate does all it can, above it
            // the plate is at rest (and U is clipped at U_max).
            return if m < self.rho_min { self.rho_min } else { 1.0 };
        }
        match self.rule {
            Rule::Split => rho_hi,
            Rule::Bias { rho_bias } => rho_bias.clamp(rho_lo, rho_hi),
            Rule::Weighted { rho_bias, k } => self.weighted_rho(m, rho_lo, rho_hi, rho_bias, k),
        }
    }

    /// The minimizer over [lo, hi] of
    /// J(rho) = (m/rho - 1)/s_max + (k/2) (rho - rho_bias)^2, strictly
    /// convex (J'' = 2m/(rho^3 s_max) + k > 0): safeguarded Newton on J'.
    fn weighted_rho(&self, m: f64, lo: f64, hi: f64, rho_bias: f64, k: f64) -> f64 {
        let s_max = self.s_max;
        let slope = |r: f64| -m / (r * r * s_max) + k * (r - rho_bias);
        if k == 0.0 || slope(hi) <= 0.0 {
            return hi;
        }
        if slope(lo) >= 0.0 {
            return lo;
        }
        let (mut lo, mut hi) = (lo, hi);
        let mut r = rho_bias.clamp(lo, hi);
        for _ in 0..200 {
            let f = slope(r);
            if f == 0.0 {
                return r;
            }
            if f < 0.0 {
                lo = r;
            } else {
                hi = r;
            }
            let curvature = 2.0 * m / (r * r * r * s_max) + k;
            let mut next = r - f / curvature;
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - r).abs() <= 4.0 * f64::EPSILON * r || hi - lo <= 4.0 * f64::EPSILON * hi {
                return next;
            }
            r = next;
        }
        r
    }

    /// The pair (U in V RMS, a in um peak) for the target friction `mu`:
    /// inside the band mu_HD rho(a) (1 + ratio U^2) = mu to rounding;
    /// outside it, saturated (U = U_max and a = 0 above, a = a_max and
    /// U = 0 below). U never exceeds U_max, a never a_max.
    #[inline]
    pub fn allocate(&self, mu: f64) -> (f64, f64) {
        let m = mu * self.inv_mu_hd;
        let rho = self.rho_for(m);
        let (a_um, rho_a) = match self.ultrasonic {
            Some(device) => {
                let a = device.amplitude_um(rho);
                (a, device.relative_friction(a))
            }
            None => (0.0, 1.0),
        };
        if rho >= m {
            // The plate renders the target by itself (or the target is below
            // the band): no voltage. rho(a) differs from rho by the
            // inverse's rounding, which U = sqrt(excess/ratio) would amplify
            // into microvolts.
            return (0.0, a_um);
        }
        // Eq. (8) over the reduced baseline mu_HD rho(a); with rho(a) = 1
        // it is PhysicalMapping::voltage_v to the bit.
        let u_v = ((m / rho_a - 1.0).max(0.0) * self.inv_ratio).sqrt().min(self.u_max_v);
        (u_v, a_um)
    }
}

/// A drive channel of the combined display.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// The electrovibration voltage, V RMS.
    Voltage,
    /// The ultrasonic amplitude, um peak.
    Amplitude,
}

/// A designed value outside its channel's stated limit (never expected:
/// the guard that no such value leaves a design).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LimitViolation {
    /// The target's index.
    pub index: usize,
    pub channel: Channel,
    pub value: f64,
    pub limit: f64,
}

impl Allocator<'_> {
    /// Both channels for every target in `mu`, each value checked to be
    /// finite and within 0 ..= its channel's stated limit (`u_max_v`,
    /// `a_max_um`; 0 for a channel not in use): the first value outside is
    /// the error.
    pub fn allocate_all(
        &self,
        mu: &[f64],
        u_max_v: f64,
        a_max_um: f64,
    ) -> Result<(Vec<f64>, Vec<f64>), LimitViolation> {
        let (voltage_v, amplitude_um): (Vec<f64>, Vec<f64>) = mu.iter().map(|&m| self.allocate(m)).unzip();
        for (channel, values, limit) in
            [(Channel::Voltage, &voltage_v, u_max_v), (Channel::Amplitude, &amplitude_um, a_max_um)]
        {
            if let Some(index) = values.iter().position(|v| !(0.0..=limit).contains(v)) {
                return Err(LimitViolation { index, channel, value: values[index], limit });
            }
        }
        Ok((voltage_v, amplitude_um))
    }
}

/// The bias level rho_bias of a profile whose lowest friction is `mu_min`:
/// the baseline lowered to it, mu_min/mu_HD, within [rho_min, 1] (1 when
/// the whole profile is above mu_HD: no vibration needed).
pub fn bias_level(mu_min: f64, mu_hd: f64, rho_min: f64) -> f64 {
    (mu_min / mu_hd).clamp(rho_min, 1.0)
}

/// The electrovibration channel of a summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ElectrovibrationSummary {
    /// U_max in V RMS: no voltage written exceeds it.
    pub u_max_v: f64,
    /// Fe/Fn per V^2 from eq. (3).
    pub fe_over_fn_per_v2: f64,
    /// The normal force used, in N (`None` with the linear contact-area law).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fn_n: Option<f64>,
    pub voltage_min_v: f64,
    pub voltage_max_v: f64,
}

/// The ultrasonic channel of a summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UltrasonicSummary {
    #[serde(flatten)]
    pub model: UltrasonicModel,
    pub amplitude_min_um: f64,
    pub amplitude_max_um: f64,
}

/// The bias level of the `bias` and `weighted` strategies.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BiasSummary {
    /// The bias amplitude in um (peak).
    pub amplitude_um: f64,
    /// rho at the bias amplitude.
    pub relative_friction: f64,
    /// Where electrovibration alone cannot reach the target from the bias
    /// baseline (mu > mu_HD rho_bias (1 + ratio U_max^2)): `bias` lowers
    /// the amplitude below its level there.
    pub lowered: Regions,
}

/// What a display mapping did, and where the display could not follow.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DisplaySummary {
    pub display: DisplayKind,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strategy: Option<StrategyKind>,
    /// The `weighted` strategy's weight.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weight: Option<f64>,
    pub n_points: usize,
    pub x_min_mm: f64,
    pub x_max_mm: f64,
    pub mu_min: f64,
    pub mu_max: f64,
    /// The display's friction with neither channel on.
    pub mu_hd: f64,
    /// The renderable band of felt friction, [mu_HD rho_min, mu_HD (1 +
    /// ratio U_max^2)].
    pub band_mu: [f64; 2],
    #[serde(skip_serializing_if = "Option::is_none")]
    pub electrovibration: Option<ElectrovibrationSummary>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ultrasonic: Option<UltrasonicSummary>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias: Option<BiasSummary>,
    /// Where mu is above the band: U = U_max (if electrovibration), a = 0.
    pub above_band: Regions,
    /// Where mu is below the band: a = a_max (if ultrasonic), U = 0 V.
    pub below_band: Regions,
    /// When the profile was made relative to its flat-surface friction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relative: Option<Relative>,
    pub warnings: Vec<String>,
}

impl fmt::Display for DisplaySummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "display: {}", self.display)?;
        if let Some(strategy) = self.strategy {
            write!(f, ", strategy {strategy}")?;
            if let Some(weight) = self.weight {
                write!(f, " (weight {})", Num(weight))?;
            }
        }
        writeln!(f)?;
        if let Some(relative) = &self.relative {
            writeln!(f, "{}", relative.describe())?;
        }
        write_profile_line(f, self.n_points, [self.x_min_mm, self.x_max_mm], [self.mu_min, self.mu_max])?;
        if let Some(ev) = &self.electrovibration {
            write!(
                f,
                "electrovibration: mu_HD = {}, Fe/Fn = {:.5e} U^2 (U in V)",
                Num(self.mu_hd),
                ev.fe_over_fn_per_v2
            )?;
            if let Some(fn_n) = ev.fn_n {
                write!(f, " at Fn = {} N", Num(fn_n))?;
            }
            writeln!(f, ", U_max = {} V", Num(ev.u_max_v))?;
        }
        if let Some(us) = &self.ultrasonic {
            writeln!(f, "ultrasonic: {}", us.model.description)?;
        }
        let ends = match self.display {
            DisplayKind::Electrovibration => "mu_HD .. mu_HD (1 + Fe(U_max)/Fn)",
            DisplayKind::Ultrasonic => "mu_HD rho_min .. mu_HD",
            DisplayKind::Combined => "mu_HD rho_min .. mu_HD (1 + Fe(U_max)/Fn)",
        };
        writeln!(f, "renderable band: mu {:.4} .. {:.4} ({ends})", self.band_mu[0], self.band_mu[1])?;
        if let Some(ev) = &self.electrovibration {
            writeln!(
                f,
                "voltage (RMS): {:.3} .. {:.3} V, U_max = {} V",
                ev.voltage_min_v,
                ev.voltage_max_v,
                Num(ev.u_max_v)
            )?;
        }
        if let Some(us) = &self.ultrasonic {
            writeln!(
                f,
                "amplitude (peak): {:.4} .. {:.4} um, a_max = {} um",
                us.amplitude_min_um,
                us.amplitude_max_um,
                Num(us.model.a_max_um)
            )?;
        }
        if let Some(bias) = &self.bias {
            writeln!(
                f,
                "bias: a = {:.4} um (rho = {:.4}); amplitude lowered below it: {:.2}% of the length{}",
                bias.amplitude_um,
                bias.relative_friction,
                100.0 * bias.lowered.fraction_of_length,
                format_ranges(&bias.lowered)
            )?;
        }
        let (above, below) = self.clip_labels();
        for (label, regions) in [(above, &self.above_band), (below, &self.below_band)] {
            writeln!(f, "{label}: {:.2}% of the length{}", 100.0 * regions.fraction_of_length, format_ranges(regions))?;
        }
        for warning in &self.warnings {
            writeln!(f, "warning: {warning}")?;
        }
        Ok(())
    }
}

impl DisplaySummary {
    /// What the display does above and below its band.
    fn clip_labels(&self) -> (&'static str, &'static str) {
        match self.display {
            DisplayKind::Electrovibration => {
                ("above the band, clipped at U_max", "below the band (mu < mu_HD), U = 0 V")
            }
            DisplayKind::Ultrasonic => ("above the band (mu > mu_HD), a = 0", "below the band, clipped at a_max"),
            DisplayKind::Combined => {
                ("above the band, U clipped at U_max (a = 0)", "below the band, a clipped at a_max (U = 0 V)")
            }
        }
    }
}

/// A display profile: per position the target friction and the drive of
/// each channel in use, with the summary of the mapping that made it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DisplayProfile {
    pub summary: DisplaySummary,
    pub x_mm: Vec<f64>,
    pub mu: Vec<f64>,
    /// Electrovibration voltage in V RMS at each position (`None` without
    /// electrovibration).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub voltage_v: Option<Vec<f64>>,
    /// Ultrasonic vibration amplitude in um (peak) at each position (`None`
    /// without ultrasonic friction reduction).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub amplitude_um: Option<Vec<f64>>,
}

impl DisplayProfile {
    /// Writes `x_mm,mu[,voltage_v][,amplitude_um]` CSV (a column per
    /// channel in use), after comment lines stating the display, each
    /// column's unit and limit, the ultrasonic model and, for a relative
    /// profile, how it was made.
    pub fn write_csv(&self, w: &mut dyn Write) -> std::io::Result<()> {
        let s = &self.summary;
        write!(w, "# haptex display profile: {} display", s.display)?;
        if let Some(strategy) = s.strategy {
            write!(w, ", strategy {strategy}")?;
            if let Some(weight) = s.weight {
                write!(w, " (weight {})", Num(weight))?;
            }
        }
        let model = match s.display {
            DisplayKind::Electrovibration => "mu_HD (1 + Fe(U)/Fn)",
            DisplayKind::Ultrasonic => "mu_HD rho(a)",
            DisplayKind::Combined => "mu_HD rho(a) (1 + Fe(U)/Fn)",
        };
        writeln!(w, "; felt friction {model} with mu_HD = {} (docs/physics.md)", Num(s.mu_hd))?;
        let mut header = String::from("x_mm,mu");
        let mut units = Vec::new();
        if let Some(ev) = &s.electrovibration {
            header.push_str(",voltage_v");
            units.push(format!(
                "voltage_v is the electrovibration voltage, RMS (a sine carrier needs peak sqrt(2)*voltage_v), at \
                 most U_max = {} V",
                crate::num::Exact(ev.u_max_v)
            ));
        }
        if let Some(us) = &s.ultrasonic {
            header.push_str(",amplitude_um");
            units.push(format!(
                "amplitude_um is the ultrasonic vibration amplitude, peak, in um, at most a_max = {} um",
                // Read back by `haptex play` as channel 2's limit: in full.
                crate::num::Exact(us.model.a_max_um)
            ));
            writeln!(w, "# ultrasonic model: {}", us.model.description)?;
        }
        writeln!(w, "# {}", units.join("; "))?;
        if let Some(relative) = &s.relative {
            writeln!(w, "# {}; the mu column is the relative friction", relative.describe())?;
        }
        writeln!(w, "{header}")?;
        let mut row = Vec::with_capacity(4);
        for i in 0..self.x_mm.len() {
            row.clear();
            row.extend([self.x_mm[i], self.mu[i]]);
            row.extend(self.voltage_v.as_ref().map(|u| u[i]));
            row.extend(self.amplitude_um.as_ref().map(|a| a[i]));
            crate::io::write_csv_row(w, &row)?;
        }
        Ok(())
    }
}

/// Maps a friction profile to the drive of a friction display: eq. (8)
/// for electrovibration, the inverse of rho(a) for ultrasonic friction
/// reduction, both allocated by a strategy for the combined display.
///
/// `fn_n` is the exploration normal force (needed only with a non-linear
/// contact-area law, as for [`crate::electrovibration::map_profile`]).
/// With `relative` the profile is first made relative to its flat-surface
/// friction ([`crate::relative`]).
pub fn map_display(
    profile: &FrictionProfile,
    device: &Device,
    channels: Channels<'_>,
    fn_n: Option<f64>,
    relative: Option<FlatMu>,
) -> Result<DisplayProfile, DisplayError> {
    device.validate()?;
    let relative = relative.map(|flat| Relative::new(profile, flat, device.mu_hd)).transpose()?;
    let scaled = relative.map(|r| r.apply(profile)).transpose()?;
    let profile = scaled.as_ref().unwrap_or(profile);
    let (kind, ultrasonic, strategy) = match channels {
        Channels::Electrovibration => (DisplayKind::Electrovibration, None, None),
        Channels::Ultrasonic(d) => (DisplayKind::Ultrasonic, Some(d), None),
        Channels::Combined(d, s) => (DisplayKind::Combined, Some(d), Some(s)),
    };
    let weight = match strategy {
        Some(Strategy::Weighted { weight }) => Some(ranges::STRATEGY_WEIGHT.check(weight)?),
        _ => None,
    };
    let electro = match kind {
        DisplayKind::Ultrasonic => None,
        _ => Some(force_ratio_for(profile, device, fn_n)?),
    };

    let (x, mu) = (profile.x_mm(), profile.mu());
    let (mu_min, mu_max) = min_max(mu);
    let rho_min = ultrasonic.map_or(1.0, UltrasonicDevice::rho_min);
    let rho_bias = bias_level(mu_min, device.mu_hd, rho_min);
    let allocator = Allocator::new(
        device.mu_hd,
        electro.map(|(_, ratio)| (ratio, device.u_max_v)),
        ultrasonic,
        strategy.unwrap_or(Strategy::Split),
        rho_bias,
    );
    let n = mu.len();
    let a_max = ultrasonic.map_or(0.0, UltrasonicDevice::a_max_um);
    let u_max = if electro.is_some() { device.u_max_v } else { 0.0 };
    let (voltage_v, amplitude_um) = allocator.allocate_all(mu, u_max, a_max).map_err(|v| DisplayError::Limit {
        index: v.index,
        x_mm: x[v.index],
        mu: mu[v.index],
        quantity: match v.channel {
            Channel::Voltage => "U (V)",
            Channel::Amplitude => "a (um)",
        },
        value: v.value,
        limit: v.limit,
    })?;

    let band_mu = allocator.band();
    let electrovibration = electro.map(|(fn_used, ratio)| {
        let (voltage_min_v, voltage_max_v) = min_max(&voltage_v);
        ElectrovibrationSummary {
            u_max_v: device.u_max_v,
            fe_over_fn_per_v2: ratio,
            fn_n: fn_used,
            voltage_min_v,
            voltage_max_v,
        }
    });
    let ultrasonic_summary = ultrasonic.map(|d| {
        let (amplitude_min_um, amplitude_max_um) = min_max(&amplitude_um);
        UltrasonicSummary { model: d.model(), amplitude_min_um, amplitude_max_um }
    });
    let bias = match (strategy, ultrasonic) {
        (Some(Strategy::Bias | Strategy::Weighted { .. }), Some(d)) => Some(BiasSummary {
            amplitude_um: d.amplitude_um(rho_bias),
            relative_friction: rho_bias,
            lowered: Regions::above(x, mu, device.mu_hd * rho_bias * (1.0 + allocator.s_max)),
        }),
        _ => None,
    };
    let mut summary = DisplaySummary {
        display: kind,
        strategy: strategy.map(Strategy::kind),
        weight,
        n_points: n,
        x_min_mm: x[0],
        x_max_mm: x[n - 1],
        mu_min,
        mu_max,
        mu_hd: device.mu_hd,
        band_mu,
        electrovibration,
        ultrasonic: ultrasonic_summary,
        bias,
        above_band: Regions::above(x, mu, band_mu[1]),
        below_band: Regions::below(x, mu, band_mu[0]),
        relative,
        warnings: Vec::new(),
    };
    summary.warnings = warnings(&summary);
    Ok(DisplayProfile {
        summary,
        x_mm: x.to_vec(),
        mu: mu.to_vec(),
        voltage_v: electro.is_some().then_some(voltage_v),
        amplitude_um: ultrasonic.is_some().then_some(amplitude_um),
    })
}

fn warnings(s: &DisplaySummary) -> Vec<String> {
    let mut warnings = Vec::new();
    let percent = |r: &Regions| 100.0 * r.fraction_of_length;
    if !s.above_band.is_empty() {
        warnings.push(match &s.electrovibration {
            Some(ev) => format!(
                "mu above the renderable band (> {:.4}) over {:.2}% of the length: U clipped at U_max = {} V{}",
                s.band_mu[1],
                percent(&s.above_band),
                Num(ev.u_max_v),
                if s.ultrasonic.is_some() { " with no vibration (a = 0)" } else { "" }
            ),
            None => format!(
                "mu > mu_HD over {:.2}% of the length: ultrasonic vibration can only lower friction, a = 0 there",
                percent(&s.above_band)
            ),
        });
    }
    if !s.below_band.is_empty() {
        warnings.push(match &s.ultrasonic {
            Some(us) => format!(
                "mu below the renderable band (< {:.4}) over {:.2}% of the length: a clipped at a_max = {} um{}",
                s.band_mu[0],
                percent(&s.below_band),
                Num(us.model.a_max_um),
                if s.electrovibration.is_some() { " with no voltage (U = 0 V)" } else { "" }
            ),
            None => format!(
                "mu_RS < mu_HD over {:.2}% of the length: not renderable by electrovibration, U = 0 V there; \
                 --display combined renders it by ultrasonic friction reduction",
                percent(&s.below_band)
            ),
        });
    }
    if let Some(bias) = &s.bias
        && !bias.lowered.is_empty()
    {
        warnings.push(format!(
            "the profile spans more than electrovibration covers over the bias baseline: the amplitude is lowered \
             below the bias level over {:.2}% of the length",
            percent(&bias.lowered)
        ));
    }
    if let Some(us) = &s.ultrasonic
        && us.model.source == ModelSource::LiteratureDefault
    {
        warnings.push(
            "the ultrasonic model is the literature default, not a calibration of this device: replace it by a \
             calibration (--ultrasonic-calibration, docs/file-formats.md)"
                .to_string(),
        );
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::electrovibration::PhysicalMapping;
    use crate::ultrasonic::Calibration;

    fn calibrated() -> UltrasonicDevice {
        let c = Calibration::new(vec![0.0, 1.0, 2.0], vec![1.0, 0.6, 0.3], "test").unwrap();
        UltrasonicDevice::calibrated(c, None).unwrap()
    }

    /// Electrovibration alone through the allocator is eq. (8) to the bit.
    #[test]
    fn electrovibration_alone_is_eq8() {
        let d = Device::PAPER;
        let ratio = d.force_ratio_per_v2(1.0);
        let eq8 = PhysicalMapping::new(d.mu_hd, ratio, d.u_max_v);
        let alloc = Allocator::new(d.mu_hd, Some((ratio, d.u_max_v)), None, Strategy::Split, 1.0);
        for mu in [-1.0, 0.0, 0.5, 0.999, 1.0, 1.05, 1.1991, 1.2, 3.0] {
            assert_eq!(alloc.allocate(mu), (eq8.voltage_v(mu), 0.0), "{mu}");
        }
    }

    /// Split: the plate only below mu_HD, the voltage only above; the band
    /// [mu_HD rho_min, mu_clip] and saturation at its ends.
    #[test]
    fn split_uses_one_channel_at_a_time() {
        let us = calibrated();
        let d = Device::PAPER;
        let ratio = d.force_ratio_per_v2(1.0);
        let alloc = Allocator::new(1.0, Some((ratio, 100.0)), Some(&us), Strategy::Split, 1.0);
        assert_eq!(alloc.band()[0], 0.3);
        let (u, a) = alloc.allocate(0.8);
        assert!(u == 0.0 && (a - 0.5).abs() < 1e-15, "{u} {a}");
        assert_eq!(alloc.allocate(1.0), (0.0, 0.0));
        let (u, a) = alloc.allocate(1.1);
        assert_eq!(a, 0.0);
        assert!((alloc.felt_mu(u, a) - 1.1).abs() < 1e-12);
        assert_eq!(alloc.allocate(0.1), (0.0, 2.0));
        assert_eq!(alloc.allocate(5.0), (100.0, 0.0));
    }

    /// Bias: one amplitude everywhere the voltage can reach the target
    /// from it; lowered where it cannot.
    #[test]
    fn bias_holds_the_amplitude_until_the_voltage_saturates() {
        let us = calibrated();
        let ratio = Device::PAPER.force_ratio_per_v2(1.0);
        let s_max = ratio * 1e4;
        let alloc = Allocator::new(1.0, Some((ratio, 100.0)), Some(&us), Strategy::Bias, 0.6);
        // From rho = 0.6 the paper's electrovibration (s_max = 0.199) reaches
        // 0.6 * 1.199 = 0.7195.
        for mu in [0.6, 0.65, 0.7, 0.6 * (1.0 + s_max)] {
            let (u, a) = alloc.allocate(mu);
            assert!((a - 1.0).abs() < 1e-12, "{mu}: a = {a}");
            assert!((alloc.felt_mu(u, a) - mu).abs() < 1e-12, "{mu}");
        }
        for mu in [0.9, 1.0, 1.1] {
            let (u, a) = alloc.allocate(mu);
            assert!(a < 1.0 && (u - 100.0).abs() < 1e-9, "{u} {a}");
            assert!((alloc.felt_mu(u, a) - mu).abs() < 1e-12);
        }
    }

    /// Weighted: weight 0 is split, a very large weight approaches bias,
    /// and in between the level lies between them.
    #[test]
    fn weighted_spans_split_to_bias() {
        let us = calibrated();
        let ratio = Device::PAPER.force_ratio_per_v2(1.0);
        let split = Allocator::new(1.0, Some((ratio, 100.0)), Some(&us), Strategy::Split, 0.6);
        let bias = Allocator::new(1.0, Some((ratio, 100.0)), Some(&us), Strategy::Bias, 0.6);
        let w0 = Allocator::new(1.0, Some((ratio, 100.0)), Some(&us), Strategy::Weighted { weight: 0.0 }, 0.6);
        let w_big = Allocator::new(1.0, Some((ratio, 100.0)), Some(&us), Strategy::Weighted { weight: 1e6 }, 0.6);
        let w1 = Allocator::new(1.0, Some((ratio, 100.0)), Some(&us), Strategy::Weighted { weight: 1.0 }, 0.6);
        for mu in [0.65, 0.8, 0.95, 1.05, 1.15] {
            assert_eq!(w0.allocate(mu), split.allocate(mu));
            let (ab, a1, a_big) = (bias.allocate(mu).1, w1.allocate(mu).1, w_big.allocate(mu).1);
            assert!((a_big - ab).abs() < 1e-3, "{mu}: {a_big} vs {ab}");
            let a_split = split.allocate(mu).1;
            assert!(a1 >= a_split - 1e-12 && a1 <= ab + 1e-12, "{mu}: {a_split} <= {a1} <= {ab}");
            let (u, a) = w1.allocate(mu);
            assert!((w1.felt_mu(u, a) - mu).abs() < 1e-12, "{mu}");
        }
    }
}
