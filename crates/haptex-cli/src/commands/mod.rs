//! One module per `haptex` subcommand.

pub mod cae;
pub mod voltage;
