//! The combined display (docs/physics.md, "The combined display"): the
//! allocation of a target friction to electrovibration and ultrasonic
//! friction reduction, checked against the model it inverts,
//! mu = mu_HD rho(a) (1 + Fe(U)/Fn) (Vezzoli et al. 2015), evaluated
//! independently here from eq. (3) and the ultrasonic device's rho(a).

use haptex_core::combined::{Channels, DisplayKind, DisplayProfile, StrategyKind, map_display};
// Named apart from proptest's `Strategy` trait.
use haptex_core::combined::Strategy as Allocation;
use haptex_core::electrovibration::{ContactArea, Device, LayerStack, Method, map_profile};
use haptex_core::io::Table;
use haptex_core::profile::FrictionProfile;
use haptex_core::relative::FlatMu;
use haptex_core::ultrasonic::{Calibration, UltrasonicDevice};
use proptest::prelude::*;

/// The felt friction of a designed pair, from the model's parts: eq. (3)
/// with A = k Fn (Fe/Fn per V^2 at 1 N) and rho(a) of the device.
fn felt(device: &Device, ultrasonic: Option<&UltrasonicDevice>, u_v: f64, a_um: f64) -> f64 {
    let rho = ultrasonic.map_or(1.0, |d| d.relative_friction(a_um));
    device.mu_hd * rho * (1.0 + device.force_ratio_per_v2(1.0) * u_v * u_v)
}

fn profile(mu: &[f64]) -> FrictionProfile {
    FrictionProfile::new((0..mu.len()).map(|i| i as f64 * 0.01).collect(), mu.to_vec()).unwrap()
}

fn strategies() -> [Allocation; 5] {
    [
        Allocation::Split,
        Allocation::Bias,
        Allocation::Weighted { weight: 0.0 },
        Allocation::Weighted { weight: 1.0 },
        Allocation::Weighted { weight: 50.0 },
    ]
}

/// A random electrovibration device around the paper's (each constant
/// within a factor of a few of Fig. 2's), mu_HD 0.2 .. 3, U_max 10 .. 500 V.
fn any_device() -> impl proptest::strategy::Strategy<Value = Device> {
    (0.2f64..3.0, 10.0f64..500.0, 50.0f64..500.0, 300.0f64..5000.0, 0.05f64..0.5, 0.0002f64..0.005).prop_map(
        |(mu_hd, u_max_v, k, eps_sc, d_sc_mm, d_i_mm)| Device {
            stack: LayerStack { d_sc_mm, eps_sc, d_i_mm, eps_i: 10.0 },
            contact: ContactArea { k_mm2_per_n: k, exponent: 1.0 },
            mu_hd,
            u_max_v,
            force_gain: 1.0,
        },
    )
}

/// A random ultrasonic device: the literature default with a_max 0.1 ..
/// 2.3 um, or a calibration of 2 to 12 points (amplitude steps 0.05 ..
/// 1 um, rho falling by a factor 0.3 .. 0.99 per step), cut at a random
/// a_max.
fn any_ultrasonic() -> impl proptest::strategy::Strategy<Value = UltrasonicDevice> {
    let literature = (0.1f64..2.3).prop_map(|a| UltrasonicDevice::literature_default(Some(a)).unwrap());
    let calibrated =
        (prop::collection::vec((0.05f64..1.0, 0.3f64..0.99), 1..12), 0.05f64..=1.0).prop_map(|(steps, cut)| {
            let (mut a, mut rho) = (vec![0.0], vec![1.0]);
            for (da, factor) in steps {
                a.push(a[a.len() - 1] + da);
                rho.push(rho[rho.len() - 1] * factor);
            }
            let a_max = (a[a.len() - 1] * cut).max(1e-3);
            UltrasonicDevice::calibrated(Calibration::new(a, rho, "random").unwrap(), Some(a_max)).unwrap()
        });
    prop_oneof![literature, calibrated]
}

fn any_strategy() -> impl proptest::strategy::Strategy<Value = Allocation> {
    prop_oneof![
        Just(Allocation::Split),
        Just(Allocation::Bias),
        Just(Allocation::Weighted { weight: 0.0 }),
        (-3.0f64..4.0).prop_map(|e| Allocation::Weighted { weight: 10f64.powf(e) }),
    ]
}

