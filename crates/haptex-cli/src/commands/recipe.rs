//! `haptex recipe run`: replays a recipe the web application wrote (its
//! *recipe* download) to the same files, byte for byte.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use haptex_core::io::OutputDir;
use haptex_core::text::Quoted;
use haptex_server::recipe::{Recipe, answers};
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
/// error names the recipe's field). A recipe must pin every data set used
/// here (library_sha256 when a library is found, database_sha256 when an
/// FE database is): one without the field, or with null, is refused unless
/// --allow-unpinned. A recipe made with a device file (`haptex serve
/// --device-file`) replays only with a file of its SHA-256 (the path it
/// records, or --device-file). The files may hold 64 MiB together, checked on each
/// play's request (duration x sample rate x channels) before anything is
/// answered.
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
    /// Replay a recipe that does not pin a data set used here (no
    /// library_sha256 or database_sha256, or null) with the data found
    /// here; what was not checked is printed on stderr. The files may then
    /// differ from the ones the recipe was made from.
    #[arg(long)]
    allow_unpinned: bool,
    /// The device file the recipe was made with (`haptex serve
    /// --device-file`; default: the path the recipe records). Its SHA-256
    /// must be the recipe's `device_file_sha256`.
    #[arg(long, value_name = "FILE")]
    device_file: Option<PathBuf>,
}

pub fn run(args: RecipeArgs) -> anyhow::Result<()> {
    let RecipeCommand::Run(args) = args.command;
    // A recipe is a few kB of JSON; 16 MiB bounds what a wrong file costs.
    const MAX_RECIPE_BYTES: u64 = 16 << 20;
    let bytes = haptex_core::io::read_file_bounded(&args.file, MAX_RECIPE_BYTES).map_err(|e| match e {
        haptex_core::io::BoundedReadError::TooLarge { .. } => {
            anyhow::anyhow!("{}: larger than {} MiB, not a recipe", args.file.display(), MAX_RECIPE_BYTES >> 20)
        }
        e => anyhow::Error::new(e).context(format!("reading {}", args.file.display())),
    })?;
    let text =
        String::from_utf8(bytes).with_context(|| format!("{}: not UTF-8 text, not a recipe", args.file.display()))?;
    let recipe = Recipe::parse(&text).with_context(|| format!("{}", args.file.display()))?;
    let library = args.library.unwrap_or_else(super::library::default_db);
    let db = args.db.unwrap_or_else(super::db::default_db);
    let state = AppState::new(library.is_file().then_some(library.as_path()), Limits::DEFAULT)?;
    let state = if db.join("metadata.json").is_file() { state.with_database(&db)? } else { state };
    // The device file: as given, else where the recipe says it was, when it pins one.
    let device_file = args
        .device_file
        .or_else(|| recipe.device_file_sha256.as_ref().and_then(|_| recipe.device_file.as_ref().map(PathBuf::from)));
    let state = match device_file {
        Some(path) => {
            let file = crate::args::read_device_file(&path)
                .with_context(|| format!("{}: the device file it was made with", args.file.display()))?;
            state.with_default_device(crate::args::server_default(&file)?)
        }
        None => state,
    };
    let unpinned = recipe
        .check(&state, args.allow_unpinned)
        .with_context(|| format!("{}: cannot replay it", args.file.display()))?;
    for line in &unpinned.0 {
        eprintln!("warning: {line} (--allow-unpinned)");
    }
    let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    let files = runtime
        .block_on(answers(state, &recipe))
        .with_context(|| format!("{}: cannot replay it", args.file.display()))?;
    // Every answer is in hand before anything is written; two downloads of
    // one name would overwrite each other.
    let mut names = std::collections::HashSet::new();
    if let Some((name, _)) = files.iter().find(|(name, _)| !names.insert(name.as_str())) {
        anyhow::bail!("{}: two downloads are both named {}", args.file.display(), Quoted(name));
    }
    // Each file is checked inside the directory (its name, and no link
    // leading out) before the first is written.
    let out = OutputDir::create(&args.out)?;
    for (name, _) in &files {
        out.member(name)?;
    }
    for (name, bytes) in files {
        let path = out.write(&name, |w| w.write_all(&bytes))?;
        eprintln!("{}: {} bytes", path.display(), bytes.len());
    }
    Ok(())
}
