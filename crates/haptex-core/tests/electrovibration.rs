//! Validation of the electrovibration mapping (paper eqs. 3-9) against hand
//! calculations in SI and the paper's Fig. 2 constants.

use haptex_core::electrovibration::{
    ContactArea, Device, ElectroError, LayerStack, Method, Regions, electrostatic_force_n, map_profile,
    map_profile_relative, required_force_n, voltage_for_force_v,
};
use haptex_core::profile::FrictionProfile;
use haptex_core::relative::{FlatMu, FlatSource, RelativeError};
use proptest::prelude::*;

/// The paper's device with U_max raised so that nothing clips.
fn unclipped() -> Device {
    Device { u_max_v: 1000.0, ..Device::PAPER }
}

fn profile(x: &[f64], mu: &[f64]) -> FrictionProfile {
    FrictionProfile::new(x.to_vec(), mu.to_vec()).unwrap()
}

/// Eq. (8) with the paper's Fig. 2 constants (eps_sc = 1650, eps_i = 10,
/// d_sc = 0.2 mm, d_i = 0.001 mm, k = 200 mm^2/N, mu_HD = 1):
/// U = sqrt(50217.6 (mu_RS - 1)) V. Reference values from physics.md and
/// issue 2: 112.05, 158.46, 224.09 V; tolerance 0.01 V (their rounding).
#[test]
fn eq8_paper_fig2_voltages() {
    let p = profile(&[0.0, 1.0, 2.0], &[1.25, 1.5, 2.0]);
    let v = map_profile(&p, &unclipped(), Method::Physical, None).unwrap();
    for (u, expected) in v.voltage_v.iter().zip([112.05, 158.46, 224.09]) {
        assert!((u - expected).abs() < 0.01, "U = {u}, expected {expected}");
    }
    assert!(v.summary.clipped.is_empty() && v.summary.not_renderable.is_empty());
    // Empty regions are +0, so the summary never prints "-0.00%".
    assert!(v.summary.clipped.fraction_of_length.is_sign_positive());
    assert!(!v.summary.to_string().contains("-0.00"), "{}", v.summary);
    assert!(v.summary.warnings.is_empty(), "{:?}", v.summary.warnings);
}

/// Fe/Fn = 1.9913e-5 U^2 with the paper's constants (physics.md), to the 5
/// significant figures given.
#[test]
fn eq3_force_ratio_paper_constants() {
    let ratio = Device::PAPER.force_ratio_per_v2(0.3);
    assert!((ratio - 1.9913e-5).abs() < 0.00005e-5, "Fe/Fn per V^2 = {ratio:e}");
}

/// Eq. (3) against a hand calculation in SI units:
/// d_sc/eps_sc = 0.2e-3 m / 1650 = 1.212121e-7 m, d_i/eps_i = 1e-6 m / 10 = 1e-7 m,
/// (sum) (d_sc + d_i) = 2.212121e-7 m * 2.01e-4 m = 4.446364e-11 m^2;
/// A = 100 mm^2 = 1e-4 m^2, U = 100 V:
/// Fe = 8.8541878128e-12 F/m * 1e-4 m^2 * 1e4 V^2 / (2 * 4.446364e-11 m^2) = 0.0995666 N.
/// Tolerance 1e-6 relative (the 7 digits carried by hand).
#[test]
fn eq3_force_hand_calculation_si() {
    let fe = electrostatic_force_n(&LayerStack::PAPER, 100.0, 100.0);
    assert!((fe / 0.0995666 - 1.0).abs() < 1e-6, "Fe = {fe}");
    assert!((LayerStack::PAPER.gap_factor_m2() / 4.446364e-11 - 1.0).abs() < 1e-6);
}

/// Eq. (6): Fe = (mu_RS/mu_HD - 1) Fn, so the display's friction
/// mu_HD (Fn + Fe) equals the reference mu_RS Fn (eqs. 4-5).
#[test]
fn eq6_equates_reference_and_display_friction() {
    let (mu_rs, mu_hd, fn_n) = (0.9, 0.6, 0.4);
    let fe = required_force_n(mu_rs, mu_hd, fn_n);
    assert!((mu_hd * (fn_n + fe) - mu_rs * fn_n).abs() < 1e-15);
}

