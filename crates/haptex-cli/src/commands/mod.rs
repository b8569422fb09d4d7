//! One module per `haptex` subcommand.

pub mod cae;
pub mod play;
pub mod library;
pub mod voltage;
