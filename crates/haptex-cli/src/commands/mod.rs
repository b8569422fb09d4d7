//! One module per `haptex` subcommand.

pub mod library;
pub mod voltage;
