//! Fuzzing the finger model file reader and the mesher (issue 13): random
//! finger models with valid TOML syntax, every field perturbed over wide
//! ranges (edge values, extreme magnitudes, non-finite numbers, Prony
//! lists of 0 to 40 terms), and random byte and line mutations of the
//! shipped file. The property: `FingerModel::from_toml` answers with a
//! model or an error naming the file (and, for a field out of range, the
//! line of its key); never a panic. Every accepted model meshes at every
//! resolution, with positive Jacobians at every Gauss point, finite nodes,
//! a contact region of free skin and node counts within the documented
//! bounds, and its 3D fingertip (coarse) meshes or is refused with an
//! error naming the setting.
//!
//! Cases per property: `HAPTEX_FUZZ_CASES` (default 1000, a few seconds in
//! CI). The campaign of issue 13 ran 1e5 cases of each property
//! (docs/fem.md, "Accepted inputs").
//!
//! The generators (`number`, `model_text`, `mutated_text`) are meant to be
//! reused by a fuzz campaign over every parser.

use haptex_fem::finger::{DEFAULT_MODEL_TOML, FingerError, FingerModel, Resolution};
use haptex_fem::solid3d::fingertip::{self, FingertipSpec};
use std::collections::BTreeMap;
use std::sync::Mutex;
use std::sync::atomic::Ordering::Relaxed;
use std::sync::atomic::{AtomicU32, AtomicUsize};

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// Cases per property, from `HAPTEX_FUZZ_CASES`.
pub fn fuzz_cases() -> u32 {
    std::env::var("HAPTEX_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1000)
}

fn runner() -> TestRunner {
    TestRunner::new(Config { cases: fuzz_cases(), failure_persistence: None, ..Config::default() })
}

/// Values at the edges of every range: zeros, signs, the smallest and
/// largest floats, non-finite values, and the bounds of the documented
/// ranges and just beyond them.
const EDGE_VALUES: [f64; 30] = [
    0.0,
    -0.0,
    -1.0,
    1.0,
    5e-324,
    1e-300,
    1e-9,
    1e-4,
    0.01,
    0.2,
    0.4999,
    0.49999,
    0.5,
    0.99,
    0.9900000000000001,
    2.0,
    1.9999999999999998,
    5.0,
    18.0,
    20.0,
    20.000000000000004,
    40.0,
    90.0,
    180.0,
    1e9,
    1e300,
    f64::MAX,
    -f64::MAX,
    f64::INFINITY,
    f64::NAN,
];

/// A number for a field whose shipped value is `typical`: mostly a
/// multiple of it (log-uniform over 1/3 .. 3, or over 1e-3 .. 1e3), else
/// an edge value or the negative of a multiple.
pub fn number(typical: f64) -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => (-1.1f64..1.1).prop_map(move |e| typical * 10f64.powf(0.477 * e)),
        2 => (-3.0f64..3.0).prop_map(move |e| typical * 10f64.powf(e)),
        1 => proptest::sample::select(EDGE_VALUES.to_vec()),
        1 => (-3.0f64..3.0).prop_map(move |e| -typical * 10f64.powf(e)),
    ]
}

/// A TOML float (or integer) literal for `v`.
pub fn literal(v: f64, as_integer: bool) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf".into() } else { "-inf".into() }
    } else if as_integer && v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v:?}")
    }
}

/// The shipped model's numbers, in file order, with their keys.
const SHIPPED: [(&str, f64); 23] = [
    ("geometry.half_width_mm", 8.0),
    ("geometry.half_height_mm", 6.0),
    ("geometry.bone_half_width_mm", 3.0),
    ("geometry.bone_half_height_mm", 1.75),
    ("geometry.bone_center_height_mm", 6.75),
    ("geometry.nail_thickness_mm", 0.5),
    ("geometry.nail_half_angle_deg", 50.0),
    ("layers.stratum_corneum_mm", 0.2),
    ("layers.viable_epidermis_mm", 0.125),
    ("layers.dermis_mm", 1.0),
    ("materials.stratum_corneum.e_mpa", 1.0),
    ("materials.stratum_corneum.nu", 0.48),
    ("materials.viable_epidermis.e_mpa", 0.75),
    ("materials.viable_epidermis.nu", 0.48),
    ("materials.dermis.e_mpa", 0.15),
    ("materials.dermis.nu", 0.48),
    ("materials.hypodermis.e_mpa", 0.03),
    ("materials.hypodermis.nu", 0.48),
    ("materials.bone.e_mpa", 17000.0),
    ("materials.bone.nu", 0.3),
    ("materials.nail.e_mpa", 170.0),
    ("materials.nail.nu", 0.3),
    ("contact.contact_half_arc_mm", 6.0),
];

