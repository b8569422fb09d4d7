//! One module per `haptex` subcommand.

pub mod cae;
pub mod calibrate;
pub mod check;
pub mod compensate;
pub mod db;
pub mod force_curve;
pub mod library;
pub mod live;
pub mod map;
pub mod play;
pub mod predict;
pub mod recipe;
pub mod serve;
pub mod simulate;
pub mod voltage;
