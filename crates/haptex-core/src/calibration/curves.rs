//! A calibration's data and fitted curves, ready to plot: per carrier the
//! friction's rise over each finger's friction at 0 V against the RMS
//! voltage with the model's curve and its 95% band ([`Eq3Fit::rise`] or
//! [`CircuitFit::rise`]) and the residuals; for the ultrasonic plate the
//! relative friction against amplitude with the monotone table and the
//! exponential's band ([`ExponentialFit::curve`]). What `haptex
//! calibrate --png` draws and `POST /api/calibrate` answers.
//!
//! Linear in the rows (fingers and carriers are looked up by map).
//!
//! [`Eq3Fit::rise`]: crate::calibration::force_fit::Eq3Fit::rise
//! [`CircuitFit::rise`]: crate::calibration::force_fit::CircuitFit::rise
//! [`ExponentialFit::curve`]: crate::calibration::ultrasonic_fit::ExponentialFit::curve

use std::collections::HashMap;

use crate::calibration::Calibration;
use crate::calibration::force_fit::carrier_name;
use crate::calibration::measurements::Measurements;
use crate::signal::{Carrier, CarrierShape};

/// Points of a model curve from 0 to the highest voltage or amplitude.
pub const CURVE_POINTS: usize = 61;

/// One carrier's data and model.
#[derive(Debug, Clone, PartialEq)]
pub struct CarrierCurves {
    pub carrier: Carrier,
    /// "sine 1000 Hz", "direct drive".
    pub name: String,
    /// Rows on this carrier (0 V rows included) whose finger has a 0 V
    /// friction: U, mu / mu_finger(0 V) - 1, and the file's line.
    pub data_u_v: Vec<f64>,
    pub data_rise: Vec<f64>,
    pub data_lines: Vec<u64>,
    /// The model's rise on [`CURVE_POINTS`] voltages: [value, low, high].
    pub grid_u_v: Vec<f64>,
    pub rise: Vec<[f64; 3]>,
    /// Every row under a voltage on this carrier: the fitted mu, measured -
    /// fitted, and the line.
    pub fitted: Vec<f64>,
    pub residual: Vec<f64>,
    pub residual_lines: Vec<u64>,
}

/// The electrostatic force's data and model.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceCurves {
    /// `circuit` (when its rho_sc and g are identified) or `eq3`.
    pub model: &'static str,
    pub carriers: Vec<CarrierCurves>,
}

/// The plate's data and model.
#[derive(Debug, Clone, PartialEq)]
pub struct UltrasonicCurves {
    /// Rows at 0 V: amplitude, mu / (mean mu at rest), line.
    pub data_amplitude_um: Vec<f64>,
    pub data_rho: Vec<f64>,
    pub data_lines: Vec<u64>,
    /// The monotone table.
    pub table_amplitude_um: Vec<f64>,
    pub table_rho: Vec<f64>,
    /// The exponential on [`CURVE_POINTS`] amplitudes, with its band.
    pub grid_amplitude_um: Vec<f64>,
    pub exponential: Option<Vec<[f64; 3]>>,
}

fn same(a: &Carrier, b: &Carrier) -> bool {
    a.shape == b.shape && (a.shape == CarrierShape::None || a.frequency_hz == b.frequency_hz)
}

fn key(c: &Carrier) -> (u8, u64) {
    (c.shape as u8, if c.shape == CarrierShape::None { 0 } else { c.frequency_hz.to_bits() })
}