/// The documented range of a field of [`SHIPPED`], and whether to draw it
/// log-uniformly.
fn range_of(key: &str) -> ((f64, f64), bool) {
    use haptex_fem::finger::limits::*;
    let name = key.rsplit('.').next().unwrap();
    match name {
        "half_width_mm" | "half_height_mm" => (HALF_AXIS_MM, true),
        "bone_half_width_mm" | "bone_half_height_mm" => (BONE_HALF_AXIS_MM, true),
        "bone_center_height_mm" => (BONE_CENTER_MM, true),
        "nail_thickness_mm" => (NAIL_THICKNESS_MM, true),
        "nail_half_angle_deg" => (NAIL_HALF_ANGLE_DEG, false),
        "stratum_corneum_mm" | "viable_epidermis_mm" | "dermis_mm" => (LAYER_MM, true),
        "e_mpa" => (E_MPA, true),
        "nu" => (NU, false),
        "contact_half_arc_mm" => (CONTACT_HALF_ARC_MM, true),
        other => panic!("no range for {other}"),
    }
}

/// A value drawn over a range (log-uniformly for positive ranges if `log`).
fn within((lo, hi): (f64, f64), log: bool) -> BoxedStrategy<f64> {
    if log && lo > 0.0 {
        (lo.ln()..=hi.ln()).prop_map(f64::exp).prop_map(move |v| v.clamp(lo, hi)).boxed()
    } else {
        (lo..=hi).boxed()
    }
}

/// One generated model: the numbers of `SHIPPED`, integer literals where
/// chosen, the Prony terms (g, tau), mu_skin, and a structural variation.
///
/// Three modes: every number drawn over its documented range (most models
/// then fail a check between fields: the bone does not fit, the skin is
/// too thick for the curvature...), every number near the shipped one
/// (x 1/2 .. 2), or wild (each number kept or drawn by [`number`]: edge
/// values, magnitudes from 1e-300 to f64::MAX, NaN and infinities).
#[derive(Debug, Clone)]
pub struct ModelCase {
    pub values: Vec<f64>,
    pub integers: Vec<bool>,
    pub prony: Vec<(f64, f64)>,
    pub mu_skin: f64,
    /// 0: none; 1: drop a key; 2: add an unknown key; 3: a `prony` list in a
    /// material; 4: Prony terms as an array of tables.
    pub variation: u8,
    pub which: usize,
}

fn in_range_values() -> BoxedStrategy<Vec<f64>> {
    SHIPPED
        .iter()
        .map(|&(key, _)| {
            let (range, log) = range_of(key);
            within(range, log)
        })
        .collect::<Vec<_>>()
        .boxed()
}

fn near_shipped_values() -> BoxedStrategy<Vec<f64>> {
    SHIPPED
        .iter()
        .map(|&(key, v)| {
            if key.ends_with(".nu") {
                (0.0f64..0.4999).boxed()
            } else {
                (-0.301f64..0.301).prop_map(move |e| v * 10f64.powf(e)).boxed()
            }
        })
        .collect::<Vec<_>>()
        .boxed()
}

fn wild_values() -> BoxedStrategy<Vec<f64>> {
    SHIPPED.iter().map(|&(_, v)| prop_oneof![3 => Just(v), 2 => number(v)].boxed()).collect::<Vec<_>>().boxed()
}