/// Eq. (9): min mu -> 0 V, max mu -> U_max exactly, square-root in between.
#[test]
fn eq9_maps_min_to_zero_and_max_to_u_max() {
    let p = profile(&[0.0, 1.0, 2.0, 3.0], &[0.7, 0.3, 0.5, 0.4]);
    let v = map_profile(&p, &Device::PAPER, Method::Normalized, None).unwrap();
    assert_eq!(v.voltage_v[1], 0.0);
    assert_eq!(v.voltage_v[0], 100.0);
    assert!((v.voltage_v[2] - 100.0 * 0.5f64.sqrt()).abs() < 1e-12);
    assert_eq!((v.summary.voltage_min_v, v.summary.voltage_max_v), (0.0, 100.0));
}

#[test]
fn eq9_constant_profile_gives_zero_volts_and_a_warning() {
    let p = profile(&[0.0, 1.0, 2.0], &[0.5, 0.5, 0.5]);
    let v = map_profile(&p, &Device::PAPER, Method::Normalized, None).unwrap();
    assert!(v.voltage_v.iter().all(|&u| u == 0.0));
    assert_eq!(v.summary.warnings.len(), 1);
    assert!(v.summary.warnings[0].contains("constant"), "{:?}", v.summary.warnings);
}

/// Below mu_HD the voltage is 0 V (not NaN) and the region is reported with
/// interpolated crossings: mu goes 1.2 -> 0.8 -> 1.2 over x = 0, 1, 2, so
/// mu < 1 on (0.5, 1.5): 50% of the length.
#[test]
fn not_renderable_region_is_zero_volts_and_reported() {
    let p = profile(&[0.0, 1.0, 2.0], &[1.2, 0.8, 1.2]);
    let v = map_profile(&p, &Device::PAPER, Method::Physical, None).unwrap();
    assert_eq!(v.voltage_v[1], 0.0);
    assert!(v.voltage_v.iter().all(|u| u.is_finite()));
    let r = &v.summary.not_renderable;
    assert_eq!(r.ranges_mm.len(), 1);
    assert!((r.ranges_mm[0][0] - 0.5).abs() < 1e-12 && (r.ranges_mm[0][1] - 1.5).abs() < 1e-12);
    assert!((r.fraction_of_length - 0.5).abs() < 1e-12);
    assert!(v.summary.warnings.iter().any(|w| w.contains("50.00%")), "{:?}", v.summary.warnings);
}

/// The physical method clips at U_max (default 100 V) and reports where.
/// U = 100 V at mu_RS = 1 + 100^2 * 1.99133e-5 = 1.199133.
#[test]
fn physical_clips_at_u_max_and_reports() {
    let p = profile(&[0.0, 1.0, 2.0], &[1.0, 1.5, 1.0]);
    let v = map_profile(&p, &Device::PAPER, Method::Physical, None).unwrap();
    assert_eq!(v.voltage_v[1], 100.0);
    let mu_clip = v.summary.mu_at_u_max.unwrap();
    assert!((mu_clip - 1.199133).abs() < 1e-6, "{mu_clip}");
    let r = &v.summary.clipped;
    let half = 1.0 - (mu_clip - 1.0) / 0.5; // crossing on each flank
    assert_eq!(r.ranges_mm.len(), 1);
    assert!((r.ranges_mm[0][0] - (1.0 - half)).abs() < 1e-9);
    assert!((r.fraction_of_length - half).abs() < 1e-9);
    assert!(v.summary.warnings.iter().any(|w| w.contains("clipped")));
}