/// Targets spread over the band and beyond it: t in [-0.3, 1.3] maps to
/// lo (hi/lo)^t, plus the band's ends and mu_HD exactly (at most 999).
fn targets(ts: &[f64], band: [f64; 2], mu_hd: f64) -> Vec<f64> {
    let [lo, hi] = band;
    // Within the accepted range of mu (|mu| <= 1000).
    let mut mu: Vec<f64> = ts.iter().map(|t| (lo * (hi / lo).powf(*t)).min(999.0)).collect();
    mu.extend([lo, hi.min(999.0), mu_hd]);
    mu
}

/// The band of a device pair, as the mapping reports it.
fn band_of(device: &Device, ultrasonic: &UltrasonicDevice) -> [f64; 2] {
    let p = profile(&[device.mu_hd, device.mu_hd]);
    map_display(&p, device, Channels::Combined(ultrasonic, Allocation::Split), None, None).unwrap().summary.band_mu
}

fn design(mu: &[f64], device: &Device, channels: Channels<'_>) -> (DisplayProfile, Vec<f64>, Vec<f64>) {
    let d = map_display(&profile(mu), device, channels, None, None).unwrap();
    let n = mu.len();
    let u = d.voltage_v.clone().unwrap_or_else(|| vec![0.0; n]);
    let a = d.amplitude_um.clone().unwrap_or_else(|| vec![0.0; n]);
    (d, u, a)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, failure_persistence: None, ..ProptestConfig::default() })]

    /// Acceptance (issue 16): the felt friction of the designed (U, a)
    /// equals the target to 1e-9 (relative to max(1, mu)) wherever the
    /// target is inside the band, for every strategy and display; outside
    /// the band the channels saturate; no value passes its limit.
    #[test]
    fn round_trip_inside_the_band_and_limits_everywhere(
        device in any_device(),
        ultrasonic in any_ultrasonic(),
        strategy in any_strategy(),
        ts in prop::collection::vec(-0.3f64..1.3, 1..200),
    ) {
        let band = band_of(&device, &ultrasonic);
        let mu = targets(&ts, band, device.mu_hd);
        for (channels, us, ev) in [
            (Channels::Combined(&ultrasonic, strategy), Some(&ultrasonic), true),
            (Channels::Ultrasonic(&ultrasonic), Some(&ultrasonic), false),
            (Channels::Electrovibration, None, true),
        ] {
            let (d, u, a) = design(&mu, &device, channels);
            let [lo, hi] = d.summary.band_mu;
            prop_assert_eq!(d.voltage_v.is_some(), ev);
            prop_assert_eq!(d.amplitude_um.is_some(), us.is_some());
            let a_max = us.map_or(0.0, UltrasonicDevice::a_max_um);
            for i in 0..mu.len() {
                prop_assert!(u[i].is_finite() && (0.0..=device.u_max_v).contains(&u[i]), "U = {}", u[i]);
                prop_assert!(a[i].is_finite() && (0.0..=a_max).contains(&a[i]), "a = {}", a[i]);
                let f = felt(&device, us, u[i], a[i]);
                if (lo..=hi).contains(&mu[i]) {
                    prop_assert!((f - mu[i]).abs() <= 1e-9 * mu[i].abs().max(1.0),
                        "{:?}: mu {} felt {} (U {}, a {})", d.summary.display, mu[i], f, u[i], a[i]);
                } else if mu[i] > hi {
                    prop_assert_eq!((u[i], a[i]), (if ev { device.u_max_v } else { 0.0 }, 0.0));
                } else {
                    prop_assert_eq!((u[i], a[i]), (0.0, a_max));
                }
            }
        }
    }

}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, failure_persistence: None, ..ProptestConfig::default() })]

    /// Each channel's allocation is monotone in the target (U
    /// non-decreasing, a non-increasing, on a grid of 20 000 targets across
    /// and beyond the band) and continuous: the grid's largest step of each
    /// is bisected 60 times, keeping the half with the larger change. A
    /// monotone function's jump stays in the kept half whatever its width;
    /// a continuous one's change vanishes with it. What remains must be
    /// below 1e-4 of the channel's limit. Rounding: where the voltage
    /// starts from 0 V, U = sqrt(excess/ratio) turns the excess's rounding
    /// (below 1e-12) into up to sqrt(1e-12/ratio) volts (0.2 mV at the
    /// paper's ratio), the tolerance of U's monotonicity.
    #[test]
    fn allocations_are_monotone_and_continuous(
        device in any_device(),
        ultrasonic in any_ultrasonic(),
        strategy in any_strategy(),
    ) {
        let [lo, hi] = band_of(&device, &ultrasonic);
        let channels = Channels::Combined(&ultrasonic, strategy);
        let (u_max, a_max) = (device.u_max_v, ultrasonic.a_max_um());
        let u_rounding = (1e-12 / device.force_ratio_per_v2(1.0)).sqrt();
        let n = 20_000;
        let mu: Vec<f64> =
            (0..n).map(|i| (0.9 * lo + (1.1 * hi - 0.9 * lo) * i as f64 / (n - 1) as f64).min(999.0)).collect();
        let (_, u, a) = design(&mu, &device, channels);
        let (mut u_step, mut a_step) = ((0.0f64, 1), (0.0f64, 1));
        for i in 1..n {
            prop_assert!(u[i] >= u[i - 1] - u_rounding, "U falls at mu = {}: {} -> {}", mu[i], u[i - 1], u[i]);
            prop_assert!(a[i] <= a[i - 1] + 1e-12 * a_max, "a rises at mu = {}: {} -> {}", mu[i], a[i - 1], a[i]);
            if u[i] - u[i - 1] > u_step.0 {
                u_step = (u[i] - u[i - 1], i);
            }
            if a[i - 1] - a[i] > a_step.0 {
                a_step = (a[i - 1] - a[i], i);
            }
        }
        // (channel index in the pair, limit, the step's right end)
        for (channel, limit, i) in [(0usize, u_max, u_step.1), (1, a_max, a_step.1)] {
            let value = |m: f64| {
                let (_, u, a) = design(&[m, m], &device, channels);
                if channel == 0 { u[0] } else { a[0] }
            };
            let (mut left, mut right) = (mu[i - 1], mu[i]);
            let (mut v_left, mut v_right) = (value(left), value(right));
            for _ in 0..60 {
                let middle = 0.5 * (left + right);
                if middle <= left || middle >= right {
                    break;
                }
                let v_middle = value(middle);
                if (v_middle - v_left).abs() >= (v_right - v_middle).abs() {
                    (right, v_right) = (middle, v_middle);
                } else {
                    (left, v_left) = (middle, v_middle);
                }
            }
            prop_assert!((v_right - v_left).abs() <= 1e-4 * limit,
                "channel {channel} jumps by {} at mu = {left} .. {right}", (v_right - v_left).abs());
        }
    }

    /// The ultrasonic inverse alone: a(rho) is the inverse of rho(a) both
    /// ways (rho(a(rho)) = rho on [rho_min, 1], a(rho(a)) = a on [0,
    /// a_max]), non-increasing, and saturates outside. Being monotone and
    /// onto [0, a_max], it is continuous.
    #[test]
    fn ultrasonic_inverse_is_monotone_continuous_and_exact(ultrasonic in any_ultrasonic()) {
        let (rho_min, a_max) = (ultrasonic.rho_min(), ultrasonic.a_max_um());
        let n = 10_000;
        let mut previous = 0.0;
        for i in 0..=n {
            let rho = 1.0 - (1.0 - rho_min) * i as f64 / n as f64;
            let a = ultrasonic.amplitude_um(rho);
            prop_assert!(a >= previous && a <= a_max);
            prop_assert!((ultrasonic.relative_friction(a) - rho).abs() <= 1e-12, "rho {rho} -> a {a}");
            previous = a;
            let a = a_max * i as f64 / n as f64;
            let back = ultrasonic.amplitude_um(ultrasonic.relative_friction(a));
            prop_assert!((back - a).abs() <= 1e-9 * a_max, "a {a} -> {back}");
        }
        prop_assert_eq!(ultrasonic.amplitude_um(rho_min), a_max);
        prop_assert_eq!(ultrasonic.amplitude_um(1.5), 0.0);
        prop_assert_eq!(ultrasonic.amplitude_um(rho_min * 0.5), a_max);
    }
}

