//! `GET /api/model`: the model behind the page, for its "model" section:
//! the paper's equations (3), (8) and (9) with the constant eq. (8) takes
//! with the paper's Fig. 2 device (computed by the library the mapping
//! uses), and the FE finger model the server checks profiles on (the
//! shipped `data/finger/finger-2d.toml`, as parsed, and the file itself,
//! whose comments give each value's source). The database's grid and
//! leave-one-out errors are `GET /api/templates`'.

use axum::Json;
use haptex_core::electrovibration::Device;
use haptex_fem::finger::{DEFAULT_MODEL_TOML, FingerModel};
use serde_json::{Value, json};

use crate::error::ApiError;
use crate::extract::NoQuery;

/// The file the shipped finger model is read from.
pub const FINGER_FILE: &str = "data/finger/finger-2d.toml";

pub async fn get(_: NoQuery) -> Result<Json<Value>, ApiError> {
    let paper = Device::PAPER;
    // Fe/Fn per V^2 with the linear contact law (Fn cancels): eq. (8) is
    // then U = sqrt((mu_RS/mu_HD - 1) / ratio).
    let ratio = paper.force_ratio_per_v2(1.0);
    let finger = FingerModel::default_model();
    let materials: Vec<Value> = finger
        .materials
        .named()
        .iter()
        .map(|(name, m)| json!({ "name": name, "e_mpa": m.e_mpa, "nu": m.nu }))
        .collect();
    Ok(Json(json!({
        "equations": [
            {
                "id": "3",
                "text": "Fe = eps0 A U^2 / (2 (d_sc/eps_sc + d_i/eps_i) (d_sc + d_i))",
                "meaning": "electrostatic force pulling the finger onto the display (Kaczmarek et al. 2006), A = k Fn^n the contact area, U the RMS voltage",
            },
            {
                "id": "8",
                "text": "U(x) = sqrt(2 (d_sc/eps_sc + d_i/eps_i) (d_sc + d_i) (mu_RS(x)/mu_HD - 1) / (eps0 k))",
                "meaning": "physical mapping: the voltage whose extra friction mu_HD Fe equals the reference surface's (A = k Fn); 0 V where mu_RS < mu_HD, clipped at U_max",
            },
            {
                "id": "9",
                "text": "U(x) = U_max sqrt((mu_RS(x) - min mu_RS) / (max mu_RS - min mu_RS))",
                "meaning": "normalized mapping: the pattern only, lowest friction at 0 V, highest at U_max",
            },
        ],
        "paper_device": {
            "mu_hd": paper.mu_hd,
            "u_max_v": paper.u_max_v,
            "eps_sc": paper.stack.eps_sc,
            "eps_i": paper.stack.eps_i,
            "d_sc_mm": paper.stack.d_sc_mm,
            "d_i_mm": paper.stack.d_i_mm,
            "k_mm2_per_n": paper.contact.k_mm2_per_n,
            "area_exponent": paper.contact.exponent,
            "fe_over_fn_per_v2": ratio,
            "eq8_u2_per_unit_excess_v2": 1.0 / ratio,
            "source": "the paper's Fig. 2 caption",
        },
        "finger": {
            "file": FINGER_FILE,
            "geometry": finger.geometry,
            "layers": finger.layers,
            "materials": materials,
            "viscoelasticity": finger.viscoelasticity,
            "contact": finger.contact,
            "file_text": DEFAULT_MODEL_TOML,
        },
    })))
}
