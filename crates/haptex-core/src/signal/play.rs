//! What `haptex play` does between reading its inputs and writing the
//! drive, shared by the command line and the Python package (`haptex.play`)
//! so that both refuse, limit and render the same way: the design's
//! stated a_max and carrier (its `#` comments), channel 2's a_max, the
//! generated finger trajectories, and the render itself.

use serde_json::json;

use super::{
    AmplitudeCurve, Carrier, DriveSignal, RenderSettings, SignalError, VoltageCurve, render, render_two_channel,
};
use crate::arg_names::ArgNames;
use crate::io::Table;
use crate::num::Num;
use crate::profile::ProfileError;
use crate::trajectory::{Trajectory, TrajectoryError};

/// What a design made with a device file states of it in a comment
/// (`haptex voltage --device`): the file's SHA-256 follows.
pub const DEVICE_SHA256_MARK: &str = "device file sha256 ";

/// Rate at which generated trajectories are sampled (linear in between), Hz.
pub const GENERATED_RATE_HZ: f64 = 1000.0;

/// A design to play: the voltage curve, the amplitude curve of a display
/// profile with an `amplitude_um` column, and the `#` comment lines before
/// its header row (where `haptex voltage` states an a_max and a design
/// carrier).
#[derive(Debug, Clone, PartialEq)]
pub struct PlayProfile {
    pub curve: VoltageCurve,
    pub amplitude: Option<AmplitudeCurve>,
    pub comments: Vec<String>,
}

impl PlayProfile {
    /// The design a table holds (`x_mm,mu,voltage_v[,amplitude_um]`, or
    /// `x_mm,voltage_v`), with its comments.
    pub fn from_table(table: &Table) -> Result<Self, ProfileError> {
        let (curve, amplitude) = VoltageCurve::from_display_table(table)?;
        Ok(Self { curve, amplitude, comments: table.comments().to_vec() })
    }

    /// The a_max the design's header states for channel 2 (`None` without
    /// an amplitude channel): [`stated_a_max`] of its comments.
    pub fn stated_a_max(&self) -> Option<f64> {
        if self.amplitude.is_some() { stated_a_max(&self.comments) } else { None }
    }

    /// Channel 2's a_max for this design, named `profile` in messages:
    /// `given` (at most what the design states), else the stated one;
    /// `None` for a design without an amplitude channel.
    pub fn a_max_um(&self, profile: &str, given: Option<f64>, names: &ArgNames) -> Result<Option<f64>, SignalError> {
        resolve_a_max_um(profile, self.amplitude.is_some(), given, self.stated_a_max(), names)
    }

    /// Refuses a carrier the design was not made for ([`check_design_carrier`]).
    pub fn check_carrier(&self, carrier: &Carrier, profile: &str, names: &ArgNames) -> Result<(), SignalError> {
        check_design_carrier(&self.comments, carrier, profile, names)
    }

    /// Renders the design along `trajectory`: one channel, or two with
    /// channel 2 clamped at `a_max_um` (from [`PlayProfile::a_max_um`]).
    /// [`modulate_at_resonance`] then puts channel 2 on the plate's
    /// resonance, if wanted.
    ///
    /// [`modulate_at_resonance`]: super::modulate_at_resonance
    pub fn render(
        &self,
        trajectory: &Trajectory,
        settings: &RenderSettings,
        a_max_um: Option<f64>,
    ) -> Result<DriveSignal, SignalError> {
        match (&self.amplitude, a_max_um) {
            (Some(amplitude), Some(a_max)) => render_two_channel(&self.curve, amplitude, a_max, trajectory, settings),
            _ => render(&self.curve, trajectory, settings),
        }
    }
}

/// Channel 2's a_max for a design named `profile` in messages, with an
/// amplitude channel or not (`has_amplitude`): `given` (`--a-max-um`, at
/// most the `stated` one), else the stated one; `None` without an
/// amplitude channel.
pub fn resolve_a_max_um(
    profile: &str,
    has_amplitude: bool,
    given: Option<f64>,
    stated: Option<f64>,
    names: &ArgNames,
) -> Result<Option<f64>, SignalError> {
    let refuse = |message: String| Err(SignalError::Settings(message));
    let a_max = names.a_max;
    match (has_amplitude, given, stated) {
        (false, Some(_), _) => {
            refuse(format!("{a_max} is for a profile with an amplitude_um column; {profile} has none"))
        }
        (false, None, _) => Ok(None),
        (true, Some(given), Some(stated)) if given > stated => refuse(format!(
            "{a_max} {} is above the a_max = {} um {profile} states it was designed for: give at most that",
            Num(given),
            Num(stated),
        )),
        (true, Some(given), _) => Ok(Some(given)),
        (true, None, Some(stated)) => Ok(Some(stated)),
        (true, None, None) => refuse(format!(
            "{profile} has an amplitude_um column (a combined or ultrasonic display's profile) but no header \
             comment stating its a_max: give {a_max}, the largest amplitude of the plate, to drive channel 2 \
             (the ultrasonic amplitude) with it as limit and full scale"
        )),
    }
}

