//! `POST /api/predict`: the friction profile of a template surface (bump,
//! edge or sine) predicted from the FE database by the conditional average
//! estimator (paper section 3.2), in microseconds: the same computation as
//! `haptex predict`.
//!
//! Body (JSON): `{"surface": "bump", "x0_mm": 5, "width_mm": 1.3,
//! "height_mm": 0.27, "velocity_mm_s": 20}` (`x0_mm` defaults to 5 mm,
//! `velocity_mm_s` to 20 mm/s). Parameters outside the database's range
//! but within the accepted range ([`crate::templates`]) are predicted with
//! `extrapolation: true` and a warning; beyond it they are refused (400).
//! At a database case, the FE profile itself is returned (`fe_exact`).
//!
//! The answer is the profile (as `POST /api/profile` gives it) plus the
//! surface height `h_mm` at each x, where the profile comes from, the
//! warnings, the template's typical error and the profile's flat-surface
//! friction `flat_mu` (the FE skin friction: what `relative` voltage
//! mappings divide by, paper Fig. 2); `?format=csv` answers the
//! `x_mm,mu` file `haptex predict` writes, with the haptex version and the
//! database's SHA-256 in a last comment line (the download's recipe).

use axum::Json;
use axum::response::{IntoResponse, Response};
use haptex_core::database::Prediction;
use haptex_core::profile::FrictionProfile;
use serde_json::json;

use crate::error::ApiError;
use crate::extract::Preamble;
use crate::templates::{TemplateQuery, TemplateSet};

pub async fn post(call: Preamble<super::Template>) -> Result<Response, ApiError> {
    let body = super::TemplateCall::start(&call)?;
    let Preamble { state, slot, .. } = call;
    let database_sha256 = state.database_sha256().map(str::to_owned);
    slot.run(move || {
        let call = body.parse()?;
        let (format, set, request) = (call.format, &call.set, call.request);
        let TemplateQuery { template, x0_mm: x0, query } = request;
        let model = call.model()?;
        let entry = set.metadata().entry(template).ok_or_else(|| ApiError::internal("a template without its entry"))?;
        let ranges = TemplateSet::ranges(model);

        let prediction =
            model.predict(x0, query[0], query[1], query[2]).map_err(|e| ApiError::bad_request(e.to_string(), None))?;
        let source = model.describe(&query, &prediction, entry);
        let warning = model.warning(&query, prediction.fe_row, &prediction.diagnostics);
        // What db validate measured on random members, for the file's
        // comments and the answer's `fe_advised`.
        let notes = model.estimate_notes(set.metadata(), &query, &prediction);
        let Prediction { x_mm, mu, fe_row, estimator, diagnostics } = prediction;
        let profile = FrictionProfile::new(x_mm, mu)
            .map_err(|e| ApiError::internal(format!("the predicted profile is invalid: {e}")))?;

        if format == "csv" {
            let mut comments =
                model.prediction_comments(set.metadata(), x0, &query, &source, warning.as_deref(), &notes);
            // The recipe's rest: with the parameters above, what reproduces the file.
            comments.push(format!(
                "haptex {} (POST /api/predict); database_sha256: {}",
                env!("CARGO_PKG_VERSION"),
                database_sha256.as_deref().unwrap_or("(none)")
            ));
            let bytes = super::to_csv(|w| profile.write_csv_commented(w, &comments))?;
            return Ok(super::csv_response(
                bytes,
                &format!("{}-w{}-h{}-v{}.csv", template.name(), query[0], query[1], query[2]),
            ));
        }

        let outside: Vec<&str> =
            ranges.iter().zip(query).filter(|(r, v)| !r.in_database(*v)).map(|(r, _)| r.name).collect();
        let h_mm = request.heights(profile.x_mm());
        let mut answer = super::profile::profile_json(&profile);
        answer["surface"] = json!(template.name());
        answer["formula"] = json!(super::templates::formula(template));
        answer["parameters"] = request.parameters_json();
        answer["fe_exact"] = json!(fe_row.is_some());
        answer["fe_row"] = json!(fe_row.map(|r| r + 1));
        answer["source"] = json!(source);
        answer["estimator"] = json!(estimator.name());
        answer["extrapolation"] = json!(warning.is_some());
        answer["outside_database"] = json!(outside);
        answer["warnings"] = json!(warning.into_iter().collect::<Vec<_>>());
        answer["diagnostics"] = json!(diagnostics);
        answer["loo_rmse"] = json!(entry.loo_rmse);
        answer["loo_rmse_relative_to_range"] = json!(entry.loo_rmse_relative_to_range);
        // What db validate measured on random members (null if it was not
        // recorded), and whether the FE run is advised over the estimate.
        let validation = set.metadata().validation.as_ref();
        // For a sine whose crests the mesh resolves, the resolved members'
        // figures where the validation told them apart.
        let crests_resolved = model.crests_resolved(set.metadata(), &query);
        answer["validation"] = json!(validation.and_then(|v| Some((v, v.figures(template, crests_resolved)?))).map(
            |(v, (f, resolved))| {
                json!({
                    "members": f.members,
                    "of_members": v.members,
                    "crests_resolved": resolved,
                    "seed": v.seed,
                    "estimator": v.estimator.name(),
                    "rms_median": f.rms_median,
                    "rms_max": f.rms_max,
                    "relative_median": f.relative_median,
                    "relative_max": f.relative_max,
                })
            }
        ));
        answer["fe_advised"] = json!(notes.advice.is_some());
        // Where the database's own FE rows are not mesh-converged (a sine
        // sharper than its mesh resolves): why, and what resolves it.
        answer["fe_caveat"] = json!(notes.caveat);
        answer["h_mm"] = json!(h_mm);
        // The profile's flat-surface friction: the mu_flat of a relative
        // voltage mapping (`POST /api/voltage` with relative and flat_mu).
        answer["flat_mu"] = json!(set.metadata().fe.flat_mu());
        Ok(Json(answer).into_response())
    })
    .await
}
