//! Closing the loop (the paper's validation, section 2.4, and beyond it):
//! the FE finger slides on the display under a voltage U(x), and the
//! friction it feels is compared with the reference profile U(x) was
//! designed for; then U(x) is corrected until the finger feels the target.
//!
//! # The check
//!
//! The target mu_RS(x) on [a, b] is mapped to U(x) by eq. (8) with the
//! device's constants (or any other U(x) is given); the finger is pressed
//! onto the display and slid over [a - run_up, b] with the voltage at its
//! position, so that the pre-sliding at the start of the slide (the
//! friction rising from 0 while the pad shears) is over before x = a. The
//! felt profile Ft/Fn (Fn the net normal force the finger applies) is then
//! compared with the target over the *renderable region*, where mu_HD <=
//! mu_RS <= mu at U_max: RMS and largest error, the spatial lag (the shift
//! of the felt profile that best matches the target), and how much of the
//! target's detail finer than the contact survives ([`CheckMetrics`]).
//!
//! # The compensated voltage
//!
//! The force is linear in U^2, so the correction works on w(x) = U(x)^2.
//! Each FE run is one trial of an iterative learning control (Bristow,
//! Tharayil and Alleyne, "A survey of iterative learning control", IEEE
//! Control Systems Magazine 26(3), 2006): with e_n(x) = felt_n(x) -
//! target(x),
//!
//! ```text
//!   w_{n+1}(x) = clip( w_n(x) - e_n(x + lag_n) / (mu_HD beta_n),  0, U_max^2 )
//! ```
//!
//! where beta_n is the gain d(mu_felt/mu_HD)/dw the run itself shows (the
//! least-squares slope of felt/mu_HD - 1 against w over the renderable
//! region: eq. (8)'s Fe/Fn per V^2 as the finger model sees it) and lag_n
//! the run's measured lag (the finger feels U(x) a little after x, while
//! the pad shears; correcting at x + lag puts the correction where it acts).
//! Eq. (8)'s voltage is the first trial; every trial is clipped to [0,
//! U_max]; the iteration stops when the RMS error is below a tolerance,
//! stops falling, or after a number of FE runs ([`Stopping`]), and keeps
//! the best trial. It cannot help where
//! the target is below mu_HD (the display cannot lower friction) or above
//! mu at U_max, nor with detail finer than the pad's pre-sliding length
//! (about 0.03 mm on the shipped finger).

use haptex_core::combined::{Channels, DisplayError as MappingError, Strategy, map_display};
use haptex_core::electrovibration::{Device, ElectroError, Method, PhysicalMapping, map_profile};
use haptex_core::num::Num;
use haptex_core::profile::{FrictionProfile, ProfileError};
use haptex_core::signal::{Extend, VoltageCurve};
use haptex_core::ultrasonic::UltrasonicDevice;
use serde::Serialize;

use crate::display::{Display, Vibration};
use crate::scenario::{self, Progress, Scenario, SimulationError, SimulationResult};
use crate::surface::SurfaceShape;