/// The a_max a display profile's header comment states: the smallest
/// `at most a_max = A um` among its comment lines.
pub fn stated_a_max(comments: &[String]) -> Option<f64> {
    comments
        .iter()
        .flat_map(|l| l.split("at most a_max = ").skip(1).map(str::to_owned).collect::<Vec<_>>())
        .filter_map(|rest| rest.split_whitespace().next().and_then(|v| v.parse::<f64>().ok()))
        .filter(|a| crate::ranges::A_MAX_UM.contains(*a))
        .reduce(f64::min)
}

/// The carrier a frequency-dependent design states it was designed for
/// (`designed for the carrier: SHAPE F Hz`, as `haptex voltage
/// --force-model circuit` writes): the shape word and the frequency, or
/// the unreadable text itself as an error.
pub fn stated_carrier(comments: &[String]) -> Option<Result<(String, f64), String>> {
    let rest = comments.iter().find_map(|l| l.split_once("designed for the carrier: ").map(|(_, r)| r.to_owned()))?;
    let mut words = rest.split_whitespace();
    let parsed = match (words.next(), words.next().and_then(|f| f.parse::<f64>().ok()), words.next()) {
        (Some(shape @ ("sine" | "square" | "none")), Some(f), Some("Hz")) if f.is_finite() && f > 0.0 => {
            Some((shape.to_owned(), f))
        }
        _ => None,
    };
    Some(parsed.ok_or(rest))
}

/// Refuses to play a frequency-dependent design (its `comments`, from the
/// file named `profile`) on another carrier than the one it was designed
/// for: its voltages render the target only there.
pub fn check_design_carrier(
    comments: &[String],
    carrier: &Carrier,
    profile: &str,
    names: &ArgNames,
) -> Result<(), SignalError> {
    let Some(stated) = stated_carrier(comments) else {
        return Ok(());
    };
    let (shape, f_hz) = stated.map_err(|text| {
        SignalError::Settings(format!(
            "{profile}: cannot read the design carrier in its comment ('designed for the carrier: {text}'): expected \
             SHAPE F Hz with SHAPE sine, square or none"
        ))
    })?;
    let played = carrier.shape.name();
    // A direct drive has no frequency; sine and square must match it to
    // the digits written (the comment prints the frequency in full).
    let same = played == shape && (shape == "none" || f_hz == carrier.frequency_hz);
    if !same {
        return Err(SignalError::Settings(format!(
            "{profile} was designed with a frequency-dependent force model for a {shape} carrier at {} Hz, and \
             renders its target only on that carrier: play it with {} (or design it again for {})",
            Num(f_hz),
            names.carrier(&shape, f_hz),
            names.carrier(played, carrier.frequency_hz)
        )));
    }
    Ok(())
}

/// A generated finger trajectory (`haptex play --velocity`): one sweep at
/// constant speed, or `strokes` back-and-forth minimum-jerk strokes at
/// mean speed `velocity_mm_s`, from `from_mm` to `to_mm` (default: the
/// curve's ends); sampled at [`GENERATED_RATE_HZ`]. Returns it with the
/// JSON description a sidecar records.
pub fn generate_trajectory(
    curve: &VoltageCurve,
    velocity_mm_s: f64,
    strokes: Option<u32>,
    from_mm: Option<f64>,
    to_mm: Option<f64>,
) -> Result<(Trajectory, serde_json::Value), TrajectoryError> {
    let (x0, x1) = curve.span_mm();
    let (from, to) = (from_mm.unwrap_or(x0), to_mm.unwrap_or(x1));
    Ok(match strokes {
        None => (
            Trajectory::constant_velocity(from, to, velocity_mm_s, GENERATED_RATE_HZ)?,
            json!({ "generator": "constant_velocity", "from_mm": from, "to_mm": to, "velocity_mm_s": velocity_mm_s }),
        ),
        Some(n) => (
            Trajectory::strokes(from, to, velocity_mm_s, n as usize, GENERATED_RATE_HZ)?,
            json!({ "generator": "minimum_jerk_strokes", "from_mm": from, "to_mm": to,
                    "mean_velocity_mm_s": velocity_mm_s, "strokes": n }),
        ),
    })
}

/// The `source` of a drive WAV's sidecar: the design (`profile`), the
/// trajectory's description, the command that made it.
pub fn sidecar_source(profile: &str, trajectory: &serde_json::Value, command: &str) -> serde_json::Value {
    json!({
        "profile": profile,
        "trajectory": trajectory,
        "command": command,
        "haptex_version": env!("CARGO_PKG_VERSION"),
    })
}
