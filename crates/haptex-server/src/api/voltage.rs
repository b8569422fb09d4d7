//! `POST /api/voltage`: friction profile -> electrovibration voltage
//! profile (paper eq. 8, or eq. 9 with `method=normalized`), with the
//! limits summary (where U is clipped at U_max, where mu_RS < mu_HD).
//!
//! Two bodies:
//!
//! - `application/json`: `{"profile": {"x_mm": [..], "mu": [..]},
//!   "method": "physical", "device": {"u_max_v": 100, ...},
//!   "relative": true, "flat_mu": 0.5}`;
//! - `text/csv`: a profile file as is (`x_mm,mu` or `x_mm,ft_n,fn_n`), the
//!   method, relative mapping and device parameters in the query string
//!   (`?method=normalized&u_max_v=80&relative=true&flat_mu=0.5`).
//!
//! `?format=csv` answers `x_mm,mu,voltage_v` CSV (the file `haptex voltage`
//! writes) instead of JSON.
//!
//! `relative: true` (`?relative=true` with a CSV body) maps the profile
//! relative to its flat-surface friction, as the paper's Fig. 2 does
//! (`haptex voltage --relative`, [`haptex_core::relative`]): mu / flat_mu *
//! mu_HD, with `flat_mu` as given, else the profile's median. `flat_mu`
//! without `relative: true` is refused rather than ignored.
//!
//! `display` (`electrovibration`, the default; `ultrasonic`; `combined`)
//! with `strategy`, `weight`, `a_max_um` and `ultrasonic_calibration`
//! ([`crate::display`]) designs the drive of an ultrasonic or combined
//! display instead (`haptex voltage --display`, the core's
//! [`map_display`]): the answer then has `amplitude_um` beside (or
//! instead of) `voltage_v`, and a summary with the renderable band
//! `band_mu` and each channel's limits. The electrovibration answer is
//! the one it always was, byte for byte.

use std::collections::BTreeMap;

use axum::Json;
use axum::response::{IntoResponse, Response};
use haptex_core::combined::{Channels, DisplayError, DisplayProfile, Strategy, map_display};
use haptex_core::electrovibration::{ElectroError, Method, Regions, VoltageProfile, map_profile, map_profile_relative};
use haptex_core::num::Num;
use haptex_core::profile::FrictionProfile;
use haptex_core::ranges;
use haptex_core::relative::{FlatMu, RelativeError};
use haptex_core::signal::Carrier;
use serde::{Deserialize, Serialize};

use crate::device_file::RequestDeviceFile;
use crate::display::{DisplayDesign, DisplayName, DisplayRequest, StrategyName};
use crate::error::ApiError;
use crate::extract::{JSON_OR_CSV, Preamble, Rest, Route};
use crate::input::{BodyKind, Pairs, ProfileJson, parse_json, parse_number, profile_from_csv};
use crate::params::{DEVICE_PARAMS, DeviceRequest, parse_method};
use crate::state::AppState;

/// The JSON body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct VoltageBody {
    profile: ProfileJson,
    #[serde(default)]
    method: Option<Method>,
    /// Device and finger parameters by name (`params::DEVICE_PARAMS`), in
    /// the order given (a name given twice is refused, not overwritten).
    #[serde(default)]
    device: Pairs,
    /// Map the profile relative to its flat-surface friction (paper Fig. 2).
    #[serde(default)]
    relative: bool,
    /// The flat-surface friction mu_flat (with `relative` only; default:
    /// the profile's median).
    #[serde(default)]
    flat_mu: Option<f64>,
    /// The friction display (default electrovibration).
    #[serde(default)]
    display: Option<DisplayName>,
    /// The combined display's strategy (default split).
    #[serde(default)]
    strategy: Option<StrategyName>,
    /// The weighted strategy's weight (default 1).
    #[serde(default)]
    weight: Option<f64>,
    /// The plate's highest vibration amplitude, um (peak).
    #[serde(default)]
    a_max_um: Option<f64>,
    /// The plate's calibration: the text of an
    /// `amplitude_um,relative_friction` CSV.
    #[serde(default)]
    ultrasonic_calibration: Option<String>,
    /// The design's provenance as the page states it (its recipe's
    /// `source`, a JSON object): with `?format=csv` the answer then begins
    /// with the recipe in `#` comments ([`recipe_comments`]).
    #[serde(default)]
    source: Option<serde_json::Value>,
    /// A calibrated display's device file, its TOML text
    /// ([`crate::device_file`]): the device constants come from it.
    #[serde(default)]
    device_file: Option<String>,
    /// The carrier the design will be played on, for the device file's
    /// force coefficient (default a 1 kHz sine; with `device_file` only).
    #[serde(default)]
    carrier: Option<Carrier>,
}