/// The check could not be done.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Electro(#[from] ElectroError),
    #[error(transparent)]
    Profile(#[from] ProfileError),
    #[error(transparent)]
    Mapping(#[from] MappingError),
    #[error("the finger model on the display: {0}")]
    Simulation(#[from] SimulationError),
    /// The target or the settings are not what a check can run
    /// ([`check_target`]): the caller's input, with the part at fault.
    #[error(transparent)]
    Target(#[from] TargetError),
    #[error("{0}")]
    Invalid(String),
}

/// Limits of a check: a slide of at most this many FE steps (at the
/// default 0.1 mm step, 10 m of profile; each step costs about 3 ms).
pub const MAX_CHECK_STEPS: usize = 100_000;

/// Most points of a target: the metrics average each point over the
/// points within three contact lengths of it ([`metrics_in_band`]), up to
/// n^2 work per FE run (4 x 10^8 at this limit, well under a second).
pub const MAX_CHECK_POINTS: usize = 20_000;

/// Closest two positions of a target may be, mm (1 nm): far below any
/// detail a finger feels or the FE model resolves (its steps are at least
/// microns), and far above the rounding of the slide's coordinates (the
/// target is placed on the slide, from 0 to at most 10^4 mm, where one
/// unit in the last place is below 2 x 10^-12 mm), so that no two
/// positions become one on the way.
pub const MIN_SPACING_MM: f64 = 1e-6;

/// Longest run-up before the target, mm.
pub const MAX_RUN_UP_MM: f64 = 100.0;

/// The part of a check's input at fault (what a caller names: a file's
/// positions, a flag, an API field).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TargetPart {
    /// The target's positions (its span, its spacing, its number of points).
    Positions,
    /// The slide step.
    Step,
    /// The run-up before the target.
    RunUp,
}

/// A target and settings a check cannot run ([`check_target`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct TargetError {
    pub part: TargetPart,
    pub message: String,
}

/// Checks what the FE check needs of a target and its settings, before
/// any work: the one validation that `haptex check` and `POST
/// /api/check` / `/api/compensate` share, so that every later step (eq.
/// (8), the target placed on the slide, the FE slide itself, the metrics)
/// only sees input it can run.
///
/// - at most [`MAX_CHECK_POINTS`] points, each at least
///   [`MIN_SPACING_MM`] from the next (positions closer than that become
///   one when the target is placed on the slide: 0 and 1e-300 mm are both
///   1 mm after a 1 mm run-up);
/// - a run-up from 0 to [`MAX_RUN_UP_MM`];
/// - a slide step no longer than the target (the finger feels the voltage
///   at its steps: a target shorter than one step lies between two of
///   them and would not be felt at all);
/// - a slide (the target's span and the run-up) within the scenario's
///   limits ([`crate::scenario::limits::SLIDE_MM`]), in at most
///   [`MAX_CHECK_STEPS`] steps.
pub fn check_target(target: &FrictionProfile, settings: &RenderSettings) -> Result<(), TargetError> {
    let err = |part, message: String| Err(TargetError { part, message });
    let x = target.x_mm();
    if x.len() > MAX_CHECK_POINTS {
        return err(
            TargetPart::Positions,
            format!(
                "the friction profile has {} points; the check takes at most {MAX_CHECK_POINTS} (resample it)",
                x.len()
            ),
        );
    }
    if let Some(i) = x.windows(2).position(|w| w[1] - w[0] < MIN_SPACING_MM) {
        return err(
            TargetPart::Positions,
            format!(
                "the friction profile's positions x = {} mm and x = {} mm are {} mm apart: the check on the finger \
                 model needs its positions at least {} mm (1 nm) apart (resample the profile)",
                Num(x[i]),
                Num(x[i + 1]),
                Num(x[i + 1] - x[i]),
                Num(MIN_SPACING_MM)
            ),
        );
    }
    let run_up = settings.run_up_mm;
    if !(run_up.is_finite() && (0.0..=MAX_RUN_UP_MM).contains(&run_up)) {
        return err(
            TargetPart::RunUp,
            format!("the run-up must be from 0 to {} mm, got {}", Num(MAX_RUN_UP_MM), Num(run_up)),
        );
    }
    let step = settings.scenario.step_mm;
    if !(step.is_finite() && step > 0.0) {
        return err(TargetPart::Step, format!("the slide step must be a positive length, got {} mm", Num(step)));
    }
    let span = target.span_mm();
    if span < step {
        return err(
            TargetPart::Step,
            format!(
                "the friction profile is {} mm long, shorter than one slide step of {} mm: the finger would feel \
                 none of it (give a step of at most {} mm, or a longer profile)",
                Num(span),
                Num(step),
                Num(span)
            ),
        );
    }
    let slide = span + run_up;
    let (min_slide, max_slide) = crate::scenario::limits::SLIDE_MM;
    if !(min_slide..=max_slide).contains(&slide) {
        return err(
            TargetPart::Positions,
            format!(
                "the slide over the friction profile and its run-up is {} mm: the finger model slides from {} to {} mm",
                Num(slide),
                Num(min_slide),
                Num(max_slide)
            ),
        );
    }
    let steps = (slide / step).ceil();
    if steps > MAX_CHECK_STEPS as f64 {
        return err(
            TargetPart::Step,
            format!(
                "the check slides {} mm in steps of {} mm: {} steps, at most {MAX_CHECK_STEPS}; check a shorter \
                 profile or use a larger step",
                Num(slide),
                Num(step),
                Num(steps)
            ),
        );
    }
    Ok(())
}

/// How a check is run.
#[derive(Debug, Clone)]
pub struct RenderSettings {
    /// The display and the finger's contact-area law of eq. (8). Its mu_HD
    /// is the skin-display friction of the FE model too.
    pub device: Device,
    /// The finger, mesh, tissue model, loading, velocity and slide step;
    /// its surface, display, slide and skin friction are set by the check.
    pub scenario: Scenario,
    /// Slide before the target's first position (mm), so that the finger
    /// is in steady sliding when it reaches it.
    pub run_up_mm: f64,
    /// The display's air gap where the skin touches it, um
    /// ([`Display::air_gap_um`]); 0, as eq. (8) assumes, unless a virtual
    /// device is to differ from its design.
    pub air_gap_um: f64,
    /// The FE finger that feels the display: the 2D plane-strain finger,
    /// or the 3D fingertip (whose load is in N, not N per mm of width).
    pub finger: FeFinger,
}

/// Which FE finger a check slides on the display.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum FeFinger {
    /// The 2D plane-strain finger: forces per mm of width, and eq. (8)'s
    /// k measured as a contact length per normal force per mm of width.
    #[default]
    Plane,
    /// The 3D fingertip ([`crate::solid3d`]) sliding at `direction_deg`
    /// from the display's x axis (0: across the finger, as in 2D): forces
    /// in N, and k measured as eq. (8) defines it, the real contact area
    /// over the normal force.
    Solid { direction_deg: f64 },
}

impl FeFinger {
    /// A check's default normal load on this finger, in [`FeFinger::load_unit`]:
    /// [`DEFAULT_LOAD_N_PER_MM`] or [`DEFAULT_LOAD_3D_N`].
    pub fn default_load(self) -> f64 {
        match self {
            Self::Plane => DEFAULT_LOAD_N_PER_MM,
            Self::Solid { .. } => DEFAULT_LOAD_3D_N,
        }
    }

    /// The unit of a normal load on this finger.
    pub fn load_unit(self) -> &'static str {
        match self {
            Self::Plane => "N/mm",
            Self::Solid { .. } => "N",
        }
    }
}

