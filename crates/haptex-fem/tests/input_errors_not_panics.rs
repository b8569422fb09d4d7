//! Bad input to the FE model is an error that names the file, the line and
//! the field, never a panic, an unbounded allocation or a silent change
//! (issue 13). One test per class of defect found; each failed before the
//! fix (a panic, an allocation of terabytes, or an error without a line).

mod common;

use haptex_fem::contact::ContactLaw;
use haptex_fem::finger::{DEFAULT_MODEL_TOML, FingerError, FingerModel, Resolution};
use haptex_fem::material::{History, MAX_PRONY_TERMS, Material, PronyTerm};
use haptex_fem::ring::contour_parameters;
use haptex_fem::scenario::{Scenario, SimulationError, run};
use haptex_fem::solver::{SolveError, Solver, SolverSettings};
use haptex_fem::surface::{RigidSurface, SurfaceShape};

/// The 1-based line of `key = ...` in `[section]` of the shipped file.
fn shipped_line(section: &str, key: &str) -> usize {
    let lines: Vec<&str> = DEFAULT_MODEL_TOML.lines().collect();
    let start = lines.iter().position(|l| l.trim() == format!("[{section}]")).unwrap();
    start + 1 + lines[start..].iter().position(|l| l.starts_with(&format!("{key} ="))).unwrap()
}

/// The shipped file with `key = value` in `[section]` replaced.
fn shipped_with(section: &str, key: &str, value: &str) -> String {
    let line = shipped_line(section, key);
    DEFAULT_MODEL_TOML
        .lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == line { format!("{key} = {value}") } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n")
}

fn field_error(text: &str) -> (usize, String) {
    match FingerModel::from_toml(text, "f.toml") {
        Err(e @ FingerError::Field { line, .. }) => (line, e.to_string()),
        other => panic!("expected a field error, got {other:?}"),
    }
}

/// Issue 13: `contact_half_arc_mm = 18` reached over the nail; the nail's
/// driven nodes became contact candidates and the solver indexed with a
/// prescribed DOF (usize::MAX). Now the file is refused at the key's line
/// with the longest arc this contour allows, and a model built in code is
/// refused by the simulation, before any step.
#[test]
fn contact_arc_longer_than_the_contour_is_an_error_not_a_panic() {
    let text = shipped_with("contact", "contact_half_arc_mm", "18");
    let (line, message) = field_error(&text);
    assert_eq!(line, shipped_line("contact", "contact_half_arc_mm"));
    assert!(
        message.starts_with(&format!(
            "f.toml: line {line}: contact.contact_half_arc_mm = 18 mm is longer than the contour allows (at most 14.4"
        )),
        "{message}"
    );
    // The limit it quotes is accepted, a little more is not.
    assert!(FingerModel::from_toml(&shipped_with("contact", "contact_half_arc_mm", "14.4"), "f.toml").is_ok());
    assert!(FingerModel::from_toml(&shipped_with("contact", "contact_half_arc_mm", "14.5"), "f.toml").is_err());

    let mut scenario = Scenario::paper(SurfaceShape::Flat);
    scenario.model.contact.contact_half_arc_mm = 18.0;
    scenario.resolution = Resolution::Coarse;
    let err = run(&scenario, &mut |_| panic!("no step may run")).expect_err("refused");
    assert!(err.to_string().contains("contact.contact_half_arc_mm = 18 mm is longer"), "{err}");
}

