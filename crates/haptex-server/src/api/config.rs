//! `GET /api/config`: what the GUI needs to build its controls: the
//! profile sources this server offers, the device parameters with the
//! paper's defaults and ranges, the mapping methods, the friction displays
//! and the combined display's strategies, the playback defaults,
//! the defaults of the check on the finger model and the limits.

use axum::Json;
use axum::extract::State;
use haptex_core::signal::{Carrier, RenderSettings};
use serde_json::{Value, json};

use crate::error::ApiError;
use crate::extract::NoQuery;
use crate::state::AppState;

pub async fn get(State(state): State<AppState>, _: NoQuery) -> Result<Json<Value>, ApiError> {
    let play = RenderSettings::DEFAULT;
    Ok(Json(json!({
        "version": env!("CARGO_PKG_VERSION"),
        // What a recipe records of the data it was made with (haptex recipe run checks them).
        "data": {
            "library_sha256": state.library_sha256(),
            "database_sha256": state.database_sha256(),
            "device_file": state.default_device().file.as_ref().map(|f| &f.path),
            "device_file_sha256": state.default_device().file.as_ref().map(|f| &f.sha256),
        },
        // The device the parameters start from: the paper's, or a device file's (haptex serve --device-file).
        "device_file": state.default_device().file,
        "sources": state.sources(),
        // Whether POST /api/recordings may add recordings to the library (haptex serve --writable).
        "library_writable": state.library_writable(),
        "device_params": crate::params::params_over(&state.default_device().device),
        "explanations": crate::explain::EXPLANATIONS,
        "methods": [
            { "id": "physical", "label": "physical (eq. 8)", "description": "the voltage that reproduces the reference friction force; clipped at U_max, 0 V where mu_RS < mu_HD" },
            { "id": "normalized", "label": "normalized (eq. 9)", "description": "the pattern only: min mu -> 0 V, max mu -> U_max" },
        ],
        "displays": [
            { "id": "electrovibration", "label": "electrovibration", "description": "eq. (8): the voltage raises friction above mu_HD; below mu_HD nothing is rendered (0 V)" },
            { "id": "ultrasonic", "label": "ultrasonic", "description": "ultrasonic friction reduction: the plate's vibration amplitude a lowers friction below mu_HD, down to mu_HD rho_min" },
            { "id": "combined", "label": "combined", "description": "both on one plate, the felt friction mu_HD rho(a) (1 + Fe(U)/Fn): every target in the band [mu_HD rho_min, mu at U_max] is rendered" },
        ],
        "strategies": [
            { "id": "split", "label": "split", "description": "the plate only below mu_HD, the voltage only above: the least drive" },
            { "id": "bias", "label": "bias", "description": "a constant amplitude lowers the baseline to the profile's minimum; the voltage renders the detail from there (one smooth voltage signal)" },
            { "id": "weighted", "label": "weighted", "description": "per point the least (U/U_max)^2 + w ((rho(a) - rho_bias)/(1 - rho_bias))^2: w = 0 is split, a large w approaches bias" },
        ],
        "ultrasonic": {
            "literature_a_max_um": haptex_core::ultrasonic::Exponential::LITERATURE.a_valid_um,
            "default_weight": crate::display::DEFAULT_WEIGHT,
            "max_calibration_bytes": crate::display::MAX_CALIBRATION_BYTES,
        },
        "play": {
            "sample_rate_hz": play.sample_rate_hz,
            "carrier": Carrier::DEFAULT,
            "velocity_mm_s": crate::api::play::DEFAULT_VELOCITY_MM_S,
        },
        "check": {
            "load_n_per_mm": haptex_fem::render::DEFAULT_LOAD_N_PER_MM,
            "load_n": haptex_fem::render::DEFAULT_LOAD_3D_N,
            "direction_deg": 0.0,
            "velocity_mm_s": crate::api::check::DEFAULT_VELOCITY_MM_S,
            "step_mm": crate::api::check::DEFAULT_STEP_MM,
            "max_runs": crate::fields::MAX_RUNS,
            "tolerance": crate::api::check::DEFAULT_TOLERANCE,
        },
        "limits": state.limits(),
        "voltage_convention": "every voltage is RMS: a sine carrier of peak sqrt(2) U gives the same mean electrostatic force",
    })))
}
