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
