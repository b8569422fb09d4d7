//! `haptex`: design the drive signals of surface haptic displays.
//!
//! Each subcommand lives in its own module under `commands/`; this file only
//! parses the command line and reports errors.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod args;
mod commands;

/// Design the drive signals of surface haptic displays: friction profiles in,
/// electrovibration voltages out.
#[derive(Debug, Parser)]
#[command(name = "haptex", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Voltage(commands::voltage::VoltageArgs),
    Cae(commands::cae::CaeArgs),
    Play(commands::play::PlayArgs),
    Live(commands::live::LiveArgs),
    Library(commands::library::LibraryArgs),
    Simulate(commands::simulate::SimulateArgs),
    Check(commands::check::CheckArgs),
    Compensate(commands::compensate::CompensateArgs),
    Db(commands::db::DbArgs),
    Predict(commands::predict::PredictArgs),
    Serve(commands::serve::ServeArgs),
    ForceCurve(commands::force_curve::ForceCurveArgs),
    Map(commands::map::MapArgs),
    Recipe(commands::recipe::RecipeArgs),
    Calibrate(commands::calibrate::CalibrateArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Voltage(args) => commands::voltage::run(args),
        Command::Cae(args) => commands::cae::run(args),
        Command::Play(args) => commands::play::run(args),
        Command::Live(args) => commands::live::run(args),
        Command::Library(args) => commands::library::run(args),
        Command::Simulate(args) => commands::simulate::run(args),
        Command::Check(args) => commands::check::run(args),
        Command::Compensate(args) => commands::compensate::run(args),
        Command::Db(args) => commands::db::run(args),
        Command::Predict(args) => commands::predict::run(args),
        Command::Serve(args) => commands::serve::run(args),
        Command::ForceCurve(args) => commands::force_curve::run(args),
        Command::Map(args) => commands::map::run(args),
        Command::Recipe(args) => commands::recipe::run(args),
        Command::Calibrate(args) => commands::calibrate::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {}", describe(&error));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, as anyhow's `{:#}` prints them, but without a
/// cause whose text the message already contains (an error that formats
/// its source and also returns it from `source()` would print it twice).
fn describe(error: &anyhow::Error) -> String {
    let mut text = error.to_string();
    for cause in error.chain().skip(1) {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            text.push_str(": ");
            text.push_str(&cause);
        }
    }
    text
}
