//! `POST /api/map` and `POST /api/map/path`: friction maps over (x, y)
//! from a grayscale image (docs/maps.md), as `haptex map from-image`,
//! `haptex map voltage` and `haptex map sample-path` make them.
//!
//! Body (JSON), both routes: `{"image_png_base64": "...", "mu_black":
//! 0.4, "mu_white": 1.2, "gamma": 1, "pixel_mm": 0.1, "pixel_mm_y": 0.1,
//! "x0_mm": 0, "y0_mm": 0, "method": "physical", "device": {...}}` (the
//! names are the command line's flags; `gamma`, `pixel_mm_y`, the origin,
//! `method` and `device` are optional, with the command line's defaults).
//! The image is an 8- or 16-bit grayscale PNG of at most
//! [`Limits::max_map_pixels`](crate::Limits::max_map_pixels) pixels (413
//! beyond, checked on its header before anything is decoded), one cell per
//! pixel, its top row at the largest y.
//!
//! `/api/map` answers the grid, the friction map `mu` and the voltage map
//! `voltage_v` (row by row from y0, index j nx + i) with the device limits
//! as areas. `/api/map/path` takes a finger path `"path": {"t_s": [..],
//! "x_mm": [..], "y_mm": [..]}` beside the same fields and answers the
//! voltage at each of its samples: the core's
//! [`PlanarTrajectory::sample`] of the voltage map, as `haptex map
//! sample-path` computes it (bilinear, the map's edge held beyond it);
//! `?format=csv` answers that command's CSV. The server keeps nothing
//! between requests: the page sends the image again with its path.

use std::collections::BTreeMap;

use axum::Json;
use axum::response::{IntoResponse, Response};
use haptex_core::electrovibration::{Method, PhysicalMapping};
use haptex_core::map::{FrictionMap, GrayMapping, MapError, MapGrid, VoltageMap, png_size};
use haptex_core::planar::PlanarTrajectory;
use haptex_core::trajectory::TrajectoryError;
use serde::{Deserialize, Serialize};

use crate::error::ApiError;
use crate::extract::{JSON_OR_CSV, Preamble, Route, Work};
use crate::input::{BodyKind, Pairs, check_points, parse_json};
use crate::params::DeviceRequest;

/// The name errors about the image give as their field.
const IMAGE: &str = "image_png_base64";

/// The working memory of a map per pixel, bytes (the request's memory
/// budget, [`crate::Limits::max_request_memory_bytes`]): the decoded
/// image (up to 2 bytes), the friction and voltage maps (8 bytes each)
/// and the answer's two numbers as text (up to 25 bytes each).
const MEMORY_PER_PIXEL: usize = 2 + 8 + 8 + 2 * 25;

/// The body of both routes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MapBody {
    /// The PNG's bytes, base64 (standard alphabet, padding optional).
    image_png_base64: String,
    mu_black: f64,
    mu_white: f64,
    #[serde(default)]
    gamma: Option<f64>,
    pixel_mm: f64,
    #[serde(default)]
    pixel_mm_y: Option<f64>,
    #[serde(default)]
    x0_mm: Option<f64>,
    #[serde(default)]
    y0_mm: Option<f64>,
    #[serde(default)]
    method: Option<Method>,
    #[serde(default)]
    device: Pairs,
    /// `/api/map/path` only.
    #[serde(default)]
    path: Option<PathJson>,
}

/// A finger path over the map.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PathJson {
    t_s: Vec<f64>,
    x_mm: Vec<f64>,
    y_mm: Vec<f64>,
}

/// The grid and the maps, as the core makes them.
struct Built {
    request: DeviceRequest,
    method: Method,
    mapping: GrayMapping,
    friction: FrictionMap,
    voltage: VoltageMap,
    bits: u8,
}

#[derive(Serialize)]
struct MapAnswer<'a> {
    parameters: BTreeMap<&'static str, f64>,
    method: Method,
    mapping: GrayMapping,
    grid: &'a MapGrid,
    /// Bits per pixel of the image (8 or 16).
    bits: u8,
    mu: &'a [f64],
    voltage_v: &'a [f64],
    u_max_v: f64,
    not_renderable_fraction: f64,
    clipped_fraction: f64,
    /// Eq. (8) only: the friction the display renders, [mu_HD, mu at
    /// U_max]; below it 0 V (not rendered), above it clipped at U_max.
    #[serde(skip_serializing_if = "Option::is_none")]
    band_mu: Option<[f64; 2]>,
}

