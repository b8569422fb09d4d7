//! The 2D finger's cross-section extruded into a 3D slice: the 2D mesh's
//! quadrilaterals of soft tissue swept along y over a width, one hexahedron
//! deep, every node held in y. That is plane strain exactly, so the 3D
//! solver run on the slice must give the 2D model's forces per mm of width
//! (tests/plane_strain_3d_vs_2d.rs): a check of the whole 3D chain (the
//! hexahedron, the visco-elastic body, the contact and its friction, the
//! condensed solver, the slide) against the 2D model that was validated
//! against CalculiX.
//!
//! Frames: the 2D model's (x, y) are the 3D (x, z); the slice spans y from
//! 0 to the width.

use super::mesh::Mesh3;
use super::slide::Finger3;
use crate::finger::{FingerError, FingerModel, Resolution, subdomain};

/// The slice of `width_mm` of the 2D finger `model` at `resolution`.
pub fn plane_strain_slice(model: &FingerModel, resolution: Resolution, width_mm: f64) -> Result<Finger3, FingerError> {
    let finger = model.mesh(resolution)?;
    let m = &finger.mesh;
    // The soft tissue's elements and the nodes they use, renumbered.
    let soft: Vec<usize> = (0..m.n_elements()).filter(|&e| m.subdomain[e] <= subdomain::HYPODERMIS).collect();
    let mut index = vec![usize::MAX; m.n_nodes()];
    let mut used = Vec::new();
    for &e in &soft {
        for &n in &m.elements[e] {
            if index[n] == usize::MAX {
                index[n] = used.len();
                used.push(n);
            }
        }
    }
    let n2 = used.len();
    let mut nodes = Vec::with_capacity(2 * n2);
    for y in [0.0, width_mm] {
        nodes.extend(used.iter().map(|&n| [m.nodes[n][0], y, m.nodes[n][1]]));
    }
    // A quadrilateral counter-clockwise in (x, z) swept along +y is
    // left-handed in (r, s, t) = (quad, quad, y): its far layer is taken
    // as the hexahedron's bottom face, so that det J > 0.
    let elements = soft
        .iter()
        .map(|&e| {
            let q = m.elements[e].map(|n| index[n]);
            [q[0] + n2, q[1] + n2, q[2] + n2, q[3] + n2, q[0], q[1], q[2], q[3]]
        })
        .collect();
    let element_layer = soft.iter().map(|&e| usize::from(m.subdomain[e])).collect();
    let mesh = Mesh3 { nodes, elements, shape: [0; 3] };
    let mut driven_nodes: Vec<usize> = finger
        .driven_nodes
        .iter()
        .filter(|&&n| index[n] != usize::MAX)
        .flat_map(|&n| [index[n], index[n] + n2])
        .collect();
    driven_nodes.sort_unstable();
    let held_dofs = (0..2 * n2).map(|n| 3 * n + 1).collect();
    let skin_faces =
        finger.contact_segments.iter().map(|&[a, b]| [index[a], index[b], index[b] + n2, index[a] + n2]).collect();
    Ok(Finger3 { mesh, element_layer, driven_nodes, held_dofs, skin_faces })
}
