//! Relative friction profiles: the paper's "typical (normalized) output in
//! terms of mu_RS" (section 3.1, Fig. 2a), to which it applies eqs. (8) and
//! (9) with mu_HD = 1 (Fig. 2b).
//!
//! A profile is divided by its flat-surface value mu_flat and scaled to the
//! display's own friction mu_HD:
//!
//! ```text
//! mu_rel(x) = mu(x) / mu_flat * mu_HD
//! ```
//!
//! so the display with no voltage stands for the reference surface's flat
//! friction, and eq. (8) renders what the features add to it:
//! mu_rel/mu_HD - 1 = mu/mu_flat - 1, the same for every mu_HD. Eq. (9)
//! sees only the pattern, which a scaling does not change (its voltages are
//! the same to rounding).
//!
//! Where mu_flat comes from ([`FlatMu`]):
//!
//! - **FE profiles** (`haptex simulate`, `haptex predict`, the FE database):
//!   the skin's Coulomb coefficient mu_skin (0.5 for the shipped database).
//!   On a flat surface, once the whole contact slips, Ft/Fn equals mu_skin
//!   (to 1e-9, the steady-sliding validation of docs/fem.md), and every
//!   bump and edge row of the shipped database starts at xi = -5 mm, before
//!   the feature reaches the contact, with Ft/Fn = 0.5 within 1.1e-5. The
//!   caller gives it ([`FlatMu::Given`]): a sine grating has no flat part
//!   to read it from.
//! - **Recordings and user files**: the friction of the finger on the
//!   flat surface when it is known (given), else the profile's median
//!   ([`FlatMu::Median`]): the level the profile keeps over most of its
//!   length, unmoved by features narrower than half of it, where a mean
//!   would be pulled by every peak. It is an estimate, and reported as
//!   one: half of a profile with no flat part lies below its median (on
//!   the shipped database the median is within 0.0004 of 0.5 for every
//!   bump, up to 0.065 above it for an edge, and 0.15 to 0.56 for a sine).

use serde::{Deserialize, Serialize};

use crate::num::Num;
use crate::profile::FrictionProfile;
use crate::ranges::{self, RangeError};

/// How a profile's flat-surface friction mu_flat is obtained.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FlatMu {
    /// A known value: the FE model's skin friction mu_skin, or the friction
    /// measured on the flat surface.
    Given(f64),
    /// The median of the profile's friction values, an estimate.
    Median,
}

/// Where the mu_flat of a relative profile came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FlatSource {
    /// Given by the caller.
    Given,
    /// Estimated as the profile's median.
    Median,
}

impl FlatSource {
    /// How outputs describe the source.
    pub fn describe(self) -> &'static str {
        match self {
            FlatSource::Given => "given",
            FlatSource::Median => "the median of the profile, an estimate",
        }
    }
}

/// A relative profile cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RelativeError {
    /// A given mu_flat (`flat_mu`), or mu_HD, outside its range: not
    /// positive, not finite, or not a friction coefficient.
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// The median cannot stand for the flat-surface friction.
    #[error(
        "the profile's median mu is {}, which cannot be its flat-surface friction (flat_mu must be {}): give \
         flat_mu, the friction of the finger on the flat surface",
        Num(*median),
        ranges::FLAT_MU.describe()
    )]
    Median { median: f64 },
    /// A relative value leaves the accepted range of mu: mu_flat is far
    /// too small for this profile.
    #[error(
        "relative profile at sample {index} (x = {} mm): mu / flat_mu * mu_HD = {} / {} * {} = {} is outside the \
         accepted range of mu ({}): is flat_mu right?",
        Num(*x_mm),
        Num(*mu),
        Num(*flat_mu),
        Num(*mu_hd),
        Num(*value),
        ranges::MU.describe()
    )]
    OutOfMuRange { index: usize, x_mm: f64, mu: f64, flat_mu: f64, mu_hd: f64, value: f64 },
}

/// How a relative profile was made: mu_rel = mu / `flat_mu` * `mu_hd`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Relative {
    /// The profile's flat-surface friction mu_flat.
    pub flat_mu: f64,
    /// Where mu_flat came from.
    pub flat_mu_source: FlatSource,
    /// The display friction mu_HD the profile is scaled to.
    pub mu_hd: f64,
}

