//! One module per `haptex` subcommand.

pub mod voltage;
