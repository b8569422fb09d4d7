//! The electrostatic force from constant-voltage measurements: eq. (3)/(8)
//! per carrier, and the circuit model (`crate::frequency`) across
//! carriers.
//!
//! Eq. (4) with eq. (3)'s force, Fe = c Fn U^2, makes the friction of a
//! finger sliding under a constant RMS voltage U
//!
//! ```text
//!   mu(U) = mu_HD (1 + c U^2)
//! ```
//!
//! with c = eps0 k / (2 (d_sc/eps_sc + d_i/eps_i)(d_sc + d_i)) (eq. 3 with
//! A = k Fn). Friction data give mu_HD and c, nothing else: c is one
//! product of the contact-area coefficient k and the layer stack, so k,
//! eps_sc, d_sc, eps_i and d_i cannot be told apart by friction alone
//! (only k / ((d_sc/eps_sc + d_i/eps_i)(d_sc + d_i)) = 2 c / eps0 is
//! measured; haptex reports the k that gives c with the stack assumed).
//!
//! The circuit model multiplies eq. (3)'s force by the gain G of the
//! carrier (`FingerCircuit::carrier_gain`): mu = mu_HD (1 + c G U^2), with
//! G depending on the stratum corneum's resistivity rho_sc and the air
//! gap g, given the stack's effective thicknesses a = d_sc/eps_sc and
//! b = d_i/eps_i. G falls from ((a + b)/(b + g))^2 at low frequency to
//! ((a + b)/(a + b + g))^2 at high frequency through the corner
//! 1/(2 pi eps0 eps_sc rho_sc): the level at high frequency fixes c (with
//! g), the ratio of the two levels fixes g, the corner fixes rho_sc. So
//! rho_sc needs carriers on both sides of the corner, and the three need
//! three or more frequencies.

use crate::calibration::least_squares::{self, Fit, Problem};
use crate::calibration::measurements::Measurements;
use crate::calibration::{Estimate, Goodness, LEVEL, Outlier, Posterior, goodness, outliers};
use crate::electrovibration::{EPS0_F_PER_M, LayerStack};
use crate::frequency::{FingerCircuit, round3};
use crate::num::Num;
use crate::signal::{Carrier, CarrierShape};

/// The friction at one carrier: c there.
#[derive(Debug, Clone, PartialEq)]
pub struct CarrierFit {
    pub carrier: Carrier,
    /// Fe / (Fn U^2) at this carrier, 1/V^2.
    pub c_per_v2: Estimate,
    /// Rows under a voltage on this carrier, and the highest voltage.
    pub rows: usize,
    pub max_voltage_v: f64,
}

/// Eq. (3)/(8) fitted per carrier, sharing mu_HD.
#[derive(Debug, Clone, PartialEq)]
pub struct Eq3Fit {
    pub mu_hd: Estimate,
    pub carriers: Vec<CarrierFit>,
    /// theta = [mu_HD, c of each carrier in `carriers`' order].
    pub posterior: Posterior,
    pub goodness: Goodness,
    pub outliers: Vec<Outlier>,
}

/// The circuit model fitted across carriers.
#[derive(Debug, Clone, PartialEq)]
pub struct CircuitFit {
    pub mu_hd: Estimate,
    /// Eq. (3)'s coefficient c (the force a perfect dielectric stack
    /// without a gap would give), 1/V^2.
    pub c_per_v2: Estimate,
    pub rho_sc_ohm_m: Estimate,
    pub gap_um: Estimate,
    /// The corner 1 / (2 pi tau) at the estimate, Hz.
    pub corner_hz: f64,
    /// theta = [mu_HD, ln c, log10 rho_sc, g in um].
    pub posterior: Posterior,
    pub goodness: Goodness,
    pub outliers: Vec<Outlier>,
}

/// What the force fits found, and what they could not.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceFit {
    pub eq3: Eq3Fit,
    /// `None` when fewer than three carrier frequencies were measured.
    pub circuit: Option<CircuitFit>,
    /// Each statement on what could not be identified, with what to
    /// measure next.
    pub verdicts: Vec<String>,
}

/// The rows that measure the electrostatic force: no vibration.
fn electro_rows(m: &Measurements) -> Vec<usize> {
    m.rows().iter().enumerate().filter(|(_, r)| r.amplitude_um == 0.0).map(|(i, _)| i).collect()
}

