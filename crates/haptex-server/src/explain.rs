//! What every parameter the GUI sets means: the symbol as the paper writes
//! it, the unit, a one-line meaning, the typical range with its source, and
//! the range the server accepts. One table, served in `GET /api/config`
//! (`explanations`), that the page builds its explanations and its
//! out-of-range warnings from, so the page cannot drift from the server.
//!
//! The accepted range is the one the server checks the field against
//! ([`haptex_core::ranges`], [`crate::fields`]), taken from the same
//! constants; a test checks that every typical range lies inside it, so a
//! typical value is always accepted.
//!
//! Sources: the paper's Fig. 2 constants and `physics.md` (the project's
//! physics notes, which mark secondary values "verify"). Where neither gives
//! a typical range, `typical` is `None` and the source says so: the page
//! then shows the paper's value and no warning.

use haptex_core::ranges::{self, Range};
use serde::Serialize;

use crate::fields;

/// A typical interval, [min, max], in the field's unit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    pub min: f64,
    pub max: f64,
}

/// One parameter of the page.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Explanation {
    /// The request field (as `/api/voltage`, `/api/check` or `/api/play`
    /// name it; the page's control carries it as `data-param` or
    /// `data-field`).
    pub field: &'static str,
    /// The control's name in the page, for messages that point to it.
    pub label: &'static str,
    /// The symbol as in the paper (ASCII: `mu_HD`, `eps_sc`, `d_sc`).
    pub symbol: &'static str,
    /// The unit ("" for a pure number).
    pub unit: &'static str,
    /// One line: what the parameter is.
    pub meaning: &'static str,
    /// The typical range, `None` where no source gives one.
    pub typical: Option<Interval>,
    /// Where the typical range (or the default) comes from.
    pub source: &'static str,
    /// The range the server accepts.
    pub accepted: Interval,
}

const fn accepted(range: Range) -> Interval {
    Interval { min: range.min, max: range.max }
}

const fn typical(min: f64, max: f64) -> Option<Interval> {
    Some(Interval { min, max })
}