#[derive(Serialize)]
struct PathAnswer<'a> {
    parameters: BTreeMap<&'static str, f64>,
    method: Method,
    grid: &'a MapGrid,
    t_s: &'a [f64],
    x_mm: &'a [f64],
    y_mm: &'a [f64],
    voltage_v: &'a [f64],
    /// Samples of the path outside the map (their voltage is the edge's).
    outside: usize,
}

/// `POST /api/map`: a JSON body, no query, heavy work.
pub(crate) struct Map;

impl Route for Map {
    const BODY: &'static [BodyKind] = &[BodyKind::Json];
    const WORK: Work = Work::Heavy;
}

/// `POST /api/map/path`: as [`Map`], answered as JSON or CSV.
pub(crate) struct MapPath;

impl Route for MapPath {
    const BODY: &'static [BodyKind] = &[BodyKind::Json];
    const FORMATS: &'static [&'static str] = JSON_OR_CSV;
    const WORK: Work = Work::Heavy;
}

/// `POST /api/map`.
pub async fn post(call: Preamble<Map>) -> Result<Response, ApiError> {
    let Preamble { state, bytes, slot, .. } = call;
    let limits = state.limits().clone();
    let base = state.default_device().device;
    slot.run(move || {
        let body: MapBody = parse_json(&bytes)?;
        if body.path.is_some() {
            return Err(ApiError::bad_request("a path is sampled by POST /api/map/path", Some("path")));
        }
        let b = build(body, &limits, &base)?;
        let answer = MapAnswer {
            parameters: b.request.values(),
            method: b.method,
            mapping: b.mapping,
            grid: &b.voltage.grid,
            bits: b.bits,
            mu: &b.friction.mu,
            voltage_v: &b.voltage.voltage_v,
            u_max_v: b.voltage.u_max_v,
            not_renderable_fraction: b.voltage.not_renderable_fraction,
            clipped_fraction: b.voltage.clipped_fraction,
            band_mu: (b.method == Method::Physical).then(|| {
                let d = &b.request.device;
                [d.mu_hd, PhysicalMapping::new(d.mu_hd, d.force_ratio_per_v2(1.0), d.u_max_v).mu_clip]
            }),
        };
        Ok(Json(answer).into_response())
    })
    .await
}

/// `POST /api/map/path`.
pub async fn path(call: Preamble<MapPath>) -> Result<Response, ApiError> {
    let Preamble { state, format, bytes, slot, .. } = call;
    let limits = state.limits().clone();
    let base = state.default_device().device;
    slot.run(move || {
        let mut body: MapBody = parse_json(&bytes)?;
        let path = body
            .path
            .take()
            .ok_or_else(|| ApiError::bad_request("a finger path {t_s, x_mm, y_mm} is required", Some("path")))?;
        check_points(path.t_s.len(), limits.max_points, "path.t_s")?;
        let path = PlanarTrajectory::new(path.t_s, path.x_mm, path.y_mm).map_err(|e| match e {
            TrajectoryError::Invalid { index, field, message } => {
                ApiError::bad_request(message, Some(&format!("path.{field}[{index}]")))
            }
            other => ApiError::bad_request(other.to_string(), Some("path")),
        })?;
        let b = build(body, &limits, &base)?;
        let v = &b.voltage;
        // What `haptex map sample-path` computes.
        let u = path.sample(&v.grid, &v.voltage_v);
        if u.iter().any(|u| !u.is_finite()) {
            return Err(ApiError::internal("a non-finite voltage sampled from a finite map (a bug)"));
        }
        if format == "csv" {
            return Ok(super::csv_response(
                super::to_csv(|w| {
                    writeln!(
                        w,
                        "# haptex map sample-path: voltage (V RMS) of the uploaded image's map along the path"
                    )?;
                    path.write_csv_with(w, "voltage_v", &u)
                })?,
                "map-path-voltage.csv",
            ));
        }
        let g = &v.grid;
        let outside = path.x_mm().iter().zip(path.y_mm()).filter(|&(&x, &y)| !g.contains(x, y)).count();
        let answer = PathAnswer {
            parameters: b.request.values(),
            method: b.method,
            grid: g,
            t_s: path.t_s(),
            x_mm: path.x_mm(),
            y_mm: path.y_mm(),
            voltage_v: &u,
            outside,
        };
        Ok(Json(answer).into_response())
    })
    .await
}

