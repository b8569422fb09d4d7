//! Flag value parsers and output helpers shared by the subcommands.

use std::io::Write;
use std::path::{Component, Path, PathBuf};

use anyhow::Context;

/// Parses a positive, finite number (for physical constants and limits).
pub fn positive(text: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|_| format!("'{text}' is not a number"))?;
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(format!("must be a positive finite number, got {text}"))
    }
}

/// Parses a finite number >= 0 (a length that may be zero).
pub fn non_negative(text: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|_| format!("'{text}' is not a number"))?;
    if value.is_finite() && value >= 0.0 { Ok(value) } else { Err(format!("must be a finite number >= 0, got {text}")) }
}

/// A flag parser for a parameter with an accepted range (the table of
/// [`haptex_core::ranges`], shared with the web API): a finite number in
/// (0, max].
pub fn in_range(range: haptex_core::ranges::Range) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |text: &str| {
        let value: f64 = text.trim().parse().map_err(|_| format!("'{text}' is not a number"))?;
        range.check(value).map_err(|e| e.to_string())
    }
}

/// Where a command writes its main output: a file (written atomically) or stdout.
#[derive(Debug, Clone)]
pub enum Output {
    Stdout,
    File(PathBuf),
}

impl Output {
    pub fn new(path: Option<PathBuf>) -> Self {
        match path {
            Some(p) if p.as_os_str() != "-" => Output::File(p),
            _ => Output::Stdout,
        }
    }

    pub fn path(&self) -> Option<&Path> {
        match self {
            Output::File(p) => Some(p),
            Output::Stdout => None,
        }
    }

    /// Writes the content produced by `fill`.
    pub fn write<F>(&self, fill: F) -> anyhow::Result<()>
    where
        F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
    {
        match self {
            Output::File(path) => Ok(haptex_core::io::write_atomic(path, fill)?),
            Output::Stdout => {
                let stdout = std::io::stdout();
                let mut lock = std::io::BufWriter::with_capacity(1 << 16, stdout.lock());
                fill(&mut lock).and_then(|()| lock.flush()).context("cannot write to stdout")
            }
        }
    }
}

/// Reads a profile from a path, or from stdin when the path is `-`.
pub fn read_profile(path: &Path) -> anyhow::Result<haptex_core::FrictionProfile> {
    use haptex_core::FrictionProfile;
    Ok(if path.as_os_str() == "-" {
        FrictionProfile::read_csv(std::io::stdin().lock(), "<stdin>")?
    } else {
        FrictionProfile::read_csv_file(path)?
    })
}

/// A shipped data file or directory: the path in environment variable
/// `env_var` if set, else `relative` (e.g. `data/db`) in this source tree.
pub fn shipped_data(env_var: &str, relative: &str) -> PathBuf {
    if let Some(path) = std::env::var_os(env_var) {
        return PathBuf::from(path);
    }
    normalize(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(relative))
}

/// Removes `.` and `..` components lexically (for readable messages).
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::ParentDir if out.file_name().is_some() => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}