/// Electrovibration alone through the display mapping is eq. (8) of
/// `map_profile`, voltage for voltage, with the same clipped and
/// not-renderable regions.
#[test]
fn electrovibration_display_is_eq8() {
    let mu: Vec<f64> = (0..500).map(|i| 0.9 + 0.4 * (i as f64 * 0.05).sin()).collect();
    let p = profile(&mu);
    let eq8 = map_profile(&p, &Device::PAPER, Method::Physical, None).unwrap();
    let d = map_display(&p, &Device::PAPER, Channels::Electrovibration, None, None).unwrap();
    assert_eq!(d.voltage_v.as_deref(), Some(eq8.voltage_v.as_slice()));
    assert_eq!(d.amplitude_um, None);
    assert_eq!(d.summary.above_band, eq8.summary.clipped);
    assert_eq!(d.summary.below_band, eq8.summary.not_renderable);
    assert_eq!(d.summary.band_mu, [1.0, eq8.summary.mu_at_u_max.unwrap()]);
}

/// The combined display renders below mu_HD where electrovibration gives
/// 0 V: the example profile's descent (0.98 behind the bump) is inside
/// the band of the literature default, so nothing is below it.
#[test]
fn combined_renders_what_electrovibration_cannot() {
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/examples/bump_friction.csv");
    let p = FrictionProfile::read_csv_file(std::path::Path::new(example)).unwrap();
    let us = UltrasonicDevice::literature_default(None).unwrap();
    let ev = map_display(&p, &Device::PAPER, Channels::Electrovibration, None, None).unwrap();
    assert!(!ev.summary.below_band.is_empty());
    for strategy in strategies() {
        let d = map_display(&p, &Device::PAPER, Channels::Combined(&us, strategy), None, None).unwrap();
        assert!(d.summary.below_band.is_empty(), "{strategy:?}");
        assert_eq!(d.summary.above_band, ev.summary.above_band, "{strategy:?}");
        let (u, a) = (d.voltage_v.as_ref().unwrap(), d.amplitude_um.as_ref().unwrap());
        for i in 0..p.len() {
            if p.mu()[i] <= d.summary.band_mu[1] {
                assert!((felt(&Device::PAPER, Some(&us), u[i], a[i]) - p.mu()[i]).abs() < 1e-12);
            }
        }
        assert!(d.summary.warnings.iter().any(|w| w.contains("literature default")), "{:?}", d.summary.warnings);
    }
}

