//! The frequency-dependent force model (haptex_core::frequency): its
//! limits against eq. (3), the square wave's closed form against two
//! independent evaluations, and eq. (8) designed with it.

use haptex_core::electrovibration::{Device, LayerStack};
use haptex_core::frequency::{FingerCircuit, ForceModel, square_gain_by_harmonics};
use haptex_core::profile::FrictionProfile;
use haptex_core::signal::{Carrier, CarrierShape};
use haptex_core::{Method, map_profile};
use proptest::prelude::*;

const PAPER: LayerStack = LayerStack::PAPER;

fn carriers(f_hz: f64) -> [Carrier; 3] {
    [CarrierShape::Sine, CarrierShape::Square, CarrierShape::None].map(|shape| Carrier { shape, frequency_hz: f_hz })
}

/// Eq. (3) is the model's limit with no gap and a perfect dielectric (at
/// every frequency and carrier) or a carrier fast against the stratum
/// corneum's relaxation; the issue asks for 1e-9.
#[test]
fn reduces_to_eq3_without_gap_for_a_perfect_dielectric_or_a_fast_carrier() {
    let ideal = FingerCircuit { rho_sc_ohm_m: f64::INFINITY, gap_um: 0.0 };
    for f in [1e-3, 1.0, 100.0, 1e3, 1e6] {
        for c in carriers(f) {
            let g = ideal.carrier_gain(&PAPER, &c);
            assert!((g - 1.0).abs() < 1e-9, "{c:?}: G = {g}");
        }
    }
    assert!((ideal.gain(&PAPER, 0.0) - 1.0).abs() < 1e-9);
    assert!((ideal.gain(&PAPER, f64::INFINITY) - 1.0).abs() < 1e-9);
    // A leaky stratum corneum (corner 109 Hz at rho_sc = 1e5 ohm m, eps_sc
    // 1650): at 1e12 Hz, w tau ~ 1e10 and G - 1 ~ (a/(a+b)) / (w tau)^2.
    let leaky = FingerCircuit { rho_sc_ohm_m: 1e5, gap_um: 0.0 };
    for shape in [CarrierShape::Sine, CarrierShape::Square] {
        let g = leaky.carrier_gain(&PAPER, &Carrier { shape, frequency_hz: 1e12 });
        assert!((g - 1.0).abs() < 1e-9, "{shape:?}: G = {g}");
    }
    assert_eq!(leaky.gain(&PAPER, f64::INFINITY), 1.0);
    // Eq. (3) itself as a model is the gain 1.
    assert_eq!(ForceModel::Eq3.gain(&PAPER), 1.0);
}

/// At DC the stratum corneum conducts: the voltage lies across insulator
/// and gap, G(0) = ((a + b) / (b + g))^2 with a = d_sc/eps_sc, b = d_i/eps_i.
#[test]
fn dc_gain_is_the_insulator_and_gap_alone() {
    let (a, b) = (0.2e-3 / 1650.0, 0.001e-3 / 10.0);
    for gap_um in [0.0, 0.1, 1.0, 10.0] {
        let c = FingerCircuit { rho_sc_ohm_m: 1e5, gap_um };
        let want = ((a + b) / (b + gap_um * 1e-6)).powi(2);
        for g in
            [c.gain(&PAPER, 0.0), c.carrier_gain(&PAPER, &Carrier { shape: CarrierShape::None, frequency_hz: 1.0 })]
        {
            assert!((g / want - 1.0).abs() < 1e-12, "gap {gap_um}: {g} vs {want}");
        }
        // And a slow carrier approaches it (w tau = 2 pi 1e-9 / 1e-3...).
        let slow = c.gain(&PAPER, 1e-6);
        assert!((slow / want - 1.0).abs() < 1e-9, "gap {gap_um}: {slow} vs {want}");
        // At high frequency the gap stays in series with the two layers.
        let fast = c.gain(&PAPER, f64::INFINITY);
        let want_fast = ((a + b) / (a + b + gap_um * 1e-6)).powi(2);
        assert!((fast / want_fast - 1.0).abs() < 1e-12);
    }
}

/// The square wave's closed form against the sum over its odd harmonics
/// (8 / (pi k)^2 of the power at k f each), 200 000 harmonics: the
/// remainder falls as 1/K^3, below 1e-9 relative at these carriers.
#[test]
fn square_wave_closed_form_matches_its_harmonics() {
    for (rho, gap) in [(1e5, 0.0), (1e4, 0.5), (3e6, 2.0), (1e5, 20.0)] {
        let c = FingerCircuit { rho_sc_ohm_m: rho, gap_um: gap };
        let corner = c.corner_hz(&PAPER);
        for f in [corner / 30.0, corner / 3.0, corner, 3.0 * corner, 30.0 * corner] {
            let closed = c.square_gain(&PAPER, f);
            let sum = square_gain_by_harmonics(&c, &PAPER, f, 200_000);
            assert!(((closed - sum) / sum).abs() < 1e-9, "rho {rho} gap {gap} f {f}: {closed} vs {sum}");
        }
    }
}