/// The longest `source` accepted, serialized (one comment line).
const MAX_SOURCE_BYTES: usize = 4096;

/// The recipe of a JSON answer: the haptex version, the design's `source`,
/// the request's settings and the SHA-256 of the data served (the
/// parameters are the answer's own `parameters`).
fn recipe_json(state: &AppState, source: &serde_json::Value, settings: &serde_json::Value) -> serde_json::Value {
    serde_json::json!({
        "haptex_version": env!("CARGO_PKG_VERSION"),
        "source": source,
        "settings": settings,
        "library_sha256": state.library_sha256(),
        "database_sha256": state.database_sha256(),
        "device_file_sha256": state.default_device().file.as_ref().map(|f| &f.sha256),
    })
}

/// The comment line naming the server's device file (`haptex serve
/// --device-file`), for a design whose device is the file's: every
/// parameter as the file gives it (a request that changes one is not the
/// file's design, and is not labelled with it).
fn device_file_comment(base: &crate::params::DefaultDevice, request: &DeviceRequest) -> Option<String> {
    let file = base.file.as_ref()?;
    (request.device == base.device).then(|| format!("# {}\n", file.comment()))
}

/// The recipe of a CSV answer as `#` comment lines: the haptex version, the
/// design's `source` (as the request gave it), the request's settings
/// (method, relative mapping, display; the calibration by its SHA-256),
/// every device parameter used (defaults filled in) and the SHA-256 of
/// the data this server serves. The profile itself is the CSV's columns.
fn recipe_comments(
    state: &AppState,
    source: &serde_json::Value,
    settings: &serde_json::Value,
    parameters: &BTreeMap<&'static str, f64>,
) -> String {
    let mut text = format!(
        "# haptex {} (POST /api/voltage); the page's recipe download replays it (haptex recipe run)\n",
        env!("CARGO_PKG_VERSION")
    );
    text.push_str(&format!("# source: {source}\n# settings: {settings}\n"));
    text.push_str(&format!("# parameters: {}\n", serde_json::json!(parameters)));
    if let Some(hash) = state.library_sha256() {
        text.push_str(&format!("# library_sha256: {hash}\n"));
    }
    if let Some(hash) = state.database_sha256() {
        text.push_str(&format!("# database_sha256: {hash}\n"));
    }
    if let Some(file) = &state.default_device().file {
        text.push_str(&format!("# device_file: {} sha256 {}\n", file.path, file.sha256));
    }
    text
}

/// Whether to map relative to the flat-surface friction, and how mu_flat
/// is found: from `relative` and `flat_mu` (body fields or query
/// parameters of these names, which errors name).
pub(crate) fn relative_request(relative: bool, flat_mu: Option<f64>) -> Result<Option<FlatMu>, ApiError> {
    match (relative, flat_mu) {
        (false, None) => Ok(None),
        (false, Some(_)) => Err(ApiError::bad_request(
            "flat_mu is the flat-surface friction of a relative mapping: give relative = true with it",
            Some("flat_mu"),
        )),
        (true, None) => Ok(Some(FlatMu::Median)),
        (true, Some(value)) => Ok(Some(FlatMu::Given(crate::fields::check(ranges::FLAT_MU, value, "flat_mu")?))),
    }
}

/// Parses the `relative` query parameter: `true` or `false`.
fn parse_bool(text: &str, field: &str) -> Result<bool, ApiError> {
    match text {
        "true" => Ok(true),
        "false" => Ok(false),
        other => Err(ApiError::bad_request(
            format!("{field} must be true or false, got {}", crate::error::quote(other)),
            Some(field),
        )),
    }
}

/// The JSON answer: the parameters used (defaults filled in), the summary
/// and the profile.
#[derive(Debug, Serialize)]
pub(crate) struct VoltageAnswer<'a> {
    pub parameters: BTreeMap<&'static str, f64>,
    #[serde(flatten)]
    pub voltage: &'a VoltageProfile,
    /// `summary.warnings` as the page shows them: the library writes them
    /// for the command line (`lower --mu-hd`); here each flag is the
    /// page's control ([`crate::explain::for_page`]).
    pub page_warnings: Vec<String>,
    /// The recipe (a request with `source` only): [`recipe_json`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recipe: Option<serde_json::Value>,
    /// The device file that designed it (a request with `device_file`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_file: Option<serde_json::Value>,
}

