//! One module per `haptex` subcommand.

pub mod cae;
pub mod check;
pub mod db;
pub mod library;
pub mod live;
pub mod play;
pub mod predict;
pub mod serve;
pub mod simulate;
pub mod voltage;
