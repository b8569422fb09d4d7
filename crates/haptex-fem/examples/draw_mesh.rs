//! Draws the finger mesh at a resolution: `cargo run -p haptex-fem --example draw_mesh -- default out.png`.
use haptex_fem::drawing::{MeshView, mesh_figure};
use haptex_fem::finger::{FingerModel, Resolution};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let resolution = match args.get(1).map(String::as_str) {
        Some("coarse") => Resolution::Coarse,
        Some("fine") => Resolution::Fine,
        _ => Resolution::Default,
    };
    let out = args.get(2).cloned().unwrap_or_else(|| "mesh.png".into());
    let finger = FingerModel::default_model().mesh(resolution).expect("mesh");
    let window = args.get(3).map(|_| ((-4.0, 4.0), (-0.2, 6.0)));
    let view = MeshView {
        title: format!(
            "finger mesh, {resolution:?}: {} nodes, {} elements",
            finger.mesh.n_nodes(),
            finger.mesh.n_elements()
        ),
        mesh: &finger.mesh,
        displacement: None,
        scale: 1.0,
        surface: None,
        window,
        outlines: true,
    };
    mesh_figure(&view, 1400).write_png(std::path::Path::new(&out)).expect("png");
}
