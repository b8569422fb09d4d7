//! The 3D finger pad's building blocks (issue 39), each validated before
//! the next is built on it: the trilinear hexahedron with the 2D model's
//! B-bar treatment ([`hex8`]), the structured hexahedral mesh ([`mesh`]),
//! contact points on the skin's faces ([`contact`]), the penalty contact
//! of an elastic body with a rigid plane, frictionless or with Coulomb
//! friction in both tangential directions ([`solver`]), checked against
//! Hertz's sphere on a flat (tests/hertz_sphere.rs) and Cattaneo-Mindlin's
//! partial slip (tests/cattaneo_mindlin_sphere.rs), and
//! the visco-elastic body of several materials with the 2D model's Prony
//! series ([`body`]; tests/prony_relaxation_3d.rs), and the fingertip's
//! layered ellipsoidal cap ([`fingertip`]; examples/contact_area_3d.rs
//! presses it onto a flat). At finite strain: the total-Lagrangian
//! neo-Hookean hexahedron ([`finite_hex8`]; tests/finite_strain_element_3d.rs)
//! and the body of several visco-elastic materials solved by Newton's
//! method ([`finite_body`]; tests/finite_strain_body_3d.rs against closed
//! forms, tests/calculix_reference_3d_nlgeom.rs against CalculiX's NLGEOM).

pub mod body;
pub mod condensed;
pub mod contact;
pub mod extrude;
pub mod fingertip;
pub mod finite_body;
pub mod finite_contact;
pub mod finite_hex8;
pub mod friction;
pub mod hex8;
pub mod mesh;
pub mod output;
pub mod slide;
pub mod solver;
pub mod surface;