/// Every explained parameter, in the order the page shows them.
pub const EXPLANATIONS: &[Explanation] = &[
    Explanation {
        field: "mu_hd",
        label: "mu_HD (Device and finger)",
        symbol: "mu_HD",
        unit: "",
        meaning: "friction coefficient of the finger on the display with no voltage; eq. (8) raises friction above it",
        typical: typical(0.4, 1.0),
        source: "dry skin on glass: 0.4 to 0.8, typically 0.5 (Derler & Gerhardt 2012, as cited in \
                 haptex's physics notes, section 2, marked 'verify' there); 1 in the paper's Fig. 2, where mu_HD stands for the \
                 surface's flat friction of a relative profile",
        accepted: accepted(ranges::MU_HD),
    },
    Explanation {
        field: "u_max_v",
        label: "U_max (Device and finger)",
        symbol: "U_max",
        unit: "V",
        meaning: "highest RMS voltage the display applies: the clip level of eq. (8), the full scale of eq. (9)",
        typical: None,
        source: "100 V in the paper's Fig. 2; no typical range sourced (the paper and haptex's physics notes give none)",
        accepted: accepted(ranges::U_MAX_V),
    },
    Explanation {
        field: "eps_sc",
        label: "eps_sc (Device and finger)",
        symbol: "eps_sc",
        unit: "",
        meaning: "relative permittivity of the stratum corneum, the skin's outer layer (eq. 3)",
        typical: None,
        source: "1650 in the paper's Fig. 2; no typical range sourced (the paper and haptex's physics notes give none)",
        accepted: accepted(ranges::EPS_SC),
    },
    Explanation {
        field: "eps_i",
        label: "eps_i (Device and finger)",
        symbol: "eps_i",
        unit: "",
        meaning: "relative permittivity of the display's insulator (eq. 3)",
        typical: None,
        source: "10 in the paper's Fig. 2; no typical range sourced (the paper and haptex's physics notes give none)",
        accepted: accepted(ranges::EPS_I),
    },
    Explanation {
        field: "d_sc_mm",
        label: "d_sc (Device and finger)",
        symbol: "d_sc",
        unit: "mm",
        meaning: "thickness of the stratum corneum, the skin's outer dielectric layer (eq. 3)",
        typical: typical(0.2, 0.3),
        source: "stratum corneum 0.2 to 0.3 mm at the finger pad (haptex's physics notes, section 2, \
                 marked 'verify' there); 0.2 mm in the paper's Fig. 2",
        accepted: accepted(ranges::D_SC_MM),
    },
    Explanation {
        field: "d_i_mm",
        label: "d_i (Device and finger)",
        symbol: "d_i",
        unit: "mm",
        meaning: "thickness of the display's insulator (eq. 3)",
        typical: None,
        source: "0.001 mm in the paper's Fig. 2; no typical range sourced (the paper and haptex's physics notes give none)",
        accepted: accepted(ranges::D_I_MM),
    },
    Explanation {
        field: "k_mm2_per_n",
        label: "k (Device and finger)",
        symbol: "k",
        unit: "mm^2/N",
        meaning: "contact-area coefficient of A = k Fn^n: the finger's contact area per newton of load",
        typical: None,
        source: "200 mm^2/N in the paper's Fig. 2; no typical range sourced (the paper and haptex's physics notes give none)",
        accepted: accepted(ranges::K_MM2_PER_N),
    },
    Explanation {
        field: "area_exponent",
        label: "n (Device and finger)",
        symbol: "n",
        unit: "",
        meaning: "contact-area exponent of A = k Fn^n; 1 is the paper's linear law, below 1 eq. (8) needs Fn",
        typical: typical(0.3, 1.0),
        source: "1 in the paper (valid below about 0.5 N); 0.3 to 0.7 for higher loads (Adams et al. 2013, as \
                 cited in haptex's physics notes, section 1, marked 'verify' there)",
        accepted: accepted(ranges::AREA_EXPONENT),
    },
    Explanation {
        field: "fn_n",
        label: "Fn (Device and finger)",
        symbol: "F_n",
        unit: "N",
        meaning: "normal force the finger explores with; used only when n is not 1 (default: the profile's mean)",
        typical: typical(0.1, 1.0),
        source: "exploration force 0.1 to 1 N (haptex's physics notes, section 2)",
        accepted: accepted(ranges::FN_N),
    },
    Explanation {
        field: "flat_mu",
        label: "flat-surface friction mu_flat (Method)",
        symbol: "mu_flat",
        unit: "",
        meaning: "friction of the reference surface where it is flat; a relative profile is mu / mu_flat * mu_HD",
        typical: typical(0.1, 0.8),
        source: "mean kinetic friction 0.108 (wax paper) to 0.797 (sandpaper) of a tool on materials (Culbertson \
                 et al. 2014, haptex's physics notes, section 5) and 0.4 to 0.8 for skin on glass (haptex's physics notes, section 2); \
                 0.5, the skin friction of the FE database's templates (the database's metadata)",
        accepted: accepted(ranges::FLAT_MU),
    },
    Explanation {
        field: "load_n_per_mm",
        label: "load (Finger on the display)",
        symbol: "F_n / w",
        unit: "N/mm",
        meaning: "normal load of the FE finger on the display per mm of finger width (the 2D model is per mm)",
        typical: typical(0.0067, 0.05),
        source: "exploration force 0.1 to 1 N (haptex's physics notes, section 2) over a 15 mm wide pad, capped at 0.05 \
                 N/mm where the FE finger's contact nears the end of its contact region (haptex's measurement with its \
                 FE finger)",
        accepted: accepted(fields::LOAD_N_PER_MM),
    },
    Explanation {
        field: "a_max_um",
        label: "a_max (Display)",
        symbol: "a_max",
        unit: "um",
        meaning: "highest vibration amplitude (peak) of the ultrasonic plate: the clip level of a(x) and the full \
                  scale of the drive's channel 2",
        typical: typical(1.0, 2.3),
        source: "typical plates: 27 to 60 kHz resonance, 1 to 2.3 µm amplitude (haptex's physics notes, \
                 'Ultrasonic friction reduction', from Wiertlewski et al. 2016, Vezzoli et al. 2017 and Sednaoui et al. 2017); default: \
                 the calibration's last amplitude, or 2.3 µm, the literature default's validity limit",
        accepted: accepted(ranges::A_MAX_UM),
    },
    Explanation {
        field: "weight",
        label: "weight (Display)",
        symbol: "w",
        unit: "",
        meaning: "weighted strategy: the cost of the vibration leaving its bias level against the voltage's share \
                  of U_max; 0 is split, large approaches bias",
        typical: None,
        source: "haptex's cost (physics notes, 'The combined display'); default 1 weighs full voltage against the \
                 vibration fully off; no typical range sourced (a design choice, not a measured quantity)",
        accepted: accepted(ranges::STRATEGY_WEIGHT),
    },
    Explanation {
        field: "velocity_mm_s",
        label: "Finger velocity (Playback)",
        symbol: "v",
        unit: "mm/s",
        meaning: "speed of the finger along the profile, which turns U(x) into U(t) for the stroke and audio",
        typical: typical(10.0, 200.0),
        source: "exploration velocity 10 to 200 mm/s (haptex's physics notes, section 2)",
        accepted: accepted(ranges::VELOCITY_MM_S),
    },
    Explanation {
        field: "carrier_hz",
        label: "Carrier frequency (Playback)",
        symbol: "f_c",
        unit: "Hz",
        meaning: "frequency of the sine carrier whose RMS amplitude is U; the force ripples at twice it",
        typical: None,
        source: "no typical range sourced (the paper and haptex's physics notes give none)",
        accepted: accepted(ranges::CARRIER_HZ),
    },
];