impl<'a> VoltageAnswer<'a> {
    pub fn new(parameters: BTreeMap<&'static str, f64>, voltage: &'a VoltageProfile) -> Self {
        let page_warnings = voltage.summary.warnings.iter().map(|w| crate::explain::for_page(w)).collect();
        VoltageAnswer { parameters, voltage, page_warnings, recipe: None, device_file: None }
    }
}

/// The JSON answer for an ultrasonic or combined display: the parameters
/// used (with the plate's a_max and the weighted strategy's weight), the
/// display profile (summary with the band, `voltage_v` and `amplitude_um`
/// per channel in use) and the warnings as the page shows them.
#[derive(Debug, Serialize)]
pub(crate) struct DisplayAnswer<'a> {
    pub parameters: BTreeMap<&'static str, f64>,
    #[serde(flatten)]
    pub display: &'a DisplayProfile,
    pub page_warnings: Vec<String>,
    /// The recipe (a request with `source` only): [`recipe_json`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recipe: Option<serde_json::Value>,
    /// The device file that designed it (a request with `device_file`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_file: Option<serde_json::Value>,
}

impl<'a> DisplayAnswer<'a> {
    pub fn new(request: &DeviceRequest, design: &DisplayDesign, display: &'a DisplayProfile) -> Self {
        let mut parameters = request.values();
        if let Channels::Ultrasonic(_) = design.channels() {
            // The ultrasonic display alone uses mu_HD only of the device.
            parameters.retain(|name, _| *name == "mu_hd");
        }
        parameters.insert("a_max_um", design.ultrasonic.a_max_um());
        if let Some(Strategy::Weighted { weight }) = design.strategy {
            parameters.insert("weight", weight);
        }
        let page_warnings = display.summary.warnings.iter().map(|w| crate::explain::for_page(w)).collect();
        DisplayAnswer { parameters, display, page_warnings, recipe: None, device_file: None }
    }
}

/// The route: a JSON body, or a CSV profile with the settings in the
/// query (which the handler reads: with a JSON body, after the body's
/// kind and size, the query has `format` only).
pub(crate) struct Voltage;

impl Route for Voltage {
    const BODY: &'static [BodyKind] = &[BodyKind::Json, BodyKind::Csv];
    const FORMATS: &'static [&'static str] = JSON_OR_CSV;
    const REST: Rest = Rest::Handler;
}

