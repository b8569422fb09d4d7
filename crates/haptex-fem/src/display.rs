//! The electrovibration display as a contact partner: a flat rigid surface
//! (Coulomb friction mu_HD, unchanged by the voltage) with one electrode
//! under a voltage U that follows the finger, U(x_f(t)), x_f the finger's
//! position on the display (the slide, the x of the friction profiles).
//! The voltage adds an electrostatic attraction on the skin
//! ([`crate::contact::Electrostatic`]); the friction law then acts on the
//! total contact pressure, as the paper's FE framework does ("friction
//! modulation due to electrostatic attraction directly from applied
//! voltage signal ... without changing the friction properties of the
//! surface", section 2.4).
//!
//! A combined display also vibrates ([`Vibration`]): the plate's amplitude
//! follows the finger too, a(x_f(t)), and lowers the skin-display friction
//! coefficient to mu_HD rho(a) ([`haptex_core::ultrasonic`]). The
//! electrostatic attraction acts on top of it, so the finger feels
//! mu_HD rho(a) (1 + Fe/Fn) (docs/physics.md, "The combined display").

use haptex_core::electrovibration::LayerStack;
use haptex_core::num::Num;
use haptex_core::profile::interpolate;
use haptex_core::signal::{Extend, VoltageCurve};
use haptex_core::ultrasonic::UltrasonicDevice;

use crate::contact::Electrostatic;

/// The display's electrode and dielectric layers, and its vibration if it
/// is a combined display.
#[derive(Debug, Clone, PartialEq)]
pub struct Display {
    /// U(x) in V RMS against the finger's position on the display (mm).
    pub voltage: VoltageCurve,
    /// The voltage (and amplitude) where the finger is outside the curve's span.
    pub extend: Extend,
    /// The dielectric layers of eq. (3).
    pub stack: LayerStack,
    /// The ultrasonic vibration, if any.
    pub vibration: Option<Vibration>,
    /// An air gap between skin and display where they touch, um (0: none;
    /// [`Electrostatic`]): the traction at geometric gap g is that of
    /// max(g, 0) + the air gap. Eq. (8) assumes none.
    pub air_gap_um: f64,
}

/// An ultrasonic plate's vibration that follows the finger: amplitude
/// a(x) in um (peak) against the finger's position on the display, and the
/// plate's relative friction rho(a). The skin-display friction is then
/// mu_HD rho(a(x_f)).
#[derive(Debug, Clone, PartialEq)]
pub struct Vibration {
    x_mm: Vec<f64>,
    amplitude_um: Vec<f64>,
    device: UltrasonicDevice,
    mu_hd: f64,
}

impl Vibration {
    /// The vibration a(x) (positions in mm strictly increasing, amplitudes
    /// within 0 ..= the device's a_max) of a plate whose friction at rest
    /// is `mu_hd` (the scenario's skin-display friction).
    pub fn new(
        x_mm: Vec<f64>,
        amplitude_um: Vec<f64>,
        device: UltrasonicDevice,
        mu_hd: f64,
    ) -> Result<Self, DisplayError> {
        let invalid = |message: String| Err(DisplayError::Vibration(message));
        if x_mm.len() < 2 || amplitude_um.len() != x_mm.len() {
            return invalid(format!("{} amplitudes for {} positions (at least 2)", amplitude_um.len(), x_mm.len()));
        }
        if let Some(i) = x_mm.windows(2).position(|w| !(w[0].is_finite() && w[1].is_finite() && w[1] > w[0])) {
            let (next, previous) = haptex_core::num::distinct(x_mm[i + 1], x_mm[i]);
            return invalid(format!("positions must be finite and increasing: {next} follows {previous}"));
        }
        if let Some(i) = amplitude_um.iter().position(|a| !(0.0..=device.a_max_um()).contains(a)) {
            return invalid(format!(
                "{} um at x = {} mm is outside 0 .. a_max = {} um",
                Num(amplitude_um[i]),
                Num(x_mm[i]),
                Num(device.a_max_um())
            ));
        }
        Ok(Self { x_mm, amplitude_um, device, mu_hd })
    }

    /// The amplitude in um with the finger at `x_mm`.
    pub fn amplitude_at(&self, x_mm: f64, extend: Extend) -> f64 {
        let (x0, x1) = (self.x_mm[0], self.x_mm[self.x_mm.len() - 1]);
        extend.position(x_mm, x0, x1).map_or(0.0, |x| interpolate(&self.x_mm, &self.amplitude_um, x))
    }

    /// The skin-display friction coefficient mu_HD rho(a) with the finger
    /// at `x_mm`.
    pub fn friction_at(&self, x_mm: f64, extend: Extend) -> f64 {
        self.mu_hd * self.device.relative_friction(self.amplitude_at(x_mm, extend))
    }

    /// The plate's friction at rest, mu_HD.
    pub fn mu_hd(&self) -> f64 {
        self.mu_hd
    }
}

/// The display is invalid.
#[derive(Debug, thiserror::Error)]
pub enum DisplayError {
    #[error("display layers: {0}")]
    Stack(#[from] haptex_core::electrovibration::ElectroError),
    #[error(
        "voltage {} V at x = {} mm attracts the skin with {} MPa at contact (eq. 3): more than {} MPa, beyond \
         what the finger model is for (its tissue moduli are below 0.1 MPa)",
        Num(*voltage_v), Num(*x_mm), Num(*pressure_mpa), Num(MAX_PRESSURE_MPA)
    )]
    TooStrong { voltage_v: f64, x_mm: f64, pressure_mpa: f64 },
    #[error("display vibration: {0}")]
    Vibration(String),
    #[error("the air gap must be a finite length >= 0, got {} um", Num(*.0))]
    AirGap(f64),
}

/// Largest electrostatic traction at contact accepted (MPa): ten times the
/// stiffest tissue's modulus. At the paper's layers it is U = 3.2 kV RMS.
pub const MAX_PRESSURE_MPA: f64 = 1.0;

impl Display {
    /// Checks the layers and that no voltage of the curve pulls harder
    /// than [`MAX_PRESSURE_MPA`].
    pub fn validate(&self) -> Result<(), DisplayError> {
        self.stack.validate()?;
        if !(self.air_gap_um.is_finite() && self.air_gap_um >= 0.0) {
            return Err(DisplayError::AirGap(self.air_gap_um));
        }
        for (&x_mm, &voltage_v) in self.voltage.x_mm().iter().zip(self.voltage.voltage_v()) {
            let pressure_mpa = Electrostatic::new(&self.stack, voltage_v).pressure_mpa;
            if pressure_mpa.is_nan() || pressure_mpa > MAX_PRESSURE_MPA {
                return Err(DisplayError::TooStrong { voltage_v, x_mm, pressure_mpa });
            }
        }
        Ok(())
    }

    /// The voltage (V RMS) with the finger at `x_mm` on the display.
    pub fn voltage_at(&self, x_mm: f64) -> f64 {
        self.voltage.voltage_at(x_mm, self.extend)
    }

    /// The electrostatic law with the finger at `x_mm`.
    pub fn electrostatic_at(&self, x_mm: f64) -> Electrostatic {
        Electrostatic::new(&self.stack, self.voltage_at(x_mm)).with_air_gap(self.air_gap_um * 1e-3)
    }

    /// The skin-display friction coefficient with the finger at `x_mm`:
    /// mu_HD rho(a(x)) with a vibration, else `None` (the scenario's).
    pub fn friction_at(&self, x_mm: f64) -> Option<f64> {
        self.vibration.as_ref().map(|v| v.friction_at(x_mm, self.extend))
    }
}
