//! Degrees of freedom and the sparse stiffness pattern.
//!
//! Each node has two displacement DOFs (x, y), global DOF 2n and 2n+1.
//! Prescribed DOFs (driven boundaries, symmetry constraints) are removed;
//! the free DOFs are numbered 0..n_free. The pattern of the free-free
//! stiffness (lower triangle, compressed sparse columns) is computed once
//! with, for every element, the slot of each of its matrix entries, so that
//! re-assembling for a new time step only writes values (faer's advice:
//! analyse the pattern once, refactor many times).

/// Marker for a prescribed DOF in the free numbering.
pub const PRESCRIBED: usize = usize::MAX;

/// The vector over the free unknowns (`n_free` of them) whose entry at the
/// free index of each free global DOF d is `value(d)`; `free` maps global
/// DOFs to free indices or [`PRESCRIBED`].
pub fn free_entries(free: &[usize], n_free: usize, value: impl Fn(usize) -> f64) -> Vec<f64> {
    let mut out = vec![0.0; n_free];
    for (d, &f) in free.iter().enumerate() {
        if f != PRESCRIBED {
            out[f] = value(d);
        }
    }
    out
}

/// The free numbering of the global DOFs.
#[derive(Debug, Clone, PartialEq)]
pub struct DofMap {
    /// Free index of each global DOF, or [`PRESCRIBED`].
    pub free: Vec<usize>,
    pub n_free: usize,
}

impl DofMap {
    /// Numbers the DOFs of `n_nodes` nodes, leaving out those in `prescribed`.
    pub fn new(n_nodes: usize, prescribed: &[usize]) -> Self {
        Self::with_dofs_per_node(n_nodes, 2, prescribed)
    }

    /// Numbers the DOFs of `n_nodes` nodes of `per_node` DOFs each (3 in
    /// the 3D model: global DOF per_node n + direction), leaving out those
    /// in `prescribed`.
    pub fn with_dofs_per_node(n_nodes: usize, per_node: usize, prescribed: &[usize]) -> Self {
        let mut free = vec![0; per_node * n_nodes];
        for &d in prescribed {
            free[d] = PRESCRIBED;
        }
        let mut n_free = 0;
        for f in free.iter_mut() {
            if *f != PRESCRIBED {
                *f = n_free;
                n_free += 1;
            }
        }
        Self { free, n_free }
    }

    /// Global DOFs of an element's nodes (u_a, v_a interleaved).
    pub fn element_dofs(nodes: &[usize; 4]) -> [usize; 8] {
        std::array::from_fn(|i| 2 * nodes[i / 2] + i % 2)
    }

    pub fn is_free(&self, global: usize) -> bool {
        self.free[global] != PRESCRIBED
    }
}

/// Lower-triangular CSC pattern of the free-free stiffness, with the value
/// slot of each element entry (i >= j in free numbering, local indices).
#[derive(Debug, Clone)]
pub struct Pattern {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    /// For each element, `(local i, local j, slot)` of its lower entries.
    pub slots: Vec<Vec<(u8, u8, usize)>>,
}

impl Pattern {
    /// The pattern of the elements listed in `elements` (others contribute nothing).
    pub fn new(dofs: &DofMap, element_nodes: &[[usize; 4]], elements: &[usize]) -> Self {
        let mut element_dofs = vec![Vec::new(); element_nodes.len()];
        for &e in elements {
            element_dofs[e] = DofMap::element_dofs(&element_nodes[e]).map(|d| dofs.free[d]).to_vec();
        }
        Self::from_element_dofs(dofs.n_free, &element_dofs)
    }

    /// The pattern of `n` free DOFs coupled by elements whose DOFs, in the
    /// order of their matrices' rows, are `element_dofs[e]` (free indices,
    /// or [`PRESCRIBED`]; an empty list for an element that contributes
    /// nothing). Any number of DOFs per element up to 256 (the 3D
    /// hexahedron has 24).
    pub fn from_element_dofs(n: usize, element_dofs: &[Vec<usize>]) -> Self {
        // Column -> sorted row set, built from element couplings.
        let mut columns: Vec<Vec<usize>> = vec![Vec::new(); n];
        for g in element_dofs {
            assert!(g.len() <= 256, "an element has at most 256 DOFs");
            for &i in g {
                for &j in g {
                    if i != PRESCRIBED && j != PRESCRIBED && i >= j {
                        columns[j].push(i);
                    }
                }
            }
        }
        // Every free DOF keeps its diagonal, even if no element touches it
        // (the assembly then reports a singular matrix instead of panicking).
        for (j, column) in columns.iter_mut().enumerate() {
            column.push(j);
            column.sort_unstable();
            column.dedup();
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for column in &columns {
            row_idx.extend_from_slice(column);
            col_ptr.push(row_idx.len());
        }
        let mut slots = vec![Vec::new(); element_dofs.len()];
        for (e, g) in element_dofs.iter().enumerate() {
            for (li, &i) in g.iter().enumerate() {
                for (lj, &j) in g.iter().enumerate() {
                    if i != PRESCRIBED && j != PRESCRIBED && i >= j {
                        let range = col_ptr[j]..col_ptr[j + 1];
                        let offset = row_idx[range.clone()].binary_search(&i).expect("entry is in the pattern");
                        slots[e].push((li as u8, lj as u8, range.start + offset));
                    }
                }
            }
        }
        Self { n, col_ptr, row_idx, slots }
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// The value slot of entry (i, j) or (j, i) of the lower triangle, if
    /// the pattern has it.
    pub fn slot(&self, i: usize, j: usize) -> Option<usize> {
        let (row, col) = if i >= j { (i, j) } else { (j, i) };
        let range = self.col_ptr[col]..self.col_ptr[col + 1];
        self.row_idx[range.clone()].binary_search(&row).ok().map(|offset| range.start + offset)
    }

    /// Adds an element matrix into `values`.
    pub fn add_element<const N: usize>(&self, e: usize, k: &[[f64; N]; N], values: &mut [f64]) {
        for &(i, j, slot) in &self.slots[e] {
            values[slot] += k[i as usize][j as usize];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pattern_of_two_elements_with_a_fixed_node() {
        // 0-1-2 / 3-4-5 strip of two elements, node 0 fixed in x and y.
        let elements = [[0, 1, 4, 3], [1, 2, 5, 4]];
        let dofs = DofMap::new(6, &[0, 1]);
        assert_eq!(dofs.n_free, 10);
        let p = Pattern::new(&dofs, &elements, &[0, 1]);
        // Column of free DOF 0 (node 1, x): couples with nodes 1,2,3,4,5 both
        // directions at rows >= 0: all 10 free rows.
        assert_eq!(p.col_ptr[1] - p.col_ptr[0], 10);
        // Every column starts with its diagonal.
        for j in 0..p.n {
            assert_eq!(p.row_idx[p.col_ptr[j]], j);
        }
    }
}
