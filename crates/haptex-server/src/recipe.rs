//! Recipes: a design written down as the API requests that made its
//! downloads, so that `haptex recipe run` replays it on the command line
//! to byte-identical files.
//!
//! A recipe is the JSON the GUI's *recipe* download writes:
//!
//! ```json
//! {
//!   "format": "haptex-recipe/1",
//!   "haptex_version": "0.1.0",
//!   "library_sha256": "…", "database_sha256": "…",
//!   "source": { "kind": "template", … },
//!   "page": { "source": "template", "template": { … }, "method": "normalized", … },
//!   "downloads": [
//!     { "file": "voltage.csv", "method": "POST", "path": "/api/voltage?format=csv", "body": { … } },
//!     …
//!   ]
//! }
//! ```
//!
//! `source` is the provenance as the page states it (the template's
//! parameters, the material and stroke seed, the file name), `page` the
//! page's controls (how the page reopens the design); the requests
//! carry everything the answers are computed from (the profile's points
//! included). [`replay`] answers each request with this server's own
//! router, in process: the code that builds a download in the browser and
//! on the command line is one and the same, so the bytes are too, as long
//! as the haptex version and the data (library, FE database: their
//! SHA-256 in the recipe) are the same, which [`replay`] checks first
//! ([`Recipe::check`]: every data set served must be pinned). A download's
//! `file` is a name by the one rule of [`haptex_core::name`].

use axum::body::Body;
use axum::http::{Method, Request, StatusCode, header};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use tower::ServiceExt;

use crate::state::AppState;

/// The `format` of the recipes this haptex writes and replays.
pub const FORMAT: &str = "haptex-recipe/1";

/// At most this many downloads in one recipe.
pub const MAX_DOWNLOADS: usize = 32;

/// The most bytes a recipe's files may hold together (64 MiB; the page's
/// recipe is a profile, its voltage as CSV and JSON, a stroke's WAV and
/// its sidecar: a few MB). The recipe's memory budget: [`replay`] holds
/// every file until the last is answered. Checked before any download is
/// answered, on each play's answer estimated from its request (duration x
/// sample rate x channels x bytes per sample), and again as each answer is
/// read.
pub const MAX_OUTPUT_BYTES: usize = 64 << 20;

/// A design as the requests of its downloads (see the module docs).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    pub format: String,
    pub haptex_version: String,
    #[serde(default)]
    pub library_sha256: Option<String>,
    #[serde(default)]
    pub database_sha256: Option<String>,
    /// The device file the server's default device came from (`haptex
    /// serve --device-file`): its path as served, and the SHA-256 of its
    /// bytes. A replay needs a device file of that SHA-256.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device_file: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub device_file_sha256: Option<String>,
    /// Provenance as the page states it (not used to compute anything).
    #[serde(default)]
    pub source: Value,
    /// The page's design: its controls (the source and its parameters,
    /// method and mapping, display, device, playback), so that the page
    /// reopens the recipe as it was designed (a template with its sliders,
    /// eq. 8 beside eq. 9); docs/web.md, "Recipes". Not used to compute
    /// anything: the replay answers the downloads' requests alone. A JSON
    /// object when present (recipes of older pages have none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub page: Option<serde_json::Map<String, Value>>,
    pub downloads: Vec<Download>,
}

/// One download: the file it is saved as and the API request that answers it.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Download {
    /// File name (no directory): `voltage.csv`, `stroke-50mm_s.wav`, ...
    pub file: String,
    /// `GET` or `POST`.
    pub method: String,
    /// An `/api/` path with its query.
    pub path: String,
    /// The JSON body of a POST.
    #[serde(default)]
    pub body: Option<Value>,
}

/// Why a recipe cannot be replayed; `field` names the recipe's field.
#[derive(Debug, thiserror::Error)]
#[error("{field}: {message}")]
pub struct RecipeError {
    pub field: String,
    pub message: String,
}

fn error(field: impl Into<String>, message: impl Into<String>) -> RecipeError {
    RecipeError { field: field.into(), message: message.into() }
}

impl Recipe {
    /// Reads a recipe (JSON), checking its format and its downloads' names
    /// and requests.
    pub fn parse(text: &str) -> Result<Self, RecipeError> {
        let recipe: Recipe = serde_json::from_str(text).map_err(|e| error("recipe", e.to_string()))?;
        if recipe.format != FORMAT {
            return Err(error("format", format!("{:?} is not {FORMAT:?}", recipe.format)));
        }
        if recipe.downloads.is_empty() || recipe.downloads.len() > MAX_DOWNLOADS {
            return Err(error("downloads", format!("1 to {MAX_DOWNLOADS} downloads, not {}", recipe.downloads.len())));
        }
        for (i, d) in recipe.downloads.iter().enumerate() {
            // The file is written into the replay's directory: a name by the
            // one rule, no directory.
            if let Err(e) = haptex_core::name::check_name(&d.file) {
                return Err(error(format!("downloads[{i}].file"), format!("{e}: a plain file name, no directory")));
            }
            if !d.path.starts_with("/api/") {
                return Err(error(format!("downloads[{i}].path"), "an /api/ path"));
            }
            match (d.method.as_str(), &d.body) {
                ("GET", None) | ("POST", Some(_)) => {}
                _ => return Err(error(format!("downloads[{i}].method"), "GET without a body or POST with one")),
            }
        }
        Ok(recipe)
    }