impl Relative {
    /// The normalization of `profile` to a display of friction `mu_hd`, with
    /// mu_flat as `flat` says. Errors when mu_flat or mu_hd is outside its
    /// range (both must be positive and finite).
    pub fn new(profile: &FrictionProfile, flat: FlatMu, mu_hd: f64) -> Result<Self, RelativeError> {
        ranges::MU_HD.check(mu_hd)?;
        let (flat_mu, flat_mu_source) = match flat {
            FlatMu::Given(value) => (ranges::FLAT_MU.check(value)?, FlatSource::Given),
            FlatMu::Median => {
                let median = profile.median_mu();
                let flat_mu = ranges::FLAT_MU.check(median).map_err(|_| RelativeError::Median { median })?;
                (flat_mu, FlatSource::Median)
            }
        };
        Ok(Self { flat_mu, flat_mu_source, mu_hd })
    }

    /// mu / mu_flat * mu_HD for one friction value. Divided first, so a
    /// value equal to mu_flat maps to exactly mu_HD.
    #[inline]
    pub fn mu(&self, mu: f64) -> f64 {
        mu / self.flat_mu * self.mu_hd
    }

    /// The relative profile: every friction value mapped by [`Self::mu`],
    /// positions and normal force unchanged.
    pub fn apply(&self, profile: &FrictionProfile) -> Result<FrictionProfile, RelativeError> {
        let mu: Vec<f64> = profile.mu().iter().map(|&m| self.mu(m)).collect();
        if let Some(index) = ranges::MU.first_outside(&mu) {
            return Err(RelativeError::OutOfMuRange {
                index,
                x_mm: profile.x_mm()[index],
                mu: profile.mu()[index],
                flat_mu: self.flat_mu,
                mu_hd: self.mu_hd,
                value: mu[index],
            });
        }
        Ok(profile.with_checked_mu(mu))
    }

    /// One line for summaries and CSV comments.
    pub fn describe(&self) -> String {
        format!(
            "relative profile (paper Fig. 2a): mu = mu_profile / mu_flat * mu_HD with mu_flat = {} ({}) and mu_HD = {}",
            Num(self.flat_mu),
            self.flat_mu_source.describe(),
            Num(self.mu_hd)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn profile(mu: &[f64]) -> FrictionProfile {
        FrictionProfile::new((0..mu.len()).map(|i| i as f64).collect(), mu.to_vec()).unwrap()
    }

    #[test]
    fn median_source_is_the_profiles_median() {
        let p = profile(&[0.5, 0.5, 0.9, 0.5, 0.2]);
        let r = Relative::new(&p, FlatMu::Median, 1.0).unwrap();
        assert_eq!((r.flat_mu, r.flat_mu_source), (0.5, FlatSource::Median));
        assert_eq!(r.apply(&p).unwrap().mu(), [1.0, 1.0, 1.8, 1.0, 0.4]);
    }

    #[test]
    fn a_median_that_is_not_a_friction_coefficient_is_refused() {
        for mu in [[0.0, 0.0, 0.3], [0.0005, 0.0002, 0.3], [20.0, 20.0, 1.0]] {
            let e = Relative::new(&profile(&mu), FlatMu::Median, 1.0).unwrap_err();
            assert!(matches!(e, RelativeError::Median { .. }), "{e}");
            assert!(e.to_string().contains("give flat_mu"), "{e}");
        }
    }

    #[test]
    fn given_values_outside_the_range_are_named() {
        let p = profile(&[0.5, 0.6]);
        for bad in [0.0, -0.5, f64::NAN, f64::INFINITY, 1e-9, 11.0] {
            let e = Relative::new(&p, FlatMu::Given(bad), 1.0).unwrap_err();
            assert!(e.to_string().starts_with("flat_mu must be from 0.001 to 10"), "{bad}: {e}");
        }
        let e = Relative::new(&p, FlatMu::Given(0.5), 0.0).unwrap_err();
        assert!(e.to_string().starts_with("mu_hd must be"), "{e}");
    }

    /// The smallest mu_flat with the largest mu_HD takes mu = 1000 to 1e7:
    /// refused at the first such sample, naming flat_mu, not written out
    /// of range.
    #[test]
    fn relative_values_beyond_the_range_of_mu_are_refused_at_their_sample() {
        let p = profile(&[0.05, 1000.0]);
        let r = Relative::new(&p, FlatMu::Given(0.001), 10.0).unwrap();
        let e = r.apply(&p).unwrap_err();
        assert!(matches!(e, RelativeError::OutOfMuRange { index: 1, .. }), "{e}");
        assert!(e.to_string().contains("is flat_mu right?"), "{e}");
    }

    #[test]
    fn normal_force_is_kept() {
        let p = profile(&[0.5, 0.6]).with_normal_force(vec![0.3, 0.5]).unwrap();
        let r = Relative::new(&p, FlatMu::Given(0.5), 1.0).unwrap().apply(&p).unwrap();
        assert_eq!(r.fn_n(), Some([0.3, 0.5].as_slice()));
        assert_eq!(r.x_mm(), p.x_mm());
    }
}