/// The flags of the command line that messages shared with it name, and
/// the page's control each stands for.
const FLAGS: &[(&str, &str)] = &[
    ("--method normalized", "the method normalized (eq. 9)"),
    ("--method physical", "the method physical (eq. 8)"),
    ("--relative", "the box relative (Fig. 2) under Method"),
    ("--flat-mu", "flat-surface friction mu_flat (Method)"),
    ("--mu-hd", "mu_HD (Device and finger)"),
    ("--u-max", "U_max (Device and finger)"),
    ("--fn-n", "Fn (Device and finger)"),
    ("--display combined", "the display combined (Display)"),
    ("--ultrasonic-calibration", "the ultrasonic calibration file (Display)"),
    ("--a-max-um", "a_max (Display)"),
    ("--strategy", "the strategy (Display)"),
    ("--weight", "the weight (Display)"),
];

/// A message of the library (written for the command line) as the page
/// shows it: each flag it names replaced by the page's control.
pub fn for_page(message: &str) -> String {
    let mut text = message.to_string();
    for (flag, control) in FLAGS {
        text = text.replace(flag, control);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typical_ranges_lie_inside_the_accepted_ones() {
        for e in EXPLANATIONS {
            if let Some(t) = e.typical {
                assert!(t.min < t.max, "{}", e.field);
                assert!(t.min >= e.accepted.min && t.max <= e.accepted.max, "{}", e.field);
            }
            assert!(!e.symbol.is_empty() && !e.meaning.is_empty() && !e.source.is_empty(), "{}", e.field);
        }
    }

    #[test]
    fn page_messages_name_controls_not_flags() {
        let cli =
            "U = 0 V everywhere; lower --mu-hd, map the profile relative (--relative), or use --method normalized";
        let page = for_page(cli);
        assert!(!page.contains("--"), "{page}");
        assert!(page.contains("mu_HD (Device and finger)") && page.contains("the method normalized (eq. 9)"), "{page}");
    }
}
