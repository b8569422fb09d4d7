//! A hexahedral mesh and its structured generator: a block over a tensor
//! grid of coordinates (graded as the caller chooses), mapped by any
//! smooth function (e.g. to give a face a curved shape), with its faces on
//! the block's six sides.

use super::hex8::{Hex8, JacobianError};

/// One of the block's six sides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    XMin,
    XMax,
    YMin,
    YMax,
    ZMin,
    ZMax,
}

/// A hexahedral mesh: node positions (mm) and elements (8 node indices in
/// the order of [`super::hex8::CORNERS`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh3 {
    pub nodes: Vec<[f64; 3]>,
    pub elements: Vec<[usize; 8]>,
    /// The grid's node counts along x, y and z (a structured block; zeros
    /// for a mesh made otherwise, whose sides and bottom faces are not
    /// known to it).
    pub shape: [usize; 3],
}

/// A mesh that cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("the {axis} coordinates must be at least two, finite and strictly increasing")]
    Coordinates { axis: char },
    #[error("element {element}: {source}")]
    Jacobian { element: usize, source: JacobianError },
    #[error("{nodes} nodes: more than the {limit} a 3D mesh may have")]
    TooLarge { nodes: usize, limit: usize },
}

/// The most nodes a mesh may have (3 DOFs each: 6 million unknowns).
pub const MAX_NODES: usize = 2_000_000;

impl Mesh3 {
    /// The block over the grid `xs` x `ys` x `zs` (each strictly
    /// increasing): node (i, j, k) has index i + nx (j + ny k).
    pub fn block(xs: &[f64], ys: &[f64], zs: &[f64]) -> Result<Self, MeshError> {
        for (axis, c) in [('x', xs), ('y', ys), ('z', zs)] {
            if c.len() < 2 || c.iter().any(|v| !v.is_finite()) || c.windows(2).any(|w| w[1] <= w[0]) {
                return Err(MeshError::Coordinates { axis });
            }
        }
        let shape = [xs.len(), ys.len(), zs.len()];
        let count = shape.iter().try_fold(1usize, |acc, &n| acc.checked_mul(n)).unwrap_or(usize::MAX);
        if count > MAX_NODES {
            return Err(MeshError::TooLarge { nodes: count, limit: MAX_NODES });
        }
        let mut nodes = Vec::with_capacity(count);
        for &z in zs {
            for &y in ys {
                for &x in xs {
                    nodes.push([x, y, z]);
                }
            }
        }
        let [nx, ny, nz] = shape;
        let id = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
        let mut elements = Vec::with_capacity((nx - 1) * (ny - 1) * (nz - 1));
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    elements.push([
                        id(i, j, k),
                        id(i + 1, j, k),
                        id(i + 1, j + 1, k),
                        id(i, j + 1, k),
                        id(i, j, k + 1),
                        id(i + 1, j, k + 1),
                        id(i + 1, j + 1, k + 1),
                        id(i, j + 1, k + 1),
                    ]);
                }
            }
        }
        Ok(Self { nodes, elements, shape })
    }

    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// The global DOFs (3 n + direction) of element `e`, in the order of
    /// its matrices' rows (u_a, v_a, w_a interleaved).
    pub fn element_dofs(&self, e: usize) -> [usize; 24] {
        let nodes = self.elements[e];
        std::array::from_fn(|i| 3 * nodes[i / 3] + i % 3)
    }

    /// The stiffness pattern of the free DOFs of `dofs` (3 per node).
    pub fn pattern(&self, dofs: &crate::assembly::DofMap) -> crate::assembly::Pattern {
        let element_dofs: Vec<Vec<usize>> =
            (0..self.elements.len()).map(|e| self.element_dofs(e).map(|d| dofs.free[d]).to_vec()).collect();
        crate::assembly::Pattern::from_element_dofs(dofs.n_free, &element_dofs)
    }

    /// Moves every node by `f` (the grid's topology is kept).
    pub fn map(&mut self, f: impl Fn([f64; 3]) -> [f64; 3]) {
        for p in &mut self.nodes {
            *p = f(*p);
        }
    }

    /// The element geometries, each checked (no inverted element).
    pub fn geometry(&self) -> Result<Vec<Hex8>, MeshError> {
        self.elements
            .iter()
            .enumerate()
            .map(|(e, nodes)| {
                Hex8::new(&nodes.map(|n| self.nodes[n])).map_err(|source| MeshError::Jacobian { element: e, source })
            })
            .collect()
    }

    /// The nodes on one side of the block.
    pub fn side_nodes(&self, side: Side) -> Vec<usize> {
        let [nx, ny, nz] = self.shape;
        let id = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
        let mut out = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let on = match side {
                        Side::XMin => i == 0,
                        Side::XMax => i == nx - 1,
                        Side::YMin => j == 0,
                        Side::YMax => j == ny - 1,
                        Side::ZMin => k == 0,
                        Side::ZMax => k == nz - 1,
                    };
                    if on {
                        out.push(id(i, j, k));
                    }
                }
            }
        }
        out
    }

    /// The element faces on the bottom side (z min), each as (element,
    /// its 4 nodes counter-clockwise seen from below, i.e. the outward
    /// normal pointing to -z in the reference block).
    pub fn bottom_faces(&self) -> Vec<(usize, [usize; 4])> {
        let [nx, ny, _] = self.shape;
        (0..(nx - 1) * (ny - 1))
            .map(|e| {
                let n = self.elements[e];
                (e, [n[0], n[3], n[2], n[1]])
            })
            .collect()
    }
}