/// A third evaluation, in the time domain: the charge of the lead-lag
/// circuit stepped exactly (exponential update of the low-pass state over
/// each constant half period, sampled finely within it) and the mean of
/// Q^2 over the last period, against both the square wave's and the
/// sine's closed forms.
#[test]
fn time_domain_mean_force_matches_the_closed_forms() {
    let (a, b) = (0.2e-3 / 1650.0, 0.001e-3 / 10.0);
    let eps0 = haptex_core::electrovibration::EPS0_F_PER_M;
    for (rho, gap_um, f) in [(1e5, 0.0, 30.0), (1e5, 0.0, 300.0), (2e4, 1.0, 1000.0)] {
        let c = FingerCircuit { rho_sc_ohm_m: rho, gap_um };
        let g = gap_um * 1e-6;
        let tau = eps0 * 1650.0 * rho;
        let c0 = a + b + g;
        let tau2 = tau * c0 / (b + g);
        let (alpha, beta) = (1.0 / c0, a / (c0 * (b + g)));
        let q_eq3 = 1.0 / (a + b);
        // Charge per eps0: Q = alpha U + beta y, y' = (U - y) / tau2.
        let mean_q2 = |u: &dyn Fn(f64) -> f64| {
            let n = 20_000usize;
            let dt = 1.0 / f / n as f64;
            let mut y = 0.0;
            let mut acc = 0.0;
            let periods = 2 + (20.0 * tau2 * f).ceil() as usize;
            for p in 0..periods {
                for i in 0..n {
                    // Midpoint input over the sub-step, exact exponential decay.
                    let t = (p * n + i) as f64 * dt;
                    let uin = u(t + dt / 2.0);
                    let y_mid = uin + (y - uin) * (-dt / (2.0 * tau2)).exp();
                    y = uin + (y - uin) * (-dt / tau2).exp();
                    if p == periods - 1 {
                        let q = alpha * uin + beta * y_mid;
                        acc += q * q;
                    }
                }
            }
            acc / n as f64
        };
        let square = mean_q2(&|t: f64| if (t * f).fract() < 0.5 { 1.0 } else { -1.0 }) / (q_eq3 * q_eq3);
        let sine =
            mean_q2(&|t: f64| std::f64::consts::SQRT_2 * (2.0 * std::f64::consts::PI * f * t).sin()) / (q_eq3 * q_eq3);
        // Midpoint sampling of 20 000 steps a period: about 1e-6 relative.
        let (sq, si) = (c.square_gain(&PAPER, f), c.gain(&PAPER, f));
        assert!(((square - sq) / sq).abs() < 1e-5, "square rho {rho} gap {gap_um} f {f}: {square} vs {sq}");
        assert!(((sine - si) / si).abs() < 1e-5, "sine rho {rho} gap {gap_um} f {f}: {sine} vs {si}");
    }
}

/// Relative rounding allowance of a gain: G is a rational expression of
/// about 20 correctly rounded operations (each within half an ulp, 1.1e-16
/// relative), so two exact gains that are equal or nearly so may compare
/// either way by a few 1e-16; 1e-13 leaves a wide margin over that and is
/// still far below any change the properties are about (0.1 % of f moves G
/// by up to 7.5e-4 relative near the corner). A fresh CI run once found
/// G(f) = 1.000000000000042 < G(1.001 f) = 1.0000000000000422 far above the
/// corner, where G is flat to rounding.
const GAIN_ROUNDING: f64 = 1e-13;