/// The force's curves (`None` without a force fit).
pub fn force(cal: &Calibration, m: &Measurements) -> Option<ForceCurves> {
    let f = cal.force.as_ref()?;
    let rows = m.rows();
    let circuit = f.circuit.as_ref().filter(|c| c.rho_sc_ohm_m.identified && c.gap_um.identified);
    // Each finger's friction at 0 V: the rise is drawn against it, so that
    // the fingers' own friction does not hide the voltage's effect.
    let mut rest: HashMap<u64, (f64, usize)> = HashMap::new();
    for r in rows.iter().filter(|r| r.voltage_v == 0.0 && r.amplitude_um == 0.0) {
        let e = rest.entry(r.finger).or_insert((0.0, 0));
        e.0 += r.mu;
        e.1 += 1;
    }
    let index: HashMap<(u8, u64), usize> =
        f.eq3.carriers.iter().enumerate().map(|(k, c)| (key(&c.carrier), k)).collect();
    let mut out: Vec<CarrierCurves> = f
        .eq3
        .carriers
        .iter()
        .map(|c| {
            let grid: Vec<f64> =
                (0..CURVE_POINTS).map(|i| c.max_voltage_v * i as f64 / (CURVE_POINTS - 1) as f64).collect();
            CarrierCurves {
                carrier: c.carrier,
                name: carrier_name(&c.carrier),
                data_u_v: Vec::new(),
                data_rise: Vec::new(),
                data_lines: Vec::new(),
                grid_u_v: grid,
                rise: Vec::new(),
                fitted: Vec::new(),
                residual: Vec::new(),
                residual_lines: Vec::new(),
            }
        })
        .collect();
    for (k, c) in out.iter_mut().enumerate() {
        c.rise = c
            .grid_u_v
            .iter()
            .map(|&v| match circuit {
                Some(ci) => ci.rise(&cal.settings.stack, &c.carrier, v),
                None => f.eq3.rise(k, v),
            })
            .collect();
    }
    for (i, r) in rows.iter().enumerate().filter(|(_, r)| r.amplitude_um == 0.0) {
        let Some(rc) = r.carrier else { continue };
        let Some(&k) = index.get(&key(&rc)) else { continue };
        let c = &mut out[k];
        debug_assert!(same(&c.carrier, &rc));
        if let Some(&(sum, n)) = rest.get(&r.finger) {
            c.data_u_v.push(r.voltage_v);
            c.data_rise.push(r.mu / (sum / n as f64) - 1.0);
            c.data_lines.push(m.line(i));
        }
        let fitted = match circuit {
            Some(ci) => ci.curve(&cal.settings.stack, &c.carrier, r.voltage_v)[0],
            None => f.eq3.curve(k, r.voltage_v)[0],
        };
        c.fitted.push(fitted);
        c.residual.push(r.mu - fitted);
        c.residual_lines.push(m.line(i));
    }
    Some(ForceCurves { model: if circuit.is_some() { "circuit" } else { "eq3" }, carriers: out })
}

/// The plate's curves (`None` without an ultrasonic table).
pub fn ultrasonic(cal: &Calibration, m: &Measurements) -> Option<UltrasonicCurves> {
    let u = cal.ultrasonic.as_ref().filter(|u| u.table.len() >= 2)?;
    let rows = m.rows();
    let (sum, n) = rows
        .iter()
        .filter(|r| r.voltage_v == 0.0 && r.amplitude_um == 0.0)
        .fold((0.0, 0usize), |(s, n), r| (s + r.mu, n + 1));
    let mu0 = sum / n.max(1) as f64;
    let (mut a, mut rho, mut lines) = (Vec::new(), Vec::new(), Vec::new());
    for (i, r) in rows.iter().enumerate().filter(|(_, r)| r.voltage_v == 0.0) {
        a.push(r.amplitude_um);
        rho.push(r.mu / mu0);
        lines.push(m.line(i));
    }
    let grid: Vec<f64> = (0..CURVE_POINTS).map(|i| u.a_max_um * i as f64 / (CURVE_POINTS - 1) as f64).collect();
    let exponential = u.exponential.as_ref().map(|e| grid.iter().map(|&x| e.curve(x)).collect());
    Some(UltrasonicCurves {
        data_amplitude_um: a,
        data_rho: rho,
        data_lines: lines,
        table_amplitude_um: u.table.iter().map(|p| p.amplitude_um).collect(),
        table_rho: u.table.iter().map(|p| p.rho).collect(),
        grid_amplitude_um: grid,
        exponential,
    })
}
