//! Files written from a simulation: the force history and friction
//! profile (CSV, design.md formats), a VTK series for ParaView (.vtu per
//! frame + .pvd collection) and a PNG of the deformed finger.

use std::io::Write;
use std::path::Path;

use haptex_core::io::{FileSet, WriteError, write_csv_row};
use haptex_core::plot::{Figure, PlotError};

use crate::drawing::{MeshView, mesh_panel};
use crate::finger::subdomain;
use crate::scenario::{Frame, Kinematics, Loading, Scenario, SimulationResult};
use crate::surface::SurfaceShape;
use haptex_core::num::Num;

/// Where a display's voltage comes from, as a simulation's description
/// names it.
#[derive(Debug, Clone, Copy)]
pub enum VoltageSource<'a> {
    /// A voltage profile read from (or given as) this.
    Profile(&'a str),
    /// One voltage over the whole slide, V RMS.
    Constant(f64),
}

/// The surface part of a simulation's description: a template with its
/// parameters (`bump x0 = 5 mm, r_w = 1.5 mm, r_h = 0.3 mm`), `flat`, the
/// display and its voltage's source, or `sampled` (what the caller read a
/// sampled surface from, e.g. `file:heights.csv`).
pub fn surface_text(shape: &SurfaceShape, display: Option<VoltageSource<'_>>, sampled: &str) -> String {
    let template = |name: &str, x0: f64, width: f64, height: f64| {
        format!("{name} x0 = {} mm, r_w = {} mm, r_h = {} mm", Num(x0), Num(width), Num(height))
    };
    match shape {
        SurfaceShape::Flat => match display {
            Some(VoltageSource::Profile(source)) => format!("display, voltage from {source}"),
            Some(VoltageSource::Constant(u)) => format!("display, constant {} V", Num(u)),
            None => "flat".to_string(),
        },
        SurfaceShape::Sampled { .. } => sampled.to_string(),
        SurfaceShape::Bump { x0, width, height } => template("bump", *x0, *width, *height),
        SurfaceShape::Edge { x0, width, height } => template("edge", *x0, *width, *height),
        SurfaceShape::Sine { x0, width, height } => template("sine", *x0, *width, *height),
    }
}

/// The description `haptex simulate` writes in its profile's first
/// comment: the surface (`surface`, from [`surface_text`]), the loading,
/// the slide, the tissue, the mesh and the kinematics.
pub fn describe(scenario: &Scenario, surface: &str) -> String {
    describe_with_load_unit(scenario, surface, "N/mm")
}

/// [`describe`] with a load in `load_unit` (the 3D finger's is N).
pub fn describe_with_load_unit(scenario: &Scenario, surface: &str, load_unit: &str) -> String {
    let loading = match scenario.loading {
        Loading::Indent(d) => format!("indent {} mm", Num(d)),
        Loading::Load(f) => format!("load {} {load_unit}", Num(f)),
    };
    format!(
        "{surface}; {loading}, slide {} mm at {} mm/s, {} tissue, {} mesh{}",
        Num(scenario.slide_mm),
        Num(scenario.velocity_mm_s),
        if scenario.viscoelastic { "visco-elastic" } else { "elastic" },
        scenario.resolution.name(),
        if scenario.kinematics == Kinematics::Finite { ", finite strain" } else { "" }
    )
}

/// Writes `t_s,slide_mm,fn_n,ft_n,contact_mm` and diagnostic columns
/// (forces per mm of finger width), then the display's `voltage_v`, the
/// electrostatic attraction `fe_n` and its part on skin in contact
/// `fe_contact_n` (0 on a passive surface).
pub fn write_history(result: &SimulationResult, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, "# haptex simulate force history; forces in N per mm of finger width (2D plane strain)")?;
    writeln!(
        w,
        "t_s,slide_mm,fn_n,ft_n,contact_mm,drive_y_mm,reaction_x_n,reaction_y_n,newton_iterations,step_cuts,voltage_v,fe_n,fe_contact_n"
    )?;
    for r in &result.history {
        write_csv_row(
            w,
            &[
                r.t_s,
                r.slide_mm,
                r.fn_n,
                r.ft_n,
                r.contact_mm,
                r.drive_y_mm,
                r.reaction_n[0],
                r.reaction_n[1],
                r.iterations as f64,
                r.cuts as f64,
                r.voltage_v,
                r.fe_n,
                r.fe_contact_n,
            ],
        )?;
    }
    Ok(())
}

/// Writes the friction profile `x_mm,mu,ft_n,fn_n`: x is the finger's
/// position on the surface, mu = Ft/Fn; a `haptex voltage` input as is.
/// A press-only run (no profile) writes its press curve instead (see
/// [`write_press_curve`]).
pub fn write_profile(result: &SimulationResult, description: &str, w: &mut dyn Write) -> std::io::Result<()> {
    let Some(p) = &result.profile else {
        return write_press_curve(result, description, w);
    };
    writeln!(w, "# haptex simulate: {description}")?;
    writeln!(w, "# x_mm: finger position on the surface; mu = ft_n/fn_n (forces per mm of finger width)")?;
    writeln!(w, "x_mm,mu,ft_n,fn_n")?;
    let fn_n = p.fn_n().unwrap_or(&[]);
    for i in 0..p.len() {
        let f = fn_n.get(i).copied().unwrap_or(f64::NAN);
        write_csv_row(w, &[p.x_mm()[i], p.mu()[i], p.mu()[i] * f, f])?;
    }
    Ok(())
}

