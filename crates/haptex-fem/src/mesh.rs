//! The finite-element mesh: nodes, 4-node elements with a subdomain tag,
//! and the boundary loops the model drives and puts in contact.

use haptex_core::num::Num;

use crate::element::{JacobianError, Q4};

/// A 2D mesh of 4-node quadrilaterals (nodes counter-clockwise, mm).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    pub nodes: Vec<[f64; 2]>,
    pub elements: Vec<[usize; 4]>,
    /// Subdomain (material) index of each element.
    pub subdomain: Vec<u8>,
    /// The outer boundary as a closed loop of node indices, counter-clockwise.
    pub outer: Vec<usize>,
    /// The inner boundary (for a ring mesh) as a closed loop, counter-clockwise.
    pub inner: Vec<usize>,
}

/// A mesh is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    // The cause is part of the message, not also a `source()`: a caller
    // printing the chain (anyhow's {:#}) would print it twice.
    #[error("element {element}: {cause}")]
    Jacobian { element: usize, cause: JacobianError },
    #[error("element {element} refers to node {node}, but the mesh has {n_nodes} nodes")]
    BadNode { element: usize, node: usize, n_nodes: usize },
    #[error("mesh generation failed: element {element} near ({}, {}) mm is inverted: {cause}", Num(at[0]), Num(at[1]))]
    Inverted {
        element: usize,
        /// The element's centroid (mm).
        at: [f64; 2],
        cause: JacobianError,
    },
    #[error("mesh generation failed: {0}")]
    Generation(String),
}

/// Shape statistics of a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshQuality {
    /// Largest ratio of longest to shortest element edge.
    pub max_aspect_ratio: f64,
    /// Smallest ratio of min to max det J over an element's Gauss points.
    pub min_jacobian_ratio: f64,
}

impl Mesh {
    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    pub fn n_elements(&self) -> usize {
        self.elements.len()
    }

    /// Coordinates of an element's nodes.
    pub fn element_coords(&self, e: usize) -> [[f64; 2]; 4] {
        self.elements[e].map(|n| self.nodes[n])
    }

    /// Geometry of every element, checking that none is inverted.
    pub fn geometry(&self) -> Result<Vec<Q4>, MeshError> {
        self.elements
            .iter()
            .enumerate()
            .map(|(e, nodes)| {
                if let Some(&node) = nodes.iter().find(|&&n| n >= self.nodes.len()) {
                    return Err(MeshError::BadNode { element: e, node, n_nodes: self.nodes.len() });
                }
                Q4::new(&self.element_coords(e)).map_err(|cause| MeshError::Jacobian { element: e, cause })
            })
            .collect()
    }

    /// Aspect ratio and Jacobian uniformity of the worst elements.
    pub fn quality(&self, geometry: &[Q4]) -> MeshQuality {
        let mut max_aspect_ratio: f64 = 1.0;
        let mut min_jacobian_ratio: f64 = 1.0;
        for (e, q) in geometry.iter().enumerate() {
            let x = self.element_coords(e);
            let edges: Vec<f64> = (0..4).map(|i| distance(x[i], x[(i + 1) % 4])).collect();
            let longest = edges.iter().cloned().fold(0.0, f64::max);
            let shortest = edges.iter().cloned().fold(f64::INFINITY, f64::min);
            max_aspect_ratio = max_aspect_ratio.max(longest / shortest);
            let (lo, hi) = q.weight.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &w| (lo.min(w), hi.max(w)));
            min_jacobian_ratio = min_jacobian_ratio.min(lo / hi);
        }
        MeshQuality { max_aspect_ratio, min_jacobian_ratio }
    }

    /// Nodes of all elements in subdomains for which `select` is true.
    pub fn nodes_of_subdomains(&self, select: impl Fn(u8) -> bool) -> Vec<usize> {
        let mut flag = vec![false; self.nodes.len()];
        for (e, nodes) in self.elements.iter().enumerate() {
            if select(self.subdomain[e]) {
                for &n in nodes {
                    flag[n] = true;
                }
            }
        }
        (0..self.nodes.len()).filter(|&n| flag[n]).collect()
    }
}

pub fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}