/// Prony terms: up to 20 with weights that sum to at most 0.99 and times
/// over the documented range, or up to 40 drawn by [`number`].
fn prony_terms() -> BoxedStrategy<Vec<(f64, f64)>> {
    use haptex_fem::finger::limits::PRONY_TAU_S;
    let valid = (0usize..=20)
        .prop_flat_map(|n| {
            let g_max = 0.99 / n.max(1) as f64;
            proptest::collection::vec((within((1e-6, g_max), true), within(PRONY_TAU_S, true)), n)
        })
        .boxed();
    prop_oneof![
        3 => valid,
        1 => proptest::collection::vec((number(0.1), number(0.1)), 0..=20),
        1 => proptest::collection::vec((number(0.1), number(0.1)), 30..=40),
    ]
    .boxed()
}

pub fn model_case() -> impl Strategy<Value = ModelCase> {
    let values = prop_oneof![2 => in_range_values(), 2 => near_shipped_values(), 1 => wild_values()];
    (
        values,
        proptest::collection::vec(any::<bool>(), SHIPPED.len()),
        prony_terms(),
        prop_oneof![3 => within(haptex_fem::finger::limits::MU_SKIN, false), 1 => number(0.5)],
        prop_oneof![12 => Just(0u8), 1 => 1u8..=4],
        0usize..SHIPPED.len(),
    )
        .prop_map(|(values, integers, prony, mu_skin, variation, which)| ModelCase {
            values,
            integers,
            prony,
            mu_skin,
            variation,
            which,
        })
}

/// The TOML text of a generated model (same layout as the shipped file).
pub fn model_text(case: &ModelCase) -> String {
    let mut text = String::new();
    let mut table = "";
    for (i, (key, _)) in SHIPPED.iter().enumerate() {
        let (section, name) = key.rsplit_once('.').unwrap();
        if section != table {
            text.push_str(&format!("\n[{section}]\n"));
            table = section;
            if case.variation == 3 && i == case.which.min(SHIPPED.len() - 2) {
                text.push_str("prony = [{ g = 0.1, tau_s = 0.1 }]\n");
            }
        }
        if case.variation == 1 && i == case.which {
            continue;
        }
        text.push_str(&format!("{name} = {}\n", literal(case.values[i], case.integers[i])));
        if case.variation == 2 && i == case.which {
            text.push_str("thickness_um = 3\n");
        }
    }
    text.push_str(&format!("mu_skin = {}\n", literal(case.mu_skin, false)));
    if case.variation == 4 {
        for (g, tau) in &case.prony {
            text.push_str(&format!(
                "\n[[viscoelasticity.prony]]\ng = {}\ntau_s = {}\n",
                literal(*g, false),
                literal(*tau, false)
            ));
        }
        if case.prony.is_empty() {
            text.push_str("\n[viscoelasticity]\nprony = []\n");
        }
    } else {
        text.push_str("\n[viscoelasticity]\nprony = [\n");
        for (g, tau) in &case.prony {
            text.push_str(&format!("    {{ g = {}, tau_s = {} }},\n", literal(*g, false), literal(*tau, false)));
        }
        text.push_str("]\n");
    }
    text
}

