//! haptex-fem: a 2D plane-strain finite-element model of a human finger pad
//! pressed onto a rigid surface and slid over it (the paper's section 2.4,
//! Fig. 1), built to be fast enough to run on demand.
//!
//! Reading order: [`material`] (elastic and Prony visco-elastic tissue),
//! [`element`] (the B-bar quadrilateral), [`mesh`] and [`ring`] (the mesh and
//! its generator).

// Numeric kernels index several arrays with one loop variable; iterator
// chains would hide the maths they mirror.
#![allow(clippy::needless_range_loop)]

pub mod analytic;
pub mod assembly;
pub mod body;
pub mod contact;
pub mod display;
pub mod drawing;
pub mod element;
pub mod finger;
pub mod finite_element;
pub mod finite_solver;
pub mod grating;
pub mod held_out;
pub mod hyperelastic;
pub mod lanes;
pub mod linalg;
pub mod loo_case;
pub mod material;
pub mod mesh;
pub mod output;
pub mod refine;
pub mod render;
pub mod ring;
pub mod scenario;
pub mod solid3d;
pub mod solver;
pub mod statics;
pub mod surface;
pub mod sweep;
