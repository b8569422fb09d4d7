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
//! presses it onto a flat).

pub mod body;
pub mod condensed;
pub mod contact;
pub mod extrude;
pub mod fingertip;
pub mod friction;
pub mod hex8;
pub mod mesh;
pub mod output;
pub mod slide;
pub mod solver;
pub mod surface;
