//! haptex's 3D fingertip against the CalculiX 2.20 reference of issue 39
//! (validation/calculix3d/: decks written from haptex's own coarse 3D mesh
//! of data/finger/half-disc.toml, C3D8I bricks, surface-to-surface penalty
//! contact 200 N/mm^3, mu 0.5, stick slope 20 N/mm^3; README.md there has
//! the provenance, the modelling choices and what failed). Elastic, small
//! strain, press 0.5 mm, slide 3 mm at 0 degrees in 0.1 mm steps.
//!
//! Tolerances come from the measured spread (validation/calculix3d/
//! results/comparison.md):
//!
//! - flat, Fn: haptex (B-bar Hex8) is 3.6-3.7 % above CalculiX C3D8I on
//!   the same coarse mesh (press: 0.30063 vs 0.28984 N; slide: at most
//!   3.72 %). The element is the whole of it: the contact variant
//!   (node-to-surface, stick slope 200) moves CalculiX by 0.02 %; the plain
//!   C3D8 lands 5.7 % above haptex (9.6 % above C3D8I), so haptex's B-bar
//!   lies inside CalculiX's element spread; on haptex's default mesh the
//!   two codes agree to 0.74 % after the press and 0.88 % over a 1 mm slide
//!   (C3D8I stiffens by 3.5 % with the refinement, haptex by 0.55 %).
//!   Tolerance 5 % on the coarse mesh (the default mesh takes ~10 s in
//!   haptex and is not run here).
//! - flat, Ft/Fn: in full slip (x >= 1 mm) both are 0.5 (tolerance 1e-3);
//!   in the transient (x < 1 mm) the largest difference is 0.011 at x =
//!   0.4 mm, tolerance 0.02.
//! - bump (x0 1.5, r_w 1.5, r_h 0.2 mm), CalculiX bump_linear_inc01: the
//!   reference deck with slide increments of 0.01 mm instead of 0.1 mm.
//!   CalculiX's surface-to-surface contact holds each point's projection
//!   and normal over an increment, and over the curved bump that errs in
//!   proportion to the increment (README, "Diagnosis of the bump":
//!   frictionless, its 0.1 mm curve is not even conservative, mean Ft/Fn
//!   +0.048 where an elastic body with frictionless contact gives 0; with
//!   mu 0.5 it ran up to 0.121 above haptex, with 0.01 mm 0.018). Fn
//!   within 5 % (measured: at most 3.8 %, the element's offset of the
//!   flat). Ft/Fn within CalculiX's own remaining increment error, the
//!   change of its curve from 0.025 to 0.01 mm increments: at most 0.030
//!   and 0.013 RMS (measured against haptex: 0.018 and 0.0075).
//! - frictionless bump: no CalculiX needed. The path is symmetric about the
//!   bump (it starts 1.5 mm ahead of it and ends 1.5 mm past it) and so is
//!   the mesh; an elastic body with frictionless penalty contact is
//!   conservative, so Ft/Fn(x) = -Ft/Fn(3 - x) (measured to 1e-8;
//!   tolerance 1e-6 of the largest |Ft/Fn|).

mod common;

use haptex_fem::finger::{FingerModel, Resolution};
use haptex_fem::scenario::{Loading, Scenario};
use haptex_fem::solid3d::slide::{Simulation3, run};
use haptex_fem::surface::SurfaceShape;