pub async fn post(call: Preamble<Voltage>) -> Result<Response, ApiError> {
    let Preamble { state: app, format, mut query, kind, bytes, slot, .. } = call;
    let limits = app.limits().clone();
    let base = app.default_device().clone();
    slot.run(move || {
        // The recipe's source and settings for the CSV's comments (JSON body with `source` only).
        let mut recipe: Option<(serde_json::Value, serde_json::Value)> = None;
        let (profile, method, request, relative, display, prefix, device_file) = match kind {
            BodyKind::Json => {
                query.finish()?;
                let body: VoltageBody = parse_json(&bytes)?;
                if let Some(source) = &body.source {
                    if !source.is_object() || source.to_string().len() > MAX_SOURCE_BYTES {
                        return Err(ApiError::bad_request(
                            format!("a JSON object of at most {MAX_SOURCE_BYTES} bytes (the design's provenance)"),
                            Some("source"),
                        ));
                    }
                    let settings = serde_json::json!({
                        "method": body.method.map(|m| format!("{m:?}").to_lowercase()),
                        "relative": body.relative,
                        "flat_mu": body.flat_mu,
                        "display": body.display.map(|d| format!("{d:?}").to_lowercase()),
                        "strategy": body.strategy.map(|s| format!("{s:?}").to_lowercase()),
                        "weight": body.weight,
                        "a_max_um": body.a_max_um,
                        "ultrasonic_calibration_sha256":
                            body.ultrasonic_calibration.as_deref().map(|t| haptex_core::io::sha256_hex(t.as_bytes())),
                        "device_file_sha256":
                            body.device_file.as_deref().map(|t| haptex_core::io::sha256_hex(t.as_bytes())),
                        "carrier": body.carrier,
                    });
                    recipe = Some((source.clone(), settings));
                }
                // A device file in the request sets the constants; without
                // one, the server's own default device (`serve
                // --device-file`) fills what the request leaves out.
                let (request, device_file) = if body.device_file.is_some() || body.carrier.is_some() {
                    crate::device_file::resolve(&body.device, body.device_file.as_deref(), body.carrier, "device.")?
                } else {
                    (DeviceRequest::from_pairs_over(body.device.iter(), "device.", &base.device)?, None)
                };
                let relative = relative_request(body.relative, body.flat_mu)?;
                let display = DisplayRequest {
                    display: body.display,
                    strategy: body.strategy,
                    weight: body.weight,
                    a_max_um: body.a_max_um,
                    ultrasonic_calibration: body.ultrasonic_calibration,
                };
                let profile = body.profile.into_profile("profile.", limits.max_points)?;
                (profile, body.method, request, relative, display, "device.", device_file)
            }
            BodyKind::Csv => {
                let method = query.take("method").map(|m| parse_method(&m, "method")).transpose()?;
                let relative = query.take("relative").map(|t| parse_bool(&t, "relative")).transpose()?;
                let flat_mu = query.take("flat_mu").map(|t| parse_number(&t, "flat_mu")).transpose()?;
                let relative = relative_request(relative.unwrap_or(false), flat_mu)?;
                let display = DisplayRequest::from_query(&mut query)?;
                let mut pairs = Vec::new();
                for (name, text) in query.take_all() {
                    if !DEVICE_PARAMS.iter().any(|p| p.name == name) {
                        return Err(ApiError::bad_request(
                            "unknown query parameter (with a CSV body the query takes format, method, relative, \
                             flat_mu, display, strategy, weight, a_max_um and the device parameters)",
                            Some(&name),
                        ));
                    }
                    let value = parse_number(&text, &name)?;
                    pairs.push((name, value));
                }
                let request =
                    DeviceRequest::from_pairs_over(pairs.iter().map(|(k, v)| (k.as_str(), *v)), "", &base.device)?;
                let profile = profile_from_csv(&bytes, limits.max_points)?;
                (profile, method, request, relative, display, "", None)
            }
        };
        let provenance = device_file.as_ref().map(RequestDeviceFile::provenance);
        let file_comment = device_file.as_ref().map(|f| format!("# {}\n", f.comment())).unwrap_or_default();
        if let Some(mut design) = display.design()? {
            crate::device_file::use_plate(device_file.as_ref(), &display, &mut design)?;
            if method == Some(Method::Normalized) {
                return Err(ApiError::bad_request(
                    "the method normalized (eq. 9) is the electrovibration display's pattern: an ultrasonic or \
                     combined display renders the friction itself (method physical)",
                    Some("method"),
                ));
            }
            let designed = compute_display(&profile, &request, relative, &design, prefix)?;
            let mut answer = DisplayAnswer::new(&request, &design, &designed);
            answer.recipe = recipe.as_ref().map(|(source, settings)| recipe_json(&app, source, settings));
            answer.device_file = provenance;
            let mut comments =
                recipe.map(|(source, settings)| recipe_comments(&app, &source, &settings, &answer.parameters));
            if let Some(line) = device_file_comment(&base, &request).filter(|_| device_file.is_none()) {
                comments = Some(format!("{line}{}", comments.unwrap_or_default()));
            }
            return Ok(match format {
                "csv" => super::csv_response(
                    super::to_csv(|w| {
                        w.write_all(comments.unwrap_or_default().as_bytes())?;
                        w.write_all(file_comment.as_bytes())?;
                        designed.write_csv(w)
                    })?,
                    "display.csv",
                ),
                _ => Json(answer).into_response(),
            });
        }
        let method = method.unwrap_or(Method::Physical);
        let voltage = compute(&profile, method, &request, relative, prefix)?;
        let json_recipe = recipe.as_ref().map(|(source, settings)| recipe_json(&app, source, settings));
        let mut comments =
            recipe.map(|(source, settings)| recipe_comments(&app, &source, &settings, &request.values()));
        if let Some(line) = device_file_comment(&base, &request).filter(|_| device_file.is_none()) {
            comments = Some(format!("{line}{}", comments.unwrap_or_default()));
        }
        Ok(match format {
            "csv" => super::csv_response(
                super::to_csv(|w| {
                    w.write_all(comments.unwrap_or_default().as_bytes())?;
                    w.write_all(file_comment.as_bytes())?;
                    voltage.write_csv(w)
                })?,
                "voltage.csv",
            ),
            _ => {
                let mut answer = VoltageAnswer::new(request.values(), &voltage);
                answer.recipe = json_recipe;
                answer.device_file = provenance;
                Json(answer).into_response()
            }
        })
    })
    .await
}