/// Issue 13: 7 Prony terms indexed past a fixed table of 6. Any number up
/// to MAX_PRONY_TERMS is supported: the recursion with 20 terms
/// reproduces G(t)/G0 = g_inf + sum g_i exp(-t/tau_i) to 1e-9 (a held
/// step strain; exact for strain constant within steps), and a scenario
/// with 7 terms runs. More terms are refused at the list's line.
#[test]
fn many_prony_terms_are_supported_and_too_many_are_an_error() {
    let prony: Vec<PronyTerm> = (0..20).map(|i| PronyTerm { g: 0.04, tau_s: 1e-3 * 1.6f64.powi(i) }).collect();
    let material = Material { e_mpa: 1.0, nu: 0.45, prony };
    material.validate().unwrap();
    let mut history = History::new(20);
    let s0 = [0.0, 0.0, 0.0, 1.0];
    history.advance(&material.step(0.0), &s0);
    let mut t = 0.0;
    for dt in [1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0] {
        history.advance(&material.step(dt), &s0);
        t += dt;
        let ratio = history.deviator(material.g_inf())[3];
        assert!((ratio - material.relaxation_ratio(t)).abs() < 1e-9, "t = {t}: {ratio}");
    }

    let seven = "prony = [\n".to_string()
        + &(0..7).map(|i| format!("    {{ g = 0.1, tau_s = {} }},\n", 0.001 * 3f64.powi(i))).collect::<String>()
        + "]";
    let text = DEFAULT_MODEL_TOML.replace(
        "prony = [\n    { g = 0.2, tau_s = 0.004 },\n    { g = 0.2, tau_s = 0.07 },\n    { g = 0.2, tau_s = 1.4 },\n]",
        &seven,
    );
    assert_ne!(text, DEFAULT_MODEL_TOML);
    let mut scenario = Scenario::paper(SurfaceShape::Flat);
    scenario.model = FingerModel::from_toml(&text, "seven.toml").unwrap();
    scenario.resolution = Resolution::Coarse;
    scenario.slide_mm = 0.3;
    let result = run(&scenario, &mut |_| {}).unwrap();
    let mu = result.profile.as_ref().unwrap().mu();
    assert!(mu.iter().all(|m| m.is_finite() && *m > 0.0 && *m <= 0.5 + 1e-9), "{mu:?}");

    let many = "prony = [\n".to_string()
        + &(0..MAX_PRONY_TERMS + 1).map(|_| "    { g = 0.01, tau_s = 0.1 },\n").collect::<String>()
        + "]";
    let text = text.replace(&seven, &many);
    let (line, message) = field_error(&text);
    assert_eq!(line, shipped_line("viscoelasticity", "prony"));
    assert!(message.contains("viscoelasticity.prony has 33 terms; at most 32 are supported"), "{message}");
}

/// Every numeric field out of range is refused at the line of its key,
/// with the value quoted readably (1e300, not 301 digits) and the range.
/// Before: no line, and several fields (nu near 0.5, absurd magnitudes,
/// tau, the contact arc) were not checked at all.
#[test]
fn every_field_out_of_range_names_its_line() {
    let fields = [
        ("geometry", "half_width_mm"),
        ("geometry", "half_height_mm"),
        ("geometry", "bone_half_width_mm"),
        ("geometry", "bone_half_height_mm"),
        ("geometry", "bone_center_height_mm"),
        ("geometry", "nail_thickness_mm"),
        ("geometry", "nail_half_angle_deg"),
        ("layers", "stratum_corneum_mm"),
        ("layers", "viable_epidermis_mm"),
        ("layers", "dermis_mm"),
        ("materials.stratum_corneum", "e_mpa"),
        ("materials.hypodermis", "nu"),
        ("materials.bone", "e_mpa"),
        ("contact", "mu_skin"),
        ("contact", "contact_half_arc_mm"),
    ];
    for (section, key) in fields {
        for value in ["1e300", "-1", "nan", "inf"] {
            let (line, message) = field_error(&shipped_with(section, key, value));
            assert_eq!(line, shipped_line(section, key), "{section}.{key} = {value}: {message}");
            let expected = format!("f.toml: line {line}: {section}.{key} = {}", value.replace("nan", "NaN"));
            assert!(message.starts_with(&expected), "{message}");
            assert!(message.contains("supported range") && message.len() < 300, "{message}");
        }
    }
    // Nearly incompressible beyond what the element is tested at.
    let (_, message) = field_error(&shipped_with("materials.dermis", "nu", "0.49999"));
    assert!(message.contains("materials.dermis.nu = 0.49999 is outside the supported range -0.9 .. 0.4999"));
    // A Prony term: the line of its list element.
    let text = DEFAULT_MODEL_TOML.replace("{ g = 0.2, tau_s = 0.07 }", "{ g = 0.2, tau_s = 1e30 }");
    let (line, message) = field_error(&text);
    assert_eq!(line, shipped_line("viscoelasticity", "prony") + 2);
    assert!(message.contains("viscoelasticity.prony[1].tau_s = 1e30 s is outside"), "{message}");
    // Weights summing to (almost) 1: the long-term modulus vanishes.
    let text = DEFAULT_MODEL_TOML.replace("{ g = 0.2, tau_s = 1.4 }", "{ g = 0.595, tau_s = 1.4 }");
    let (_, message) = field_error(&text);
    assert!(message.contains("viscoelasticity.prony[2].g = 0.595 brings the sum of the Prony weights to 0.995"));
}

