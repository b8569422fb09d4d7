//! Files written from a 3D simulation ([`super::slide`]): the friction
//! profile and the force history (CSV, with forces in N, not per mm of
//! width as in 2D), a PNG of the contact patch, and a VTK series of the
//! whole field for ParaView.

use std::io::Write;
use std::path::Path;

use haptex_core::io::{WriteError, write_csv_row};
use haptex_core::plot::{Figure, Panel, PlotError, Series, Shape};

use super::slide::{Frame3, Patch, SURFACE_GRID, Simulation3};

/// Writes `x_mm,mu,ft_n,fn_n,ft_lateral_n,force_angle_deg`: x the distance
/// the finger travelled along its direction, mu = Ft/Fn with Ft the
/// friction along the motion; a `haptex voltage` input as is. The lateral
/// force and the tangential force's angle from the motion's direction
/// follow. A press-only run writes its press curve instead.
pub fn write_profile(result: &Simulation3, description: &str, w: &mut dyn Write) -> std::io::Result<()> {
    let Some(p) = &result.profile else {
        return write_press_curve(result, description, w);
    };
    writeln!(w, "# haptex simulate --model 3d: {description}")?;
    writeln!(
        w,
        "# x_mm: distance travelled at {} degrees from the surface's x axis; mu = ft_n/fn_n; forces in N on the \
         3D finger; force_angle_deg: the tangential force's direction from the motion's, positive to its left",
        haptex_core::num::Num(result.direction_deg)
    )?;
    if let Some(u) = result.unresolved() {
        writeln!(w, "# warning: {u}")?;
    }
    writeln!(w, "x_mm,mu,ft_n,fn_n,ft_lateral_n,force_angle_deg")?;
    // The slide's rows of the history: those past the press.
    for (i, r) in result.history.iter().filter(|r| r.slide_mm > 0.0).enumerate() {
        let angle = r.ft_lateral_n.atan2(r.ft_n).to_degrees();
        write_csv_row(w, &[p.x_mm()[i], p.mu()[i], r.ft_n, r.fn_n, r.ft_lateral_n, angle])?;
    }
    Ok(())
}

/// Writes the press of a press-only run: `t_s,indent_mm,fn_n,contact_area_mm2`.
pub fn write_press_curve(result: &Simulation3, description: &str, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, "# haptex simulate --model 3d (press only): {description}")?;
    writeln!(w, "# indent_mm: the bone moved down since first touch; fn_n in N; contact_area_mm2 in mm^2")?;
    writeln!(w, "t_s,indent_mm,fn_n,contact_area_mm2")?;
    for r in &result.history {
        write_csv_row(w, &[r.t_s, -r.drive_z_mm, r.fn_n, r.contact_area_mm2])?;
    }
    Ok(())
}

/// Writes every step: `t_s,slide_mm,fn_n,ft_n,ft_lateral_n,contact_area_mm2,drive_z_mm,newton_iterations`,
/// then the contact's length along the motion and, on a display, the
/// electrostatic attraction `fe_n` and its part on skin in contact
/// `fe_contact_n` (0 on a passive surface; `fn_n` is the net force), and
/// how far the surface reaches into the skin, `surface_reach_mm`
/// ([`super::slide::Row3::surface_reach_mm`]).
pub fn write_history(result: &Simulation3, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, "# haptex simulate --model 3d force history; forces in N on the 3D finger")?;
    writeln!(
        w,
        "t_s,slide_mm,fn_n,ft_n,ft_lateral_n,contact_area_mm2,drive_z_mm,newton_iterations,contact_length_mm,fe_n,\
         fe_contact_n,surface_reach_mm"
    )?;
    for r in &result.history {
        write_csv_row(
            w,
            &[
                r.t_s,
                r.slide_mm,
                r.fn_n,
                r.ft_n,
                r.ft_lateral_n,
                r.contact_area_mm2,
                r.drive_z_mm,
                r.iterations as f64,
                r.contact_length_mm,
                r.fe_n,
                r.fe_contact_n,
                r.surface_reach_mm,
            ],
        )?;
    }
    Ok(())
}

/// Pressure colours, from the lowest band to the highest.
const BANDS: [(u8, u8, u8); 6] =
    [(254, 240, 217), (253, 212, 158), (253, 187, 132), (252, 141, 89), (227, 74, 51), (179, 0, 0)];

