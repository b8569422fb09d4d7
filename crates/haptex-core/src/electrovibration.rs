//! Electrovibration: from a reference friction profile mu_RS(x) to the
//! voltage U(x) an electrovibration display must apply (paper sections
//! 2.2-2.3, eqs. 3-9).
//!
//! Units: lengths in mm and areas in mm^2 at the interface (struct fields say
//! so), converted to SI inside each function; forces in N; voltages in V.
//! Every voltage is the effective (RMS) value that produces the mean
//! electrostatic force: a sine carrier of peak amplitude sqrt(2) U gives the
//! same mean force (docs/physics.md).

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::num::{Fixed, Num};
use crate::profile::FrictionProfile;
use crate::ranges::{self, RangeError};
use crate::relative::{FlatMu, Relative, RelativeError};

/// Vacuum permittivity eps0 in F/m (CODATA 2018).
pub const EPS0_F_PER_M: f64 = 8.8541878128e-12;

const MM: f64 = 1e-3;
const MM2: f64 = 1e-6;

/// Invalid device or finger parameters, or a mapping that cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ElectroError {
    /// A parameter outside its accepted range ([`crate::ranges`]).
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// The device constants are each valid but together out of range.
    #[error("the device constants give {quantity} = {}, which is not a usable device: {hint}", Num(*value))]
    Degenerate { quantity: &'static str, value: f64, hint: &'static str },
    /// A voltage came out non-finite: the profile's values are beyond what
    /// the mapping can represent (never the device's fault: it was checked).
    #[error(
        "profile sample {index} (x = {} mm, mu = {}): the voltage is not finite; the profile's friction values \
         are out of range for the mapping",
        Num(*x_mm),
        Num(*mu)
    )]
    NonFiniteVoltage { index: usize, x_mm: f64, mu: f64 },
    /// Voltages put in place of a profile's do not fit it.
    #[error("replacement voltages: {0}")]
    Replacement(String),
    #[error(
        "the contact-area law A = k Fn^n with n = {exponent} makes the voltage depend on the \
         normal force: give Fn (--fn-n), or a profile with an fn_n column"
    )]
    NormalForceRequired { exponent: f64 },
    /// The relative profile (paper Fig. 2a) cannot be made: mu_flat is
    /// invalid, or makes the profile leave the range of mu.
    #[error(transparent)]
    Relative(#[from] RelativeError),
}

/// The two dielectric layers between finger and electrode (paper eq. 3):
/// the stratum corneum and the display's insulator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LayerStack {
    /// Stratum corneum thickness d_sc in mm.
    pub d_sc_mm: f64,
    /// Stratum corneum relative permittivity eps_sc.
    pub eps_sc: f64,
    /// Insulator thickness d_i in mm.
    pub d_i_mm: f64,
    /// Insulator relative permittivity eps_i.
    pub eps_i: f64,
}

impl LayerStack {
    /// The constants of the paper's Fig. 2: eps_sc = 1650, eps_i = 10,
    /// d_sc = 0.2 mm, d_i = 0.001 mm.
    pub const PAPER: Self = Self { d_sc_mm: 0.2, eps_sc: 1650.0, d_i_mm: 0.001, eps_i: 10.0 };

    /// The geometric factor of eq. (3), (d_sc/eps_sc + d_i/eps_i)(d_sc + d_i), in m^2.
    pub fn gap_factor_m2(&self) -> f64 {
        let (d_sc, d_i) = (self.d_sc_mm * MM, self.d_i_mm * MM);
        (d_sc / self.eps_sc + d_i / self.eps_i) * (d_sc + d_i)
    }

    pub fn validate(&self) -> Result<(), ElectroError> {
        ranges::D_SC_MM.check(self.d_sc_mm)?;
        ranges::EPS_SC.check(self.eps_sc)?;
        ranges::D_I_MM.check(self.d_i_mm)?;
        ranges::EPS_I.check(self.eps_i)?;
        Ok(())
    }
}

impl Default for LayerStack {
    fn default() -> Self {
        Self::PAPER
    }
}