/// Maps the profile (relative to its flat-surface friction when `relative`
/// says how to find it). The ranges of the device parameters, of flat_mu
/// and of the profile keep every result finite (`params`, `fields`); a
/// non-finite number would be a bug, answered 500 rather than as NaN or
/// null. `prefix` starts the field names of device errors (`device.` for
/// a JSON body).
pub(crate) fn compute(
    profile: &FrictionProfile,
    method: Method,
    request: &DeviceRequest,
    relative: Option<FlatMu>,
    prefix: &str,
) -> Result<VoltageProfile, ApiError> {
    let mapped = match relative {
        None => map_profile(profile, &request.device, method, request.fn_n),
        Some(flat) => map_profile_relative(profile, &request.device, method, request.fn_n, flat),
    };
    let voltage = mapped.map_err(|e| electro_error(e, prefix))?;
    let s = &voltage.summary;
    let finite = voltage.voltage_v.iter().all(|u| u.is_finite())
        && [s.fe_over_fn_per_v2, s.mu_at_u_max].iter().flatten().all(|v| v.is_finite() && *v > 0.0)
        && [&s.clipped, &s.not_renderable].iter().all(|r| finite_regions(r));
    if !finite {
        return Err(ApiError::internal("the voltage mapping gave a non-finite number for accepted input (a bug)"));
    }
    Ok(voltage)
}

fn finite_regions(r: &Regions) -> bool {
    r.length_mm.is_finite() && r.fraction_of_length.is_finite() && r.ranges_mm.iter().flatten().all(|x| x.is_finite())
}

/// Designs the drive of an ultrasonic or combined display (the core's
/// [`map_display`], as `haptex voltage --display` does), with the same
/// errors and guard as [`compute`].
pub(crate) fn compute_display(
    profile: &FrictionProfile,
    request: &DeviceRequest,
    relative: Option<FlatMu>,
    design: &DisplayDesign,
    prefix: &str,
) -> Result<DisplayProfile, ApiError> {
    let designed =
        map_display(profile, &request.device, design.channels(), request.fn_n, relative).map_err(|e| match e {
            DisplayError::Electro(e) => electro_error(e, prefix),
            DisplayError::Relative(r) => electro_error(ElectroError::Relative(r), prefix),
            DisplayError::OutOfRange(ref r) if r.name == "weight" => {
                ApiError::bad_request(e.to_string(), Some("weight"))
            }
            DisplayError::OutOfRange(_) => ApiError::bad_request(e.to_string(), None),
            DisplayError::Limit { .. } => ApiError::internal(format!("{e} (a bug)")),
        })?;
    let s = &designed.summary;
    let finite = designed.voltage_v.iter().chain(designed.amplitude_um.iter()).flatten().all(|v| v.is_finite())
        && s.band_mu.iter().all(|m| m.is_finite())
        && [&s.above_band, &s.below_band].iter().all(|r| finite_regions(r));
    if !finite {
        return Err(ApiError::internal("the display mapping gave a non-finite number for accepted input (a bug)"));
    }
    Ok(designed)
}

/// An error of the electrovibration mapping, naming the field at fault
/// (`prefix` starts the device's field names).
fn electro_error(e: ElectroError, prefix: &str) -> ApiError {
    match e {
        ElectroError::NormalForceRequired { exponent } => ApiError::bad_request(
            format!(
                "the contact-area law A = k Fn^n with n = {} makes the voltage depend on the normal force: give \
                 fn_n, or a profile with an fn_n column",
                Num(exponent)
            ),
            Some(&format!("{prefix}fn_n")),
        ),
        // mu_flat: out of range (checked before, so only mu_hd can be here,
        // and it was checked too), a median that is not a friction
        // coefficient, or a relative profile beyond the range of mu.
        ElectroError::Relative(RelativeError::OutOfRange(ref r)) if r.name == "mu_hd" => {
            ApiError::bad_request(e.to_string(), Some(&format!("{prefix}mu_hd")))
        }
        ElectroError::Relative(_) => ApiError::bad_request(e.to_string(), Some("flat_mu")),
        // Unreachable with the ranges of `params` and `fields`; named all
        // the same: a profile sample, or the device as a whole.
        ElectroError::NonFiniteVoltage { index, .. } => {
            let field = if prefix.is_empty() { "mu".to_string() } else { format!("profile.mu[{index}]") };
            ApiError::bad_request(e.to_string(), Some(&field))
        }
        other => ApiError::bad_request(other.to_string(), Some(prefix.trim_end_matches('.')).filter(|p| !p.is_empty())),
    }
}
