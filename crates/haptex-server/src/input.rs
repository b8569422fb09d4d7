//! Request input: bodies (JSON or `text/csv`), query strings, and the
//! friction profiles and trajectories they carry, each error turned into an
//! [`ApiError`] naming the field (a JSON path such as `profile.mu[3]`, a
//! query parameter, or a CSV column with its line).

use std::collections::HashSet;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::http::{HeaderMap, StatusCode, header};
use haptex_core::io::{Table, TableError};
use haptex_core::profile::{FrictionProfile, ProfileError};
use haptex_core::trajectory::{Trajectory, TrajectoryError};
use serde::Deserialize;
use serde::de::DeserializeOwned;

use crate::error::{ApiError, quote};

/// The format of a request body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyKind {
    /// `application/json`
    Json,
    /// `text/csv`: a haptex CSV file as the body (the upload path).
    Csv,
}

/// The body kind from `Content-Type`; 415 if it is missing or not one of
/// `accepted`.
pub fn body_kind(headers: &HeaderMap, accepted: &[BodyKind]) -> Result<BodyKind, ApiError> {
    let names = |kinds: &[BodyKind]| {
        kinds
            .iter()
            .map(|k| match k {
                BodyKind::Json => "application/json",
                BodyKind::Csv => "text/csv",
            })
            .collect::<Vec<_>>()
            .join(" or ")
    };
    let Some(value) = headers.get(header::CONTENT_TYPE) else {
        return Err(ApiError::unsupported_media_type(format!("no Content-Type: send {}", names(accepted))));
    };
    let essence = value.to_str().unwrap_or("").split(';').next().unwrap_or("").trim().to_ascii_lowercase();
    let kind = match essence.as_str() {
        "application/json" => Some(BodyKind::Json),
        "text/csv" => Some(BodyKind::Csv),
        _ => None,
    };
    match kind {
        Some(k) if accepted.contains(&k) => Ok(k),
        _ => Err(ApiError::unsupported_media_type(format!(
            "Content-Type {} is not accepted here: send {}",
            quote(value.to_str().unwrap_or("(not text)")),
            names(accepted)
        ))),
    }
}

/// The body bytes, or the error of reading them (413 past the body limit).
pub fn body_bytes(body: Result<Bytes, BytesRejection>, max_body_bytes: usize) -> Result<Bytes, ApiError> {
    match body {
        Ok(bytes) if bytes.is_empty() => Err(ApiError::bad_request("the request body is empty", Some("body"))),
        Ok(bytes) => Ok(bytes),
        Err(rejection) if rejection.status() == StatusCode::PAYLOAD_TOO_LARGE => Err(ApiError::too_large(
            format!("the request body is larger than the limit of {max_body_bytes} bytes"),
            Some("body"),
        )),
        Err(rejection) => Err(ApiError::new(rejection.status(), rejection.body_text(), Some("body"))),
    }
}

/// Parses a JSON body, an object (every body of this API is one); errors
/// name the JSON path of the bad value (a field given twice is named
/// too).
pub fn parse_json<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, ApiError> {
    // serde would also read a struct from an array of its fields in order.
    if bytes.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
        return Err(ApiError::bad_request("the body must be a JSON object ({...})", Some("body")));
    }
    let mut deserializer = serde_json::Deserializer::from_slice(bytes);
    let value = serde_path_to_error::deserialize(&mut deserializer).map_err(|e| {
        let path = e.path().to_string();
        // "." is the whole body, "?" a position serde could not name (a
        // truncated document).
        let field = if path == "." || path == "?" { "body".to_string() } else { path };
        let message = e.inner().to_string();
        // Past the nesting limit the path is a pile of "[0]": name the
        // top-level field it is in.
        let field = if message.starts_with("recursion limit exceeded") {
            field.split(['.', '[']).next().filter(|f| !f.is_empty()).unwrap_or("body").to_string()
        } else {
            field
        };
        let field = match duplicate_field(&message) {
            Some(name) if field == "body" => name.to_string(),
            Some(name) if !field.ends_with(name) => format!("{field}.{name}"),
            _ => field,
        };
        ApiError::bad_request(format!("invalid JSON body: {message}"), Some(&field))
    })?;
    deserializer.end().map_err(|e| ApiError::bad_request(format!("invalid JSON body: {e}"), Some("body")))?;
    Ok(value)
}

