//! A virtual device: synthetic calibration measurements from known
//! constants, with the noise a real measurement has. It stands in for
//! hardware in the tests (the intervals' coverage) and makes the example
//! measurements shipped in data/examples (labelled synthetic there).
//!
//! The friction of finger j in one steady segment at RMS voltage U on
//! carrier C, plate amplitude a:
//!
//! ```text
//!   mu = mu_HD f_j rho(a) (1 + c G_C U^2) (1 + s e_seg)
//! ```
//!
//! with f_j = 1 + sigma_finger N(0, 1) the finger's own friction (the
//! truth is the population's mean, f = 1), e_seg ~ N(0, 1) the
//! stroke-to-stroke variation, G_C the circuit's gain (1 for eq. 3), and
//! rho(a) the exponential form. The force sensor adds Gaussian noise to Ft
//! and Fn per sample; each segment averages `samples` samples (or writes
//! them all, one row each). The normal force varies from segment to
//! segment around its nominal value, and the velocity jitters.

use crate::calibration::measurements::{Measurement, Measurements};
use crate::electrovibration::LayerStack;
use crate::frequency::FingerCircuit;
use crate::recording::rng::SplitMix64;
use crate::signal::{Carrier, CarrierShape};
use crate::ultrasonic::Exponential;

/// The device's true constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    pub mu_hd: f64,
    /// Eq. (3)'s force coefficient c = Fe / (Fn U^2) (before any gain), 1/V^2.
    pub c_per_v2: f64,
    /// The circuit (`None`: eq. 3, no frequency dependence).
    pub circuit: Option<FingerCircuit>,
    pub stack: LayerStack,
    /// rho(a) of the plate (`None`: no ultrasonic plate).
    pub ultrasonic: Option<Exponential>,
}

/// What is measured, and how often.
#[derive(Debug, Clone, PartialEq)]
pub struct Protocol {
    /// RMS voltages per carrier (0 V is measured once per repetition).
    pub voltages_v: Vec<f64>,
    pub carriers: Vec<Carrier>,
    /// Vibration amplitudes at 0 V (0 is the plate at rest, measured with
    /// the voltages).
    pub amplitudes_um: Vec<f64>,
    pub fingers: usize,
    pub repetitions: usize,
    /// Samples per segment; with `rows_per_sample`, each is a row.
    pub samples: usize,
    pub rows_per_sample: bool,
    /// Nominal normal force (N) and velocity (mm/s).
    pub fn_n: f64,
    pub velocity_mm_s: f64,
}

impl Default for Protocol {
    /// docs/calibration.md's protocol: 0 to 100 V in 20 V steps on sine
    /// carriers at 10, 30, 100, 300, 1000 and 3000 Hz and a direct drive; amplitudes
    /// 0 to 2.5 um in 0.25 um steps; four fingers, three repetitions; 0.5 N
    /// at 40 mm/s, 500 samples (0.5 s at 1 kHz) per segment.
    fn default() -> Self {
        let sine = |f| Carrier { shape: CarrierShape::Sine, frequency_hz: f };
        Self {
            voltages_v: vec![20.0, 40.0, 60.0, 80.0, 100.0],
            carriers: vec![
                sine(10.0),
                sine(30.0),
                sine(100.0),
                sine(300.0),
                sine(1000.0),
                sine(3000.0),
                Carrier { shape: CarrierShape::None, frequency_hz: 0.0 },
            ],
            amplitudes_um: (1..=10).map(|i| 0.25 * i as f64).collect(),
            fingers: 4,
            repetitions: 3,
            samples: 500,
            rows_per_sample: false,
            fn_n: 0.5,
            velocity_mm_s: 40.0,
        }
    }
}

