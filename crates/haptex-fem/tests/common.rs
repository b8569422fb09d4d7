//! Shared builders for the validation tests (included with `mod common;`).
#![allow(dead_code)]

use haptex_fem::mesh::Mesh;

/// A 4x4-node grid over [0, 3]^2 whose interior nodes are moved off the
/// grid and whose edge nodes slide along the edges: a distorted 3x3 patch.
/// Returns the mesh and the indices of the boundary nodes.
pub fn distorted_patch() -> (Mesh, Vec<usize>) {
    // Fixed offsets (in place of random ones, so the test is reproducible).
    let offsets = [[0.21, -0.17], [-0.23, 0.14], [0.16, 0.24], [-0.19, -0.22]];
    let mut nodes = Vec::new();
    let mut boundary = Vec::new();
    let mut interior = 0;
    for j in 0..4 {
        for i in 0..4 {
            let (mut x, mut y) = (i as f64, j as f64);
            let on_x_edge = i == 0 || i == 3;
            let on_y_edge = j == 0 || j == 3;
            if on_x_edge || on_y_edge {
                boundary.push(nodes.len());
                // Slide edge nodes along their edge (corners stay).
                if !on_x_edge {
                    x += 0.13 * if i == 1 { 1.0 } else { -1.0 };
                }
                if !on_y_edge {
                    y += 0.11 * if j == 1 { -1.0 } else { 1.0 };
                }
            } else {
                x += offsets[interior][0];
                y += offsets[interior][1];
                interior += 1;
            }
            nodes.push([x, y]);
        }
    }
    let mut elements = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            let n = 4 * j + i;
            elements.push([n, n + 1, n + 5, n + 4]);
        }
    }
    let subdomain = vec![0; elements.len()];
    (Mesh { nodes, elements, subdomain, outer: Vec::new(), inner: Vec::new() }, boundary)
}

use haptex_fem::body::{Body, SubdomainModel};
use haptex_fem::contact::{ContactLaw, ContactSet};
use haptex_fem::element::Formulation;
use haptex_fem::material::Material;
use haptex_fem::ring::{RingSpec, Transition, contour_parameters, mesh_ring};
use haptex_fem::solver::ContactProblem;
use haptex_fem::surface::{RigidSurface, SurfaceShape};

/// A homogeneous cylinder of radius `radius` (lowest point at the origin)
/// around a rigid core of radius `core` (the driven set), meshed with a
/// pad spacing `pad` over +-`half_arc` of arc at the bottom, over a flat
/// rigid surface.
pub fn cylinder_on_flat(
    radius: f64,
    core: f64,
    pad: f64,
    half_arc: f64,
    material: Material,
    law: ContactLaw,
) -> ContactProblem {
    let map = |phi: f64, t: f64| {
        let r = radius - t;
        [r * phi.sin(), radius - r * phi.cos()]
    };
    let contour = |phi: f64| map(phi, 0.0);
    let (phis, n_fine) = contour_parameters(&contour, half_arc, pad, 8.0 * pad).unwrap();
    // Rows graded from the pad spacing at the surface, growing by 1.15.
    let depth = radius - core;
    let mut rows = vec![0.0];
    let mut h = pad;
    while *rows.last().unwrap() + h < depth {
        rows.push(rows.last().unwrap() + h);
        h *= 1.15;
    }
    rows.push(depth);
    let first = rows.iter().position(|&t| t > 2.5 * pad).unwrap();
    let second = rows.iter().position(|&t| t > 10.0 * pad).unwrap().max(first + 2);
    let transitions = vec![
        Transition { after_row: first, range: None },
        Transition { after_row: second, range: Some((0, n_fine / 3)) },
    ];
    let ring = mesh_ring(&RingSpec { map: &map, phis, rows, transitions, subdomain: &|_, _| 0 }).unwrap();
    let mesh = ring.mesh;
    let segments: Vec<[usize; 2]> = (0..n_fine).map(|k| [mesh.outer[k], mesh.outer[k + 1]]).collect();
    let contact = ContactSet::new(&mesh.nodes, &segments, 4);
    let other = mesh.outer[n_fine + 1..].to_vec();
    let driven = mesh.inner.clone();
    let body = Body::new(mesh, vec![SubdomainModel::Deformable(material)], Formulation::BBar).unwrap();
    ContactProblem {
        body,
        driven_nodes: driven,
        contact,
        other_surface_nodes: other,
        surface: RigidSurface::new(&SurfaceShape::Flat, -radius - 20.0, radius + 20.0).unwrap(),
        law,
        display: None,
    }
}

/// The body of the 3D contact tests (Hertz, Cattaneo-Mindlin): the block
/// over the grid `xs` x `ys` x `zs` (z from 0 to `length`) whose bottom
/// face becomes Hertz's paraboloid z = r^2 / (2 `radius`) out to 4 `a`,
/// continued by its tangent cone beyond (C1, so that the far corners stay
/// thick; the contact reaches a), the top kept flat; with the bottom
/// faces that may touch (centres within 1.6 a).
pub fn paraboloid_block(
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    radius: f64,
    a: f64,
) -> (haptex_fem::solid3d::mesh::Mesh3, Vec<[usize; 4]>) {
    let length = *zs.last().expect("z coordinates");
    let mut mesh = haptex_fem::solid3d::mesh::Mesh3::block(xs, ys, zs).expect("a valid grid");
    let r_c = 4.0 * a;
    let face =
        |r: f64| if r <= r_c { r * r / (2.0 * radius) } else { r_c * r_c / (2.0 * radius) + r_c / radius * (r - r_c) };
    mesh.map(|[x, y, z]| [x, y, z + face(x.hypot(y)) * (1.0 - z / length)]);
    let faces = mesh
        .bottom_faces()
        .into_iter()
        .map(|(_, f)| f)
        .filter(|f| {
            let c: [f64; 2] = std::array::from_fn(|k| f.iter().map(|&n| mesh.nodes[n][k]).sum::<f64>() / 4.0);
            c[0].hypot(c[1]) < 1.6 * a
        })
        .collect();
    (mesh, faces)
}

/// Ft/Fn of a 3D run at x = 0, 0.1, ..., 3 mm (x = 0: the end of the
/// press), its largest magnitude and the largest |Ft/Fn(x) + Ft/Fn(3 - x)|:
/// the antisymmetry of a conservative pad's profile over a path
/// symmetric about a bump's top.
pub fn antisymmetry_over_3_mm(result: &haptex_fem::solid3d::slide::Simulation3) -> (f64, f64) {
    let at = |x: f64| {
        let row =
            result.history.iter().rev().find(|h| (h.slide_mm - x).abs() < 1e-6).unwrap_or_else(|| panic!("x = {x}"));
        row.ft_n / row.fn_n
    };
    let mu: Vec<f64> = (0..=30).map(|i| at(0.1 * i as f64)).collect();
    let largest = mu.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = (0..=30).map(|i| (mu[i] + mu[30 - i]).abs()).fold(0.0f64, f64::max);
    (largest, worst)
}

/// A display at a constant `u_v` volts (held), the paper's layers, no
/// vibration, no air gap.
pub fn constant_display(u_v: f64) -> haptex_fem::display::Display {
    use haptex_core::electrovibration::LayerStack;
    use haptex_core::signal::{Extend, VoltageCurve};
    haptex_fem::display::Display {
        voltage: VoltageCurve::new(vec![0.0, 1.0], vec![u_v, u_v]).unwrap(),
        extend: Extend::Hold,
        stack: LayerStack::PAPER,
        vibration: None,
        air_gap_um: 0.0,
    }
}