    /// Checks that this haptex and the data served are the recipe's: the
    /// haptex version (which fixes the code and the finger model compiled
    /// into it), and the SHA-256 of every data set the replay serves (the
    /// texture library, the FE database). Each data set served must be
    /// pinned by the recipe, since the answers depend on it (a library
    /// stroke, a template's prediction, and the data's SHA-256 written into
    /// the voltage downloads' recipe comments and the WAV sidecar): a
    /// recipe without the field (or with `null`) is refused, unless
    /// `allow_unpinned`, when the answer lists what was not checked.
    pub fn check(&self, state: &AppState, allow_unpinned: bool) -> Result<Unpinned, RecipeError> {
        let version = env!("CARGO_PKG_VERSION");
        if self.haptex_version != version {
            return Err(error(
                "haptex_version",
                format!("the recipe was made by haptex {}, this is {version}", self.haptex_version),
            ));
        }
        let library_sha256 = state.library_sha256();
        let mut unpinned = Unpinned::default();
        for (field, what, want, have) in [
            ("library_sha256", "texture library", &self.library_sha256, library_sha256.as_deref()),
            ("database_sha256", "FE database", &self.database_sha256, state.database_sha256()),
        ] {
            match (want, have) {
                (Some(want), have) if have != Some(want.as_str()) => {
                    return Err(error(
                        field,
                        format!(
                            "the recipe was made with data of SHA-256 {}, this has {}",
                            haptex_core::text::Quoted(want),
                            have.unwrap_or("none")
                        ),
                    ));
                }
                (Some(_), _) | (None, None) => {}
                (None, Some(have)) if allow_unpinned => unpinned.0.push(format!(
                    "{field}: the recipe does not pin the {what}; replayed with the one served here (SHA-256 {have}), \
                     not checked"
                )),
                (None, Some(have)) => {
                    return Err(error(
                        field,
                        format!(
                            "missing (or null): the answers depend on the {what}, and the recipe does not say which \
                             it was made with (this one's SHA-256 is {have}); add the field, or replay without the \
                             check (haptex recipe run --allow-unpinned)"
                        ),
                    ));
                }
            }
        }
        self.check_device_file(state)?;
        Ok(unpinned)
    }

    /// The device file: a recipe made with one replays only with a file
    /// of the same SHA-256 (the designs' defaults are its constants), and
    /// one made without only without.
    fn check_device_file(&self, state: &AppState) -> Result<(), RecipeError> {
        let have = state.default_device().file.as_ref();
        match (&self.device_file_sha256, have) {
            (None, None) => Ok(()),
            (Some(want), Some(have)) if *want == have.sha256 => Ok(()),
            (Some(want), have) => Err(error(
                "device_file_sha256",
                format!(
                    "the recipe was made with device file {} of SHA-256 {want}, {}: replay it with that file (haptex \
                     recipe run --device-file FILE)",
                    self.device_file.as_deref().unwrap_or("(path not recorded)"),
                    match have {
                        Some(have) => format!("and {} has SHA-256 {}", have.path, have.sha256),
                        None => "and no device file is given".to_string(),
                    }
                ),
            )),
            (None, Some(have)) => Err(error(
                "device_file_sha256",
                format!(
                    "missing: the recipe was made without a device file, and {} is given; replay it without one",
                    have.path
                ),
            )),
        }
    }
}

/// What [`Recipe::check`] did not check (with `allow_unpinned`): one line
/// per data set the recipe does not pin; empty when everything was.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Unpinned(pub Vec<String>);