/// Fields that are valid alone but not together: each error names the
/// field to change and the bound that applies.
#[test]
fn inconsistent_geometry_names_the_field_to_change() {
    let cases = [
        (
            ("geometry", "bone_center_height_mm", "2"),
            "geometry.bone_center_height_mm = 2 mm puts the bone into the skin",
        ),
        (("geometry", "bone_half_width_mm", "7"), "geometry.bone_half_width_mm = 7 mm is too wide"),
        (("geometry", "bone_half_height_mm", "5.5"), "geometry.bone_half_height_mm = 5.5 mm is too tall"),
        (("geometry", "nail_thickness_mm", "1.4"), "geometry.nail_thickness_mm = 1.4 mm must be thinner than the skin"),
        (("layers", "dermis_mm", "4"), "layers.dermis_mm = 4 makes the skin"),
    ];
    for ((section, key, value), expected) in cases {
        let (_, message) = field_error(&shipped_with(section, key, value));
        assert!(message.contains(expected), "{section}.{key} = {value}: {message}");
    }
    // A nail over the top half leaves 11 mm of contour below it.
    let text = shipped_with("contact", "contact_half_arc_mm", "10.5").replace("= 50.0", "= 90");
    let (_, message) = field_error(&text);
    assert!(message.contains("contact.contact_half_arc_mm = 10.5 mm is longer than the contour allows (at most 10.0"));
    assert!(message.contains("the nail, which covers the top 180 degrees)"), "{message}");
    // A field a material does not take here, and an unknown key.
    let text = DEFAULT_MODEL_TOML.replace("[materials.dermis]\n", "[materials.dermis]\nprony = []\nsoftness = 2\n");
    let err = FingerModel::from_toml(&text, "f.toml").unwrap_err().to_string();
    assert!(err.starts_with("f.toml: line 49: unknown field `softness`"), "{err}");
    let text =
        DEFAULT_MODEL_TOML.replace("[materials.dermis]\n", "[materials.dermis]\nprony = [{ g = 0.1, tau_s = 1 }]\n");
    let (line, message) = field_error(&text);
    assert_eq!(line, 48);
    assert!(message.contains("materials.dermis.prony is not read here"), "{message}");
}

/// A model built in code (fields are public) is checked by `mesh` too:
/// NaN or absurd values are errors, not panics or huge allocations.
#[test]
fn a_model_built_in_code_is_checked_before_it_is_meshed() {
    for change in [
        |m: &mut FingerModel| m.geometry.half_width_mm = f64::NAN,
        |m: &mut FingerModel| m.geometry.half_width_mm = 1e300,
        |m: &mut FingerModel| m.contact.contact_half_arc_mm = 1e9,
        |m: &mut FingerModel| m.layers.dermis_mm = 0.0,
    ] {
        let mut model = FingerModel::default_model();
        change(&mut model);
        for resolution in Resolution::ALL {
            let err = model.mesh(resolution).unwrap_err();
            assert!(matches!(err, FingerError::Invalid(_)), "{err}");
        }
    }
}

