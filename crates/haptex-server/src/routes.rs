//! The route table: every route the server answers, in one list that the
//! router is built from and that the OpenAPI test compares with
//! `/api/openapi.json`.
//!
//! To add a route: write its handler under `api/`, add one [`endpoint`]
//! line here and describe it in `src/openapi.json`; the test fails until
//! both agree.

use axum::Router;
use axum::handler::Handler;
use axum::http::Method;
use axum::routing::{MethodFilter, MethodRouter, on};

use crate::state::AppState;
use crate::{api, assets};

/// One route: method, path (axum syntax: `{name}` for a segment,
/// `{*name}` for the rest of the path) and handler.
pub struct Endpoint {
    pub method: Method,
    pub path: &'static str,
    handler: MethodRouter<AppState>,
}

fn endpoint<H, T>(method: Method, path: &'static str, handler: H) -> Endpoint
where
    H: Handler<T, AppState>,
    T: 'static,
{
    let filter = MethodFilter::try_from(method.clone()).expect("a standard HTTP method");
    Endpoint { method, path, handler: on(filter, handler) }
}

/// Every route.
pub fn table() -> Vec<Endpoint> {
    vec![
        endpoint(Method::GET, "/", assets::index),
        endpoint(Method::GET, "/static/{*path}", assets::file),
        endpoint(Method::GET, "/api/health", api::health::get),
        endpoint(Method::GET, "/api/config", api::config::get),
        endpoint(Method::GET, "/api/openapi.json", api::openapi::get),
        endpoint(Method::GET, "/api/model", api::model::get),
        endpoint(Method::GET, "/api/templates", api::templates::get),
        endpoint(Method::POST, "/api/predict", api::predict::post),
        endpoint(Method::POST, "/api/simulate", api::simulate::post),
        endpoint(Method::POST, "/api/check", api::check::check),
        endpoint(Method::POST, "/api/compensate", api::check::compensate),
        endpoint(Method::POST, "/api/voltage", api::voltage::post),
        endpoint(Method::POST, "/api/profile", api::profile::post),
        endpoint(Method::GET, "/api/materials", api::materials::list),
        endpoint(Method::GET, "/api/materials/{name}/sample", api::materials::sample),
        endpoint(Method::POST, "/api/recordings", api::recordings::post),
        endpoint(Method::POST, "/api/play", api::play::post),
        endpoint(Method::GET, "/map", assets::map_page),
        endpoint(Method::POST, "/api/map", api::map::post),
        endpoint(Method::POST, "/api/map/path", api::map::path),
        endpoint(Method::GET, "/api/live", api::live::get),
        endpoint(Method::GET, "/api/live/ws", api::live::socket),
        endpoint(Method::POST, "/api/calibrate", api::calibrate::post),
        endpoint(Method::POST, "/api/compensate/measured", api::measured::post),
    ]
}

/// The router of [`table`] (without state, fallback and middleware: see
/// [`crate::app`]).
pub fn router() -> Router<AppState> {
    table().into_iter().fold(Router::new(), |router, e| router.route(e.path, e.handler))
}

/// `(method, path)` of every route, paths in OpenAPI syntax (`{*path}` ->
/// `{path}`).
pub fn list() -> Vec<(Method, String)> {
    table().into_iter().map(|e| (e.method, e.path.replace("{*", "{"))).collect()
}
