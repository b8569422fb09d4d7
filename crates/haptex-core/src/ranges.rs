//! The accepted range of every number a user gives haptex: device and
//! signal parameters, and the quantities of profile, voltage and
//! trajectory files. The one table the command line, the file readers and
//! the web API check against, so that a value accepted in one place is
//! accepted in all.
//!
//! Each value must be finite and within [min, max]. The ranges are far
//! beyond any real finger or display (an insulator is microns thick, a
//! display's voltage hundreds of volts, a friction coefficient below 10)
//! but finite, so that every sum, span, ratio and square computed from
//! accepted values stays finite: eq. (3) and the clip level of eq. (8)
//! stay inside the floating-point range at every corner of the device
//! ranges (a test of the web API walks the corners).

use crate::num::Num;

/// A quantity's name (as the flag, the API field and the CSV column spell
/// it), accepted interval and unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    pub name: &'static str,
    pub min: f64,
    pub max: f64,
    pub unit: &'static str,
}

/// A value outside its [`Range`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{name} must be {}, got {}", range_text(*min, *max, unit), shown(*value, *min, *max))]
pub struct RangeError {
    pub name: &'static str,
    pub value: f64,
    pub min: f64,
    pub max: f64,
    pub unit: &'static str,
}

/// The refused value, in full when [`Num`] would show it as its bound
/// (1000.0000000000001 is not "1000").
fn shown(value: f64, min: f64, max: f64) -> String {
    crate::num::against(value, &[min, max])
}

fn range_text(min: f64, max: f64, unit: &str) -> String {
    let unit = if unit.is_empty() { String::new() } else { format!(" {unit}") };
    format!("from {} to {}{unit}", Num(min), Num(max))
}

impl Range {
    /// Whether `value` is finite and within [min, max].
    pub fn contains(&self, value: f64) -> bool {
        value.is_finite() && value >= self.min && value <= self.max
    }

    /// The value, if it is within the range.
    pub fn check(&self, value: f64) -> Result<f64, RangeError> {
        if self.contains(value) { Ok(value) } else { Err(self.refusal(value)) }
    }

    /// The error for `value`.
    pub fn refusal(&self, value: f64) -> RangeError {
        RangeError { name: self.name, value, min: self.min, max: self.max, unit: self.unit }
    }

    /// `from MIN to MAX UNIT`, for messages and documentation.
    pub fn describe(&self) -> String {
        range_text(self.min, self.max, self.unit)
    }

    /// The index of the first value outside the range.
    pub fn first_outside(&self, values: &[f64]) -> Option<usize> {
        values.iter().position(|v| !self.contains(*v))
    }
}

pub const fn range(name: &'static str, min: f64, max: f64, unit: &'static str) -> Range {
    Range { name, min, max, unit }
}

// Quantities of files and request bodies.

/// Surface heights of a height map (mm): +-1 m, the FE surfaces' limit.
pub const HEIGHT_MM: Range = range("h_mm", -1e3, 1e3, "mm");

/// Positions along the surface (profiles, voltage curves, trajectories,
/// stroke ends): +-1 km.
pub const POSITION_MM: Range = range("x_mm", -1e6, 1e6, "mm");
/// Friction of a profile or map, given or derived: mu = Ft / Fn, the
/// tangential over the normal force on the finger (paper eq. 4), with Ft
/// along the sliding direction. This is the friction a force sensor under
/// the surface measures, not a Coulomb coefficient: over relief it holds
/// the slope's share of the contact force, and on a downslope steeper than
/// the skin's own friction (tan(slope) > mu_skin) the surface pushes the
/// finger along and mu < 0. The FE finger computes such values (the
/// shipped sine database reaches -0.030; `haptex simulate --surface sine
/// --width 0.5 --height 0.5` -0.026), so refusing them would refuse the
/// model's own profiles.
/// eq. (8) renders any target below mu_HD, negative ones included, as
/// U = 0 and counts it in the unrenderable fraction. The Coulomb
/// coefficients (mu_HD, flat_mu, the FE's skin friction) are positive by
/// their own ranges. +-1000 keeps every span and ratio finite. The sign
/// of a recorded force along +x belongs to the recordings pipeline, which
/// knows each stroke's direction ([`crate::recording::pipeline`]:
/// mu = sign(direction) ft_n / fn_n).
pub const MU: Range = range("mu", -1e3, 1e3, "");
/// Tangential (friction) force.
pub const FT_N: Range = range("ft_n", -100.0, 100.0, "N");
/// Normal force of a profile, and the exploration force of eq. (8).
pub const FN_N: Range = range("fn_n", 1e-6, 100.0, "N");
/// Times of a trajectory: +-11.6 days.
pub const TIME_S: Range = range("t_s", -1e6, 1e6, "s");
/// RMS voltages of a voltage profile.
pub const VOLTAGE_V: Range = range("voltage_v", 0.0, 1e6, "V");

// Device (eqs. 3-9).

/// Friction coefficient of the finger on the display, mu_HD.
pub const MU_HD: Range = range("mu_hd", 1e-3, 10.0, "");
/// Highest voltage of the display, U_max (RMS).
pub const U_MAX_V: Range = range("u_max_v", 1e-3, 10_000.0, "V");
/// Relative permittivity of the stratum corneum.
pub const EPS_SC: Range = range("eps_sc", 1.0, 1e6, "");
/// Relative permittivity of the insulator.
pub const EPS_I: Range = range("eps_i", 1.0, 1e6, "");
/// Stratum corneum thickness.
pub const D_SC_MM: Range = range("d_sc_mm", 1e-6, 10.0, "mm");
/// Insulator thickness.
pub const D_I_MM: Range = range("d_i_mm", 1e-6, 10.0, "mm");
/// Contact-area coefficient k of A = k Fn^n.
pub const K_MM2_PER_N: Range = range("k_mm2_per_n", 1e-6, 1e6, "mm^2/N");
/// Contact-area exponent n of A = k Fn^n.
pub const AREA_EXPONENT: Range = range("area_exponent", 1e-3, 2.0, "");
/// Flat-surface friction mu_flat of a reference profile, the value a
/// relative profile (paper Fig. 2a) is divided by ([`crate::relative`]): a
/// friction coefficient of finger on a surface, the range of mu_HD.
pub const FLAT_MU: Range = range("flat_mu", 1e-3, 10.0, "");