/// The shipped file with random edits: bytes replaced, inserted or
/// removed, lines duplicated, removed or swapped, numbers replaced by edge
/// values. Invalid UTF-8 is replaced by U+FFFD (`from_toml` takes text;
/// the file reader's UTF-8 check has its own test).
pub fn mutated_text() -> impl Strategy<Value = String> {
    let edit = prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(at, b)| Edit::Replace(at, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(at, b)| Edit::Insert(at, b)),
        any::<usize>().prop_map(Edit::Remove),
        any::<usize>().prop_map(Edit::DuplicateLine),
        any::<usize>().prop_map(Edit::RemoveLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
        (any::<usize>(), proptest::sample::select(EDGE_VALUES.to_vec())).prop_map(|(at, v)| Edit::Number(at, v)),
    ];
    proptest::collection::vec(edit, 1..8).prop_map(|edits| {
        let mut bytes = DEFAULT_MODEL_TOML.as_bytes().to_vec();
        for e in edits {
            e.apply(&mut bytes);
        }
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

#[derive(Debug, Clone)]
pub enum Edit {
    Replace(usize, u8),
    Insert(usize, u8),
    Remove(usize),
    DuplicateLine(usize),
    RemoveLine(usize),
    SwapLines(usize, usize),
    /// Replace the number after the `at`-th `=` with this value.
    Number(usize, f64),
}

impl Edit {
    fn apply(&self, bytes: &mut Vec<u8>) {
        let n = bytes.len().max(1);
        let mut lines: Vec<Vec<u8>> = bytes.split(|&b| b == b'\n').map(|l| l.to_vec()).collect();
        let m = lines.len();
        match *self {
            Edit::Replace(at, b) if !bytes.is_empty() => bytes[at % n] = b,
            Edit::Insert(at, b) => bytes.insert(at % (bytes.len() + 1), b),
            Edit::Remove(at) if !bytes.is_empty() => {
                bytes.remove(at % n);
            }
            Edit::DuplicateLine(at) => {
                lines.insert(at % m, lines[at % m].clone());
                *bytes = lines.join(&b'\n');
            }
            Edit::RemoveLine(at) => {
                lines.remove(at % m);
                *bytes = lines.join(&b'\n');
            }
            Edit::SwapLines(a, b) => {
                lines.swap(a % m, b % m);
                *bytes = lines.join(&b'\n');
            }
            Edit::Number(at, v) => {
                let positions: Vec<usize> = (0..bytes.len()).filter(|&i| bytes[i] == b'=').collect();
                if positions.is_empty() {
                    return;
                }
                let start = positions[at % positions.len()] + 1;
                let end = (start..bytes.len())
                    .find(|&i| matches!(bytes[i], b'\n' | b',' | b'}' | b'#'))
                    .unwrap_or(bytes.len());
                bytes.splice(start..end, format!(" {}", literal(v, false)).into_bytes());
            }
            _ => {}
        }
    }
}

/// The largest meshes of accepted models: nodes, contact segments.
static MOST_NODES: AtomicUsize = AtomicUsize::new(0);
static MOST_SEGMENTS: AtomicUsize = AtomicUsize::new(0);
/// 3D fingertips of accepted models meshed and refused (issue 39).
static MESHED_3D: AtomicUsize = AtomicUsize::new(0);
static REFUSED_3D: AtomicUsize = AtomicUsize::new(0);

/// Why generated models were refused: the field (or "syntax") and a count.
static REFUSED: Mutex<BTreeMap<String, u32>> = Mutex::new(BTreeMap::new());

fn tally(e: &FingerError) {
    let key = match e {
        FingerError::Field { error, .. } => error.field.split('[').next().unwrap().to_string(),
        _ => "syntax, missing or unknown key".to_string(),
    };
    *REFUSED.lock().unwrap().entry(key).or_default() += 1;
}

/// The property: a model or a clean error; an accepted model meshes.
fn check(text: &str) -> Result<bool, TestCaseError> {
    let lines = text.split('\n').count();
    match FingerModel::from_toml(text, "fuzz.toml") {
        Err(e) => {
            tally(&e);
            let message = e.to_string();
            prop_assert!(message.starts_with("fuzz.toml: "), "{message}");
            prop_assert!(message.len() < 600, "a long message: {message}");
            if let FingerError::Field { line, error, .. } = &e {
                prop_assert!((1..=lines).contains(line), "line {line} of {lines}: {message}");
                // The key of the field is on that line (its last part, or
                // the list element for Prony terms).
                let key = error.field.rsplit('.').next().unwrap();
                let key = key.split('[').next().unwrap();
                let line_text = text.split('\n').nth(line - 1).unwrap();
                prop_assert!(
                    line_text.contains(key) || line_text.contains("g =") || line_text.contains("g="),
                    "line {line} ({line_text:?}) does not hold {}: {message}",
                    error.field
                );
            }
            Ok(false)
        }
        Ok(model) => {
            for resolution in Resolution::ALL {
                let finger = model
                    .mesh(resolution)
                    .map_err(|e| TestCaseError::fail(format!("{resolution:?}: accepted model does not mesh: {e}")))?;
                check_mesh(&finger, resolution)?;
            }
            // The 3D fingertip of the same model (issue 39), coarse: a
            // mesh of positive volumes or an error naming a setting.
            let spec = FingertipSpec::from_model(&model, Resolution::Coarse);
            match fingertip::mesh(&spec) {
                Ok(tip) => {
                    prop_assert!(tip.mesh.nodes.iter().flatten().all(|v| v.is_finite()));
                    prop_assert_eq!(tip.mesh.elements.len(), 12 * 12 * 6);
                    MESHED_3D.fetch_add(1, Relaxed);
                }
                Err(e) => {
                    let message = e.to_string();
                    prop_assert!(message.contains(" = ") || message.contains("element"), "{message}");
                    REFUSED_3D.fetch_add(1, Relaxed);
                }
            }
            Ok(true)
        }
    }
}

/// A usable finger mesh: finite nodes, positive Jacobians, the contact
/// region within the documented bounds and free of driven nodes.
pub fn check_mesh(finger: &haptex_fem::finger::FingerMesh, resolution: Resolution) -> Result<(), TestCaseError> {
    let m = &finger.mesh;
    prop_assert!(m.nodes.iter().flatten().all(|v| v.is_finite()));
    let geometry = m.geometry().map_err(|e| TestCaseError::fail(format!("{resolution:?}: {e}")))?;
    let quality = m.quality(&geometry);
    prop_assert!(quality.min_jacobian_ratio > 0.0, "{resolution:?}: {quality:?}");
    prop_assert!(geometry.iter().all(|q| q.weight.iter().all(|&w| w > 0.0)));
    // The bounds of the fine mesh, scaled for the extra-fine one (half the
    // pad spacing: twice the segments, about four times the nodes).
    let scale = (0.05 / resolution.parameters().pad_spacing_mm).max(1.0);
    prop_assert!(m.n_nodes() as f64 <= 40_000.0 * scale * scale, "{resolution:?}: {} nodes", m.n_nodes());
    let segments = finger.contact_segments.len();
    MOST_NODES.fetch_max(m.n_nodes(), Relaxed);
    MOST_SEGMENTS.fetch_max(segments, Relaxed);
    prop_assert!(segments >= 18 && segments as f64 <= 900.0 * scale, "{resolution:?}: {segments} contact segments");
    prop_assert!(!finger.other_surface_nodes.is_empty());
    for [a, b] in &finger.contact_segments {
        prop_assert!(finger.driven_nodes.binary_search(a).is_err() && finger.driven_nodes.binary_search(b).is_err());
    }
    Ok(())
}

#[test]
fn random_finger_models_are_read_or_refused_and_accepted_ones_mesh() {
    let accepted = AtomicU32::new(0);
    let total = AtomicU32::new(0);
    runner()
        .run(&model_case(), |case| {
            total.fetch_add(1, Relaxed);
            accepted.fetch_add(check(&model_text(&case))? as u32, Relaxed);
            Ok(())
        })
        .unwrap();
    let (total, accepted) = (total.into_inner(), accepted.into_inner());
    eprintln!(
        "finger models: {total} cases, {accepted} accepted and meshed at 3 resolutions (largest mesh so far {} nodes, \
         {} contact segments)",
        MOST_NODES.load(Relaxed),
        MOST_SEGMENTS.load(Relaxed)
    );
    eprintln!("refused (both properties so far), by field: {:?}", REFUSED.lock().unwrap());
    eprintln!(
        "3D fingertips of accepted models (both properties so far): {} meshed, {} refused",
        MESHED_3D.load(Relaxed),
        REFUSED_3D.load(Relaxed)
    );
    assert!(accepted > 0, "no generated model was accepted: the generator misses the valid region");
}

#[test]
fn mutated_shipped_model_files_are_read_or_refused() {
    let accepted = AtomicU32::new(0);
    let total = AtomicU32::new(0);
    runner()
        .run(&mutated_text(), |text| {
            total.fetch_add(1, Relaxed);
            accepted.fetch_add(check(&text)? as u32, Relaxed);
            Ok(())
        })
        .unwrap();
    let (total, accepted) = (total.into_inner(), accepted.into_inner());
    eprintln!("mutated model files: {total} cases, {accepted} accepted and meshed at 3 resolutions");
}