/// The noise of the measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// Force sensor noise per sample, N (RMS), on Ft and Fn alike.
    pub force_n: f64,
    /// Finger-to-finger variation of the friction (relative SD).
    pub finger: f64,
    /// Stroke-to-stroke variation (relative SD).
    pub stroke: f64,
    /// Normal-force variation between segments (relative SD).
    pub normal_force: f64,
    /// Velocity jitter (relative SD).
    pub velocity: f64,
    /// Fraction of segments spoiled (a slip, a lifted finger): their
    /// friction is off by 30 to 60%.
    pub spoiled: f64,
}

impl Default for Noise {
    /// A 6-axis force sensor's 5 mN per sample; fingers 10% apart;
    /// strokes 2%; normal force held within 10%; velocity within 5%; no
    /// spoiled segment.
    fn default() -> Self {
        Self { force_n: 0.005, finger: 0.10, stroke: 0.02, normal_force: 0.10, velocity: 0.05, spoiled: 0.0 }
    }
}

/// Synthetic measurements and the fingers' own factors f_j.
#[derive(Debug, Clone)]
pub struct Synthetic {
    pub measurements: Measurements,
    pub finger_factors: Vec<f64>,
}

/// The gain of `carrier` on eq. (3)'s force under the truth's circuit.
fn gain(truth: &Truth, carrier: &Carrier) -> f64 {
    truth.circuit.map_or(1.0, |c| c.carrier_gain(&truth.stack, carrier))
}

/// Measures the virtual device by `protocol` with `noise` (seeded).
pub fn measure(truth: &Truth, protocol: &Protocol, noise: &Noise, seed: u64) -> Synthetic {
    let mut rng = SplitMix64::new(seed);
    let finger_factors: Vec<f64> =
        (0..protocol.fingers).map(|_| (1.0 + noise.finger * rng.normal()).max(0.2)).collect();
    let mut rows = Vec::new();
    let samples = protocol.samples.max(1);
    let segment =
        |rng: &mut SplitMix64, finger: usize, rep: usize, voltage_v: f64, carrier: Option<Carrier>, a: f64| {
            let rho = truth.ultrasonic.map_or(1.0, |e| e.rho_inf + (1.0 - e.rho_inf) * (-a / e.a_c_um).exp());
            let g = carrier.map_or(0.0, |c| gain(truth, &c));
            let mut mu =
                truth.mu_hd * finger_factors[finger] * rho * (1.0 + truth.c_per_v2 * g * voltage_v * voltage_v);
            mu *= 1.0 + noise.stroke * rng.normal();
            if noise.spoiled > 0.0 && rng.uniform() < noise.spoiled {
                mu *= if rng.uniform() < 0.5 { 0.5 } else { 1.5 };
            }
            let fn_true = protocol.fn_n * (1.0 + noise.normal_force * rng.normal()).max(0.2);
            let velocity = protocol.velocity_mm_s * (1.0 + noise.velocity * rng.normal()).max(0.1);
            let draw = |rng: &mut SplitMix64, n: usize| {
                let sd = noise.force_n / (n as f64).sqrt();
                (mu * fn_true + sd * rng.normal(), fn_true + sd * rng.normal())
            };
            let mut out = Vec::new();
            if protocol.rows_per_sample {
                for _ in 0..samples {
                    out.push(draw(rng, 1));
                }
            } else {
                out.push(draw(rng, samples));
            }
            out.into_iter()
                .map(|(ft, fnn)| Measurement {
                    voltage_v,
                    carrier,
                    amplitude_um: a,
                    mu: ft.abs() / fnn.max(1e-6),
                    velocity_mm_s: Some(velocity),
                    finger: finger as u64 + 1,
                    repetition: rep as u64 + 1,
                })
                .collect::<Vec<_>>()
        };
    for finger in 0..protocol.fingers {
        for rep in 0..protocol.repetitions {
            let rest = protocol.carriers.first().copied();
            rows.extend(segment(&mut rng, finger, rep, 0.0, rest, 0.0));
            for carrier in &protocol.carriers {
                for &v in &protocol.voltages_v {
                    rows.extend(segment(&mut rng, finger, rep, v, Some(*carrier), 0.0));
                }
            }
            if truth.ultrasonic.is_some() {
                for &a in &protocol.amplitudes_um {
                    rows.extend(segment(&mut rng, finger, rep, 0.0, rest, a));
                }
            }
        }
    }
    Synthetic { measurements: Measurements::from_rows(rows, "virtual device"), finger_factors }
}