/// The finger's apparent contact area as a function of normal force,
/// A = k Fn^n. The paper (eq. 8, footnote 5) uses n = 1, valid below about
/// 0.5 N; a power law with n < 1 (Adams et al. 2013) suits higher loads.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactArea {
    /// Coefficient k in mm^2 / N^n (mm^2/N for the linear law).
    pub k_mm2_per_n: f64,
    /// Exponent n (1 = the paper's linear law).
    pub exponent: f64,
}

impl ContactArea {
    /// The paper's linear law A = k Fn with k = 200 mm^2/N (Fig. 2).
    pub const PAPER: Self = Self { k_mm2_per_n: 200.0, exponent: 1.0 };

    /// Contact area in mm^2 at normal force `fn_n` (N).
    pub fn area_mm2(&self, fn_n: f64) -> f64 {
        self.k_mm2_per_n * fn_n.powf(self.exponent)
    }

    /// True when the area is proportional to Fn, so Fe/Fn is independent of Fn.
    pub fn is_linear(&self) -> bool {
        self.exponent == 1.0
    }

    fn validate(&self) -> Result<(), ElectroError> {
        ranges::K_MM2_PER_N.check(self.k_mm2_per_n)?;
        ranges::AREA_EXPONENT.check(self.exponent)?;
        Ok(())
    }
}

impl Default for ContactArea {
    fn default() -> Self {
        Self::PAPER
    }
}

/// Eq. (3), Kaczmarek et al. 2006: electrostatic force in N between finger
/// and display for contact area `area_mm2` (mm^2) and voltage `u_v` (V RMS):
/// Fe = eps0 A U^2 / (2 (d_sc/eps_sc + d_i/eps_i)(d_sc + d_i)).
pub fn electrostatic_force_n(stack: &LayerStack, area_mm2: f64, u_v: f64) -> f64 {
    EPS0_F_PER_M * area_mm2 * MM2 * u_v * u_v / (2.0 * stack.gap_factor_m2())
}

/// Eq. (6): the electrostatic force in N that makes the display's friction
/// mu_HD (Fn + Fe) equal the reference friction mu_RS Fn:
/// Fe = (mu_RS/mu_HD - 1) Fn. Negative where mu_RS < mu_HD.
pub fn required_force_n(mu_rs: f64, mu_hd: f64, fn_n: f64) -> f64 {
    (mu_rs / mu_hd - 1.0) * fn_n
}

/// Eq. (7): the voltage in V (RMS) that produces electrostatic force
/// `fe_n` (N) over contact area `area_mm2` (mm^2); the inverse of eq. (3).
/// `None` when `fe_n` < 0: electrovibration can only add normal force.
pub fn voltage_for_force_v(stack: &LayerStack, area_mm2: f64, fe_n: f64) -> Option<f64> {
    (fe_n >= 0.0).then(|| (2.0 * stack.gap_factor_m2() * fe_n / (EPS0_F_PER_M * area_mm2 * MM2)).sqrt())
}

/// An electrovibration display and the finger on it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Device {
    pub stack: LayerStack,
    pub contact: ContactArea,
    /// Friction coefficient of the finger on the display with no voltage, mu_HD.
    pub mu_hd: f64,
    /// Highest voltage the display can apply, U_max in V (RMS).
    pub u_max_v: f64,
    /// Factor on eq. (3)'s force from a frequency-dependent force model for
    /// the carrier that will be played ([`crate::frequency::ForceModel`]);
    /// 1 is eq. (3) itself, the paper's (and then not serialized).
    #[serde(default = "unit_gain", skip_serializing_if = "is_unit_gain")]
    pub force_gain: f64,
}

fn unit_gain() -> f64 {
    1.0
}

fn is_unit_gain(g: &f64) -> bool {
    *g == 1.0
}

impl Device {
    /// The paper's Fig. 2 device: eps_sc = 1650, eps_i = 10, d_sc = 0.2 mm,
    /// d_i = 0.001 mm, k = 200 mm^2/N, U_max = 100 V, mu_HD = 1.
    pub const PAPER: Self =
        Self { stack: LayerStack::PAPER, contact: ContactArea::PAPER, mu_hd: 1.0, u_max_v: 100.0, force_gain: 1.0 };