#[test]
fn everything_below_mu_hd_warns() {
    let p = profile(&[0.0, 1.0], &[0.4, 0.6]);
    let v = map_profile(&p, &Device::PAPER, Method::Physical, None).unwrap();
    assert!(v.voltage_v.iter().all(|&u| u == 0.0));
    assert_eq!(v.summary.not_renderable.fraction_of_length, 1.0);
    assert!(v.summary.warnings[0].contains("whole profile"));
}

/// With A = k Fn^n and n != 1, Fe/Fn = eps0 k Fn^(n-1) / (2 G) depends on Fn.
/// Check against eq. (7) evaluated directly with the area at that force.
#[test]
fn power_law_area_needs_and_uses_normal_force() {
    let device = Device { contact: ContactArea { k_mm2_per_n: 150.0, exponent: 0.5 }, u_max_v: 1e4, ..Device::PAPER };
    let p = profile(&[0.0, 1.0], &[1.3, 1.6]);
    let err = map_profile(&p, &device, Method::Physical, None).unwrap_err();
    assert!(matches!(err, ElectroError::NormalForceRequired { .. }));
    let fn_n = 0.8;
    let v = map_profile(&p, &device, Method::Physical, Some(fn_n)).unwrap();
    let area = 150.0 * fn_n.sqrt();
    for (mu, u) in [1.3, 1.6].iter().zip(&v.voltage_v) {
        let expected = voltage_for_force_v(&device.stack, area, required_force_n(*mu, 1.0, fn_n)).unwrap();
        assert!((u / expected - 1.0).abs() < 1e-12);
    }
    // The profile's mean fn_n is used when no force is given.
    let with_fn = FrictionProfile::from_forces(vec![0.0, 1.0], &[1.04, 1.28], vec![0.8, 0.8]).unwrap();
    let w = map_profile(&with_fn, &device, Method::Physical, None).unwrap();
    assert_eq!(w.summary.fn_n, Some(0.8));
    assert!((w.voltage_v[1] / v.voltage_v[1] - 1.0).abs() < 1e-12);
}

#[test]
fn invalid_device_parameters_are_named() {
    for (device, name) in [
        (Device { mu_hd: 0.0, ..Device::PAPER }, "mu_hd"),
        (Device { u_max_v: f64::NAN, ..Device::PAPER }, "u_max_v"),
        (Device { stack: LayerStack { eps_sc: -1.0, ..LayerStack::PAPER }, ..Device::PAPER }, "eps_sc"),
    ] {
        let err = map_profile(&profile(&[0.0, 1.0], &[1.0, 1.1]), &device, Method::Physical, None).unwrap_err();
        assert!(matches!(&err, ElectroError::OutOfRange(e) if e.name == name), "{err}");
    }
}

/// Issue 13: constants that are each positive and finite but under- or
/// overflow together (k = 5e-324 mm^2/N made Fe/Fn = 0, so U = inf; U_max
/// = 1e300 V made the clip level infinite) are refused by name, each
/// outside its accepted range ([`haptex_core::ranges`]), not mapped; the
/// ranges keep every derived quantity finite, and the device check behind
/// them refuses what would not be. Extreme friction values are refused by
/// the profile, never blamed on the device.
#[test]
fn degenerate_device_is_refused_not_mapped() {
    use haptex_core::electrovibration::ContactArea;
    let p = profile(&[0.0, 1.0], &[1.0, 1.1]);
    for method in [Method::Physical, Method::Normalized] {
        let tiny_k = Device { contact: ContactArea { k_mm2_per_n: 5e-324, ..ContactArea::PAPER }, ..Device::PAPER };
        let err = map_profile(&p, &tiny_k, method, None).unwrap_err();
        assert_eq!(err.to_string(), "k_mm2_per_n must be from 1e-6 to 1000000 mm^2/N, got 5e-324");
        let err = map_profile(&p, &Device { u_max_v: 1e300, ..Device::PAPER }, method, None).unwrap_err();
        assert_eq!(err.to_string(), "u_max_v must be from 0.001 to 10000 V, got 1e300");
    }
    // Huge friction values never reach the device check: the profile
    // refuses them.
    assert!(FrictionProfile::new(vec![0.0, 1.0], vec![-1e308, 1e308]).is_err());
    let wide = profile(&[0.0, 1.0], &[0.0, 1e3]);
    let v = map_profile(&wide, &Device::PAPER, Method::Normalized, None).unwrap();
    assert_eq!(v.voltage_v, [0.0, 100.0]);
}

