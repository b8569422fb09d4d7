//! The preamble of a request as axum extractors: the checks every
//! handler made first, each in its own code until issue 37.
//!
//! [`Preamble`] is the preamble of a route with a body: the query string,
//! the body's kind, the body (bounded), and the slot its work runs in. A
//! route says what it takes with a [`Route`] (a marker type in its
//! module): its body kinds, its answer formats, whether its handler reads
//! more of the query, whether its work is heavy whatever the body's size,
//! and what of the server it needs. The checks run in one order for every
//! route, and the first that fails is the answer:
//!
//! 1. the query: malformed or a parameter given twice (400), then
//!    `format` (400, for a route with [`Route::FORMATS`]), then any
//!    parameter left (400 naming it), unless the handler reads the rest
//!    ([`Rest::Handler`]);
//! 2. what the route needs of the server ([`Route::available`]: 404 when
//!    the server has no FE database, for the template routes), right
//!    after the query, as the routes of the texture library check theirs;
//! 3. the body's kind by `Content-Type` (415, field `content-type`);
//! 4. the body: empty (400, field `body`), over
//!    [`Limits::max_body_bytes`] (413, field `body`);
//! 5. the slot of its work ([`Slot`]): a heavy slot for a heavy route or a
//!    body over [`Limits::heavy_body_bytes`] (503 when busy), taken last,
//!    when the request is known to be well-formed.
//!
//! The body is read (up to the limit) before these checks, as axum's body
//! extractors read it before a handler runs.
//!
//! [`NoQuery`] is the preamble of a route without a body and without
//! parameters (400 naming the first parameter given), and [`Query`] the
//! query of a route that takes parameters of its own.
//!
//! [`Limits::max_body_bytes`]: crate::Limits::max_body_bytes
//! [`Limits::heavy_body_bytes`]: crate::Limits::heavy_body_bytes

use std::marker::PhantomData;

use axum::body::Bytes;
use axum::extract::{FromRequest, FromRequestParts, Request};
use axum::http::request::Parts;

use crate::error::ApiError;
use crate::input::{BodyKind, Query, body_bytes, body_kind};
use crate::state::AppState;
use crate::work::Slot;

/// The answer formats of a route that answers JSON or CSV
/// (`?format=json|csv`, JSON by default).
pub(crate) const JSON_OR_CSV: &[&str] = &["json", "csv"];

/// What a route takes; see the module's documentation for the order of
/// the checks.
pub(crate) trait Route: 'static {
    /// The body kinds accepted, in the order the 415 names them.
    const BODY: &'static [BodyKind];
    /// The values of `format`, the default first; none: the route takes
    /// no `format` ([`Preamble::format`] is then empty).
    const FORMATS: &'static [&'static str] = &[];
    /// Who refuses the query's other parameters.
    const REST: Rest = Rest::Refused;
    /// The slot of the route's work.
    const WORK: Work = Work::BySize;

    /// What the route needs of the server, checked after the query.
    fn available(_state: &AppState) -> Result<(), ApiError> {
        Ok(())
    }
}

/// The query's parameters besides `format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rest {
    /// None is taken: any is refused before the body is looked at.
    Refused,
    /// The handler takes them from [`Preamble::query`] and refuses what
    /// is left ([`Query::finish`]).
    Handler,
}

/// The slot of a route's work.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Work {
    /// A heavy slot if the body is over `heavy_body_bytes`
    /// ([`Slot::for_input`]).
    BySize,
    /// A heavy slot whatever the body (a map, a calibration).
    Heavy,
}

/// A request whose query, body kind and body are checked and whose work
/// has its slot: what a handler of route `R` starts from.
pub(crate) struct Preamble<R> {
    pub state: AppState,
    /// The answer's format (one of [`Route::FORMATS`]; empty for a route
    /// without).
    pub format: &'static str,
    /// The query's parameters not taken yet: none unless the route's
    /// [`Route::REST`] is [`Rest::Handler`].
    pub query: Query,
    pub kind: BodyKind,
    /// The body: not empty, at most `max_body_bytes`.
    pub bytes: Bytes,
    /// The slot the work runs in ([`Slot::run`]).
    pub slot: Slot,
    route: PhantomData<fn() -> R>,
}

impl<R: Route> FromRequest<AppState> for Preamble<R> {
    type Rejection = ApiError;

    async fn from_request(request: Request, state: &AppState) -> Result<Self, ApiError> {
        let query = query::<R>(request.uri().query());
        let kind = body_kind(request.headers(), R::BODY);
        let body = Bytes::from_request(request, state).await;
        let (query, format) = query?;
        R::available(state)?;
        let kind = kind?;
        let bytes = body_bytes(body, state.limits().max_body_bytes)?;
        let slot = match R::WORK {
            Work::BySize => Slot::for_input(state, bytes.len()).await?,
            Work::Heavy => Slot::heavy(state).await?,
        };
        Ok(Self { state: state.clone(), format, query, kind, bytes, slot, route: PhantomData })
    }
}

/// The query of route `R`: parsed, its `format` taken, the rest refused
/// unless the handler takes it.
fn query<R: Route>(raw: Option<&str>) -> Result<(Query, &'static str), ApiError> {
    let mut query = Query::parse(raw)?;
    let format = if R::FORMATS.is_empty() { "" } else { query.take_format(R::FORMATS)? };
    if R::REST == Rest::Refused {
        std::mem::take(&mut query).finish()?;
    }
    Ok((query, format))
}

/// A route that takes no query parameter: 400 naming the first given.
pub(crate) struct NoQuery;

impl<S: Send + Sync> FromRequestParts<S> for NoQuery {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, ApiError> {
        Query::from_request_parts(parts, state).await?.finish()?;
        Ok(Self)
    }
}

/// The query string as parameters (400 when malformed or a parameter is
/// given twice); the handler takes its own and refuses the rest.
impl<S: Send + Sync> FromRequestParts<S> for Query {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, _state: &S) -> Result<Self, ApiError> {
        Query::parse(parts.uri.query())
    }
}