/// The name in serde's "duplicate field `name`" message.
fn duplicate_field(message: &str) -> Option<&str> {
    message.strip_prefix("duplicate field `")?.split('`').next()
}

/// A query string as `name=value` pairs, consumed parameter by parameter;
/// [`Query::finish`] refuses whatever is left (unknown parameters).
#[derive(Debug, Default)]
pub struct Query {
    pairs: Vec<(String, String)>,
}

impl Query {
    /// Parses a raw query string (`None`: no query).
    pub fn parse(raw: Option<&str>) -> Result<Self, ApiError> {
        let pairs: Vec<(String, String)> = serde_urlencoded::from_str(raw.unwrap_or(""))
            .map_err(|e| ApiError::bad_request(format!("malformed query string: {e}"), Some("query")))?;
        let mut seen = HashSet::with_capacity(pairs.len());
        if let Some((name, _)) = pairs.iter().find(|(name, _)| !seen.insert(name.as_str())) {
            return Err(ApiError::bad_request("parameter given twice", Some(name)));
        }
        Ok(Self { pairs })
    }

    /// Takes the text of parameter `name`, if given.
    pub fn take(&mut self, name: &str) -> Option<String> {
        let i = self.pairs.iter().position(|(n, _)| n == name)?;
        Some(self.pairs.remove(i).1)
    }

    /// Takes every remaining parameter (for tables of named parameters).
    pub fn take_all(&mut self) -> Vec<(String, String)> {
        std::mem::take(&mut self.pairs)
    }

    /// Takes a non-negative integer parameter.
    pub fn take_u64(&mut self, name: &str) -> Result<Option<u64>, ApiError> {
        self.take(name)
            .map(|text| {
                text.trim().parse::<u64>().map_err(|_| {
                    ApiError::bad_request(
                        format!("{name} must be a whole number from 0 to 2^64-1, got {}", quote(&text)),
                        Some(name),
                    )
                })
            })
            .transpose()
    }

    /// Takes the `format` parameter: one of `allowed` (default: the first).
    pub fn take_format(&mut self, allowed: &[&'static str]) -> Result<&'static str, ApiError> {
        match self.take("format") {
            None => Ok(allowed[0]),
            Some(text) => allowed.iter().copied().find(|a| *a == text).ok_or_else(|| {
                ApiError::bad_request(
                    format!("unknown format {}: use {}", quote(&text), allowed.join(" or ")),
                    Some("format"),
                )
            }),
        }
    }

    /// Refuses any parameter not taken.
    pub fn finish(self) -> Result<(), ApiError> {
        match self.pairs.first() {
            None => Ok(()),
            Some((name, _)) => Err(ApiError::bad_request("unknown query parameter", Some(name))),
        }
    }
}

/// Parses a number given as text (a query parameter).
pub fn parse_number(text: &str, field: &str) -> Result<f64, ApiError> {
    let value: f64 = text
        .trim()
        .parse()
        .map_err(|_| ApiError::bad_request(format!("not a number: {}", quote(text)), Some(field)))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ApiError::bad_request(format!("not a finite number: {}", quote(text)), Some(field)))
    }
}

/// A JSON object of numbers as `(name, value)` pairs in the order given,
/// a name given twice kept twice (so that it can be refused, where a map
/// would silently keep the last value).
#[derive(Debug, Clone, Default)]
pub struct Pairs(pub Vec<(String, f64)>);

impl Pairs {
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> {
        self.0.iter().map(|(k, v)| (k.as_str(), *v))
    }
}

impl<'de> Deserialize<'de> for Pairs {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = Pairs;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an object of numbers")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Pairs, A::Error> {
                let mut pairs = Vec::new();
                while let Some(entry) = map.next_entry::<String, f64>()? {
                    pairs.push(entry);
                }
                Ok(Pairs(pairs))
            }
        }
        deserializer.deserialize_map(Visitor)
    }
}