/// Paper Fig. 2 (issue 15): an FE-like bump profile around the skin
/// friction 0.5, mapped with the paper's device (mu_HD = 1). As it is,
/// eq. (8) gives 0 V everywhere (0.6 < mu_HD); relative to its flat value
/// mu_flat = 0.5 it is mu/0.5 * 1 = 1.0, 1.1, 1.15, 0.9, 1.0, and eq. (8)
/// by hand with the Fig. 2 constants, U = sqrt(50217.6 (mu_rel - 1)) V
/// (docs/physics.md), gives 0, sqrt(5021.76) = 70.864, sqrt(7532.64) =
/// 86.791, 0 (below flat: not renderable), 0 V. Tolerance 0.01 V (the
/// rounding of 50217.6).
#[test]
fn relative_bump_gives_the_hand_computed_eq8_voltages() {
    let p = profile(&[0.0, 1.0, 2.0, 3.0, 4.0], &[0.5, 0.55, 0.575, 0.45, 0.5]);
    let raw = map_profile(&p, &Device::PAPER, Method::Physical, None).unwrap();
    assert!(raw.voltage_v.iter().all(|&u| u == 0.0), "{:?}", raw.voltage_v);
    assert_eq!(raw.summary.relative, None);

    let v = map_profile_relative(&p, &Device::PAPER, Method::Physical, None, FlatMu::Given(0.5)).unwrap();
    for (u, expected) in v.voltage_v.iter().zip([0.0, 70.864, 86.791, 0.0, 0.0]) {
        assert!((u - expected).abs() < 0.01, "U = {u}, expected {expected}: {:?}", v.voltage_v);
    }
    assert!(v.voltage_v[1] > 0.0 && v.voltage_v[2] > v.voltage_v[1]);
    assert_eq!(v.mu, [1.0, 1.1, 1.15, 0.9, 1.0]);
    let r = v.summary.relative.unwrap();
    assert_eq!((r.flat_mu, r.flat_mu_source, r.mu_hd), (0.5, FlatSource::Given, 1.0));
    // Where mu < mu_flat the display cannot follow: reported as usual, on
    // the relative profile (1.15 at x = 2 mm to 0.9 at 3 mm crosses 1 at
    // 2.6 mm; back to 1, not below it, at 4 mm).
    let below = &v.summary.not_renderable.ranges_mm;
    assert!(below.len() == 1 && (below[0][0] - 2.6).abs() < 1e-12 && below[0][1] == 4.0, "{below:?}");
    let text = v.summary.to_string();
    assert!(text.contains("mu_flat = 0.5 (given) and mu_HD = 1"), "{text}");

    // Eq. (8) of the relative profile does not depend on mu_HD.
    for mu_hd in [0.3, 2.5] {
        let w =
            map_profile_relative(&p, &Device { mu_hd, ..Device::PAPER }, Method::Physical, None, FlatMu::Given(0.5))
                .unwrap();
        for (a, b) in w.voltage_v.iter().zip(&v.voltage_v) {
            assert!((a - b).abs() < 1e-9, "mu_HD {mu_hd}: {a} vs {b}");
        }
    }
    // Eq. (9) sees only the pattern: the same voltages to rounding.
    let pattern = map_profile(&p, &Device::PAPER, Method::Normalized, None).unwrap();
    let relative = map_profile_relative(&p, &Device::PAPER, Method::Normalized, None, FlatMu::Median).unwrap();
    for (a, b) in pattern.voltage_v.iter().zip(&relative.voltage_v) {
        assert!((a - b).abs() < 1e-12, "{a} vs {b}");
    }
    assert_eq!(relative.summary.relative.unwrap().flat_mu_source, FlatSource::Median);
}

