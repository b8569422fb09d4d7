//! Handlers, one module per resource.

pub mod calibrate;
pub mod check;
pub mod config;
pub mod health;
pub mod live;
pub mod map;
pub mod materials;
pub mod measured;
pub mod model;
pub mod openapi;
pub mod play;
pub mod predict;
pub mod profile;
pub mod recordings;
pub mod simulate;
pub mod templates;
pub mod voltage;

use std::sync::Arc;

use axum::body::Bytes;
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use haptex_core::database::TemplateModel;

use crate::ApiError;
use crate::extract::{JSON_OR_CSV, Preamble, Route};
use crate::input::BodyKind;
use crate::state::AppState;
use crate::templates::{TemplateQuery, TemplateSet};

/// The template routes (`predict`, `simulate`): the answer format
/// (`?format=json|csv`, nothing else in the query), a JSON body, and a
/// server with an FE database.
pub(crate) struct Template;

impl Route for Template {
    const BODY: &'static [BodyKind] = &[BodyKind::Json];
    const FORMATS: &'static [&'static str] = JSON_OR_CSV;

    fn available(state: &AppState) -> Result<(), ApiError> {
        state.templates().map(drop)
    }
}

/// What the template routes start from: the answer format and the JSON
/// body checked against the server's templates.
pub(crate) struct TemplateCall {
    pub format: &'static str,
    pub set: Arc<TemplateSet>,
    pub request: TemplateQuery,
}

/// A template request whose query, content type and body size are
/// checked; [`TemplateBody::parse`] (CPU work) checks the body.
pub(crate) struct TemplateBody {
    format: &'static str,
    set: Arc<TemplateSet>,
    bytes: Bytes,
}

impl TemplateCall {
    /// The body of a checked request, with the server's templates.
    pub fn start(call: &Preamble<Template>) -> Result<TemplateBody, ApiError> {
        let set = Arc::clone(call.state.templates()?);
        Ok(TemplateBody { format: call.format, set, bytes: call.bytes.clone() })
    }

    /// The requested template's model (present: the request was checked
    /// against the set).
    pub fn model(&self) -> Result<&TemplateModel, ApiError> {
        self.set.model(self.request.template).ok_or_else(|| ApiError::internal("a template without its model"))
    }
}

impl TemplateBody {
    /// Parses and checks the body.
    pub fn parse(self) -> Result<TemplateCall, ApiError> {
        let request = TemplateQuery::parse(&self.bytes, &self.set)?;
        Ok(TemplateCall { format: self.format, set: self.set, request })
    }
}

/// A CSV body offered as a download named `filename`.
pub(crate) fn csv_response(bytes: Vec<u8>, filename: &str) -> Response {
    let disposition = HeaderValue::from_str(&format!("attachment; filename=\"{filename}\""))
        .unwrap_or_else(|_| HeaderValue::from_static("attachment"));
    (
        [
            (header::CONTENT_TYPE, HeaderValue::from_static("text/csv; charset=utf-8")),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        bytes,
    )
        .into_response()
}

/// Runs CSV writing into a buffer (writing to memory cannot fail short of
/// running out of it).
pub(crate) fn to_csv(
    fill: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<Vec<u8>, crate::ApiError> {
    let mut bytes = Vec::new();
    fill(&mut bytes).map_err(|e| crate::ApiError::internal(format!("cannot write CSV: {e}")))?;
    Ok(bytes)
}
