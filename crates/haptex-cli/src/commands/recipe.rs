//! `haptex recipe run`: replays a recipe the web application wrote (its
//! *recipe* download) to the same files, byte for byte.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use haptex_server::recipe::{Recipe, replay};
use haptex_server::{AppState, Limits};

/// Recipes: a design of the web application written down as the API
/// requests of its downloads (docs/web.md, "Recipes").
#[derive(Debug, Args)]
pub struct RecipeArgs {
    #[command(subcommand)]
    command: RecipeCommand,
}

#[derive(Debug, Subcommand)]
enum RecipeCommand {
    Run(RunArgs),
}

/// Write every download of a recipe into a directory, byte for byte what
/// the web application gave.
///
/// Each download is answered by the web application's own code, in
/// process (no server is started). The recipe's haptex version and the
/// SHA-256 of the texture library and FE database it was made with must
/// be this haptex's and these files' (else nothing is written and the
/// error names the recipe's field).
#[derive(Debug, Args)]
#[command(after_help = "Example:\n  haptex recipe run haptex-recipe.json -o replay/")]
struct RunArgs {
    /// The recipe (JSON, the GUI's *recipe* download).
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// Directory to write the files into (created if missing).
    #[arg(short = 'o', long = "out", value_name = "DIR")]
    out: PathBuf,
    /// Texture library (default: $HAPTEX_LIBRARY, else the shipped one).
    #[arg(long, value_name = "PATH")]
    library: Option<PathBuf>,
    /// FE database (default: $HAPTEX_DB, else the shipped data/db).
    #[arg(long, value_name = "DIR")]
    db: Option<PathBuf>,
}

pub fn run(args: RecipeArgs) -> anyhow::Result<()> {
    let RecipeCommand::Run(args) = args.command;
    let text = std::fs::read_to_string(&args.file).with_context(|| format!("reading {}", args.file.display()))?;
    let recipe = Recipe::parse(&text).with_context(|| format!("{}", args.file.display()))?;
    let library = args.library.unwrap_or_else(super::library::default_db);
    let db = args.db.unwrap_or_else(super::db::default_db);
    let state = AppState::new(library.is_file().then_some(library.as_path()), Limits::DEFAULT)?;
    let state = if db.join("metadata.json").is_file() { state.with_database(&db)? } else { state };
    let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    let files = runtime
        .block_on(replay(state, &recipe))
        .with_context(|| format!("{}: cannot replay it", args.file.display()))?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    for (name, bytes) in files {
        let path = args.out.join(&name);
        std::fs::write(&path, &bytes).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("{}: {} bytes", path.display(), bytes.len());
    }
    Ok(())
}