/// The relative CSV says how the profile was made, and its U_max is the
/// largest voltage it can hold.
#[test]
fn relative_csv_comments_name_mu_flat_mu_hd_and_u_max() {
    let p = profile(&[0.0, 1.0, 2.0], &[0.5, 0.8, 0.5]);
    let device = Device { mu_hd: 0.8, u_max_v: 60.0, ..Device::PAPER };
    let v = map_profile_relative(&p, &device, Method::Physical, None, FlatMu::Given(0.5)).unwrap();
    let mut bytes = Vec::new();
    v.write_csv(&mut bytes).unwrap();
    let text = String::from_utf8(bytes).unwrap();
    let comment = text.lines().nth(1).unwrap();
    assert_eq!(
        comment,
        "# relative profile (paper Fig. 2a): mu = mu_profile / mu_flat * mu_HD with mu_flat = 0.5 (given) and \
         mu_HD = 0.8; the mu column is the relative friction; U_max = 60 V (clip level)"
    );
    // 0.8 / 0.5 = 1.6 relative to mu_HD needs 141.7 V: clipped at 60 V.
    assert_eq!(v.voltage_v, [0.0, 60.0, 0.0]);
    let table = haptex_core::io::Table::read(text.as_bytes(), "v").unwrap();
    assert_eq!(table.column("mu").unwrap(), [0.8, 0.8 / 0.5 * 0.8, 0.8]);
}

#[test]
fn relative_bad_flat_values_are_typed_errors() {
    let p = profile(&[0.0, 1.0, 2.0], &[0.5, 0.6, 0.5]);
    for bad in [0.0, -0.5, f64::NAN, f64::INFINITY] {
        let err = map_profile_relative(&p, &Device::PAPER, Method::Physical, None, FlatMu::Given(bad)).unwrap_err();
        assert!(
            matches!(&err, ElectroError::Relative(RelativeError::OutOfRange(e)) if e.name == "flat_mu"),
            "{bad}: {err}"
        );
    }
    let zero = profile(&[0.0, 1.0, 2.0], &[0.0, 0.0, 0.2]);
    let err = map_profile_relative(&zero, &Device::PAPER, Method::Physical, None, FlatMu::Median).unwrap_err();
    assert!(matches!(err, ElectroError::Relative(RelativeError::Median { median }) if median == 0.0), "{err}");
    // The device is checked first, as without --relative.
    let err = map_profile_relative(&p, &Device { mu_hd: 0.0, ..Device::PAPER }, Method::Physical, None, FlatMu::Median)
        .unwrap_err();
    assert!(matches!(&err, ElectroError::OutOfRange(e) if e.name == "mu_hd"), "{err}");
}

#[test]
fn regions_merge_across_samples_and_handle_touching_points() {
    let x = [0.0, 1.0, 2.0, 3.0, 4.0];
    let r = Regions::above(&x, &[2.0, 2.0, 0.0, 1.0, 2.0], 1.0);
    assert_eq!(r.ranges_mm, vec![[0.0, 1.5], [3.0, 4.0]]);
    assert!((r.length_mm - 2.5).abs() < 1e-15);
    let none = Regions::above(&x, &[1.0, 1.0, 1.0, 1.0, 1.0], 1.0);
    assert!(none.is_empty() && none.fraction_of_length == 0.0);
}