    /// Checks every parameter is positive and finite.
    pub fn validate(&self) -> Result<(), ElectroError> {
        self.stack.validate()?;
        self.contact.validate()?;
        ranges::MU_HD.check(self.mu_hd)?;
        ranges::U_MAX_V.check(self.u_max_v)?;
        if !(self.force_gain.is_finite() && self.force_gain > 0.0) {
            return Err(ElectroError::Degenerate {
                quantity: "force gain on eq. (3)",
                value: self.force_gain,
                hint: "check the frequency-dependent force model's parameters",
            });
        }
        // Each constant may be fine and their combination still overflow
        // (d_sc = 1e300 mm): the derived quantities must be finite too.
        let ratio = self.force_ratio_per_v2(1.0);
        if !(ratio.is_finite() && ratio > 0.0) {
            return Err(ElectroError::Degenerate {
                quantity: "Fe/Fn per V^2 at 1 N",
                value: ratio,
                hint: "check the thicknesses, permittivities and k (eq. 3)",
            });
        }
        let mu_clip = self.mu_hd * (1.0 + self.u_max_v * self.u_max_v * ratio);
        if !mu_clip.is_finite() {
            return Err(ElectroError::Degenerate {
                quantity: "mu_RS at U_max",
                value: mu_clip,
                hint: "U_max or mu_HD is far too large for these layers",
            });
        }
        Ok(())
    }

    /// Fe/Fn per V^2 at normal force `fn_n` (N), from eq. (3) with A = k Fn^n:
    /// eps0 k Fn^(n-1) / (2 (d_sc/eps_sc + d_i/eps_i)(d_sc + d_i)), times
    /// the force gain of a frequency-dependent model (1 for eq. 3).
    pub fn force_ratio_per_v2(&self, fn_n: f64) -> f64 {
        // Times 1.0 is exact: eq. (3)'s designs are unchanged to the bit.
        electrostatic_force_n(&self.stack, self.contact.area_mm2(fn_n), 1.0) / fn_n * self.force_gain
    }

    /// Eq. (8) (eq. 7 with A = k Fn^n): the unclipped voltage in V (RMS) that
    /// renders mu_RS at normal force `fn_n`,
    /// U = sqrt((mu_RS/mu_HD - 1) / (Fe/Fn per V^2)). With the linear law
    /// (n = 1) Fn cancels and this is the paper's eq. (8). `None` where
    /// mu_RS < mu_HD (no real solution: electrovibration cannot lower friction).
    pub fn voltage_v(&self, mu_rs: f64, fn_n: f64) -> Option<f64> {
        let excess = mu_rs / self.mu_hd - 1.0;
        (excess >= 0.0).then(|| (excess / self.force_ratio_per_v2(fn_n)).sqrt())
    }
}

impl Default for Device {
    fn default() -> Self {
        Self::PAPER
    }
}

/// How friction is mapped to voltage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Eq. (8): the voltage that reproduces the reference friction force.
    Physical,
    /// Eq. (9): the pattern only, min mu -> 0 V, max mu -> U_max.
    Normalized,
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Method::Physical => "physical (eq. 8)",
            Method::Normalized => "normalized (eq. 9)",
        })
    }
}

/// Part of a profile's length where a condition holds: the union of
/// intervals on the piecewise-linear profile, with crossings interpolated.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Regions {
    /// Total length in mm.
    pub length_mm: f64,
    /// Length as a fraction of the profile's span, 0..=1.
    pub fraction_of_length: f64,
    /// The intervals [start, end] in mm, in increasing order.
    pub ranges_mm: Vec<[f64; 2]>,
}