impl Recipe {
    /// Checks the recipe's files against [`MAX_OUTPUT_BYTES`] before any
    /// download is answered: each play's answer estimated from its request
    /// (checked as `POST /api/play` checks it); the error names the first
    /// download that passes the budget.
    pub fn check_budget(&self, limits: &crate::Limits) -> Result<(), RecipeError> {
        let mut total = 0.0;
        for (i, d) in self.downloads.iter().enumerate() {
            let (Some(body), Some("/api/play")) = (&d.body, d.path.split('?').next()) else { continue };
            let bytes = serde_json::to_vec(body).map_err(|e| error(format!("downloads[{i}].body"), e.to_string()))?;
            let answer = crate::api::play::answer_bytes(&bytes, limits).map_err(|e| {
                let field = e
                    .field
                    .as_deref()
                    .map_or_else(|| format!("downloads[{i}].body"), |f| format!("downloads[{i}].body.{f}"));
                error(field, e.message)
            })?;
            total += answer;
            if total > MAX_OUTPUT_BYTES as f64 {
                return Err(error(
                    format!("downloads[{i}]"),
                    format!(
                        "this play's answer of about {} MiB brings the recipe's files to about {} MiB, more than the \
                         {} MiB a recipe may write",
                        haptex_core::num::Num((answer / f64::from(1 << 20)).ceil()),
                        haptex_core::num::Num((total / f64::from(1 << 20)).ceil()),
                        MAX_OUTPUT_BYTES >> 20
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The files of a recipe's downloads, each answered by the server's router
/// (`crate::app`) as the page's download is: (file name, bytes). The
/// recipe is checked first ([`Recipe::check`]).
pub async fn replay(state: AppState, recipe: &Recipe) -> Result<Vec<(String, Vec<u8>)>, RecipeError> {
    recipe.check(&state, false)?;
    answers(state, recipe).await
}

/// The files of a recipe's downloads without [`Recipe::check`]: the caller
/// checked it (with `allow_unpinned`, and reports what was not pinned).
/// The memory budget ([`Recipe::check_budget`]) is checked here, before
/// the first download is answered, and each answer is read within what is
/// left of it.
pub async fn answers(state: AppState, recipe: &Recipe) -> Result<Vec<(String, Vec<u8>)>, RecipeError> {
    recipe.check_budget(state.limits())?;
    let mut remaining = MAX_OUTPUT_BYTES;
    let app = crate::app(state);
    let mut files = Vec::with_capacity(recipe.downloads.len());
    for (i, d) in recipe.downloads.iter().enumerate() {
        let method = if d.method == "GET" { Method::GET } else { Method::POST };
        let mut request = Request::builder().method(method).uri(&d.path).header(header::HOST, "localhost");
        let body = match &d.body {
            Some(body) => {
                request = request.header(header::CONTENT_TYPE, "application/json");
                Body::from(serde_json::to_vec(body).map_err(|e| error(format!("downloads[{i}].body"), e.to_string()))?)
            }
            None => Body::empty(),
        };
        let request = request.body(body).map_err(|e| error(format!("downloads[{i}].path"), e.to_string()))?;
        let response = app.clone().oneshot(request).await.unwrap_or_else(|never| match never {});
        let status = response.status();
        let bytes = axum::body::to_bytes(response.into_body(), remaining).await.map_err(|e| {
            error(
                format!("downloads[{i}]"),
                format!(
                    "reading the answer: {e} (the recipe's files may hold {} MiB together; {} MiB were left for it)",
                    MAX_OUTPUT_BYTES >> 20,
                    remaining >> 20
                ),
            )
        })?;
        remaining -= bytes.len();
        if status != StatusCode::OK {
            return Err(error(
                format!("downloads[{i}]"),
                format!("{} answered {status}: {}", d.path, String::from_utf8_lossy(&bytes)),
            ));
        }
        files.push((d.file.clone(), bytes.to_vec()));
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recipe_with(page: &str) -> String {
        format!(
            r#"{{"format": "haptex-recipe/1", "haptex_version": "0.1.0", "source": {{"kind": "template"}},{page}
                "downloads": [{{"file": "voltage.csv", "method": "POST", "path": "/api/voltage?format=csv", "body": {{}}}}]}}"#
        )
    }

    /// The page's design is kept as written (the page reads it), recipes of
    /// older pages have none, and anything but an object is refused.
    #[test]
    fn the_page_object_is_optional_and_an_object() {
        let r = Recipe::parse(&recipe_with(r#" "page": {"source": "template", "both": true},"#)).unwrap();
        let page = r.page.as_ref().unwrap();
        assert_eq!((page["source"].as_str(), page["both"].as_bool()), (Some("template"), Some(true)));
        let again = serde_json::to_value(&r).unwrap();
        assert_eq!(again["page"]["both"], Value::Bool(true));
        let old = Recipe::parse(&recipe_with("")).unwrap();
        assert!(old.page.is_none() && serde_json::to_value(&old).unwrap().get("page").is_none());
        let e = Recipe::parse(&recipe_with(r#" "page": [1],"#)).unwrap_err();
        assert_eq!(e.field, "recipe");
        assert!(e.message.contains("invalid type"), "{e}");
        assert!(Recipe::parse(&recipe_with(r#" "pages": {},"#)).unwrap_err().message.contains("unknown field"));
    }
}