proptest! {
    /// Eq. (8) (and its clipping) never decreases as mu_RS increases.
    /// Exact, no tolerance: each step (mu / mu_HD - 1, the division by the
    /// device constant, sqrt, the clamp; for eq. (9) the affine map of mu)
    /// is a correctly rounded monotone operation, and a composition of
    /// those is non-decreasing in floating point too.
    #[test]
    fn voltage_is_monotone_in_mu(
        mut mu in prop::collection::vec(0.0f64..4.0, 2..50),
        mu_hd in 0.2f64..2.0,
        u_max in 1.0f64..500.0,
    ) {
        mu.sort_by(f64::total_cmp);
        let x: Vec<f64> = (0..mu.len()).map(|i| i as f64).collect();
        let device = Device { mu_hd, u_max_v: u_max, ..Device::PAPER };
        let p = FrictionProfile::new(x, mu).unwrap();
        for method in [Method::Physical, Method::Normalized] {
            let v = map_profile(&p, &device, method, None).unwrap();
            for w in v.voltage_v.windows(2) {
                prop_assert!(w[1] >= w[0], "{method}: {} after {}", w[1], w[0]);
            }
            prop_assert!(v.voltage_v.iter().all(|u| u.is_finite() && *u >= 0.0 && *u <= u_max));
        }
    }

    /// A constant profile made relative is exactly mu_HD everywhere,
    /// whatever its level and mu_HD, whether mu_flat is given or the
    /// median: the display with no voltage stands for the flat surface, and
    /// eq. (8) gives exactly 0 V with nothing reported as not renderable.
    /// Exact, no tolerance: x / x is exactly 1 in IEEE arithmetic and
    /// 1 * mu_HD exactly mu_HD.
    #[test]
    fn relative_constant_profile_is_exactly_mu_hd(
        level in 1e-3f64..10.0,
        mu_hd in 1e-3f64..10.0,
        n in 2usize..20,
    ) {
        let x: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let p = FrictionProfile::new(x, vec![level; n]).unwrap();
        let device = Device { mu_hd, ..Device::PAPER };
        for flat in [FlatMu::Given(level), FlatMu::Median] {
            let v = map_profile_relative(&p, &device, Method::Physical, None, flat).unwrap();
            prop_assert!(v.mu.iter().all(|&m| m == mu_hd), "{:?} -> {:?}, mu_HD {}", flat, v.mu, mu_hd);
            prop_assert!(v.voltage_v.iter().all(|&u| u == 0.0));
            prop_assert!(v.summary.not_renderable.is_empty());
        }
    }

    /// Eq. (7) inverts eq. (3): the voltage for the force of voltage U is U,
    /// to 1e-12 relative (a square and a square root through a handful of
    /// products: a few ulps, 1e-15, with a wide margin).
    #[test]
    fn eq7_inverts_eq3(
        u in 0.0f64..2000.0,
        area in 1.0f64..500.0,
        d_sc in 0.01f64..1.0,
        eps_sc in 1.0f64..1e4,
        d_i in 1e-4f64..0.1,
        eps_i in 1.0f64..100.0,
    ) {
        let stack = LayerStack { d_sc_mm: d_sc, eps_sc, d_i_mm: d_i, eps_i };
        let fe = electrostatic_force_n(&stack, area, u);
        let back = voltage_for_force_v(&stack, area, fe).unwrap();
        prop_assert!((back - u).abs() <= 1e-12 * u.max(1.0), "{u} -> {fe} N -> {back}");
    }
}

#[test]
fn replacement_voltages_keep_the_profile_and_its_limit() {
    // Voltages put in place of eq. (8)'s (a compensated voltage) must fit
    // the profile and stay within its U_max; the summary follows them.

    let profile = FrictionProfile::new(vec![0.0, 1.0, 2.0], vec![1.0, 1.1, 1.05]).unwrap();
    let mapped = map_profile(&profile, &Device::PAPER, Method::Physical, None).unwrap();
    let replaced = mapped.clone().with_voltages(vec![0.0, 80.0, 100.0]).unwrap();
    assert_eq!(replaced.voltage_v, [0.0, 80.0, 100.0]);
    assert_eq!((replaced.summary.voltage_min_v, replaced.summary.voltage_max_v), (0.0, 100.0));
    assert_eq!(replaced.mu, mapped.mu);
    for bad in [vec![0.0, 100.5, 0.0], vec![0.0, -1.0, 0.0], vec![0.0, f64::NAN, 0.0], vec![1.0, 2.0]] {
        assert!(mapped.clone().with_voltages(bad.clone()).is_err(), "{bad:?}");
    }
}