impl Regions {
    /// Where the piecewise-linear `values(x)` is strictly above `threshold`.
    pub fn above(x_mm: &[f64], values: &[f64], threshold: f64) -> Self {
        let mut ranges: Vec<[f64; 2]> = Vec::new();
        let mut push = |a: f64, b: f64| match ranges.last_mut() {
            Some(last) if last[1] == a => last[1] = b,
            _ => ranges.push([a, b]),
        };
        for i in 0..x_mm.len() - 1 {
            let (x0, x1, v0, v1) = (x_mm[i], x_mm[i + 1], values[i], values[i + 1]);
            let crossing = || x0 + (threshold - v0) / (v1 - v0) * (x1 - x0);
            match (v0 > threshold, v1 > threshold) {
                (true, true) => push(x0, x1),
                (true, false) => push(x0, crossing()),
                (false, true) => push(crossing(), x1),
                (false, false) => {}
            }
        }
        // Fold from +0.0: an empty f64 sum is -0.0, which prints as "-0.00%".
        let length_mm = ranges.iter().fold(0.0, |sum, r| sum + (r[1] - r[0]));
        let span = x_mm[x_mm.len() - 1] - x_mm[0];
        Self { length_mm, fraction_of_length: length_mm / span, ranges_mm: ranges }
    }

    /// Where the piecewise-linear `values(x)` is strictly below `threshold`.
    pub fn below(x_mm: &[f64], values: &[f64], threshold: f64) -> Self {
        let negated: Vec<f64> = values.iter().map(|v| -v).collect();
        Self::above(x_mm, &negated, -threshold)
    }

    pub fn is_empty(&self) -> bool {
        self.ranges_mm.is_empty()
    }
}

/// What a mapping did, and where the device could not follow the profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VoltageSummary {
    pub method: Method,
    pub n_points: usize,
    pub x_min_mm: f64,
    pub x_max_mm: f64,
    pub mu_min: f64,
    pub mu_max: f64,
    /// U_max in V (RMS): the clip level (physical) or the scale (normalized).
    pub u_max_v: f64,
    pub voltage_min_v: f64,
    pub voltage_max_v: f64,
    /// Physical method: mu_HD.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mu_hd: Option<f64>,
    /// Physical method: the normal force used, in N (`None` with the linear
    /// contact-area law, where Fn cancels).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fn_n: Option<f64>,
    /// Physical method: Fe/Fn per V^2 from eq. (3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fe_over_fn_per_v2: Option<f64>,
    /// Physical method: the mu_RS at which U reaches U_max.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mu_at_u_max: Option<f64>,
    /// Where U would exceed U_max and was clipped to it (physical method).
    pub clipped: Regions,
    /// Where mu_RS < mu_HD: not renderable by electrovibration, U = 0 V there
    /// (physical method).
    pub not_renderable: Regions,
    /// When the profile was made relative to its flat-surface friction
    /// before the mapping (paper Fig. 2a): how. `mu`, `mu_min` and `mu_max`
    /// are then the relative values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relative: Option<Relative>,
    pub warnings: Vec<String>,
}

/// The "profile: N points, x .. mm, mu .." line of a design's summary
/// (this one and the display summaries of [`crate::combined`]).
pub(crate) fn write_profile_line(
    f: &mut fmt::Formatter<'_>,
    n_points: usize,
    [x_min_mm, x_max_mm]: [f64; 2],
    [mu_min, mu_max]: [f64; 2],
) -> fmt::Result {
    writeln!(
        f,
        "profile: {} points, x {} .. {} mm, mu {} .. {}",
        n_points,
        Num(x_min_mm),
        Num(x_max_mm),
        Fixed(mu_min, 4),
        Fixed(mu_max, 4)
    )
}