// Ultrasonic friction reduction and the combined display
// ([`crate::ultrasonic`], [`crate::combined`]).

/// Peak vibration amplitude of an ultrasonic plate (calibration tables):
/// plates vibrate a few um; 100 um is far beyond any of them.
pub const AMPLITUDE_UM: Range = range("amplitude_um", 0.0, 100.0, "um");
/// Highest vibration amplitude the plate and its driver can reach, a_max.
pub const A_MAX_UM: Range = range("a_max_um", 1e-3, 100.0, "um");
/// Relative friction rho = mu(a) / mu_HD of an ultrasonic calibration:
/// in (0, 1], with a floor of 1e-6 so that 1/rho stays finite.
pub const RELATIVE_FRICTION: Range = range("relative_friction", 1e-6, 1.0, "");
/// Weight of the `weighted` allocation's ultrasonic term.
pub const STRATEGY_WEIGHT: Range = range("weight", 0.0, 1e6, "");
/// DC resistivity of the stratum corneum in the frequency-dependent force
/// model (its relaxation time eps0 eps_sc rho_sc stays finite).
pub const RHO_SC_OHM_M: Range = range("rho_sc_ohm_m", 1e-3, 1e15, "ohm m");
/// Air gap between skin and display in the frequency-dependent force model.
pub const GAP_UM: Range = range("gap_um", 0.0, 1000.0, "um");

// Drive signal.

/// Envelope slew limit.
pub const SLEW_V_PER_S: Range = range("slew_v_per_s", 1e-3, 1e9, "V/s");
/// Peak output of the amplifier.
pub const AMPLIFIER_RANGE_V: Range = range("amplifier_range_v", 1e-3, 100_000.0, "V");
/// Volts at the amplifier output for a full-scale WAV sample.
pub const VOLTS_PER_FULL_SCALE: Range = range("volts_per_full_scale", 1e-3, 100_000.0, "V");
/// Carrier frequency (also below the Nyquist frequency of the rate).
pub const CARRIER_HZ: Range = range("carrier_hz", 1e-3, 1e6, "Hz");
/// Resonance of an ultrasonic plate, the carrier of channel 2 when it is
/// played modulated (`haptex play --plate-resonance-hz`): plates vibrate
/// from about 20 to 100 kHz (Sednaoui et al. 2015, 2017: 27 to 60 kHz);
/// the bounds leave room on both sides.
pub const PLATE_RESONANCE_HZ: Range = range("plate_resonance_hz", 1e3, 1e6, "Hz");
/// Finger speed of a generated stroke.
pub const VELOCITY_MM_S: Range = range("velocity_mm_s", 1e-6, 1e4, "mm/s");

/// Every range, in the order the docs list them.
pub const ALL: &[Range] = &[
    POSITION_MM,
    HEIGHT_MM,
    MU,
    FT_N,
    FN_N,
    TIME_S,
    VOLTAGE_V,
    MU_HD,
    U_MAX_V,
    EPS_SC,
    EPS_I,
    D_SC_MM,
    D_I_MM,
    K_MM2_PER_N,
    AREA_EXPONENT,
    FLAT_MU,
    AMPLITUDE_UM,
    A_MAX_UM,
    RELATIVE_FRICTION,
    STRATEGY_WEIGHT,
    RHO_SC_OHM_M,
    GAP_UM,
    SLEW_V_PER_S,
    AMPLIFIER_RANGE_V,
    VOLTS_PER_FULL_SCALE,
    CARRIER_HZ,
    VELOCITY_MM_S,
];

/// The range of a file column or body field by its name, if it has one.
pub fn of(name: &str) -> Option<&'static Range> {
    ALL.iter().find(|r| r.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_and_message() {
        assert_eq!(U_MAX_V.check(100.0), Ok(100.0));
        assert_eq!(U_MAX_V.check(10_000.0), Ok(10_000.0));
        for bad in [0.0, -1.0, 10_000.5, f64::NAN, f64::INFINITY, 1e308] {
            assert!(U_MAX_V.check(bad).is_err(), "{bad}");
        }
        assert_eq!(U_MAX_V.check(1e308).unwrap_err().to_string(), "u_max_v must be from 0.001 to 10000 V, got 1e308");
        assert_eq!(FN_N.check(5e-324).unwrap_err().to_string(), "fn_n must be from 1e-6 to 100 N, got 5e-324");
        assert_eq!(MU.check(-1e3 - 0.1).unwrap_err().to_string(), "mu must be from -1000 to 1000, got -1000.1");
        assert_eq!(MU.check(-0.2), Ok(-0.2));
        // A value that rounds to its bound at 15 digits is shown in full.
        assert_eq!(
            MU.check(1000.0000000000001).unwrap_err().to_string(),
            "mu must be from -1000 to 1000, got 1000.0000000000001"
        );
        assert_eq!(MU.check(0.1 + 1e3).unwrap_err().to_string(), "mu must be from -1000 to 1000, got 1000.1");
        let names: std::collections::HashSet<_> = ALL.iter().map(|r| r.name).collect();
        assert_eq!(names.len(), ALL.len());
    }
}