/// Coordinates from 0 to `length`: spacing `h0` up to `uniform_to`, then
/// growing by `ratio` per cell, the last cell stretched or shrunk so that
/// the grid ends exactly at `length` (never below half a cell).
pub fn graded(h0: f64, uniform_to: f64, ratio: f64, length: f64) -> Vec<f64> {
    let mut c = vec![0.0];
    let mut h = h0;
    loop {
        let last = *c.last().expect("non-empty");
        if last + h >= length - 0.5 * h {
            break;
        }
        c.push(last + h);
        if last + h >= uniform_to - 1e-9 * h {
            h *= ratio;
        }
    }
    c.push(length);
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_block_has_its_nodes_elements_and_volume() {
        let m = Mesh3::block(&[0.0, 1.0, 3.0], &[0.0, 2.0], &[0.0, 0.5, 1.0, 2.0]).unwrap();
        assert_eq!(m.n_nodes(), 3 * 2 * 4);
        assert_eq!(m.elements.len(), 6); // 2 x 1 x 3
        let volume: f64 = m.geometry().unwrap().iter().map(|h| h.volume).sum();
        assert!((volume - 3.0 * 2.0 * 2.0).abs() < 1e-12);
        assert_eq!(m.side_nodes(Side::ZMin).len(), 6);
        assert_eq!(m.side_nodes(Side::XMax), vec![2, 5, 8, 11, 14, 17, 20, 23]);
        assert_eq!(m.bottom_faces().len(), 2);
        for (_, face) in m.bottom_faces() {
            assert!(face.iter().all(|&n| m.nodes[n][2] == 0.0));
        }
    }

    #[test]
    fn bad_coordinates_are_refused() {
        assert!(Mesh3::block(&[0.0], &[0.0, 1.0], &[0.0, 1.0]).is_err());
        assert!(Mesh3::block(&[0.0, 1.0, 1.0], &[0.0, 1.0], &[0.0, 1.0]).is_err());
        assert!(Mesh3::block(&[0.0, f64::NAN], &[0.0, 1.0], &[0.0, 1.0]).is_err());
        let many: Vec<f64> = (0..200).map(f64::from).collect();
        assert!(matches!(Mesh3::block(&many, &many, &many), Err(MeshError::TooLarge { .. })));
    }

    #[test]
    fn graded_coordinates_end_at_the_length() {
        let c = graded(0.1, 1.0, 1.3, 20.0);
        assert_eq!(c[0], 0.0);
        assert_eq!(*c.last().unwrap(), 20.0);
        assert!(c.windows(2).all(|w| w[1] > w[0]));
        assert!((c[1] - 0.1).abs() < 1e-15 && (c[10] - 1.0).abs() < 1e-12);
        let steps: Vec<f64> = c.windows(2).map(|w| w[1] - w[0]).collect();
        assert!((steps[9] - 0.1).abs() < 1e-12 && (steps[10] - 0.13).abs() < 1e-12);
    }
}