impl fmt::Display for VoltageSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "method: {}", self.method)?;
        if let Some(relative) = &self.relative {
            writeln!(f, "{}", relative.describe())?;
        }
        write_profile_line(f, self.n_points, [self.x_min_mm, self.x_max_mm], [self.mu_min, self.mu_max])?;
        if let (Some(mu_hd), Some(ratio)) = (self.mu_hd, self.fe_over_fn_per_v2) {
            write!(f, "device: mu_HD = {}, Fe/Fn = {ratio:.5e} U^2 (U in V)", Num(mu_hd))?;
            if let Some(fn_n) = self.fn_n {
                write!(f, " at Fn = {} N", Num(fn_n))?;
            }
            writeln!(f)?;
        }
        writeln!(
            f,
            "voltage (RMS): {:.3} .. {:.3} V, U_max = {} V",
            self.voltage_min_v,
            self.voltage_max_v,
            Num(self.u_max_v)
        )?;
        for (label, regions) in [("clipped at U_max", &self.clipped), ("mu_RS < mu_HD (U = 0 V)", &self.not_renderable)]
        {
            if self.method == Method::Physical {
                writeln!(
                    f,
                    "{label}: {:.2}% of the length{}",
                    100.0 * regions.fraction_of_length,
                    format_ranges(regions)
                )?;
            }
        }
        for warning in &self.warnings {
            writeln!(f, "warning: {warning}")?;
        }
        Ok(())
    }
}

pub(crate) fn format_ranges(regions: &Regions) -> String {
    const SHOWN: usize = 5;
    if regions.is_empty() {
        return String::new();
    }
    let mut text: Vec<String> = regions.ranges_mm.iter().take(SHOWN).map(|[a, b]| format!("{a:.3}..{b:.3}")).collect();
    if regions.ranges_mm.len() > SHOWN {
        text.push(format!("and {} more", regions.ranges_mm.len() - SHOWN));
    }
    format!(" (x in mm: {})", text.join(", "))
}

/// A voltage profile U(x) and the summary of the mapping that made it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VoltageProfile {
    pub summary: VoltageSummary,
    pub x_mm: Vec<f64>,
    pub mu: Vec<f64>,
    /// Voltage in V (RMS) at each position.
    pub voltage_v: Vec<f64>,
}

impl VoltageProfile {
    /// The same profile with other voltages (V RMS, one per position, each
    /// within 0 ..= the summary's U_max), e.g. a voltage compensated on the
    /// finger model; the summary's voltage range follows them.
    pub fn with_voltages(mut self, voltage_v: Vec<f64>) -> Result<Self, ElectroError> {
        if voltage_v.len() != self.x_mm.len() {
            return Err(ElectroError::Replacement(format!(
                "{} voltages for {} positions",
                voltage_v.len(),
                self.x_mm.len()
            )));
        }
        let u_max = self.summary.u_max_v;
        if let Some(i) = voltage_v.iter().position(|u| !(0.0..=u_max).contains(u)) {
            return Err(ElectroError::Replacement(format!(
                "{} V at x = {} mm is outside 0 .. U_max = {} V",
                Num(voltage_v[i]),
                Num(self.x_mm[i]),
                Num(u_max)
            )));
        }
        (self.summary.voltage_min_v, self.summary.voltage_max_v) = min_max(&voltage_v);
        self.voltage_v = voltage_v;
        Ok(self)
    }

    /// Writes `x_mm,mu,voltage_v` CSV, after a comment line stating the
    /// RMS convention and, for a relative profile, one saying how it was
    /// made (the `mu` column is then the relative friction).
    pub fn write_csv(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(
            w,
            "# haptex voltage profile, method {}; voltage_v is the RMS (effective) voltage; a sine carrier needs peak sqrt(2)*voltage_v",
            self.summary.method
        )?;
        if let Some(relative) = &self.summary.relative {
            let role = match self.summary.method {
                Method::Physical => "clip level",
                Method::Normalized => "full scale",
            };
            writeln!(
                w,
                "# {}; the mu column is the relative friction; U_max = {} V ({role})",
                relative.describe(),
                Num(self.summary.u_max_v)
            )?;
        }
        w.write_all(b"x_mm,mu,voltage_v\n")?;
        for i in 0..self.x_mm.len() {
            crate::io::write_csv_row(w, &[self.x_mm[i], self.mu[i], self.voltage_v[i]])?;
        }
        Ok(())
    }
}

/// Maps a friction profile to the voltage profile of `device`.
///
/// `fn_n` is the exploration normal force in N. It is needed only with a
/// non-linear contact-area law; if `None`, the profile's mean `fn_n` is used
/// when it has one (paper section 2.4).
pub fn map_profile(
    profile: &FrictionProfile,
    device: &Device,
    method: Method,
    fn_n: Option<f64>,
) -> Result<VoltageProfile, ElectroError> {
    device.validate()?;
    map_validated(profile, device, method, fn_n, None)
}

