//! Regenerates the FE figures of docs/fem.md from actual runs:
//! `cargo run --release -p haptex-fem --example docs_figures -- docs/img`.

use std::path::Path;

use haptex_core::plot::{Figure, Panel};
use haptex_fem::drawing::{MeshView, mesh_figure};
use haptex_fem::finger::{FingerModel, Resolution};
use haptex_fem::output::write_png;
use haptex_fem::scenario::{Scenario, SimulationResult, run};
use haptex_fem::surface::SurfaceShape;

fn simulate(surface: SurfaceShape, velocity: f64, viscoelastic: bool) -> SimulationResult {
    let mut scenario = Scenario::paper(surface);
    scenario.velocity_mm_s = velocity;
    scenario.viscoelastic = viscoelastic;
    let result = run(&scenario, &mut |_| {}).expect("simulation");
    eprintln!("{:?}: {:?}", scenario.surface, result.statistics);
    result
}

fn main() {
    let dir = std::env::args().nth(1).unwrap_or_else(|| "docs/img".into());
    let dir = Path::new(&dir);
    std::fs::create_dir_all(dir).unwrap();

    let finger = FingerModel::default_model().mesh(Resolution::Default).unwrap();
    let view = MeshView {
        title: format!(
            "default finger mesh: {} nodes, {} elements (pad spacing 0.1 mm)",
            finger.mesh.n_nodes(),
            finger.mesh.n_elements()
        ),
        mesh: &finger.mesh,
        displacement: None,
        scale: 1.0,
        surface: None,
        window: None,
        outlines: true,
    };
    mesh_figure(&view, 1100).write_png(&dir.join("fem_mesh.png")).unwrap();

    let bump = SurfaceShape::Bump { x0: 5.0, width: 1.5, height: 0.3 };
    let edge = SurfaceShape::Edge { x0: 5.0, width: 1.5, height: 0.3 };
    let sine = SurfaceShape::Sine { x0: 5.0, width: 2.0, height: 0.2 };
    let b = simulate(bump.clone(), 20.0, true);
    write_png(
        &b,
        "bump x0 = 5, r_w = 1.5, r_h = 0.3 mm: after the press, and over the bump",
        &dir.join("fem_bump_deformed.png"),
    )
    .unwrap();
    let e = simulate(edge, 20.0, true);
    let s = simulate(sine, 20.0, true);
    let mut figure =
        Figure::new("Ft/Fn along a 10 mm slide at 20 mm/s (visco-elastic finger, skin mu = 0.5)").size(1000, 260);
    for (label, r) in [
        ("bump x0 = 5, r_w = 1.5, r_h = 0.3 mm", &b),
        ("edge x0 = 5, r_w = 1.5, r_h = 0.3 mm", &e),
        ("sine x0 = 5, period 2, amplitude 0.2 mm", &s),
    ] {
        figure = figure.panel(Panel::new("finger position on the surface x (mm)", "Ft/Fn").title(label).line(
            "",
            r.profile.as_ref().unwrap().x_mm(),
            r.profile.as_ref().unwrap().mu(),
        ));
    }
    figure.write_png(&dir.join("fem_profiles.png")).unwrap();

    let mut mu_panel = Panel::new("finger position on the surface x (mm)", "Ft/Fn").title("Ft/Fn");
    let mut fn_panel = Panel::new("finger position on the surface x (mm)", "Fn (N per mm of width)")
        .title("normal force (0.25 mm press)");
    for velocity in [10.0, 20.0, 50.0, 100.0] {
        let r = simulate(bump.clone(), velocity, true);
        let fn_n: Vec<f64> = r.history.iter().filter(|h| h.slide_mm > 0.0).map(|h| h.fn_n).collect();
        mu_panel = mu_panel.line(
            format!("{velocity} mm/s"),
            r.profile.as_ref().unwrap().x_mm(),
            r.profile.as_ref().unwrap().mu(),
        );
        fn_panel = fn_panel.line(format!("{velocity} mm/s"), r.profile.as_ref().unwrap().x_mm(), &fn_n);
    }
    let r = simulate(bump, 20.0, false);
    let fn_n: Vec<f64> = r.history.iter().filter(|h| h.slide_mm > 0.0).map(|h| h.fn_n).collect();
    mu_panel =
        mu_panel.line("elastic (any velocity)", r.profile.as_ref().unwrap().x_mm(), r.profile.as_ref().unwrap().mu());
    fn_panel = fn_panel.line("elastic (any velocity)", r.profile.as_ref().unwrap().x_mm(), &fn_n);
    Figure::new("velocity dependence over the bump (x0 = 5, r_w = 1.5, r_h = 0.3 mm)")
        .size(1000, 330)
        .panel(mu_panel)
        .panel(fn_panel)
        .write_png(&dir.join("fem_velocity.png"))
        .unwrap();
}