/// The image decoded with its mapping and the voltage map of it: the
/// core's `FrictionMap::read_gray_png` and `FrictionMap::voltages`, what
/// `haptex map from-image` and `haptex map voltage` call.
fn build(
    body: MapBody,
    limits: &crate::Limits,
    base: &haptex_core::electrovibration::Device,
) -> Result<Built, ApiError> {
    let png = decode_base64(&body.image_png_base64)
        .map_err(|m| ApiError::bad_request(format!("the image is not base64 text: {m}"), Some(IMAGE)))?;
    let (width, height) = png_size(&png, IMAGE).map_err(|e| ApiError::bad_request(e.message, Some(IMAGE)))?;
    let (max_pixels, pixels) = (limits.max_map_pixels, width.saturating_mul(height));
    if pixels > max_pixels {
        return Err(ApiError::too_large(
            format!(
                "{width} x {height} pixels: at most {max_pixels} pixels here (use haptex map from-image for larger)"
            ),
            Some(IMAGE),
        ));
    }
    // The request's memory budget, before anything is decoded.
    let memory = pixels.saturating_mul(MEMORY_PER_PIXEL);
    if memory > limits.max_request_memory_bytes {
        return Err(ApiError::too_large(
            format!(
                "{width} x {height} pixels take about {} MiB to map and answer, more than the {} MiB a request may \
                 take",
                memory.div_ceil(1 << 20),
                limits.max_request_memory_bytes >> 20
            ),
            Some(IMAGE),
        ));
    }
    let mapping = GrayMapping { mu_black: body.mu_black, mu_white: body.mu_white, gamma: body.gamma.unwrap_or(1.0) };
    let spacing = (body.pixel_mm, body.pixel_mm_y.unwrap_or(body.pixel_mm));
    let origin = (body.x0_mm.unwrap_or(0.0), body.y0_mm.unwrap_or(0.0));
    let request = DeviceRequest::from_pairs_over(body.device.iter(), "device.", base).map_err(device_words)?;
    let method = body.method.unwrap_or(Method::Physical);
    if method == Method::Physical && request.device.contact.exponent != 1.0 {
        return Err(ApiError::bad_request(
            "a friction map is mapped with the linear contact-area law (area exponent 1), as eq. (8)",
            Some("device.area_exponent"),
        ));
    }
    let friction = FrictionMap::read_gray_png(&png, &mapping, spacing, origin, IMAGE)
        .map_err(|e| map_error(e, body.pixel_mm_y.is_some()))?;
    let voltage = friction.voltages(&request.device, method).map_err(|e| map_error(e, false))?;
    if voltage.voltage_v.iter().any(|u| !u.is_finite()) {
        return Err(ApiError::internal("the voltage mapping gave a non-finite number for accepted input (a bug)"));
    }
    let bits = if png.len() > 24 && png[24] == 16 { 16 } else { 8 };
    Ok(Built { request, method, mapping, friction, voltage, bits })
}

/// A core map error with the request field it is about, in words: the
/// core names the grid's and the mapping's fields as its files do
/// (`dx_mm`, `mu`) after the source (here the image's field); the answer
/// names the request field in `field` and says the field's name in the
/// message as a person reads it ("pixel size must be a positive number of
/// mm, got -5"), not the image's field nor a column name.
fn map_error(e: MapError, pixel_y_given: bool) -> ApiError {
    let place = e.place.as_deref();
    let (field, name) = match (e.source_name.as_str(), place) {
        ("device", _) => ("device", None),
        (_, Some("mu_black")) => ("mu_black", Some("mu of black")),
        (_, Some("mu_white")) => ("mu_white", Some("mu of white")),
        (_, Some("gamma")) => ("gamma", Some("gamma")),
        (_, Some("x0_mm")) => ("x0_mm", Some("x of the first column")),
        (_, Some("y0_mm")) => ("y0_mm", Some("y of the bottom row")),
        (_, Some("dx_mm")) => ("pixel_mm", Some("pixel size")),
        (_, Some("x_mm")) => ("pixel_mm", Some("the last column's x")),
        (_, Some("dy_mm")) if pixel_y_given => ("pixel_mm_y", Some("pixel height")),
        (_, Some("dy_mm")) => ("pixel_mm", Some("pixel size")),
        (_, Some("y_mm")) if pixel_y_given => ("pixel_mm_y", Some("the top row's y")),
        (_, Some("y_mm")) => ("pixel_mm", Some("the top row's y")),
        _ => (IMAGE, None),
    };
    let message = match name {
        Some(name) => named(name, &e.message),
        None => e.message,
    };
    ApiError::bad_request(message, Some(field))
}

/// `message` about the field a person calls `name`: the core's own subject
/// ("spacing", a range's column name such as `mu` or `x_mm`) replaced by
/// the name, so that the sentence says what it is about.
fn named(name: &str, message: &str) -> String {
    let rest = ["spacing ", "mu ", "x_mm ", "y_mm "]
        .iter()
        .find_map(|subject| message.strip_prefix(subject).filter(|r| r.starts_with("must ")))
        .unwrap_or(message);
    let rest = rest.replace("mu_black", "mu of black");
    if rest.starts_with("must ") { format!("{name} {rest}") } else { format!("{name}: {rest}") }
}