/// Maps a friction profile made relative to its flat-surface friction, as
/// the paper does for Fig. 2 ([`crate::relative`]): mu_rel = mu / mu_flat *
/// mu_HD, with mu_flat as `flat` says, then eq. (8) or (9) as
/// [`map_profile`] does. The summary records mu_flat, where it came from
/// and mu_HD; the voltage profile's `mu` is the relative friction, so the
/// file is consistent with its voltages (eq. 8 with the device's mu_HD).
pub fn map_profile_relative(
    profile: &FrictionProfile,
    device: &Device,
    method: Method,
    fn_n: Option<f64>,
    flat: FlatMu,
) -> Result<VoltageProfile, ElectroError> {
    device.validate()?;
    let relative = Relative::new(profile, flat, device.mu_hd)?;
    let scaled = relative.apply(profile)?;
    map_validated(&scaled, device, method, fn_n, Some(relative))
}

fn map_validated(
    profile: &FrictionProfile,
    device: &Device,
    method: Method,
    fn_n: Option<f64>,
    relative: Option<Relative>,
) -> Result<VoltageProfile, ElectroError> {
    let (x, mu) = (profile.x_mm(), profile.mu());
    let (mu_min, mu_max) = min_max(mu);
    let mut voltage_v = vec![0.0; mu.len()];
    let mut summary = VoltageSummary {
        method,
        n_points: mu.len(),
        x_min_mm: x[0],
        x_max_mm: x[x.len() - 1],
        mu_min,
        mu_max,
        u_max_v: device.u_max_v,
        voltage_min_v: 0.0,
        voltage_max_v: 0.0,
        mu_hd: None,
        fn_n: None,
        fe_over_fn_per_v2: None,
        mu_at_u_max: None,
        clipped: Regions::default(),
        not_renderable: Regions::default(),
        relative,
        warnings: Vec::new(),
    };
    match method {
        Method::Normalized => {
            if !normalized_voltages(mu, device.u_max_v, &mut voltage_v) {
                summary.warnings.push(format!(
                    "the profile is constant (mu = {}): eq. (9) is undefined, all voltages are 0 V",
                    Num(mu_min)
                ));
            }
        }
        Method::Physical => {
            let (fn_used, ratio) = force_ratio_for(profile, device, fn_n)?;
            let mapping = PhysicalMapping::new(device.mu_hd, ratio, device.u_max_v);
            mapping.fill(mu, &mut voltage_v);
            summary.mu_hd = Some(device.mu_hd);
            summary.fn_n = fn_used;
            summary.fe_over_fn_per_v2 = Some(ratio);
            summary.mu_at_u_max = Some(mapping.mu_clip);
            summary.clipped = Regions::above(x, mu, mapping.mu_clip);
            summary.not_renderable = Regions::below(x, mu, device.mu_hd);
            summary.warnings.extend(physical_warnings(&summary));
        }
    }
    if let Some(index) = voltage_v.iter().position(|u| !u.is_finite()) {
        return Err(ElectroError::NonFiniteVoltage { index, x_mm: x[index], mu: mu[index] });
    }
    (summary.voltage_min_v, summary.voltage_max_v) = min_max(&voltage_v);
    Ok(VoltageProfile { summary, x_mm: x.to_vec(), mu: mu.to_vec(), voltage_v })
}

/// Fe/Fn per V^2 (eq. 3 with A = k Fn^n) for mapping `profile`, and the
/// normal force it was evaluated at: `None` with the linear law, where Fn
/// cancels; else `fn_n`, or the profile's mean `fn_n` (paper section 2.4).
pub(crate) fn force_ratio_for(
    profile: &FrictionProfile,
    device: &Device,
    fn_n: Option<f64>,
) -> Result<(Option<f64>, f64), ElectroError> {
    let fn_used = if device.contact.is_linear() {
        None
    } else {
        let f = fn_n
            .or(profile.mean_fn_n())
            .ok_or(ElectroError::NormalForceRequired { exponent: device.contact.exponent })?;
        Some(ranges::FN_N.check(f)?)
    };
    // With the linear law Fe/Fn does not depend on Fn; evaluate at 1 N.
    Ok((fn_used, device.force_ratio_per_v2(fn_used.unwrap_or(1.0))))
}

