//! The 3D finger (solid3d::slide) pressed and slid over a surface: prints
//! the force history and the run's statistics.
//!
//!   cargo run --release -p haptex-fem --example slide_3d -- SURFACE MESH DIRECTION_DEG SLIDE_MM [INDENT_MM [PENALTY [MU]]]
//!
//! SURFACE: flat, bump, edge or sine (x0 = 5, r_w = 1.5, r_h = 0.3 mm);
//! MESH: coarse, default or fine.

use haptex_fem::finger::Resolution;
use haptex_fem::scenario::{Loading, Scenario};
use haptex_fem::solid3d::slide;
use haptex_fem::surface::SurfaceShape;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: usize, default: &str| args.get(k).cloned().unwrap_or_else(|| default.to_string());
    let (x0, width, height) = (5.0, 1.5, 0.3);
    let surface = match arg(0, "flat").as_str() {
        "flat" => SurfaceShape::Flat,
        "bump" => SurfaceShape::Bump { x0, width, height },
        "edge" => SurfaceShape::Edge { x0, width, height },
        "sine" => SurfaceShape::Sine { x0, width, height },
        other => return Err(format!("unknown surface {other}").into()),
    };
    let mut scenario = Scenario::paper(surface);
    scenario.resolution = match arg(1, "coarse").as_str() {
        "coarse" => Resolution::Coarse,
        "default" => Resolution::Default,
        "fine" => Resolution::Fine,
        other => return Err(format!("unknown mesh {other}").into()),
    };
    let direction: f64 = arg(2, "0").parse()?;
    scenario.slide_mm = arg(3, "2").parse()?;
    scenario.loading = Loading::Indent(arg(4, "0.5").parse()?);
    scenario.penalty_mpa_per_mm = arg(5, "200").parse()?;
    scenario.mu_skin = args.get(6).map(|m| m.parse()).transpose()?;
    let result = slide::run(&scenario, direction, &mut |_| {})?;
    println!("t_s,slide_mm,fn_n,ft_n,ft_lateral_n,contact_area_mm2,iterations");
    for r in &result.history {
        println!(
            "{:.4},{:.3},{:.5},{:.5},{:.5},{:.3},{}",
            r.t_s, r.slide_mm, r.fn_n, r.ft_n, r.ft_lateral_n, r.contact_area_mm2, r.iterations
        );
    }
    eprintln!("{:?}", result.statistics);
    Ok(())
}