/// Writes the press of a press-only run, step by step:
/// `t_s,indent_mm,fn_n,ft_n,contact_mm` with indent_mm the downward
/// displacement of bone and nail since first touch, and the forces on the
/// finger per mm of width (Fn pressing, Ft along -x).
pub fn write_press_curve(result: &SimulationResult, description: &str, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(w, "# haptex simulate (press only): {description}")?;
    writeln!(w, "# indent_mm: bone and nail moved down since first touch; forces in N per mm of finger width")?;
    writeln!(w, "t_s,indent_mm,fn_n,ft_n,contact_mm")?;
    for r in &result.history {
        write_csv_row(w, &[r.t_s, -r.drive_y_mm, r.fn_n, r.ft_n, r.contact_mm])?;
    }
    Ok(())
}

/// Writes one .vtu per frame and a .pvd collection into `dir` (created if
/// missing). Points are the reference positions with a `displacement`
/// vector (use ParaView's Warp By Vector); cells carry the subdomain id
/// (0-5 as in the finger model, 6 = rigid surface) and the stress.
///
/// The frames are a file set whose marker is `simulation.pvd`: removed
/// first, written last (with each frame's SHA-256 in an XML comment), so a
/// run interrupted while writing leaves no collection that could name a
/// mix of old and new frames.
pub fn write_vtk_series(result: &SimulationResult, dir: &Path) -> Result<Vec<std::path::PathBuf>, WriteError> {
    let times: Vec<f64> = result.frames.iter().map(|f| f.t_s).collect();
    write_series(dir, "haptex simulate", &times, |k, w| write_vtu(result, &result.frames[k], w))
}