/// Bias holds one amplitude and renders the rest by voltage: on a profile
/// whose range fits the voltage's span over the bias baseline, the
/// amplitude is the same everywhere and the voltage is 0 V at the lowest
/// friction.
#[test]
fn bias_is_one_amplitude_when_the_profile_fits() {
    let us = UltrasonicDevice::literature_default(None).unwrap();
    // mu_HD = 1, the paper's electrovibration spans x1.1991: 0.8 .. 0.95 fits.
    let mu: Vec<f64> = (0..200).map(|i| 0.875 + 0.075 * (i as f64 * 0.1).sin()).collect();
    let d = map_display(&profile(&mu), &Device::PAPER, Channels::Combined(&us, Allocation::Bias), None, None).unwrap();
    let a = d.amplitude_um.as_ref().unwrap();
    let bias = d.summary.bias.as_ref().unwrap();
    assert!(a.iter().all(|&v| (v - bias.amplitude_um).abs() < 1e-12), "{a:?}");
    assert!(bias.lowered.is_empty());
    assert!((bias.relative_friction - d.summary.mu_min).abs() < 1e-15);
    assert_eq!(d.summary.electrovibration.as_ref().unwrap().voltage_min_v, 0.0);
}

/// The file pairs each sample with its unit and limit: a column per
/// channel in use, named with its unit, every value within the limit
/// the file's comment states.
#[test]
fn csv_columns_follow_the_channels_and_stay_within_the_stated_limits() {
    let us = UltrasonicDevice::literature_default(Some(2.0)).unwrap();
    let mu: Vec<f64> = (0..300).map(|i| 0.05 + 1.5 * i as f64 / 299.0).collect();
    let p = profile(&mu);
    let limit = |text: &str, key: &str| -> f64 {
        let rest = text.split(key).nth(1).unwrap_or_else(|| panic!("{key} not stated:\n{text}"));
        rest.split(' ').next().unwrap().parse().unwrap()
    };
    for (channels, header) in [
        (Channels::Combined(&us, Allocation::Weighted { weight: 1.0 }), "x_mm,mu,voltage_v,amplitude_um"),
        (Channels::Ultrasonic(&us), "x_mm,mu,amplitude_um"),
        (Channels::Electrovibration, "x_mm,mu,voltage_v"),
    ] {
        let d = map_display(&p, &Device::PAPER, channels, None, None).unwrap();
        let mut text = Vec::new();
        d.write_csv(&mut text).unwrap();
        let text = String::from_utf8(text).unwrap();
        assert!(text.lines().any(|l| l == header), "{text}");
        let table = Table::read(text.as_bytes(), "d.csv").unwrap();
        assert_eq!(table.column("mu").unwrap(), mu.as_slice());
        if let Some(u) = table.column("voltage_v") {
            let u_max = limit(&text, "at most U_max = ");
            assert_eq!(u_max, 100.0);
            assert!(u.iter().all(|&v| (0.0..=u_max).contains(&v)));
            assert_eq!(u, d.voltage_v.as_deref().unwrap());
        }
        if let Some(a) = table.column("amplitude_um") {
            let a_max = limit(&text, "at most a_max = ");
            assert_eq!(a_max, 2.0);
            assert!(a.iter().all(|&v| (0.0..=a_max).contains(&v)));
            assert_eq!(a.iter().copied().fold(0.0, f64::max), a_max);
            assert_eq!(a, d.amplitude_um.as_deref().unwrap());
        }
        // JSON: the same columns, absent for a channel not in use.
        let json = serde_json::to_value(&d).unwrap();
        assert_eq!(json.get("voltage_v").is_some(), header.contains("voltage_v"));
        assert_eq!(json.get("amplitude_um").is_some(), header.contains("amplitude_um"));
    }
}

