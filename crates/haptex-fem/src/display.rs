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

use haptex_core::electrovibration::LayerStack;
use haptex_core::num::Num;
use haptex_core::signal::{Extend, VoltageCurve};

use crate::contact::Electrostatic;

/// The display's electrode and dielectric layers.
#[derive(Debug, Clone, PartialEq)]
pub struct Display {
    /// U(x) in V RMS against the finger's position on the display (mm).
    pub voltage: VoltageCurve,
    /// The voltage where the finger is outside the curve's span.
    pub extend: Extend,
    /// The dielectric layers of eq. (3).
    pub stack: LayerStack,
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
}

/// Largest electrostatic traction at contact accepted (MPa): ten times the
/// stiffest tissue's modulus. At the paper's layers it is U = 3.2 kV RMS.
pub const MAX_PRESSURE_MPA: f64 = 1.0;

impl Display {
    /// Checks the layers and that no voltage of the curve pulls harder
    /// than [`MAX_PRESSURE_MPA`].
    pub fn validate(&self) -> Result<(), DisplayError> {
        self.stack.validate()?;
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
        Electrostatic::new(&self.stack, self.voltage_at(x_mm))
    }
}