/// The contact patches of a run seen from below the surface: each skin
/// face of the contact region at its deformed place, filled by its mean
/// pressure (over its contact points) in six bands up to the largest
/// pressure of the run, with the
/// patch's area and force in the panel's title; the direction of motion
/// as an arrow from the pad's centre.
pub fn patch_figure(result: &Simulation3, title: &str) -> Figure {
    let peak =
        result.patches.iter().flat_map(|p| p.points.iter().map(|q| q.pressure_mpa)).fold(0.0f64, f64::max).max(1e-12);
    let mut figure = Figure::new(title).size(760, 560);
    for patch in &result.patches {
        figure = figure.panel(patch_panel(patch, peak, result.direction_deg));
    }
    figure
}

fn patch_panel(patch: &Patch, peak: f64, direction_deg: f64) -> Panel {
    let area: f64 = patch.points.iter().filter(|p| p.pressure_mpa > 0.0).map(|p| p.weight_mm2).sum();
    let force: f64 = patch.points.iter().map(|p| p.pressure_mpa * p.weight_mm2).sum();
    let mut panel = Panel::new("x across the finger (mm)", "y along the finger (mm)").title(format!(
        "t = {:.3} s, travelled {:.2} mm: contact {area:.1} mm^2, pressure force {force:.3} N",
        patch.t_s, patch.slide_mm
    ));
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (face, corners) in patch.points.chunks_exact(patch.per_face.max(1)).zip(&patch.faces) {
        let pressure = face.iter().map(|p| p.pressure_mpa * p.weight_mm2).sum::<f64>()
            / face.iter().map(|p| p.weight_mm2).sum::<f64>().max(1e-300);
        let fill = if pressure > 0.0 {
            for c in corners {
                for d in 0..2 {
                    lo[d] = lo[d].min(c[d]);
                    hi[d] = hi[d].max(c[d]);
                }
            }
            let band = ((pressure / peak) * BANDS.len() as f64).floor() as usize;
            BANDS[band.min(BANDS.len() - 1)]
        } else {
            (255, 255, 255)
        };
        let points = corners.iter().map(|c| (c[0], c[1])).collect();
        panel = panel.shape(Shape { points, fill: Some(fill), stroke: Some((170, 170, 170)) });
    }
    for (k, &color) in BANDS.iter().enumerate() {
        let (a, b) = (peak * k as f64 / BANDS.len() as f64, peak * (k + 1) as f64 / BANDS.len() as f64);
        panel = panel.swatch(format!("{:.0}-{:.0} kPa", 1e3 * a, 1e3 * b), color);
    }
    let theta = direction_deg.to_radians();
    let arrow = 2.0;
    panel = panel.series(
        Series::line("finger's motion", &[0.0, arrow * theta.cos()], &[0.0, arrow * theta.sin()]).color((20, 60, 160)),
    );
    // A square window around the patch, with a margin.
    let half = if lo[0].is_finite() { (hi[0] - lo[0]).max(hi[1] - lo[1]) / 2.0 + 2.0 } else { 6.0 };
    let mid = if lo[0].is_finite() { [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0] } else { [0.0, 0.0] };
    panel.x_range(mid[0] - half, mid[0] + half).y_range(mid[1] - half, mid[1] + half)
}

/// Writes [`patch_figure`] as a PNG.
pub fn write_png(result: &Simulation3, title: &str, path: &Path) -> Result<(), PlotError> {
    patch_figure(result, title).write_png(path)
}

/// Writes one .vtu per frame of `result` ([`Simulation3::frames`]) and a
/// .pvd collection into `dir` (created if missing), as the 2D model's
/// series (crate::output::write_vtk_series): the marker `simulation.pvd`
/// is removed first and written last with each frame's SHA-256, so that an
/// interrupted run leaves no collection naming a mix of frames.
///
/// Each frame holds, on the reference positions with a point vector
/// `displacement` (mm; ParaView's Warp By Vector shows the deformed
/// finger) and a point field `driven` (1 on the nodes the bone drives):
///
/// - the hexahedra (VTK_HEXAHEDRON), `part` 0-3 their layer (stratum
///   corneum to hypodermis);
/// - the contact region's skin faces (VTK_QUAD, `part` 4) with their mean
///   `pressure_MPa`, tangential `traction_MPa` (on the finger), and the
///   fractions of their area `in_contact` and `sticking`;
/// - the surface under the finger (VTK_QUAD, `part` 6), in place.
pub fn write_vtk_series(result: &Simulation3, dir: &Path) -> Result<Vec<std::path::PathBuf>, WriteError> {
    let times: Vec<f64> = result.frames.iter().map(|f| f.t_s).collect();
    crate::output::write_series(dir, "haptex simulate --model 3d", &times, |k, w| {
        write_vtu(result, &result.frames[k], w)
    })
}

/// The `part` of the contact faces and of the surface in a VTK frame.
pub const VTK_PART_CONTACT_FACE: usize = 4;
pub const VTK_PART_SURFACE: usize = 6;