impl RenderSettings {
    /// The paper's device (with mu_HD = `mu_hd`) and finger, pressed with a
    /// constant normal load of `load_n_per_mm` (a user presses with a
    /// force, not a displacement), 20 mm/s, 1 mm run-up.
    pub fn new(mu_hd: f64, load_n_per_mm: f64) -> Self {
        let mut scenario = Scenario::paper(SurfaceShape::Flat);
        scenario.loading = crate::scenario::Loading::Load(load_n_per_mm);
        Self {
            device: Device { mu_hd, ..Device::PAPER },
            scenario,
            run_up_mm: 1.0,
            air_gap_um: 0.0,
            finger: FeFinger::Plane,
        }
    }
}

/// The default normal load of a check, N per mm of finger width: the
/// force of the paper's 0.25 mm press on a flat surface with the shipped
/// finger's elastic tissue (the visco-elastic finger's press reaches
/// 0.0098 N/mm and relaxes to 0.0075 N/mm over the slide).
pub const DEFAULT_LOAD_N_PER_MM: f64 = 0.0133;

/// The default normal load of a check on the 3D finger, N: within the
/// paper's "typical screen exploration (< 0.5 N)", at its top.
pub const DEFAULT_LOAD_3D_N: f64 = 0.5;

/// What the finger felt on the display.
#[derive(Debug, Clone)]
pub struct Felt {
    /// The FE run (its positions are the slide, from 0 at x = a - run_up).
    pub result: FeRun,
    /// Felt Ft/Fn at the target's positions.
    pub mu: Vec<f64>,
    /// Contact length (2D, per mm of width) or area (3D) over net normal
    /// force at the target's positions, mm^2/N.
    pub k_mm2_per_n: Vec<f64>,
    /// Mean contact length over the slide (3D: along the motion), mm.
    pub contact_mm: f64,
}

/// The FE run of a check, on the finger it ran on.
#[derive(Debug, Clone)]
pub enum FeRun {
    Plane(Box<SimulationResult>),
    Solid(Box<crate::solid3d::slide::Simulation3>),
}

impl FeRun {
    /// The 2D run, if the check ran on the 2D finger.
    pub fn plane(&self) -> Option<&SimulationResult> {
        match self {
            Self::Plane(r) => Some(r),
            Self::Solid(_) => None,
        }
    }
}

/// How well the felt friction follows the target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CheckMetrics {
    /// RMS and largest |felt - target| over the renderable region.
    pub rms_error: f64,
    pub max_error: f64,
    /// Fraction of the target's length where mu_RS < mu_HD (the display
    /// cannot lower friction) and where mu_RS is above mu at U_max.
    pub not_renderable_fraction: f64,
    pub clipped_fraction: f64,
    /// The shift (mm, > 0: the felt profile comes later) within +-0.1 mm
    /// that best aligns felt and target over the renderable region.
    pub lag_mm: f64,
    /// RMS of the target's detail finer than the contact (the target less
    /// its Gaussian average over the contact length), and the fraction of
    /// it the felt profile keeps (RMS of the felt detail over the target's;
    /// `None` when the target has no such detail).
    pub target_detail_rms: f64,
    pub detail_retained: Option<f64>,
    /// The contact-area coefficient as the FE finger sees it: its contact
    /// length per unit net normal force (mm per N/mm = mm^2/N), averaged
    /// over the target; eq. (8)'s k per mm of finger width.
    pub k_fe_mm2_per_n: f64,
    /// Mean contact length over the target, mm.
    pub contact_mm: f64,
}

/// One check: the target, the voltage, what was felt and how well.
#[derive(Debug, Clone)]
pub struct Check {
    pub target: FrictionProfile,
    /// U(x) in V RMS at the target's positions.
    pub voltage_v: Vec<f64>,
    /// a(x) in um (peak) at the target's positions, on a combined display.
    pub amplitude_um: Option<Vec<f64>>,
    pub felt: Felt,
    pub metrics: CheckMetrics,
}

/// The renderable range of mu_RS, mu_HD ..= mu at U_max (eq. 8's clip
/// level, as `map_profile` computes it).
fn renderable_range(device: &Device) -> std::ops::RangeInclusive<f64> {
    let mapping = PhysicalMapping::new(device.mu_hd, device.force_ratio_per_v2(1.0), device.u_max_v);
    device.mu_hd..=mapping.mu_clip
}

/// Eq. (8)'s voltage for `target` (clipped at U_max).
pub fn eq8_voltage(target: &FrictionProfile, device: &Device) -> Result<Vec<f64>, RenderError> {
    Ok(map_profile(target, device, Method::Physical, None)?.voltage_v)
}

/// Checks the settings against the target before any FE run.
fn validate(target: &FrictionProfile, settings: &RenderSettings) -> Result<(), RenderError> {
    settings.device.validate()?;
    check_target(target, settings)?;
    Ok(())
}

