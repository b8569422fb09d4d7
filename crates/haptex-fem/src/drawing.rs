//! Pictures of the finger: the (deformed) mesh coloured by subdomain over
//! the rigid surface, like the paper's Fig. 1c,d. Drawn with
//! `haptex_core::plot` (pure Rust, embedded font).

use haptex_core::plot::{Figure, Panel, Series, Shape};

use crate::finger::subdomain;
use crate::mesh::Mesh;

/// Colour of each subdomain (index as in [`subdomain`]).
pub const SUBDOMAIN_COLORS: [(u8, u8, u8); 6] = [
    (196, 122, 84),  // stratum corneum
    (233, 170, 140), // viable epidermis
    (240, 200, 180), // dermis
    (250, 230, 160), // hypodermis
    (235, 235, 225), // bone
    (170, 190, 215), // nail
];

/// What to draw in one panel.
pub struct MeshView<'a> {
    pub title: String,
    pub mesh: &'a Mesh,
    /// Nodal displacements (global vector, 2 per node), or `None` for the
    /// reference configuration.
    pub displacement: Option<&'a [f64]>,
    /// Displacements are multiplied by this for display (1 = true scale).
    pub scale: f64,
    /// The surface as a polyline in the finger's frame, if any.
    pub surface: Option<(Vec<f64>, Vec<f64>)>,
    /// Visible window (x range, y range) in mm; `None` shows everything.
    pub window: Option<((f64, f64), (f64, f64))>,
    /// Draw element outlines.
    pub outlines: bool,
}

/// A panel drawing the mesh view.
pub fn mesh_panel(view: &MeshView<'_>) -> Panel {
    let m = view.mesh;
    let position = |n: usize| {
        let [x, y] = m.nodes[n];
        match view.displacement {
            Some(u) => (x + view.scale * u[2 * n], y + view.scale * u[2 * n + 1]),
            None => (x, y),
        }
    };
    let mut panel = Panel::new("x (mm)", "y (mm)").title(view.title.clone());
    // The rigid bone: the inner boundary polygon.
    if !m.inner.is_empty() {
        panel = panel.shape(Shape {
            points: m.inner.iter().map(|&n| position(n)).collect(),
            fill: Some(SUBDOMAIN_COLORS[subdomain::BONE as usize]),
            stroke: Some((120, 120, 110)),
        });
    }
    let outline = view.outlines.then_some((90, 70, 60));
    for (e, nodes) in m.elements.iter().enumerate() {
        let points: Vec<(f64, f64)> = nodes.iter().map(|&n| position(n)).collect();
        if let Some(((x0, x1), (y0, y1))) = view.window
            && points.iter().all(|&(x, y)| x < x0 || x > x1 || y < y0 || y > y1)
        {
            continue;
        }
        let color = SUBDOMAIN_COLORS[(m.subdomain[e] as usize).min(5)];
        panel = panel.shape(Shape { points, fill: Some(color), stroke: outline });
    }
    if let Some((x, y)) = &view.surface {
        panel = panel.series(Series::line("rigid surface", x, y).color((40, 40, 40)));
    }
    for (i, name) in subdomain::NAMES.iter().enumerate() {
        panel = panel.swatch(*name, SUBDOMAIN_COLORS[i]);
    }
    if let Some(((x0, x1), (y0, y1))) = view.window {
        panel = panel.x_range(x0, x1).y_range(y0, y1);
    }
    panel
}

/// A one-panel figure of the view, sized so that x and y have the same scale.
pub fn mesh_figure(view: &MeshView<'_>, width_px: u32) -> Figure {
    let panel = mesh_panel(view);
    let ((x0, x1), (y0, y1)) = view
        .window
        .unwrap_or_else(|| (lo_hi(view.mesh.nodes.iter().map(|p| p[0])), lo_hi(view.mesh.nodes.iter().map(|p| p[1]))));
    // Plot area is about width - 105 px wide and height - 90 px high.
    let height = (((y1 - y0) / (x1 - x0)) * (width_px as f64 - 105.0) + 90.0).round().clamp(150.0, 4000.0) as u32;
    Figure::new("").size(width_px, height).panel(panel)
}

fn lo_hi(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)))
}