/// A tiny spacing over a long contour asked the mesher for ~1e12 nodes;
/// now the node count is bounded before anything is allocated.
#[test]
fn tiny_spacing_over_a_long_contour_is_refused_before_allocating() {
    let circle = |phi: f64| [10.0 * phi.sin(), 10.0 - 10.0 * phi.cos()];
    let err = contour_parameters(&circle, 20.0, 1e-9, 1e-9).unwrap_err().to_string();
    assert!(err.contains("needs more than 100000 nodes"), "{err}");
    let err = contour_parameters(&circle, 30.0, 0.1, 0.4).unwrap_err().to_string();
    assert!(err.contains("more than 0.4 of the contour's perimeter"), "{err}");
    let err = contour_parameters(&circle, f64::NAN, 0.1, 0.4).unwrap_err().to_string();
    assert!(err.contains("half-arc must be a positive length"), "{err}");
    assert!(contour_parameters(&circle, 6.0, 0.1, 0.4).is_ok());
}

/// Simulation settings that sized vectors or loops before they were
/// checked (slide/step of 1e301 steps overflowed `press_steps +
/// slide_steps`; a 1 nm feature asked for 6e9 surface points; a frame per
/// step over a long slide kept gigabytes): refused with the setting named.
#[test]
fn settings_that_size_memory_or_loops_are_bounded() {
    let mut scenario = Scenario::paper(SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 });
    scenario.step_mm = 1e-300;
    let err = scenario.slide_steps().unwrap_err().to_string();
    assert!(err.contains("takes 1e301 steps; at most 1000000"), "{err}");

    let scenario = Scenario::paper(SurfaceShape::Bump { x0: 5.0, width: 1e-3, height: 0.3 });
    let err = scenario.validate().unwrap_err().to_string();
    assert!(err.contains("takes 6000000 points, more than 4000000"), "{err}");
    let err = RigidSurface::new(&SurfaceShape::Bump { x0: 5.0, width: 1e-6, height: 0.3 }, -10.0, 20.0)
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("surface width r_w = 0.000001 mm is outside") || err.contains("1e-6 mm is outside"), "{err}");

    let mut scenario = Scenario::paper(SurfaceShape::Flat);
    scenario.slide_mm = 1000.0;
    scenario.frame_every = 1;
    let err = scenario.validate().unwrap_err().to_string();
    assert!(err.contains("keeps 10000 full-field frames in memory; at most 1000"), "{err}");

    let mut scenario = Scenario::paper(SurfaceShape::Flat);
    scenario.loading = haptex_fem::scenario::Loading::Indent(6.0);
    let err = scenario.validate().unwrap_err().to_string();
    assert!(err.contains("less than the pulp under the bone (5 mm)"), "{err}");
}

/// Height profiles: magnitudes beyond the limits are refused at their line
/// and column (before: 1e300 heights overflowed the arc length to inf and
/// the contact arc coordinates to NaN).
#[test]
fn height_file_values_are_bounded_with_line_and_column() {
    let text = "# heights\nx_mm,h_mm\n0,0\n1,1e300\n2,0\n";
    let err = SurfaceShape::read_csv_from(text.as_bytes(), "h.csv").unwrap_err().to_string();
    assert_eq!(err, "h.csv, line 4, column 'h_mm': h = 1e300 mm is outside the supported range +-1000 mm");
    let text = "x_mm,h_mm\n-1e7,0\n2,0\n";
    let err = SurfaceShape::read_csv_from(text.as_bytes(), "h.csv").unwrap_err().to_string();
    assert_eq!(err, "h.csv, line 2, column 'x_mm': x = -10000000 mm is outside the supported range +-1000000 mm");
    let text = "x_mm,h_mm\n0,0\n1,0.1\n1,0\n";
    let err = SurfaceShape::read_csv_from(text.as_bytes(), "h.csv").unwrap_err().to_string();
    assert!(err.starts_with("h.csv, line 4, column 'x_mm': x must be strictly increasing"), "{err}");
}