/// Slides the FE finger over the display under `voltage_v` (V RMS at the
/// target's positions) and returns what it felt there.
pub fn feel(
    target: &FrictionProfile,
    voltage_v: &[f64],
    settings: &RenderSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<Felt, RenderError> {
    feel_display(target, voltage_v, None, settings, progress)
}

/// [`feel`] on a display that may also vibrate: `vibration` is the
/// amplitude in um at the target's positions and the plate, whose
/// friction at rest is the device's mu_HD; the skin-display friction is
/// then mu_HD rho(a(x_f)) at the finger's position.
pub fn feel_display(
    target: &FrictionProfile,
    voltage_v: &[f64],
    vibration: Option<(&[f64], &UltrasonicDevice)>,
    settings: &RenderSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<Felt, RenderError> {
    validate(target, settings)?;
    let x = target.x_mm();
    let start = x[0] - settings.run_up_mm;
    // The FE's position is the slide s from 0; the target's x = start + s.
    let shifted: Vec<f64> = x.iter().map(|&x| x - start).collect();
    let vibration = vibration
        .map(|(a, device)| Vibration::new(shifted.clone(), a.to_vec(), device.clone(), settings.device.mu_hd))
        .transpose()
        .map_err(|e| RenderError::Invalid(e.to_string()))?;
    let voltage = VoltageCurve::new(shifted, voltage_v.to_vec())?;
    let mut scenario = settings.scenario.clone();
    scenario.surface = SurfaceShape::Flat;
    scenario.mu_skin = Some(settings.device.mu_hd);
    scenario.slide_mm = x[x.len() - 1] - start;
    scenario.display = Some(Display {
        voltage,
        extend: Extend::Hold,
        stack: settings.device.stack,
        vibration,
        air_gap_um: settings.air_gap_um,
    });
    // Each slide step's position, Ft, Fn (net), contact length along the
    // motion, and contact length (2D) or area (3D).
    let (result, rows): (FeRun, Vec<[f64; 5]>) = match settings.finger {
        FeFinger::Plane => {
            let result = scenario::run(&scenario, progress)?;
            let rows = result.history.iter().filter(|r| r.slide_mm > 0.0);
            let rows = rows.map(|r| [r.slide_mm, r.ft_n, r.fn_n, r.contact_mm, r.contact_mm]).collect();
            (FeRun::Plane(Box::new(result)), rows)
        }
        FeFinger::Solid { direction_deg } => {
            let result = crate::solid3d::slide::run(&scenario, direction_deg, progress)?;
            let rows = result.history.iter().filter(|r| r.slide_mm > 0.0);
            let rows = rows.map(|r| [r.slide_mm, r.ft_n, r.fn_n, r.contact_length_mm, r.contact_area_mm2]).collect();
            (FeRun::Solid(Box::new(result)), rows)
        }
    };
    let slide: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let contact_mm = mean(&rows.iter().map(|r| r[3]).collect::<Vec<_>>());
    let mu_run: Vec<f64> = rows.iter().map(|r| r[1] / r[2]).collect();
    let k_run: Vec<f64> = rows.iter().map(|r| r[4] / r[2]).collect();
    let at = |values: &[f64], x: f64| haptex_core::profile::interpolate(&slide, values, x - start);
    let mu = x.iter().map(|&x| at(&mu_run, x)).collect();
    let k_mm2_per_n = x.iter().map(|&x| at(&k_run, x)).collect();
    Ok(Felt { result, mu, k_mm2_per_n, contact_mm })
}

/// The metrics of a felt profile against its target, on the
/// electrovibration display of `device` (renderable: mu_HD ..= mu at U_max).
pub fn metrics(target: &FrictionProfile, felt: &Felt, device: &Device) -> CheckMetrics {
    let range = renderable_range(device);
    metrics_in_band(target, felt, [*range.start(), *range.end()])
}

/// The metrics of a felt profile against its target over a display's
/// renderable band [low, high]: below it counts as not renderable, above
/// it as clipped.
pub fn metrics_in_band(target: &FrictionProfile, felt: &Felt, band: [f64; 2]) -> CheckMetrics {
    let (x, mu) = (target.x_mm(), target.mu());
    let n = x.len();
    // Trapezoid weights: the length each sample stands for.
    let weight: Vec<f64> = (0..n).map(|i| 0.5 * (x[(i + 1).min(n - 1)] - x[i.saturating_sub(1)])).collect();
    let range = band[0]..=band[1];
    let inside: Vec<bool> = mu.iter().map(|m| range.contains(m)).collect();
    let span = target.span_mm().max(f64::MIN_POSITIVE);
    let fraction = |f: &dyn Fn(usize) -> bool| (0..n).filter(|&i| f(i)).map(|i| weight[i]).sum::<f64>() / span;
    let not_renderable_fraction = fraction(&|i| mu[i] < band[0]).max(0.0);
    let clipped_fraction = fraction(&|i| mu[i] > band[1]).max(0.0);
    let rms_of = |shift: f64| {
        let (mut sum, mut length) = (0.0, 0.0);
        for i in (0..n).filter(|&i| inside[i]) {
            let felt = haptex_core::profile::interpolate(x, &felt.mu, x[i] + shift);
            sum += weight[i] * (felt - mu[i]).powi(2);
            length += weight[i];
        }
        if length > 0.0 { (sum / length).sqrt() } else { 0.0 }
    };
    let rms_error = rms_of(0.0);
    let max_error = (0..n).filter(|&i| inside[i]).map(|i| (felt.mu[i] - mu[i]).abs()).fold(0.0, f64::max);
    // Lag: the best shift on a 0.005 mm grid within +-0.1 mm (three
    // times the pad's pre-sliding length: a larger shift would only align
    // unrelated detail).
    let mut lag_mm = 0.0;
    let mut best = rms_error;
    for k in -20..=20 {
        let shift = 0.005 * k as f64;
        let e = rms_of(shift);
        if e < best - 1e-15 {
            (best, lag_mm) = (e, shift);
        }
    }
    let k_fe_mm2_per_n = mean(&felt.k_mm2_per_n);
    let contact_mm = felt.contact_mm;
    // Detail finer than the contact: the profile less its Gaussian average
    // with a standard deviation of half the contact length.
    let sigma = 0.5 * contact_mm;
    let detail = |values: &[f64]| -> Vec<f64> {
        let smooth = gaussian_smooth(x, values, sigma);
        values.iter().zip(&smooth).map(|(v, s)| v - s).collect()
    };
    let (dt, df) = (detail(mu), detail(&felt.mu));
    let rms = |d: &[f64]| ((0..n).map(|i| weight[i] * d[i] * d[i]).sum::<f64>() / span).sqrt();
    let target_detail_rms = rms(&dt);
    let detail_retained = (target_detail_rms > 1e-4).then(|| rms(&df) / target_detail_rms);
    CheckMetrics {
        rms_error,
        max_error,
        not_renderable_fraction,
        clipped_fraction,
        lag_mm,
        target_detail_rms,
        detail_retained,
        k_fe_mm2_per_n,
        contact_mm,
    }
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 }
}

/// Gaussian average of `values` at each of `x` (sorted) over +-3 sigma,
/// O(n * window).
fn gaussian_smooth(x: &[f64], values: &[f64], sigma: f64) -> Vec<f64> {
    if sigma.is_nan() || sigma <= 0.0 {
        return values.to_vec();
    }
    let (mut lo, mut hi) = (0, 0);
    x.iter()
        .map(|&xi| {
            while x[lo] < xi - 3.0 * sigma {
                lo += 1;
            }
            while hi < x.len() && x[hi] <= xi + 3.0 * sigma {
                hi += 1;
            }
            let (mut sum, mut total) = (0.0, 0.0);
            for j in lo..hi {
                let w = (-0.5 * ((x[j] - xi) / sigma).powi(2)).exp();
                sum += w * values[j];
                total += w;
            }
            sum / total
        })
        .collect()
}

/// Maps `target` by eq. (8), runs the finger on the display and measures.
pub fn check(
    target: &FrictionProfile,
    settings: &RenderSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<Check, RenderError> {
    let voltage_v = eq8_voltage(target, &settings.device)?;
    check_voltage(target, voltage_v, settings, progress)
}

/// Runs the finger on the display under `voltage_v` and measures.
pub fn check_voltage(
    target: &FrictionProfile,
    voltage_v: Vec<f64>,
    settings: &RenderSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<Check, RenderError> {
    if voltage_v.len() != target.len() {
        return Err(RenderError::Invalid(format!(
            "{} voltages for {} profile positions",
            voltage_v.len(),
            target.len()
        )));
    }
    if let Some(i) = voltage_v.iter().position(|&u| !(u >= 0.0 && u <= settings.device.u_max_v)) {
        return Err(RenderError::Invalid(format!(
            "voltage {} V at x = {} mm is outside 0 .. U_max = {} V",
            Num(voltage_v[i]),
            Num(target.x_mm()[i]),
            Num(settings.device.u_max_v)
        )));
    }
    let felt = feel(target, &voltage_v, settings, progress)?;
    let metrics = metrics(target, &felt, &settings.device);
    Ok(Check { target: target.clone(), voltage_v, amplitude_um: None, felt, metrics })
}

/// The check of a combined display (docs/physics.md, "The combined
/// display"): the target allocated to (U(x), a(x)) by `strategy` on the
/// settings' device and the plate `ultrasonic` (whose friction at rest is
/// the device's mu_HD), the finger slid on the display vibrating and under
/// voltage, and the metrics over the combined display's band.
pub fn check_combined(
    target: &FrictionProfile,
    settings: &RenderSettings,
    ultrasonic: &UltrasonicDevice,
    strategy: Strategy,
    progress: &mut dyn FnMut(Progress),
) -> Result<Check, RenderError> {
    let design = map_display(target, &settings.device, Channels::Combined(ultrasonic, strategy), None, None)?;
    let (Some(voltage_v), Some(amplitude_um)) = (design.voltage_v, design.amplitude_um) else {
        return Err(RenderError::Invalid("the combined display's design lacks a channel".into()));
    };
    let felt = feel_display(target, &voltage_v, Some((&amplitude_um, ultrasonic)), settings, progress)?;
    let metrics = metrics_in_band(target, &felt, design.summary.band_mu);
    Ok(Check { target: target.clone(), voltage_v, amplitude_um: Some(amplitude_um), felt, metrics })
}

/// The trials of a compensation.
#[derive(Debug, Clone)]
pub struct Compensation {
    /// Every trial's check, eq. (8) first.
    pub trials: Vec<Check>,
    /// Index of the best trial (smallest RMS error).
    pub best: usize,
    /// Why it stopped.
    pub stop: CompensationStop,
}

/// Why a compensation stopped ([`Stopping`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompensationStop {
    /// The last trial's RMS error was within the tolerance.
    Tolerance,
    /// The last trial took off less than the required fraction of the
    /// best error so far.
    Stalled,
    /// The runs allowed were spent.
    MaxRuns,
}

impl CompensationStop {
    /// In a sentence, with the settings that made it stop.
    pub fn describe(self, stopping: &Stopping) -> String {
        match self {
            Self::Tolerance => format!("stopped: the RMS error is within the tolerance {:.1e}", stopping.tolerance),
            Self::Stalled => format!(
                "stopped: the last FE run did not bring the RMS error below {}% of the best so far",
                Num(100.0 * stopping.min_reduction)
            ),
            Self::MaxRuns => format!("stopped: the {} FE runs allowed were spent", stopping.max_runs),
        }
    }
}

impl Compensation {
    pub fn best(&self) -> &Check {
        &self.trials[self.best]
    }
}

/// When a compensation stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stopping {
    /// Most FE runs, eq. (8)'s included (1 ..= 100).
    pub max_runs: usize,
    /// Stop once the RMS error over the renderable region is below this
    /// (in units of mu).
    pub tolerance: f64,
    /// Stop when a trial's RMS error is above this fraction of the best so
    /// far (the error has stopped falling).
    pub min_reduction: f64,
}

impl Default for Stopping {
    /// 8 runs; a tolerance of 1e-4 in mu, ten times below the FE profiles'
    /// own discretization error (docs/fem.md, "Convergence"); stop when a
    /// run takes off less than 10% of the error.
    fn default() -> Self {
        Self { max_runs: 8, tolerance: 1e-4, min_reduction: 0.9 }
    }
}

/// Iterates U(x) from eq. (8)'s until the finger feels the target (module
/// docs), as `stopping` says. `progress` is told the trial number (from 0)
/// and the FE's progress.
pub fn compensate(
    target: &FrictionProfile,
    settings: &RenderSettings,
    stopping: Stopping,
    progress: &mut dyn FnMut(usize, Progress),
) -> Result<Compensation, RenderError> {
    let Stopping { max_runs, tolerance, min_reduction } = stopping;
    if !(1..=100).contains(&max_runs) {
        return Err(RenderError::Invalid(format!("the compensation needs 1 to 100 FE runs, got {max_runs}")));
    }
    if !(tolerance.is_finite() && tolerance >= 0.0 && (0.0..=1.0).contains(&min_reduction)) {
        return Err(RenderError::Invalid(format!(
            "the compensation's tolerance ({}) must be >= 0 and its reduction ({}) from 0 to 1",
            Num(tolerance),
            Num(min_reduction)
        )));
    }
    let device = settings.device;
    let u_max2 = device.u_max_v * device.u_max_v;
    let (x, mu) = (target.x_mm(), target.mu());
    let mut trials: Vec<Check> = Vec::new();
    let range = renderable_range(&device);
    let mut w: Vec<f64> = eq8_voltage(target, &device)?.iter().map(|u| u * u).collect();
    let mut best = 0;
    let mut stop = CompensationStop::MaxRuns;
    for run in 0..max_runs {
        let voltage: Vec<f64> = w.iter().map(|&w| w.clamp(0.0, u_max2).sqrt().min(device.u_max_v)).collect();
        let trial = check_voltage(target, voltage, settings, &mut |p| progress(run, p))?;
        let best_error = trials.get(best).map_or(f64::INFINITY, |b| b.metrics.rms_error);
        let error = trial.metrics.rms_error;
        trials.push(trial);
        if error < best_error {
            best = trials.len() - 1;
        }
        if error <= tolerance {
            stop = CompensationStop::Tolerance;
            break;
        }
        if run > 0 && error > min_reduction * best_error {
            stop = CompensationStop::Stalled;
            break;
        }
        if run + 1 == max_runs {
            break;
        }
        // The gain as this trial shows it: felt/mu_HD - 1 against w.
        let last = &trials[trials.len() - 1];
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..x.len() {
            if range.contains(&mu[i]) && w[i] > 0.0 {
                num += (last.felt.mu[i] / device.mu_hd - 1.0) * w[i];
                den += w[i] * w[i];
            }
        }
        let beta = if den > 0.0 && num > 0.0 { num / den } else { device.force_ratio_per_v2(1.0) };
        let lag = last.metrics.lag_mm;
        for i in 0..x.len() {
            // w(x) acts on the friction felt at x + lag.
            let error = haptex_core::profile::interpolate(x, &last.felt.mu, x[i] + lag) - target.mu_at(x[i] + lag);
            w[i] = (w[i] - error / (device.mu_hd * beta)).clamp(0.0, u_max2);
        }
    }
    Ok(Compensation { trials, best, stop })
}

/// `haptex voltage --compensate`: eq. (8)'s design `voltage` (on
/// `device`) with its voltage compensated on the FE finger pressed with
/// `load_n_per_mm` (default [`DEFAULT_LOAD_N_PER_MM`]), visco-elastic,
/// default mesh, 0.05 mm steps, in at most `max_runs` FE runs; and the
/// comment its file starts with (the achieved error). `stop` cancels the
/// runs ([`Scenario::stop`]); `progress` is told the run (from 0) and the
/// FE's progress.
pub fn compensate_design(
    voltage: haptex_core::electrovibration::VoltageProfile,
    device: &Device,
    load_n_per_mm: Option<f64>,
    max_runs: usize,
    stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    progress: &mut dyn FnMut(usize, Progress),
) -> Result<(haptex_core::electrovibration::VoltageProfile, String), RenderError> {
    if voltage.summary.method != Method::Physical || !device.contact.is_linear() {
        return Err(RenderError::Invalid(
            "--compensate needs --method physical and the linear contact-area law (--area-exponent 1)".into(),
        ));
    }
    let load = load_n_per_mm.unwrap_or(DEFAULT_LOAD_N_PER_MM);
    let target = FrictionProfile::new(voltage.x_mm.clone(), voltage.mu.clone())?;
    let mut settings = RenderSettings::new(device.mu_hd, load);
    settings.device = *device;
    settings.scenario.step_mm = 0.05;
    settings.scenario.stop = stop;
    let stopping = Stopping { max_runs, ..Stopping::default() };
    let c = compensate(&target, &settings, stopping, progress)?;
    let (eq8, best) = (&c.trials[0].metrics, c.best());
    let comment = format!(
        "compensated on the FE finger (load {} N/mm, visco-elastic, default mesh): felt-friction RMS error {:.3e} \
         over the renderable region after {} FE runs (eq. 8: {:.3e})",
        Num(load),
        best.metrics.rms_error,
        c.trials.len(),
        eq8.rms_error
    );
    let voltage_v = best.voltage_v.clone();
    Ok((voltage.with_voltages(voltage_v)?, comment))
}

/// A check of the electrovibration display as `haptex check` reports it
/// ([`check_electrovibration`]).
#[derive(Debug, Clone)]
pub struct CheckRun {
    /// The check reported: eq. (8)'s, or the compensation's best trial.
    pub check: Check,
    /// Every trial of a compensation, eq. (8) first (empty without one).
    pub trials: Vec<CheckMetrics>,
    /// Index of `check` in `trials` (0 without a compensation).
    pub best: usize,
    /// The FE finger's k of a first run when eq. (8) took it (`fe_k`).
    pub fe_k_mm2_per_n: Option<f64>,
    /// What the voltage is: "eq. (8)" or "compensated (trial N)".
    pub label: String,
    /// The report's lines (the fe-k run, the trials, the metrics).
    pub lines: Vec<String>,
    /// The settings the check ran with (k the FE finger's with `fe_k`).
    pub settings: RenderSettings,
}

/// `haptex check` on the electrovibration display: with `fe_k` a first
/// eq. (8) run measures the FE finger's k, which eq. (8) then takes; then
/// eq. (8)'s voltage is checked, or (`compensate`) compensated as
/// `stopping` says. `progress` is told the run (from 0; the fe-k run and
/// the compensation both count from 0) and the FE's progress.
pub fn check_electrovibration(
    target: &FrictionProfile,
    mut settings: RenderSettings,
    fe_k: bool,
    compensate_with: Option<Stopping>,
    progress: &mut dyn FnMut(usize, Progress),
) -> Result<CheckRun, RenderError> {
    let mut lines = Vec::new();
    let mut fe_k_mm2_per_n = None;
    if fe_k {
        let first = check(target, &settings, &mut |p| progress(0, p))?;
        let k = first.metrics.k_fe_mm2_per_n;
        lines.push(format!(
            "eq. (8) with k = {} mm^2/N: RMS error {:.3e}; the FE finger's k is {k:.1} mm^2/N",
            Num(settings.device.contact.k_mm2_per_n),
            first.metrics.rms_error,
        ));
        settings.device.contact.k_mm2_per_n =
            haptex_core::ranges::K_MM2_PER_N.check(k).map_err(|e| RenderError::Invalid(e.to_string()))?;
        fe_k_mm2_per_n = Some(k);
    }
    let (check, trials, best, label) = match compensate_with {
        Some(stopping) => {
            let c = compensate(target, &settings, stopping, progress)?;
            for (i, t) in c.trials.iter().enumerate() {
                lines.push(format!(
                    "trial {} ({}): RMS error {:.3e}, max {:.3e}",
                    i + 1,
                    if i == 0 { "eq. 8" } else { "compensated" },
                    t.metrics.rms_error,
                    t.metrics.max_error
                ));
            }
            lines.push(c.stop.describe(&stopping));
            let trials: Vec<CheckMetrics> = c.trials.iter().map(|t| t.metrics).collect();
            let best = c.best;
            let check = c.trials.into_iter().nth(best).expect("best trial exists");
            (check, trials, best, format!("compensated (trial {})", best + 1))
        }
        None => (check(target, &settings, &mut |p| progress(0, p))?, Vec::new(), 0, "eq. (8)".to_string()),
    };
    lines.extend(describe_metrics(&check.metrics, &settings));
    Ok(CheckRun { check, trials, best, fe_k_mm2_per_n, label, lines, settings })
}

/// The finger's loading as a check's header says it.
pub fn loading_text(loading: crate::scenario::Loading, finger: FeFinger) -> String {
    match loading {
        crate::scenario::Loading::Load(f) => format!("{} {}", Num(f), finger.load_unit()),
        crate::scenario::Loading::Indent(d) => format!("indent {} mm", Num(d)),
    }
}

/// The FE finger as a check's header names it.
pub fn finger_text(finger: FeFinger) -> String {
    match finger {
        FeFinger::Plane => "FE finger".to_string(),
        FeFinger::Solid { direction_deg } => format!("3D FE finger sliding at {} degrees", Num(direction_deg)),
    }
}

/// The first line of `haptex check`'s report and files: the profile
/// (`profile`, as the caller names it), the finger, the load and what the
/// voltage is; `device_file` the device file's path, if any.
pub fn check_header(profile: &str, run: &CheckRun, device_file: Option<&str>) -> String {
    format!(
        "haptex check: {profile} on the {} ({}, load {}), voltage {}{}",
        finger_text(run.settings.finger),
        if run.settings.scenario.viscoelastic { "visco-elastic" } else { "elastic" },
        loading_text(run.settings.scenario.loading, run.settings.finger),
        run.label,
        device_file.map_or(String::new(), |f| format!(", device file {f}"))
    )
}

/// The first comment of the voltage a check writes (`--voltage-out`).
pub fn voltage_comment(header: &str, metrics: &CheckMetrics) -> String {
    format!("{header}; felt-friction RMS error {} over the renderable region", Num(metrics.rms_error))
}

/// The report's lines on the metrics of an electrovibration check.
pub fn describe_metrics(m: &CheckMetrics, settings: &RenderSettings) -> Vec<String> {
    let d = &settings.device;
    let k_paper = d.contact.k_mm2_per_n;
    vec![
        format!(
            "felt friction against the target over the renderable region: RMS error {:.3e}, max {:.3e}, lag {:.3} mm",
            m.rms_error, m.max_error, m.lag_mm
        ),
        format!(
            "not renderable (mu_RS < mu_HD = {}): {:.1}% of the length; above mu at U_max: {:.1}%",
            Num(d.mu_hd),
            100.0 * m.not_renderable_fraction,
            100.0 * m.clipped_fraction
        ),
        match m.detail_retained {
            Some(r) => format!(
                "detail finer than the contact ({:.2} mm): target RMS {:.4}, {:.0}% of it felt",
                m.contact_mm,
                m.target_detail_rms,
                100.0 * r
            ),
            None => format!("the target has no detail finer than the contact ({:.2} mm)", m.contact_mm),
        },
        match settings.finger {
            FeFinger::Plane => format!(
                "contact-area coefficient: eq. (8) used k = {k_paper:.1} mm^2/N; the FE finger's contact length per \
                 normal force is {:.1} mm^2/N (per mm of width; --fe-k uses it)",
                m.k_fe_mm2_per_n
            ),
            FeFinger::Solid { .. } => format!(
                "contact-area coefficient: eq. (8) used k = {k_paper:.1} mm^2/N; the 3D finger's contact area per \
                 normal force is {:.1} mm^2/N (--fe-k uses it)",
                m.k_fe_mm2_per_n
            ),
        },
    ]
}

/// The first line of a combined display's check report.
pub fn combined_header(
    profile: &str,
    settings: &RenderSettings,
    ultrasonic: &UltrasonicDevice,
    strategy: Strategy,
    device_file: Option<&str>,
) -> String {
    format!(
        "haptex check: {profile} on the {}, combined display ({} strategy{}; plate: {}), load {}{}",
        finger_text(settings.finger),
        strategy.kind(),
        match strategy {
            Strategy::Weighted { weight } => format!(", weight {}", Num(weight)),
            _ => String::new(),
        },
        ultrasonic.describe(),
        loading_text(settings.scenario.loading, settings.finger),
        device_file.map_or(String::new(), |f| format!(", device file {f}"))
    )
}

/// The report's lines on the metrics of a combined display's check.
pub fn describe_combined_metrics(m: &CheckMetrics) -> Vec<String> {
    vec![
        format!(
            "felt friction against the target over the combined display's band: RMS error {:.3e}, max {:.3e}, lag {:.3} mm",
            m.rms_error, m.max_error, m.lag_mm
        ),
        format!(
            "outside the band: {:.1}% of the length below it, {:.1}% above it",
            100.0 * m.not_renderable_fraction,
            100.0 * m.clipped_fraction
        ),
    ]
}

/// Writes a check as `haptex check -o` does: `# header`, `# line` each,
/// then `x_mm,target_mu,voltage_v,felt_mu,k_fe_mm2_per_n` (electrovibration)
/// or `x_mm,target_mu,voltage_v,amplitude_um,felt_mu` (combined), in full
/// precision.
pub fn write_check_csv(
    check: &Check,
    header: &str,
    lines: &[String],
    w: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    writeln!(w, "# {header}")?;
    for line in lines {
        writeln!(w, "# {line}")?;
    }
    let (x, mu) = (check.target.x_mm(), check.target.mu());
    match &check.amplitude_um {
        None => {
            writeln!(w, "x_mm,target_mu,voltage_v,felt_mu,k_fe_mm2_per_n")?;
            for i in 0..check.target.len() {
                haptex_core::io::write_csv_row(
                    w,
                    &[x[i], mu[i], check.voltage_v[i], check.felt.mu[i], check.felt.k_mm2_per_n[i]],
                )?;
            }
        }
        Some(amplitude) => {
            writeln!(w, "x_mm,target_mu,voltage_v,amplitude_um,felt_mu")?;
            for (i, &a) in amplitude.iter().enumerate() {
                haptex_core::io::write_csv_row(w, &[x[i], mu[i], check.voltage_v[i], a, check.felt.mu[i]])?;
            }
        }
    }
    Ok(())
}