/// A carrier as a key: shape and frequency (0 for a direct drive).
fn same(a: &Carrier, b: &Carrier) -> bool {
    a.shape == b.shape && (a.shape == CarrierShape::None || a.frequency_hz == b.frequency_hz)
}

/// Fits eq. (3) per carrier and, with three or more carrier frequencies,
/// the circuit model. `None` when no row measures the force.
pub fn fit(m: &Measurements, stack: &LayerStack) -> Option<ForceFit> {
    let rows = electro_rows(m);
    if rows.is_empty() {
        return None;
    }
    let mut verdicts = Vec::new();
    let data = m.rows();
    // The carriers, in the order met; each row under voltage belongs to one.
    let mut carriers: Vec<Carrier> = Vec::new();
    let mut group = vec![usize::MAX; rows.len()];
    for (k, &i) in rows.iter().enumerate() {
        if data[i].voltage_v > 0.0 {
            let c = data[i].carrier.expect("a row under voltage has a carrier (checked on reading)");
            let g = carriers.iter().position(|x| same(x, &c)).unwrap_or_else(|| {
                carriers.push(c);
                carriers.len() - 1
            });
            group[k] = g;
        }
    }
    let y: Vec<f64> = rows.iter().map(|&i| data[i].mu).collect();
    let u2: Vec<f64> = rows.iter().map(|&i| data[i].voltage_v * data[i].voltage_v).collect();
    let (cluster, level) = m.clusters(&rows);
    let levels = {
        let mut v: Vec<f64> = rows.iter().map(|&i| data[i].voltage_v).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    if carriers.is_empty() || levels.len() < 2 {
        verdicts.push(format!(
            "mu_HD and the force coefficient c cannot be separated from {} voltage level{} ({} V): measure at 0 V \
             and at three or more voltages up to U_max on each carrier",
            levels.len(),
            if levels.len() == 1 { "" } else { "s" },
            levels.iter().map(|v| Num(*v).to_string()).collect::<Vec<_>>().join(", ")
        ));
    }
    // Eq. (3) per carrier: theta = [mu_HD, c_1 .. c_K].
    let kc = carriers.len();
    let mu0 = {
        let at_zero: Vec<f64> = (0..rows.len()).filter(|&k| u2[k] == 0.0).map(|k| y[k]).collect();
        if at_zero.is_empty() { y.iter().cloned().fold(f64::INFINITY, f64::min) } else { mean(&at_zero) }
    };
    let mut start = vec![mu0.clamp(1e-3, 10.0)];
    for g in 0..kc {
        // Least squares slope of mu/mu0 - 1 against U^2 through the origin.
        let (mut num, mut den) = (0.0, 0.0);
        for k in (0..rows.len()).filter(|&k| group[k] == g) {
            num += (y[k] / start[0] - 1.0) * u2[k];
            den += u2[k] * u2[k];
        }
        start.push(if den > 0.0 { (num / den).max(0.0) } else { 0.0 });
    }
    let typical_c = start[1..].iter().cloned().fold(1e-9, f64::max);
    let problem = Problem {
        y: &y,
        cluster: &cluster,
        start,
        lower: std::iter::once(1e-4).chain(std::iter::repeat_n(-1.0, kc)).collect(),
        upper: std::iter::once(100.0).chain(std::iter::repeat_n(1.0, kc)).collect(),
        typical: std::iter::once(mu0.max(1e-3)).chain(std::iter::repeat_n(typical_c, kc)).collect(),
    };
    let model = |t: &[f64], out: &mut [f64]| {
        for k in 0..out.len() {
            let c = if group[k] == usize::MAX { 0.0 } else { t[1 + group[k]] };
            out[k] = t[0] * (1.0 + c * u2[k]);
        }
    };
    let eq3 = match least_squares::fit(&problem, &model) {
        Ok(f) => f,
        Err(e) => {
            verdicts.push(format!("eq. (3) cannot be fitted: {e}"));
            return Some(ForceFit { eq3: empty_eq3(), circuit: None, verdicts });
        }
    };
    let distinct_settings = settings_key(&rows, m);
    let eq3_goodness = goodness(&eq3, &y, &distinct_settings, level, kc + 1);
    let mu_hd = Estimate::linear(&eq3, 0, levels.len() >= 2 && kc > 0);
    let mut carrier_fits = Vec::new();
    for (g, carrier) in carriers.iter().enumerate() {
        let in_group: Vec<usize> = (0..rows.len()).filter(|&k| group[k] == g).collect();
        let max_voltage_v = in_group.iter().map(|&k| u2[k].sqrt()).fold(0.0, f64::max);
        let mut c = Estimate::linear(&eq3, 1 + g, levels.len() >= 2);
        if c.identified && c.interval[0] <= 0.0 {
            c.identified = false;
            verdicts.push(format!(
                "on the {} carrier the voltage does not measurably raise the friction (c's interval reaches 0): \
                 measure at higher voltages (up to U_max), or more repetitions",
                carrier_name(carrier)
            ));
        }
        carrier_fits.push(CarrierFit { carrier: *carrier, c_per_v2: c, rows: in_group.len(), max_voltage_v });
    }
    let eq3_fit = Eq3Fit {
        mu_hd,
        carriers: carrier_fits,
        posterior: Posterior::of(&eq3),
        goodness: eq3_goodness,
        outliers: outliers(&eq3, &y, &rows, m),
    };
    // The circuit, from three or more frequencies (a direct drive is 0 Hz).
    let mut frequencies: Vec<f64> = carriers.iter().map(frequency_of).collect();
    frequencies.sort_by(f64::total_cmp);
    frequencies.dedup();
    let circuit = if frequencies.len() >= 3 {
        fit_circuit(m, &rows, &y, &u2, &group, &carriers, &cluster, level, stack, &frequencies, &mut verdicts)
    } else {
        verdicts.push(format!(
            "rho_sc and the air gap g are not identifiable from {} carrier frequenc{}: measure at three or more \
             between 30 Hz and 1 kHz (the stratum corneum's corner lies near 100 Hz for rho_sc = 1e5 ohm m); until \
             then c holds only at the carrier measured",
            frequencies.len(),
            if frequencies.len() == 1 { "y" } else { "ies" }
        ));
        None
    };
    Some(ForceFit { eq3: eq3_fit, circuit, verdicts })
}

fn empty_eq3() -> Eq3Fit {
    Eq3Fit {
        mu_hd: Estimate::unidentified(f64::NAN),
        carriers: Vec::new(),
        posterior: Posterior::default(),
        goodness: Goodness::default(),
        outliers: Vec::new(),
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The frequency a carrier's force sees (0 for a direct drive).
fn frequency_of(c: &Carrier) -> f64 {
    if c.shape == CarrierShape::None { 0.0 } else { c.frequency_hz }
}

pub fn carrier_name(c: &Carrier) -> String {
    match c.shape {
        CarrierShape::None => "direct (none)".to_string(),
        shape => format!("{} {} Hz", shape.name(), Num(c.frequency_hz)),
    }
}

/// A key per row for the lack-of-fit test: rows with the same voltage,
/// carrier and amplitude are replicates.
pub(crate) fn settings_key(rows: &[usize], m: &Measurements) -> Vec<usize> {
    // A map, not a search of the keys so far: linear in the rows however
    // many distinct settings there are (sample-level data can have one per row).
    let mut keys: std::collections::HashMap<(u64, u8, u64, u64), usize> = std::collections::HashMap::new();
    rows.iter()
        .map(|&i| {
            let r = &m.rows()[i];
            let (shape, f) = r.carrier.map_or((3, 0.0), |c| (c.shape as u8, frequency_of(&c)));
            let key = (r.voltage_v.to_bits(), shape, f.to_bits(), r.amplitude_um.to_bits());
            let next = keys.len();
            *keys.entry(key).or_insert(next)
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn fit_circuit(
    m: &Measurements,
    rows: &[usize],
    y: &[f64],
    u2: &[f64],
    group: &[usize],
    carriers: &[Carrier],
    cluster: &[usize],
    level: crate::calibration::measurements::ClusterLevel,
    stack: &LayerStack,
    frequencies: &[f64],
    verdicts: &mut Vec<String>,
) -> Option<CircuitFit> {
    let gains = |log_rho: f64, gap_um: f64| -> Vec<f64> {
        let circuit = FingerCircuit { rho_sc_ohm_m: 10f64.powf(log_rho), gap_um };
        carriers.iter().map(|c| circuit.carrier_gain(stack, c)).collect()
    };
    // Start: the best (rho_sc, g) on a grid, mu_HD and mu_HD c by linear
    // least squares at each (variable projection).
    let mut best = (f64::INFINITY, 5.0, 0.0, 1.0, 1e-5);
    for i in 0..=40 {
        let log_rho = 1.0 + 0.25 * i as f64;
        for &gap in &[0.0, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0] {
            let g = gains(log_rho, gap);
            let x: Vec<f64> =
                (0..y.len()).map(|k| if group[k] == usize::MAX { 0.0 } else { g[group[k]] * u2[k] }).collect();
            let (n, sx, sy) = (x.len() as f64, x.iter().sum::<f64>(), y.iter().sum::<f64>());
            let sxx: f64 = x.iter().map(|v| v * v).sum();
            let sxy: f64 = x.iter().zip(y).map(|(a, b)| a * b).sum();
            let det = n * sxx - sx * sx;
            if det <= 0.0 {
                continue;
            }
            let slope = (n * sxy - sx * sy) / det;
            let intercept = (sy - slope * sx) / n;
            if intercept <= 0.0 || slope <= 0.0 {
                continue;
            }
            let sse: f64 = x.iter().zip(y).map(|(a, b)| (b - intercept - slope * a).powi(2)).sum();
            if sse < best.0 {
                best = (sse, log_rho, gap, intercept, slope / intercept);
            }
        }
    }
    if !best.0.is_finite() {
        verdicts.push("the circuit model cannot be fitted: the friction does not rise with the voltage".into());
        return None;
    }
    let (_, log_rho0, gap0, mu0, c0) = best;
    let problem = Problem {
        y,
        cluster,
        start: vec![mu0, c0.ln(), log_rho0, gap0],
        lower: vec![1e-4, (1e-15f64).ln(), -3.0, 0.0],
        upper: vec![100.0, 1.0f64.ln(), 15.0, 1000.0],
        typical: vec![mu0, 1.0, 1.0, 0.1],
    };
    let model = |t: &[f64], out: &mut [f64]| {
        let g = gains(t[2], t[3]);
        let c = t[1].exp();
        for k in 0..out.len() {
            let gk = if group[k] == usize::MAX { 0.0 } else { g[group[k]] };
            out[k] = t[0] * (1.0 + c * gk * u2[k]);
        }
    };
    let fit = match least_squares::fit(&problem, &model) {
        Ok(f) => f,
        Err(e) => {
            verdicts.push(format!("the circuit model cannot be fitted: {e}"));
            return None;
        }
    };
    let keys = settings_key(rows, m);
    let goodness = goodness(&fit, y, &keys, level, 4);
    let t_ = crate::calibration::distributions::t_quantile(LEVEL, fit.df);
    let mu_hd = Estimate::linear(&fit, 0, true);
    let c = Estimate::log_natural(&fit, 1, true);
    // rho_sc on a log10 scale.
    let (lr, hw) = (fit.theta[2], t_ * fit.std_error(2));
    let circuit = FingerCircuit { rho_sc_ohm_m: 10f64.powf(lr), gap_um: fit.theta[3] };
    let corner_hz = circuit.corner_hz(stack);
    let (f_lo, f_hi) = (frequencies[0], frequencies[frequencies.len() - 1]);
    let mut rho_identified = hw.is_finite() && hw <= 1.0;
    if !rho_identified || corner_hz < f_lo.max(1e-3) / 3.0 || corner_hz > 3.0 * f_hi {
        rho_identified = false;
        verdicts.push(format!(
            "rho_sc is not identifiable from carriers at {} Hz: the stratum corneum's corner{} must lie among \
             them; measure at three or more frequencies spanning it (30 Hz to 1 kHz covers rho_sc from about 1e4 \
             to 1e6 ohm m)",
            frequencies.iter().map(|f| Num(*f).to_string()).collect::<Vec<_>>().join(", "),
            if corner_hz.is_finite() {
                format!(" (estimated at {} Hz)", Num(round3(corner_hz)))
            } else {
                String::new()
            },
        ));
    }
    let rho_sc = Estimate {
        value: 10f64.powf(lr),
        interval: [10f64.powf(lr - hw), 10f64.powf(lr + hw)],
        identified: rho_identified,
    };
    // The gap: identified when its interval is narrower than the
    // electrical thickness of the stack with the gap, a + b + g (the
    // high-frequency charge goes as 1 / (a + b + g): then the interval
    // moves it by less than a third either way).
    let mut gap = Estimate::linear(&fit, 3, true);
    gap.interval[0] = gap.interval[0].max(0.0);
    let thickness_um = (stack.d_sc_mm / stack.eps_sc + stack.d_i_mm / stack.eps_i) * 1e3 + gap.value;
    let width = gap.interval[1] - gap.interval[0];
    if width.is_nan() || width > thickness_um {
        gap.identified = false;
        verdicts.push(format!(
            "the air gap g is not identifiable (95% interval {} .. {} um, wider than the stack's {} um with the gap): measure \
             with a direct drive or a carrier well below the corner as well as one well above it",
            Num(round3(gap.interval[0])),
            Num(round3(gap.interval[1])),
            Num(round3(thickness_um))
        ));
    }
    let outliers = outliers(&fit, y, rows, m);
    Some(CircuitFit {
        mu_hd,
        c_per_v2: c,
        rho_sc_ohm_m: rho_sc,
        gap_um: gap,
        corner_hz,
        posterior: Posterior::of(&fit),
        goodness,
        outliers,
    })
}

impl Eq3Fit {
    /// The fitted mu at RMS voltage `u_v` on carrier number `k`, with its
    /// 95% band: [value, low, high].
    pub fn curve(&self, k: usize, u_v: f64) -> [f64; 3] {
        self.posterior.band(&|t| t[0] * (1.0 + t[1 + k] * u_v * u_v))
    }

    /// The friction's rise mu / mu_HD - 1 = c U^2 on carrier number `k`,
    /// with its 95% band.
    pub fn rise(&self, k: usize, u_v: f64) -> [f64; 3] {
        self.posterior.band(&|t| t[1 + k] * u_v * u_v)
    }
}

impl CircuitFit {
    /// The fitted mu at RMS voltage `u_v` on `carrier`, with its 95% band.
    pub fn curve(&self, stack: &LayerStack, carrier: &Carrier, u_v: f64) -> [f64; 3] {
        self.posterior.band(&|t| {
            let circuit = FingerCircuit { rho_sc_ohm_m: 10f64.powf(t[2]), gap_um: t[3].max(0.0) };
            t[0] * (1.0 + t[1].exp() * circuit.carrier_gain(stack, carrier) * u_v * u_v)
        })
    }

    /// The friction's rise mu / mu_HD - 1 = c G U^2 on `carrier`, with its
    /// 95% band.
    pub fn rise(&self, stack: &LayerStack, carrier: &Carrier, u_v: f64) -> [f64; 3] {
        self.posterior.band(&|t| {
            let circuit = FingerCircuit { rho_sc_ohm_m: 10f64.powf(t[2]), gap_um: t[3].max(0.0) };
            t[1].exp() * circuit.carrier_gain(stack, carrier) * u_v * u_v
        })
    }
}

/// The contact-area coefficient k (mm^2/N) that gives force coefficient
/// `c_per_v2` with `stack` (eq. 3 with A = k Fn): k = 2 c gap_factor / eps0.
pub fn equivalent_k_mm2_per_n(c_per_v2: f64, stack: &LayerStack) -> f64 {
    2.0 * c_per_v2 * stack.gap_factor_m2() / EPS0_F_PER_M * 1e6
}

/// The measured product k / ((d_sc/eps_sc + d_i/eps_i)(d_sc + d_i)) =
/// 2 c / eps0, in 1/N (what friction data determine, whatever the stack).
pub fn k_over_stack_per_n(c_per_v2: f64) -> f64 {
    2.0 * c_per_v2 / EPS0_F_PER_M
}

impl Estimate {
    /// A parameter fitted on its natural scale: estimate +- t SE.
    pub(crate) fn linear(fit: &Fit, j: usize, identified: bool) -> Self {
        let (v, hw) = (fit.theta[j], fit.half_width(j, LEVEL));
        Self { value: v, interval: [v - hw, v + hw], identified: identified && hw.is_finite() }
    }

    /// A positive parameter fitted as its logarithm: exp(estimate +- t SE).
    pub(crate) fn log_natural(fit: &Fit, j: usize, identified: bool) -> Self {
        let (v, hw) = (fit.theta[j], fit.half_width(j, LEVEL));
        Self { value: v.exp(), interval: [(v - hw).exp(), (v + hw).exp()], identified: identified && hw.is_finite() }
    }
}
