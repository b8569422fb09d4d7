//! `GET /api/templates`: the surface templates this server predicts (the
//! FE database's bump, edge and sine), each with its height formula, its
//! parameters' ranges (database, accepted, slider; see
//! [`crate::templates`]) and the accuracy of its predictions (the
//! leave-one-out error of the CAE over the database), plus the FE settings
//! every database run shares.

use axum::Json;
use axum::extract::State;
use haptex_core::database::Template;
use serde_json::{Value, json};

use crate::error::ApiError;
use crate::extract::NoQuery;
use crate::state::AppState;
use crate::templates::{DEFAULT_X0_MM, MAX_ABS_X0_MM, TemplateSet};

/// The height formula of a template (design.md, "Surface templates").
pub(crate) fn formula(template: Template) -> &'static str {
    match template {
        Template::Bump => "h(x) = r_h exp(-((x - x0) / (r_w / 2))^2)",
        Template::Edge => "h(x) = r_h s((x - x0 + r_w) / r_w), s(t) = 3t^2 - 2t^3 on [0, 1]",
        Template::Sine => "h(x) = r_h sin(2 pi (x - x0) / r_w)",
    }
}

pub async fn get(State(state): State<AppState>, _: NoQuery) -> Result<Json<Value>, ApiError> {
    let set = state.templates()?;
    let metadata = set.metadata();
    let templates: Vec<Value> = set
        .templates()
        .filter_map(|t| Some((t, set.model(t)?, metadata.entry(t)?)))
        .map(|(template, model, entry)| {
            json!({
                "name": template.name(),
                "formula": formula(template),
                "rows": entry.rows,
                "parameters": TemplateSet::ranges(model),
                "cae_widths": entry.widths,
                "loo_rmse": entry.loo_rmse,
                "loo_rmse_relative_to_range": entry.loo_rmse_relative_to_range,
            })
        })
        .collect();
    let fe = &metadata.fe;
    Ok(Json(json!({
        "database": set.dir().file_name().map(|n| n.to_string_lossy().into_owned()),
        "created": metadata.created,
        "haptex_version": metadata.haptex_version,
        "grid": metadata.grid,
        "x0_mm": { "default": DEFAULT_X0_MM, "accepted": [-MAX_ABS_X0_MM, MAX_ABS_X0_MM] },
        "fe": {
            "mesh": fe.mesh,
            "material": fe.material,
            "indent_mm": fe.indent_mm,
            "mu_skin": fe.mu_skin,
            "finger_model": fe.finger_model,
            // Whether POST /api/simulate can run the FE model with these
            // settings, and why not.
            "simulate": set.fe().is_ok(),
            "simulate_unavailable": set.fe().err(),
        },
        "templates": templates,
    })))
}