/// A CalculiX curve `x_mm,fn_n,ft_n,mu` of validation/calculix3d/results.
fn reference(name: &str) -> Vec<[f64; 4]> {
    let path = format!("{}/../../validation/calculix3d/results/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    text.lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|v| v.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

/// As `haptex simulate --model 3d --finger data/finger/half-disc.toml
/// --material elastic --mesh coarse --indent 0.5 --slide 3 --step 0.1
/// --direction-deg 0` (validation/calculix3d/run.sh).
fn fingertip(surface: SurfaceShape) -> Simulation3 {
    fingertip_with(surface, None)
}

/// [`fingertip`] with the skin friction `mu_skin` (None: the model's 0.5).
fn fingertip_with(surface: SurfaceShape, mu_skin: Option<f64>) -> Simulation3 {
    let mut scenario = Scenario::paper(surface);
    scenario.mu_skin = mu_skin;
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/finger/half-disc.toml");
    scenario.model = FingerModel::read(std::path::Path::new(path)).unwrap();
    scenario.viscoelastic = false;
    scenario.resolution = Resolution::Coarse;
    scenario.loading = Loading::Indent(0.5);
    scenario.slide_mm = 3.0;
    scenario.step_mm = 0.1;
    run(&scenario, 0.0, &mut |_| {}).unwrap()
}

/// (x, haptex Fn, haptex Ft/Fn, CalculiX Fn, CalculiX Ft/Fn) at every x of
/// the CalculiX curve that is on haptex's step grid.
fn pairs(result: &Simulation3, ccx: &[[f64; 4]]) -> Vec<[f64; 5]> {
    let mut out = Vec::new();
    for r in ccx {
        if let Some(row) = result.history.iter().find(|h| h.slide_mm > 0.0 && (h.slide_mm - r[0]).abs() < 1e-6) {
            out.push([r[0], row.fn_n, row.ft_n / row.fn_n, r[1], r[3]]);
        }
    }
    out
}

#[test]
fn flat_slide_matches_calculix() {
    let result = fingertip(SurfaceShape::Flat);
    let ccx = reference("flat_linear.csv");
    let pairs = pairs(&result, &ccx);
    assert_eq!(pairs.len(), 30, "CalculiX's 0.1 mm increments over 3 mm");
    for [x, fn_h, mu_h, fn_c, mu_c] in pairs {
        let dfn = fn_h / fn_c - 1.0;
        let dmu = mu_h - mu_c;
        eprintln!(
            "x {x:.1}: Fn {fn_h:.5} vs {fn_c:.5} ({:+.2} %), Ft/Fn {mu_h:.4} vs {mu_c:.4} ({dmu:+.4})",
            100.0 * dfn
        );
        assert!(dfn.abs() < 0.05, "x = {x}: Fn differs by {dfn:+.4}");
        let tolerance = if x >= 1.0 { 1e-3 } else { 0.02 };
        assert!(dmu.abs() < tolerance, "x = {x}: Ft/Fn differs by {dmu:+.4}");
    }
}

#[test]
fn bump_slide_matches_calculix_with_short_increments() {
    let result = fingertip(SurfaceShape::Bump { x0: 1.5, width: 1.5, height: 0.2 });
    let ccx = reference("bump_linear_inc01.csv");
    let pairs = pairs(&result, &ccx);
    assert_eq!(pairs.len(), 30, "haptex's 0.1 mm steps over 3 mm, among CalculiX's 0.01 mm increments");
    let mut sum = 0.0;
    for &[x, fn_h, mu_h, fn_c, mu_c] in &pairs {
        let dfn = fn_h / fn_c - 1.0;
        let dmu = mu_h - mu_c;
        eprintln!(
            "x {x:.1}: Fn {fn_h:.5} vs {fn_c:.5} ({:+.2} %), Ft/Fn {mu_h:.4} vs {mu_c:.4} ({dmu:+.4})",
            100.0 * dfn
        );
        assert!(dfn.abs() < 0.05, "x = {x}: Fn differs by {dfn:+.4}");
        assert!(dmu.abs() < 0.030, "x = {x}: Ft/Fn differs by {dmu:+.4}");
        sum += dmu * dmu;
    }
    let rms = (sum / pairs.len() as f64).sqrt();
    eprintln!("bump: Ft/Fn RMS difference {rms:.4}");
    assert!(rms < 0.013, "bump Ft/Fn RMS difference {rms}");
}

#[test]
fn frictionless_bump_is_antisymmetric_about_its_top() {
    let result = fingertip_with(SurfaceShape::Bump { x0: 1.5, width: 1.5, height: 0.2 }, Some(0.0));
    let (largest, worst) = common::antisymmetry_over_3_mm(&result);
    assert!(largest > 0.05, "the bump tilts the contact: |Ft/Fn| up to {largest}");
    assert!(worst <= 1e-6 * largest, "asymmetry {worst} of {largest}");
}