fn write_vtu(result: &Simulation3, frame: &Frame3, w: &mut dyn Write) -> std::io::Result<()> {
    let mesh = &result.mesh;
    let n_nodes = mesh.n_nodes();
    let grid = SURFACE_GRID;
    let surface_quads = (grid - 1) * (grid - 1);
    let (hexes, faces) = (mesh.elements.len(), result.contact_faces.len());
    let cells = hexes + faces + surface_quads;
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(w, "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">")?;
    writeln!(w, "  <UnstructuredGrid>")?;
    writeln!(w, "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{cells}\">", n_nodes + frame.surface.len())?;
    writeln!(w, "      <Points>\n        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">")?;
    for p in mesh.nodes.iter().chain(&frame.surface) {
        writeln!(w, "{} {} {}", p[0], p[1], p[2])?;
    }
    writeln!(w, "        </DataArray>\n      </Points>")?;
    writeln!(w, "      <Cells>\n        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">")?;
    // VTK_HEXAHEDRON's corners are hex8::CORNERS' order: the bottom face
    // counter-clockwise, then the top face above it.
    for e in &mesh.elements {
        writeln!(w, "{} {} {} {} {} {} {} {}", e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7])?;
    }
    for f in &result.contact_faces {
        writeln!(w, "{} {} {} {}", f[0], f[1], f[2], f[3])?;
    }
    for j in 0..grid - 1 {
        for i in 0..grid - 1 {
            let a = n_nodes + j * grid + i;
            writeln!(w, "{} {} {} {}", a, a + 1, a + grid + 1, a + grid)?;
        }
    }
    writeln!(w, "        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">")?;
    let mut offset = 0;
    for k in 0..cells {
        offset += if k < hexes { 8 } else { 4 };
        writeln!(w, "{offset}")?;
    }
    writeln!(w, "        </DataArray>\n        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">")?;
    for k in 0..cells {
        writeln!(w, "{}", if k < hexes { 12 } else { 9 })?;
    }
    writeln!(w, "        </DataArray>\n      </Cells>")?;
    writeln!(w, "      <PointData Vectors=\"displacement\">")?;
    writeln!(
        w,
        "        <DataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\" format=\"ascii\">"
    )?;
    for u in frame.displacement.chunks_exact(3) {
        writeln!(w, "{} {} {}", u[0], u[1], u[2])?;
    }
    for _ in &frame.surface {
        writeln!(w, "0 0 0")?;
    }
    writeln!(w, "        </DataArray>")?;
    writeln!(w, "        <DataArray type=\"UInt8\" Name=\"driven\" format=\"ascii\">")?;
    let mut driven = vec![0u8; n_nodes + frame.surface.len()];
    for &n in &result.driven_nodes {
        driven[n] = 1;
    }
    for d in driven {
        writeln!(w, "{d}")?;
    }
    writeln!(w, "        </DataArray>\n      </PointData>")?;
    writeln!(w, "      <CellData Scalars=\"part\">")?;
    writeln!(w, "        <DataArray type=\"Int32\" Name=\"part\" format=\"ascii\">")?;
    for layer in &result.element_layer {
        writeln!(w, "{layer}")?;
    }
    for _ in 0..faces {
        writeln!(w, "{VTK_PART_CONTACT_FACE}")?;
    }
    for _ in 0..surface_quads {
        writeln!(w, "{VTK_PART_SURFACE}")?;
    }
    writeln!(w, "        </DataArray>")?;
    let face_field = |w: &mut dyn Write, name: &str, values: &[f64]| -> std::io::Result<()> {
        writeln!(w, "        <DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">")?;
        for _ in 0..hexes {
            writeln!(w, "0")?;
        }
        for v in values {
            writeln!(w, "{v}")?;
        }
        for _ in 0..surface_quads {
            writeln!(w, "0")?;
        }
        writeln!(w, "        </DataArray>")
    };
    face_field(w, "pressure_MPa", &frame.face_pressure_mpa)?;
    face_field(w, "in_contact", &frame.face_contact)?;
    face_field(w, "sticking", &frame.face_sticking)?;
    writeln!(
        w,
        "        <DataArray type=\"Float64\" Name=\"traction_MPa\" NumberOfComponents=\"3\" format=\"ascii\">"
    )?;
    for _ in 0..hexes {
        writeln!(w, "0 0 0")?;
    }
    for t in &frame.face_traction_mpa {
        writeln!(w, "{} {} {}", t[0], t[1], t[2])?;
    }
    for _ in 0..surface_quads {
        writeln!(w, "0 0 0")?;
    }
    writeln!(w, "        </DataArray>\n      </CellData>")?;
    writeln!(w, "    </Piece>\n  </UnstructuredGrid>\n</VTKFile>")
}
