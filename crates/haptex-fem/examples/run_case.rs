//! Runs one scenario and prints timing: `cargo run --release -p haptex-fem --example run_case -- bump 1.5 0.3 [elastic]`.
use haptex_fem::scenario::{Scenario, run};
use haptex_fem::surface::SurfaceShape;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kind = args.get(1).map(String::as_str).unwrap_or("bump");
    let width: f64 = args.get(2).and_then(|v| v.parse().ok()).unwrap_or(1.5);
    let height: f64 = args.get(3).and_then(|v| v.parse().ok()).unwrap_or(0.3);
    let surface = match kind {
        "flat" => SurfaceShape::Flat,
        "edge" => SurfaceShape::Edge { x0: 5.0, width, height },
        "sine" => SurfaceShape::Sine { x0: 5.0, width, height },
        _ => SurfaceShape::Bump { x0: 5.0, width, height },
    };
    let mut scenario = Scenario::paper(surface);
    if let Some(mu) = args.iter().find_map(|a| a.strip_prefix("mu=")).and_then(|v| v.parse().ok()) {
        scenario.mu_skin = Some(mu);
    }
    if let Some(p) = args.iter().find_map(|a| a.strip_prefix("penalty=")).and_then(|v| v.parse().ok()) {
        scenario.penalty_mpa_per_mm = p;
    }
    if let Some(d) = args.iter().find_map(|a| a.strip_prefix("smooth=")).and_then(|v| v.parse().ok()) {
        scenario.smoothing_mm = d;
    }
    if args.iter().any(|a| a == "fine") {
        scenario.resolution = haptex_fem::finger::Resolution::Fine;
    }
    if args.iter().any(|a| a == "coarse") {
        scenario.resolution = haptex_fem::finger::Resolution::Coarse;
    }
    if let Some(d) = args.iter().find_map(|a| a.strip_prefix("step=")).and_then(|v| v.parse().ok()) {
        scenario.step_mm = d;
    }
    if let Some(out) = args.iter().find_map(|a| a.strip_prefix("csv=")) {
        scenario.frame_every = 0;
        let _ = out;
    }
    if args.iter().any(|a| a == "elastic") {
        scenario.viscoelastic = false;
    }
    let result = run(&scenario, &mut |_| {}).unwrap();
    let s = result.statistics;
    println!("{s:?}");
    if let Some(out) = args.iter().find_map(|a| a.strip_prefix("png=")) {
        use haptex_core::plot::{Figure, Panel};
        let h = &result.history[scenario.press_steps..];
        let x: Vec<f64> = h.iter().map(|r| r.slide_mm).collect();
        let fig = Figure::new(format!("{kind} w={width} h={height}"))
            .panel(Panel::new("x (mm)", "Ft/Fn").line("mu", &x, result.profile.as_ref().unwrap().mu()))
            .panel(
                Panel::new("x (mm)", "force (N/mm)")
                    .line("Fn", &x, &h.iter().map(|r| r.fn_n).collect::<Vec<_>>())
                    .line("Ft", &x, &h.iter().map(|r| r.ft_n).collect::<Vec<_>>()),
            )
            .panel(Panel::new("x (mm)", "contact (mm)").line(
                "contact",
                &x,
                &h.iter().map(|r| r.contact_mm).collect::<Vec<_>>(),
            ));
        fig.write_png(std::path::Path::new(out)).unwrap();
    }
    if let Some(out) = args.iter().find_map(|a| a.strip_prefix("csv=")) {
        result.profile.as_ref().unwrap().write_csv_file(std::path::Path::new(out)).unwrap();
    }
    let mu = result.profile.as_ref().unwrap().mu();
    let x = result.profile.as_ref().unwrap().x_mm();
    for i in (0..mu.len()).step_by(mu.len() / 20) {
        let h = &result.history[scenario.press_steps + i];
        println!(
            "x {:.2} mu {:.4} fn {:.5} ft {:.5} contact {:.3} its {} reaction {:?}",
            x[i], mu[i], h.fn_n, h.ft_n, h.contact_mm, h.iterations, h.reaction_n
        );
    }
}