/// Writes measurements in the file format (for the shipped example),
/// after `comments` (each written as a `# ` line).
pub fn write_csv(m: &Measurements, comments: &[String], w: &mut dyn std::io::Write) -> std::io::Result<()> {
    for c in comments {
        writeln!(w, "# {c}")?;
    }
    writeln!(w, "voltage_v,carrier,carrier_hz,amplitude_um,mu,velocity_mm_s,finger,repetition")?;
    for r in m.rows() {
        let (shape, hz) = r.carrier.map_or(("none", 0.0), |c| (c.shape.name(), c.frequency_hz));
        let mut b = ryu::Buffer::new();
        let mut num = |x: f64| -> String {
            if x == x.trunc() && x.abs() < 1e15 { format!("{}", x as i64) } else { b.format(x).to_string() }
        };
        writeln!(
            w,
            "{},{},{},{},{},{},{},{}",
            num(r.voltage_v),
            shape,
            num(hz),
            num(r.amplitude_um),
            num(r.mu),
            num(r.velocity_mm_s.unwrap_or(0.0)),
            r.finger,
            r.repetition
        )?;
    }
    Ok(())
}

/// The virtual device of the shipped example (data/examples/
/// calibration-measurements.csv): the paper's stack and k = 200 mm^2/N,
/// mu_HD = 0.6, rho_sc = 1e5 ohm m (corner 109 Hz), a 0.1 um gap, and a
/// plate with rho_inf = 0.1, a_c = 0.7 um.
pub fn example_truth() -> Truth {
    let stack = LayerStack::PAPER;
    Truth {
        mu_hd: 0.6,
        c_per_v2: crate::electrovibration::EPS0_F_PER_M * 200.0 * 1e-6 / (2.0 * stack.gap_factor_m2()),
        circuit: Some(FingerCircuit { rho_sc_ohm_m: 1e5, gap_um: 0.1 }),
        stack,
        ultrasonic: Some(Exponential { rho_inf: 0.1, a_c_um: 0.7, a_valid_um: 2.5 }),
    }
}

/// The seed of the shipped example.
pub const EXAMPLE_SEED: u64 = 2026;

/// The shipped example's text, byte for byte: the default protocol and
/// noise on [`example_truth`], with its provenance in comment lines.
pub fn example_csv() -> Vec<u8> {
    let truth = example_truth();
    let s = measure(&truth, &Protocol::default(), &Noise::default(), EXAMPLE_SEED);
    let comments = vec![
        "SYNTHETIC measurements: made by haptex's virtual device (crates/haptex-core/src/calibration/virtual_device.rs), \
         not measured on a display"
            .to_string(),
        format!(
            "truth: mu_HD = 0.6; c = {} 1/V^2 (k = 200 mm^2/N on the paper's stack); rho_sc = 1e5 ohm m; air gap 0.1 um; \
             ultrasonic rho_inf = 0.1, a_c = 0.7 um",
            crate::num::Num(truth.c_per_v2)
        ),
        format!(
            "protocol: 4 fingers x 3 repetitions; 0 to 100 V on sine 10 Hz to 3 kHz and a direct drive; 0 to 2.5 um at 0 V; \
             noise: 5 mN sensor, 10% finger, 2% stroke (seed {EXAMPLE_SEED})"
        ),
        "regenerate: HAPTEX_REGENERATE=1 cargo test -p haptex-core --test calibration shipped_example".to_string(),
    ];
    let mut bytes = Vec::new();
    write_csv(&s.measurements, &comments, &mut bytes).expect("writing to memory");
    bytes
}