/// Writes a VTK series into `dir` (created if missing): frame k's
/// `frame_kkkk.vtu` by `frame(k, w)` for each of `times`, then the
/// collection `simulation.pvd` naming each with its time and SHA-256
/// (`written_by` in its comment). The collection is the file set's marker:
/// removed first, written last, so that an interrupted run leaves no
/// collection naming a mix of old and new frames.
pub fn write_series(
    dir: &Path,
    written_by: &str,
    times: &[f64],
    frame: impl Fn(usize, &mut dyn Write) -> std::io::Result<()>,
) -> Result<Vec<std::path::PathBuf>, WriteError> {
    let mut set = FileSet::begin(dir, "simulation.pvd")?;
    let mut written = Vec::new();
    let mut entries = Vec::new();
    for (k, &t) in times.iter().enumerate() {
        let name = format!("frame_{k:04}.vtu");
        written.push(set.write(&name, |w| frame(k, w))?);
        entries.push((t, name));
    }
    let pvd = set.finish(|w, hashes| {
        writeln!(w, "<?xml version=\"1.0\"?>")?;
        writeln!(w, "<!-- written by {written_by}; SHA-256 of each frame:")?;
        for (name, hash) in hashes {
            writeln!(w, "     {hash}  {name}")?;
        }
        writeln!(w, "-->")?;
        writeln!(w, "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">")?;
        writeln!(w, "  <Collection>")?;
        for (t, name) in &entries {
            writeln!(w, "    <DataSet timestep=\"{t}\" group=\"\" part=\"0\" file=\"{name}\"/>")?;
        }
        writeln!(w, "  </Collection>\n</VTKFile>")
    })?;
    written.push(pvd);
    Ok(written)
}

fn write_vtu(result: &SimulationResult, frame: &Frame, w: &mut dyn Write) -> std::io::Result<()> {
    let mesh = &result.mesh;
    let n_nodes = mesh.n_nodes();
    // The surface as a polyline in the finger's frame at this frame's slide,
    // subsampled to at most 2000 points.
    let (x0, x1) = result.surface.range();
    let n_surface = 2000usize;
    let surface: Vec<[f64; 2]> = (0..n_surface)
        .map(|i| {
            let xs = x0 + (x1 - x0) * i as f64 / (n_surface - 1) as f64;
            [xs - frame.slide_mm, result.surface.height(xs) + result.lift_mm]
        })
        .collect();
    let cells = mesh.n_elements() + 2;
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(w, "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">")?;
    writeln!(w, "  <UnstructuredGrid>")?;
    writeln!(w, "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{cells}\">", n_nodes + n_surface)?;
    writeln!(w, "      <Points>\n        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">")?;
    for p in &mesh.nodes {
        writeln!(w, "{} {} 0", p[0], p[1])?;
    }
    for p in &surface {
        writeln!(w, "{} {} 0", p[0], p[1])?;
    }
    writeln!(w, "        </DataArray>\n      </Points>")?;
    writeln!(w, "      <Cells>\n        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">")?;
    for e in &mesh.elements {
        writeln!(w, "{} {} {} {}", e[0], e[1], e[2], e[3])?;
    }
    let bone: Vec<String> = mesh.inner.iter().map(|n| n.to_string()).collect();
    writeln!(w, "{}", bone.join(" "))?;
    let line: Vec<String> = (0..n_surface).map(|i| (n_nodes + i).to_string()).collect();
    writeln!(w, "{}", line.join(" "))?;
    writeln!(w, "        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">")?;
    let mut offset = 0;
    for _ in &mesh.elements {
        offset += 4;
        writeln!(w, "{offset}")?;
    }
    offset += mesh.inner.len();
    writeln!(w, "{offset}")?;
    offset += n_surface;
    writeln!(w, "{offset}")?;
    writeln!(w, "        </DataArray>\n        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">")?;
    for _ in &mesh.elements {
        writeln!(w, "9")?; // VTK_QUAD
    }
    writeln!(w, "7\n4")?; // VTK_POLYGON (bone), VTK_POLY_LINE (surface)
    writeln!(w, "        </DataArray>\n      </Cells>")?;
    writeln!(w, "      <PointData Vectors=\"displacement\">")?;
    writeln!(
        w,
        "        <DataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\" format=\"ascii\">"
    )?;
    for n in 0..n_nodes {
        writeln!(w, "{} {} 0", frame.displacement[2 * n], frame.displacement[2 * n + 1])?;
    }
    for _ in 0..n_surface {
        writeln!(w, "0 0 0")?;
    }
    writeln!(w, "        </DataArray>\n      </PointData>")?;
    writeln!(w, "      <CellData Scalars=\"subdomain\">")?;
    writeln!(w, "        <DataArray type=\"Int32\" Name=\"subdomain\" format=\"ascii\">")?;
    for s in &mesh.subdomain {
        writeln!(w, "{s}")?;
    }
    writeln!(w, "{}\n6", subdomain::BONE)?;
    writeln!(w, "        </DataArray>")?;
    writeln!(
        w,
        "        <DataArray type=\"Float64\" Name=\"stress_MPa\" NumberOfComponents=\"4\" ComponentName0=\"xx\" \
         ComponentName1=\"yy\" ComponentName2=\"zz\" ComponentName3=\"xy\" format=\"ascii\">"
    )?;
    for s in &frame.stress {
        writeln!(w, "{} {} {} {}", s[0], s[1], s[2], s[3])?;
    }
    writeln!(w, "0 0 0 0\n0 0 0 0")?;
    writeln!(w, "        </DataArray>")?;
    writeln!(w, "        <DataArray type=\"Float64\" Name=\"von_mises_MPa\" format=\"ascii\">")?;
    for s in &frame.stress {
        writeln!(w, "{}", von_mises(s))?;
    }
    writeln!(w, "0\n0")?;
    writeln!(w, "        </DataArray>\n      </CellData>")?;
    writeln!(w, "    </Piece>\n  </UnstructuredGrid>\n</VTKFile>")
}

/// Von Mises equivalent stress of (xx, yy, zz, xy).
pub fn von_mises(s: &[f64; 4]) -> f64 {
    let [a, b, c, t] = *s;
    (0.5 * ((a - b).powi(2) + (b - c).powi(2) + (c - a).powi(2)) + 3.0 * t * t).sqrt()
}

/// The paper's Fig. 1c,d for this run: the deformed finger after the press
/// and with the feature under the pad (or at the end), at true scale, over
/// the surface, zoomed on the pad.
pub fn deformation_figure(result: &SimulationResult, title: &str) -> Figure {
    let second = result.feature_frame.unwrap_or(result.frames.len().saturating_sub(1));
    let mut frames: Vec<&Frame> = result.frames.first().into_iter().collect();
    if second > 0 {
        frames.push(&result.frames[second]);
    }
    let window = ((-6.0, 6.0), (-1.0, 5.0));
    let mut figure = Figure::new(title).size(1100, 560);
    for frame in frames {
        let (x0, x1) = (window.0.0 + frame.slide_mm, window.0.1 + frame.slide_mm);
        let n = 1200;
        let xs: Vec<f64> = (0..n).map(|i| x0 + (x1 - x0) * i as f64 / (n - 1) as f64).collect();
        let surface_x: Vec<f64> = xs.iter().map(|x| x - frame.slide_mm).collect();
        let surface_y: Vec<f64> = xs.iter().map(|&x| result.surface.height(x) + result.lift_mm).collect();
        let view = MeshView {
            title: format!("t = {:.3} s, finger at x = {:.2} mm on the surface", frame.t_s, frame.slide_mm),
            mesh: &result.mesh,
            displacement: Some(&frame.displacement),
            scale: 1.0,
            surface: Some((surface_x, surface_y)),
            window: Some(window),
            outlines: true,
        };
        figure = figure.panel(mesh_panel(&view));
    }
    figure
}

/// Writes [`deformation_figure`] as a PNG.
pub fn write_png(result: &SimulationResult, title: &str, path: &Path) -> Result<(), PlotError> {
    deformation_figure(result, title).write_png(path)
}
