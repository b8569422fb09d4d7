//! `POST /api/simulate`: the finite-element model run on demand for one
//! template surface, with the FE settings the database was built with
//! (finger model, mesh, visco-elastic tissue, 0.25 mm press, 10 mm slide):
//! what `haptex db loo` does for a case outside the database. About half a
//! second of one core; at most [`crate::Limits::concurrent_simulations`]
//! run at once, a request waits up to
//! [`crate::Limits::simulation_wait`] for its turn, then 503.
//!
//! Body: as `POST /api/predict`. Each parameter must lie in its
//! `simulate` range (`GET /api/templates`): from the database's smallest
//! value (features the mesh resolves) to the GUI slider's end. The answer
//! is the FE profile on the database grid shifted to x0 (`x_mm`, `mu`,
//! rounded to 6 decimals as database rows are), the surface height, the
//! wall time, and the RMS difference of the CAE prediction for the same
//! parameters (how good the instant estimate is here). An FE run that
//! fails (the solver's clear error: time, step, residual) answers 422.
//! `?format=csv` answers `x_mm,mu` with the settings in `#` comments.

use std::time::Instant;

use axum::Json;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use haptex_core::num::Num;
use haptex_core::profile::FrictionProfile;
use haptex_fem::sweep::{DatabaseSpec, Run};
use serde_json::json;

use crate::error::ApiError;
use crate::extract::Preamble;
use crate::templates::{TemplateQuery, TemplateSet};
use crate::work;

pub async fn post(call: Preamble<super::Template>) -> Result<Response, ApiError> {
    let body = super::TemplateCall::start(&call)?;
    let Preamble { state, slot, .. } = call;
    let call = slot.run(move || simulable(body.parse()?)).await?;
    let spec = std::sync::Arc::clone(
        call.set.fe().map_err(|why| ApiError::not_found(format!("FE simulation is not available: {why}"), None))?,
    );

    let permit = work::fe_slot(&state).await?;
    let heavy = work::heavy_slot(&state).await?;
    work::blocking_long(vec![permit, heavy], move || answer(call, &spec)).await
}

/// The request, if the FE model runs on demand for its parameters: each
/// within its `simulate` range.
fn simulable(call: super::TemplateCall) -> Result<super::TemplateCall, ApiError> {
    for (range, value) in TemplateSet::ranges(call.model()?).iter().zip(call.request.query) {
        if !range.simulates(value) {
            return Err(ApiError::bad_request(
                format!(
                    "{} = {} {}: the FE model runs on demand for {} .. {} {} (from the database's smallest \
                     value, which the mesh resolves, to the slider's end); use POST /api/predict beyond",
                    range.name,
                    Num(value),
                    range.unit,
                    Num(range.simulate[0]),
                    Num(range.simulate[1]),
                    range.unit
                ),
                Some(range.name),
            ));
        }
    }
    Ok(call)
}

/// Runs the FE model for `call` and builds the answer (on a blocking
/// thread, in a simulation slot).
fn answer(call: super::TemplateCall, spec: &DatabaseSpec) -> Result<Response, ApiError> {
    let (format, set, request) = (call.format, &call.set, call.request);
    let TemplateQuery { template, x0_mm, query } = request;
    let model = call.model()?;
    let run = Run { template, width_mm: query[0], height_mm: query[1], velocity_mm_s: query[2] };
    let started = Instant::now();
    let fe = spec
        .simulate(&run)
        .map_err(|e| ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, format!("the FE simulation failed: {e}"), None))?;
    let seconds = started.elapsed().as_secs_f64();

    let x_mm: Vec<f64> = model.grid.positions_from(x0_mm);
    let profile = FrictionProfile::new(x_mm, fe)
        .map_err(|e| ApiError::internal(format!("the simulated profile is invalid: {e}")))?;
    let prediction = model
        .predict(x0_mm, query[0], query[1], query[2])
        .map_err(|e| ApiError::internal(format!("the CAE prediction failed: {e}")))?;
    let cae_rms = (prediction.mu.iter().zip(profile.mu()).map(|(p, f)| (p - f) * (p - f)).sum::<f64>()
        / profile.len() as f64)
        .sqrt();
    let fe_settings = &set.metadata().fe;
    let settings = format!(
        "FE model of the database: {} mesh, {} tissue, press {} mm, mu_skin {}",
        fe_settings.mesh, fe_settings.material, fe_settings.indent_mm, fe_settings.mu_skin
    );

    if format == "csv" {
        let comments = vec![
            format!("haptex FE simulation: {} ({seconds:.2} s)", template.describe_query(x0_mm, &query)),
            settings,
            format!("RMS difference of the CAE prediction for the same parameters: {cae_rms:.6}"),
        ];
        let bytes = super::to_csv(|w| profile.write_csv_commented(w, &comments))?;
        return Ok(super::csv_response(
            bytes,
            &format!("{}-w{}-h{}-v{}-fe.csv", template.name(), query[0], query[1], query[2]),
        ));
    }
    let mut answer = super::profile::profile_json(&profile);
    answer["surface"] = json!(template.name());
    answer["parameters"] = request.parameters_json();
    answer["h_mm"] = json!(request.heights(profile.x_mm()));
    answer["fe_seconds"] = json!(seconds);
    answer["fe_settings"] = json!(settings);
    answer["cae_rms_difference"] = json!(cae_rms);
    Ok(Json(answer).into_response())
}