/// The finger file reader: a file without end (`/dev/zero`) is refused
/// after 1 MiB instead of filling the memory, and bytes that are not
/// UTF-8 are named by line.
#[test]
fn finger_file_reader_bounds_its_input() {
    let err = FingerModel::read(std::path::Path::new("/dev/zero")).unwrap_err().to_string();
    assert!(err.starts_with("/dev/zero: longer than 1048576 bytes"), "{err}");
    let dir = std::env::temp_dir().join(format!("haptex-finger-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("latin1.toml");
    let mut bytes = DEFAULT_MODEL_TOML.as_bytes().to_vec();
    bytes.splice(0..0, b"# caf\xe9\n".iter().copied());
    std::fs::write(&path, &bytes).unwrap();
    let err = FingerModel::read(&path).unwrap_err().to_string();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(err.ends_with("latin1.toml: line 1: not UTF-8 text"), "{err}");
}

/// The solver's own assumption: contact candidates are free DOFs. A
/// problem whose contact node is driven is refused by `Solver::new`
/// (before: an index of usize::MAX in the first step).
#[test]
fn driven_contact_node_is_refused_by_the_solver() {
    let law = ContactLaw {
        penalty_normal: 200.0,
        penalty_tangential: 200.0,
        mu: 0.5,
        smoothing_mm: 0.0,
        geometric_tangent: false,
        electrostatic: None,
    };
    let mut problem = common::cylinder_on_flat(8.0, 2.0, 0.2, 2.0, Material::elastic(1.0, 0.3), law);
    let node = problem.contact.nodes[3];
    problem.driven_nodes.push(node);
    problem.driven_nodes.sort_unstable();
    let err = Solver::new(problem, SolverSettings::default(), 0.0).err().expect("refused");
    assert_eq!(err, SolveError::PrescribedContactNode { node });
    let settings = SolverSettings { max_cuts: u32::MAX, ..SolverSettings::default() };
    let problem = common::cylinder_on_flat(8.0, 2.0, 0.2, 2.0, Material::elastic(1.0, 0.3), law);
    assert!(matches!(Solver::new(problem, settings, 0.0), Err(SolveError::Settings(_))));
    // A simulation error of this kind reads as one.
    let e = SimulationError::Solve(SolveError::PrescribedContactNode { node: 7 });
    assert!(e.to_string().contains("must be free skin"));
}

/// Syntax errors name the line they are on. (Before: the line was the
/// count of `lines()` before the error's offset, one short when the error
/// starts a line, as a duplicate key does.)
#[test]
fn syntax_errors_name_the_line_they_are_on() {
    let line = shipped_line("geometry", "half_height_mm");
    let duplicate =
        DEFAULT_MODEL_TOML.replace("half_height_mm = 6.0\n", "half_height_mm = 6.0\nhalf_height_mm = 7.0\n");
    let err = FingerModel::from_toml(&duplicate, "f.toml").unwrap_err().to_string();
    assert!(err.starts_with(&format!("f.toml: line {}: duplicate key", line + 1)), "{err}");
    let missing_value = DEFAULT_MODEL_TOML.replace("half_height_mm = 6.0\n", "half_height_mm =\n");
    let err = FingerModel::from_toml(&missing_value, "f.toml").unwrap_err().to_string();
    assert!(err.starts_with(&format!("f.toml: line {line}: ")), "{err}");
    let missing_key = DEFAULT_MODEL_TOML.replace("half_height_mm = 6.0\n", "");
    let err = FingerModel::from_toml(&missing_key, "f.toml").unwrap_err().to_string();
    assert!(err.contains("missing field `half_height_mm`"), "{err}");
}