/// A friction profile in JSON: `x_mm` plus `mu`, or `x_mm` plus `ft_n`
/// and `fn_n` (mu = ft/fn, paper eq. 4); `fn_n` may come with `mu` too.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileJson {
    pub x_mm: Vec<f64>,
    #[serde(default)]
    pub mu: Option<Vec<f64>>,
    #[serde(default)]
    pub ft_n: Option<Vec<f64>>,
    #[serde(default)]
    pub fn_n: Option<Vec<f64>>,
}

impl ProfileJson {
    /// Validates the profile; `prefix` (e.g. `profile.`) starts the field
    /// names of errors.
    pub fn into_profile(self, prefix: &str, max_points: usize) -> Result<FrictionProfile, ApiError> {
        check_points(self.x_mm.len(), max_points, &format!("{prefix}x_mm"))?;
        // haptex-core checks every column against its range
        // (haptex_core::ranges, as for a file), and mu = ft/fn after the
        // division; its errors name the column and sample.
        let at = |e: ProfileError| profile_error(e, prefix);
        let profile = match (self.mu, self.ft_n, self.fn_n) {
            (Some(mu), None, fn_n) => {
                let profile = FrictionProfile::new(self.x_mm, mu).map_err(at)?;
                match fn_n {
                    Some(f) => profile.with_normal_force(f).map_err(at)?,
                    None => profile,
                }
            }
            (None, Some(ft), Some(fn_n)) => FrictionProfile::from_forces(self.x_mm, &ft, fn_n).map_err(at)?,
            (Some(_), Some(_), _) => {
                return Err(ApiError::bad_request(
                    "give mu, or ft_n and fn_n, not both",
                    Some(&format!("{prefix}ft_n")),
                ));
            }
            (None, _, _) => {
                return Err(ApiError::bad_request(
                    "a profile needs mu (or ft_n and fn_n) beside x_mm",
                    Some(&format!("{prefix}mu")),
                ));
            }
        };
        Ok(profile)
    }
}

/// Reads a friction profile CSV body (`x_mm,mu` or `x_mm,ft_n,fn_n`);
/// errors name the line and column.
pub fn profile_from_csv(bytes: &[u8], max_points: usize) -> Result<FrictionProfile, ApiError> {
    let table = Table::read(bytes, "request body").map_err(table_error)?;
    check_points(table.n_rows(), max_points, "body")?;
    FrictionProfile::from_table(&table).map_err(|e| profile_error(e, ""))
}

/// A finger trajectory in JSON: times in s and positions in mm.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrajectoryJson {
    pub t_s: Vec<f64>,
    pub x_mm: Vec<f64>,
}

impl TrajectoryJson {
    pub fn into_trajectory(self, prefix: &str, max_points: usize) -> Result<Trajectory, ApiError> {
        check_points(self.t_s.len(), max_points, &format!("{prefix}t_s"))?;
        Trajectory::new(self.t_s, self.x_mm).map_err(|e| match e {
            TrajectoryError::Table(t) => table_error(t),
            TrajectoryError::Invalid { index, field, message } => {
                ApiError::bad_request(message, Some(&format!("{prefix}{field}[{index}]")))
            }
            TrajectoryError::Generator(message) => ApiError::bad_request(message, Some(prefix.trim_end_matches('.'))),
        })
    }
}

/// 413 if `n` exceeds the point limit.
pub fn check_points(n: usize, max_points: usize, field: &str) -> Result<(), ApiError> {
    if n > max_points {
        Err(ApiError::too_large(format!("{n} points: more than the limit of {max_points}"), Some(field)))
    } else {
        Ok(())
    }
}

pub(crate) fn profile_error(error: ProfileError, prefix: &str) -> ApiError {
    match error {
        ProfileError::Table(t) => table_error(t),
        ProfileError::Invalid { index, field, message } => {
            ApiError::bad_request(message, Some(&format!("{prefix}{field}[{index}]")))
        }
        ProfileError::Resample(message) => ApiError::bad_request(message, None),
    }
}

/// A CSV error: the message names the line and column; `field` is the
/// column (or `body` when the error is not tied to one), `line` the line.
fn table_error(error: TableError) -> ApiError {
    let field = error.column.clone().unwrap_or_else(|| "body".to_string());
    ApiError::bad_request(error.to_string(), Some(&field)).with_line(error.line)
}
