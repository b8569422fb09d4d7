//! haptex core: friction profiles, the electrovibration mapping of the
//! paper (eqs. 3-9), ultrasonic friction reduction and the combined
//! display, and the file formats every haptex command shares.
//!
//! Units follow `docs/file-formats.md`: positions in mm, forces in N,
//! voltages in V (RMS), and every field that carries a unit names it.

pub mod arg_names;
pub mod buffer;
pub mod cae;
pub mod calibration;
pub mod combined;
pub mod crests;
pub mod database;
pub mod electrovibration;
pub mod frequency;
pub mod grid;
pub mod height;
pub mod ilc;
pub mod io;
pub mod library;
pub mod live;
pub mod map;
pub mod name;
pub mod num;
pub mod planar;
pub mod profile;
pub mod ranges;
pub mod recording;
pub mod relative;

pub use electrovibration::{Device, Method, VoltageProfile, VoltageSummary, map_profile, map_profile_relative};
pub use profile::{FrictionProfile, ProfileError};
pub mod plot;
pub mod realtime;
pub mod signal;
pub mod text;
pub mod trajectory;
pub mod ultrasonic;
