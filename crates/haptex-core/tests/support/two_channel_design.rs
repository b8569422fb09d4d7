//! The combined display's design the real-time tests share (included with
//! `#[path] mod`): over 0..10 mm every 0.01 mm, U up to 110 V and a up to
//! 2.4 um, above U_max = 100 V and a 2 um a_max over part of the span, so
//! that both clamps are exercised.

use haptex_core::signal::{AmplitudeCurve, VoltageCurve};

pub fn design() -> (VoltageCurve, AmplitudeCurve) {
    let x: Vec<f64> = (0..=1000).map(|i| i as f64 * 0.01).collect();
    let u = x.iter().map(|x| 60.0 + 50.0 * (std::f64::consts::TAU * x / 2.5).sin()).collect();
    let a = x.iter().map(|x| 1.2 + 1.2 * (std::f64::consts::TAU * x / 3.0).cos()).collect();
    (VoltageCurve::new(x.clone(), u).unwrap(), AmplitudeCurve::new(x, a).unwrap())
}
