//! The profiles look physically right (issue 3): on a bump Ft/Fn rises
//! while the finger climbs and falls while it descends; an edge gives a
//! single transient back to the skin's Coulomb value; a sine gives a
//! profile periodic at the surface period. And the velocity dependence:
//! the elastic finger is rate independent (profiles identical to 1e-9 at
//! 10 and 100 mm/s), the visco-elastic one is not.

use haptex_fem::scenario::{Scenario, SimulationResult, run};
use haptex_fem::surface::SurfaceShape;

fn simulate(surface: SurfaceShape, velocity: f64, viscoelastic: bool) -> SimulationResult {
    let mut scenario = Scenario::paper(surface);
    scenario.velocity_mm_s = velocity;
    scenario.viscoelastic = viscoelastic;
    run(&scenario, &mut |_| {}).unwrap()
}

fn argmax(v: &[f64]) -> usize {
    (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap()
}

fn argmin(v: &[f64]) -> usize {
    (0..v.len()).min_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap()
}

#[test]
fn bump_raises_then_lowers_friction() {
    let r = simulate(SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 }, 20.0, true);
    let (x, mu) = (r.profile.as_ref().unwrap().x_mm(), r.profile.as_ref().unwrap().mu());
    let (hi, lo) = (argmax(mu), argmin(&mu[5..]) + 5);
    eprintln!("max {:.3} at {:.2} mm, min {:.3} at {:.2} mm", mu[hi], x[hi], mu[lo], x[lo]);
    assert!(x[hi] < 5.0 && x[lo] > 5.0, "climb before the top, descent after");
    assert!(mu[hi] > 0.55 && mu[lo] < 0.45, "a 0.3 mm bump changes Ft/Fn by more than 0.05 around mu = 0.5");
    // Far from the bump, the Coulomb value.
    for (x, m) in x.iter().zip(mu) {
        if (0.5..1.0).contains(x) || *x > 9.5 {
            assert!((m - 0.5).abs() < 0.005, "{m} at {x}");
        }
    }
}

#[test]
fn edge_gives_a_single_transient() {
    let r = simulate(SurfaceShape::Edge { x0: 5.0, width: 1.5, height: 0.3 }, 20.0, true);
    let (x, mu) = (r.profile.as_ref().unwrap().x_mm(), r.profile.as_ref().unwrap().mu());
    // One excursion above mu: a single contiguous run away from 0.5.
    let away: Vec<bool> = mu.iter().zip(x).map(|(m, x)| *x > 0.5 && (m - 0.5).abs() > 0.005).collect();
    let runs = away.windows(2).filter(|w| !w[0] && w[1]).count() + usize::from(away[0]);
    assert_eq!(runs, 1, "Ft/Fn leaves the Coulomb value once");
    assert!(mu.iter().cloned().fold(0.0, f64::max) > 0.55);
    assert!((mu[mu.len() - 1] - 0.5).abs() < 0.005, "back to Coulomb on the plateau");
}

#[test]
fn sine_profile_is_periodic_at_the_surface_period() {
    let period = 2.0;
    let r = simulate(SurfaceShape::Sine { x0: 5.0, width: period, height: 0.2 }, 20.0, true);
    let (x, mu) = (r.profile.as_ref().unwrap().x_mm(), r.profile.as_ref().unwrap().mu());
    // After the press transient (x > 2 mm), mu(x + P) ~ mu(x): the change
    // over one period is small next to the profile's own variation. (The
    // slow relaxation of the visco-elastic finger leaves a small drift.)
    let shift = (0..x.len()).find(|&i| x[i] >= x[0] + period - 1e-9).unwrap();
    let start = x.iter().position(|&x| x > 2.0).unwrap();
    let mean = mu[start..].iter().sum::<f64>() / (mu.len() - start) as f64;
    let spread = (mu[start..].iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (mu.len() - start) as f64).sqrt();
    let n = mu.len() - shift - start;
    let change = ((start..start + n).map(|i| (mu[i + shift] - mu[i]).powi(2)).sum::<f64>() / n as f64).sqrt();
    eprintln!("RMS change over one period {change:.4}, RMS variation {spread:.4}");
    assert!(change < 0.3 * spread, "not periodic at the surface period: {change} vs {spread}");
    // The spectrum has its energy at multiples of 1/P, not between them.
    let power = |f: f64| {
        let (mut c, mut s) = (0.0, 0.0);
        for i in start..mu.len() {
            c += (mu[i] - mean) * (std::f64::consts::TAU * f * x[i]).cos();
            s += (mu[i] - mean) * (std::f64::consts::TAU * f * x[i]).sin();
        }
        c * c + s * s
    };
    let harmonic = (1..=3).map(|k| power(k as f64 / period)).fold(0.0, f64::max);
    for f in [0.5 / period, 1.5 / period, 2.5 / period] {
        assert!(power(f) < 0.1 * harmonic, "energy at {f}/mm: {} vs {harmonic}", power(f));
    }
}

#[test]
fn velocity_dependence_only_with_viscoelasticity() {
    let bump = SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 };
    let slow = simulate(bump.clone(), 10.0, false);
    let fast = simulate(bump.clone(), 100.0, false);
    for (a, b) in slow.profile.as_ref().unwrap().mu().iter().zip(fast.profile.as_ref().unwrap().mu()) {
        assert!((a - b).abs() < 1e-9, "elastic: {a} vs {b}");
    }
    let slow = simulate(bump.clone(), 10.0, true);
    let fast = simulate(bump, 100.0, true);
    let difference = slow
        .profile
        .as_ref()
        .unwrap()
        .mu()
        .iter()
        .zip(fast.profile.as_ref().unwrap().mu())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let fn_ratio = fast.history.last().unwrap().fn_n / slow.history.last().unwrap().fn_n;
    eprintln!("visco-elastic: max |mu(10) - mu(100)| = {difference:.4}, Fn(100)/Fn(10) at the end = {fn_ratio:.3}");
    assert!(difference > 0.005, "visco-elastic profiles should differ with velocity");
    // Faster sliding leaves less time to relax: a stiffer finger, higher Fn.
    assert!(fn_ratio > 1.0);
}
