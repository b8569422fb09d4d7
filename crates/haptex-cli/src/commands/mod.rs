//! One module per `haptex` subcommand.

pub mod play;
pub mod voltage;