proptest! {
    /// Without a gap the gain falls monotonically and continuously with the
    /// carrier frequency, from G(0) > 1 down to 1; a gap lowers it at every
    /// frequency. Each comparison allows [`GAIN_ROUNDING`] (relative).
    #[test]
    fn gain_falls_with_frequency_and_with_the_gap(
        log_rho in 2.0f64..9.0,
        gap_um in 0.01f64..50.0,
        log_f in -1.0f64..5.0,
    ) {
        let c = FingerCircuit { rho_sc_ohm_m: 10f64.powf(log_rho), gap_um: 0.0 };
        let f = 10f64.powf(log_f);
        let (g0, g1, g2) = (c.gain(&PAPER, f), c.gain(&PAPER, f * 1.001), c.gain(&PAPER, f * 1.01));
        let at_least = |a: f64, b: f64| a >= b * (1.0 - GAIN_ROUNDING);
        prop_assert!(at_least(g0, g1) && at_least(g1, g2), "{g0} {g1} {g2}");
        prop_assert!(at_least(g2, 1.0) && at_least(c.gain(&PAPER, 0.0), g0), "{g2} {g0}");
        prop_assert!((g0 - g1).abs() < 0.01 * g0);
        let (s0, s1) = (c.square_gain(&PAPER, f), c.square_gain(&PAPER, f * 1.01));
        prop_assert!(at_least(s0, s1) && at_least(s1, 1.0), "{s0} {s1}");
        // The smallest gap (0.01 um) adds 1e-5 mm to a stack of at most
        // d_sc/eps_sc + d_i/eps_i = 2.2e-4 mm: G falls by several percent,
        // far beyond rounding, so the comparison is strict.
        let with_gap = FingerCircuit { gap_um, ..c };
        prop_assert!(with_gap.gain(&PAPER, f) < c.gain(&PAPER, f));
    }
}

/// The case a fresh CI run's random seed found (issue 35), kept: far above
/// the corner G is 1 to rounding, and G(f) and G(1.001 f) differ in the
/// 14th digit, in the direction rounding chose; within [`GAIN_ROUNDING`].
#[test]
fn gain_falls_with_frequency_the_ci_case() {
    let c = FingerCircuit { rho_sc_ohm_m: 10f64.powf(8.691188210201037), gap_um: 0.0 };
    let f = 10f64.powf(4.983495846171337);
    let (g0, g1) = (c.gain(&PAPER, f), c.gain(&PAPER, f * 1.001));
    assert!((g0 - 1.0).abs() < 1e-12 && (g1 - 1.0).abs() < 1e-12, "{g0} {g1}");
    assert!(g0 >= g1 * (1.0 - GAIN_ROUNDING), "{g0} {g1}");
}

/// Eq. (8) designed with the model: the voltage is eq. (3)'s divided by
/// sqrt(G), so the design for a 100 Hz carrier and for 1 kHz differ as the
/// circuit says; G = 1 leaves eq. (8) unchanged to the bit.
#[test]
fn voltage_design_follows_the_carrier() {
    let x: Vec<f64> = (0..50).map(|i| i as f64 * 0.2).collect();
    let mu: Vec<f64> = x.iter().map(|x| 1.0 + 0.1 * (-(x - 5.0) * (x - 5.0)).exp()).collect();
    let p = FrictionProfile::new(x, mu).unwrap();
    let circuit = FingerCircuit { rho_sc_ohm_m: 1e5, gap_um: 0.0 };
    let eq3 = map_profile(&p, &Device::PAPER, Method::Physical, None).unwrap();
    let same = map_profile(&p, &Device { force_gain: 1.0, ..Device::PAPER }, Method::Physical, None).unwrap();
    assert_eq!(eq3.voltage_v, same.voltage_v);
    let mut designs = Vec::new();
    for f in [100.0, 1000.0] {
        let model = ForceModel::Circuit { circuit, carrier: Carrier { shape: CarrierShape::Sine, frequency_hz: f } };
        let gain = model.gain(&PAPER);
        let device = Device { force_gain: gain, ..Device::PAPER };
        let v = map_profile(&p, &device, Method::Physical, None).unwrap();
        for (u, u3) in v.voltage_v.iter().zip(&eq3.voltage_v) {
            assert!((u - u3 / gain.sqrt()).abs() <= 1e-12 * u3, "{u} vs {}", u3 / gain.sqrt());
        }
        designs.push((gain, v.summary.voltage_max_v));
    }
    // 100 Hz is at the corner (109 Hz): it needs clearly less voltage.
    assert!(designs[0].0 > 1.5 && (designs[1].0 - 1.0) < 0.02, "{designs:?}");
    assert!(designs[0].1 < 0.8 * designs[1].1);
}

/// A gain that is not finite and positive is refused by the device check.
#[test]
fn degenerate_gains_are_refused() {
    for g in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(Device { force_gain: g, ..Device::PAPER }.validate().is_err(), "{g}");
    }
    for bad in [FingerCircuit { rho_sc_ohm_m: -1.0, gap_um: 0.0 }, FingerCircuit { rho_sc_ohm_m: 1e5, gap_um: -1.0 }] {
        assert!(bad.validate().is_err());
    }
}