/// A device parameter's refusal with the parameter's symbol (`mu_HD`,
/// `U_max`, as the paper writes them) where the message begins with its
/// API name (`mu_hd must be ...`); the field stays the API's path.
fn device_words(mut e: ApiError) -> ApiError {
    let name = e.field.as_deref().and_then(|f| f.strip_prefix("device.")).unwrap_or_default();
    if let Some(x) = crate::explain::EXPLANATIONS.iter().find(|x| x.field == name)
        && let Some(rest) = e.message.strip_prefix(name).filter(|r| r.starts_with(' '))
    {
        e.message = format!("{}{rest}", x.symbol);
    }
    e
}

/// Standard base64 (RFC 4648, `+` and `/`), padding optional, no
/// whitespace ([`base64`]'s decoder: linear in the text's length).
fn decode_base64(text: &str) -> Result<Vec<u8>, String> {
    use base64::Engine;
    use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
    const STANDARD_ANY_PADDING: GeneralPurpose = GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
    );
    STANDARD_ANY_PADDING.decode(text).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use haptex_core::map::MapError;

    use super::{decode_base64, device_words, map_error};
    use crate::error::ApiError;

    #[test]
    fn map_errors_name_the_field_in_words_not_the_image() {
        let e = |place: &str, message: &str| MapError {
            source_name: "image_png_base64".into(),
            place: Some(place.into()),
            message: message.into(),
        };
        for (place, message, y_given, field, words) in [
            (
                "dx_mm",
                "spacing must be a positive number of mm, got -5",
                false,
                "pixel_mm",
                "pixel size must be a positive number of mm, got -5",
            ),
            (
                "dy_mm",
                "spacing must be a positive number of mm, got 0",
                true,
                "pixel_mm_y",
                "pixel height must be a positive number of mm, got 0",
            ),
            (
                "mu_black",
                "mu must be from -1000 to 1000, got 1e9",
                false,
                "mu_black",
                "mu of black must be from -1000 to 1000, got 1e9",
            ),
            ("mu_white", "must differ from mu_black", false, "mu_white", "mu of white must differ from mu of black"),
            (
                "x0_mm",
                "x_mm must be from -1e6 to 1e6 mm, got -5e6",
                false,
                "x0_mm",
                "x of the first column must be from -1e6 to 1e6 mm, got -5e6",
            ),
            (
                "x_mm",
                "x_mm must be from -1e6 to 1e6 mm, got 2e6",
                false,
                "pixel_mm",
                "the last column's x must be from -1e6 to 1e6 mm, got 2e6",
            ),
        ] {
            let a = map_error(e(place, message), y_given);
            assert_eq!((a.field.as_deref(), a.message.as_str()), (Some(field), words));
        }
        let image =
            MapError { source_name: "image_png_base64".into(), place: None, message: "an RGB colour image".into() };
        let a = map_error(image, false);
        assert_eq!((a.field.as_deref(), a.message.as_str()), (Some("image_png_base64"), "an RGB colour image"));
    }

    #[test]
    fn device_refusals_say_the_papers_symbol() {
        let a = device_words(ApiError::bad_request("mu_hd must be from 0.001 to 10, got -1", Some("device.mu_hd")));
        assert_eq!(
            (a.field.as_deref(), a.message.as_str()),
            (Some("device.mu_hd"), "mu_HD must be from 0.001 to 10, got -1")
        );
        let a =
            device_words(ApiError::bad_request("u_max_v must be from 0.001 to 10000 V, got 0", Some("device.u_max_v")));
        assert_eq!(a.message, "U_max must be from 0.001 to 10000 V, got 0");
    }

    #[test]
    fn base64_decodes_the_rfc_4648_vectors_and_refuses_others() {
        for (text, bytes) in [
            ("", ""),
            ("Zg==", "f"),
            ("Zm8=", "fo"),
            ("Zm9v", "foo"),
            ("Zm9vYg==", "foob"),
            ("Zm9vYmE=", "fooba"),
            ("Zm9vYmFy", "foobar"),
            ("Zm9vYg", "foob"),
        ] {
            assert_eq!(decode_base64(text).unwrap(), bytes.as_bytes(), "{text}");
        }
        assert_eq!(decode_base64("//+/").unwrap(), [0xff, 0xff, 0xbf]);
        for bad in ["Zm9v!", "Z", "Zm9v====", "Zm 9v", "Zm9v\n"] {
            assert!(decode_base64(bad).is_err(), "{bad:?}");
        }
    }
}