fn physical_warnings(s: &VoltageSummary) -> Vec<String> {
    let mut warnings = Vec::new();
    let percent = |r: &Regions| 100.0 * r.fraction_of_length;
    if s.not_renderable.fraction_of_length >= 1.0 {
        warnings.push(if s.relative.is_some() {
            "mu_RS < mu_HD over the whole profile: the profile never rises above its flat-surface friction \
             mu_flat, so U = 0 V everywhere; check mu_flat, or use --method normalized"
                .to_string()
        } else {
            "mu_RS < mu_HD over the whole profile: electrovibration can only raise friction, so U = 0 V \
             everywhere; lower --mu-hd, map the profile relative to its flat-surface friction as the paper's \
             Fig. 2 does (--relative), or use --method normalized"
                .to_string()
        });
    } else if !s.not_renderable.is_empty() {
        warnings.push(format!(
            "mu_RS < mu_HD over {:.2}% of the length: not renderable by electrovibration, U = 0 V there",
            percent(&s.not_renderable)
        ));
    }
    if !s.clipped.is_empty() {
        warnings.push(format!(
            "U exceeds U_max = {} V over {:.2}% of the length (mu_RS > {}): clipped to U_max",
            Num(s.u_max_v),
            percent(&s.clipped),
            Fixed(s.mu_at_u_max.unwrap_or(f64::NAN), 4)
        ));
    }
    warnings
}

/// Eq. (8) over a whole profile, with the constants folded:
/// U = min(U_max, sqrt(max(0, mu/mu_HD - 1) / ratio)).
#[derive(Debug, Clone, Copy)]
pub struct PhysicalMapping {
    inv_mu_hd: f64,
    inv_ratio: f64,
    u_max_v: f64,
    /// mu_RS at which U reaches U_max.
    pub mu_clip: f64,
}

impl PhysicalMapping {
    /// `ratio` is Fe/Fn per V^2 (see [`Device::force_ratio_per_v2`]).
    pub fn new(mu_hd: f64, ratio: f64, u_max_v: f64) -> Self {
        Self {
            inv_mu_hd: 1.0 / mu_hd,
            inv_ratio: 1.0 / ratio,
            u_max_v,
            mu_clip: mu_hd * (1.0 + u_max_v * u_max_v * ratio),
        }
    }

    /// The clipped voltage in V for one friction value.
    #[inline]
    pub fn voltage_v(&self, mu_rs: f64) -> f64 {
        let excess = (mu_rs * self.inv_mu_hd - 1.0).max(0.0);
        (excess * self.inv_ratio).sqrt().min(self.u_max_v)
    }

    /// Fills `out` with the voltage of each friction value in `mu`.
    pub fn fill(&self, mu: &[f64], out: &mut [f64]) {
        for (u, &m) in out.iter_mut().zip(mu) {
            *u = self.voltage_v(m);
        }
    }
}

/// Eq. (9): U = U_max sqrt((mu - min mu) / (max mu - min mu)), into `out`.
/// Returns false (and fills 0 V) when the profile is constant.
pub fn normalized_voltages(mu: &[f64], u_max_v: f64, out: &mut [f64]) -> bool {
    let (lo, hi) = min_max(mu);
    let range = hi - lo;
    if range <= 0.0 {
        out.fill(0.0);
        return false;
    }
    // Divide (not multiply by 1/range) so max mu maps to exactly U_max.
    for (u, &m) in out.iter_mut().zip(mu) {
        *u = u_max_v * ((m - lo) / range).sqrt();
    }
    true
}

pub(crate) fn min_max(values: &[f64]) -> (f64, f64) {
    values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
}