/// A relative profile (paper Fig. 2a) on the combined display: an FE-like
/// bump around mu_skin = 0.5 is 1.0 .. 1.1 and 0.9 relative to it, all
/// inside the band, rendered to rounding.
#[test]
fn relative_profiles_map_on_the_combined_display() {
    let us = UltrasonicDevice::literature_default(None).unwrap();
    let p = profile(&[0.5, 0.55, 0.45, 0.5]);
    let d = map_display(&p, &Device::PAPER, Channels::Combined(&us, Allocation::Split), None, Some(FlatMu::Given(0.5)))
        .unwrap();
    assert_eq!(d.mu, [1.0, 1.1, 0.9, 1.0]);
    assert_eq!(d.summary.relative.unwrap().flat_mu, 0.5);
    assert_eq!((d.summary.display, d.summary.strategy), (DisplayKind::Combined, Some(StrategyKind::Split)));
    let (u, a) = (d.voltage_v.unwrap(), d.amplitude_um.unwrap());
    for i in 0..4 {
        assert!((felt(&Device::PAPER, Some(&us), u[i], a[i]) - d.mu[i]).abs() < 1e-12);
    }
    assert!(u[2] == 0.0 && a[2] > 0.0 && a[1] == 0.0 && u[1] > 0.0);
}

/// A weight outside its range is refused, naming it.
#[test]
fn bad_weight_is_refused() {
    let us = UltrasonicDevice::literature_default(None).unwrap();
    for w in [-1.0, f64::NAN, f64::INFINITY] {
        let e = map_display(
            &profile(&[1.0, 1.1]),
            &Device::PAPER,
            Channels::Combined(&us, Allocation::Weighted { weight: w }),
            None,
            None,
        )
        .unwrap_err();
        assert!(e.to_string().starts_with("weight must be from 0 to 1000000"), "{e}");
    }
}
