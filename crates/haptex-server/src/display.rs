//! The friction display a request designs for: electrovibration (eq. 8,
//! the default), ultrasonic friction reduction, or both combined
//! (docs/physics.md, "The combined display"), as `haptex voltage
//! --display --strategy --weight --ultrasonic-calibration --a-max-um`
//! takes it, with the same checks and the core's types
//! ([`haptex_core::combined`], [`haptex_core::ultrasonic`]).
//!
//! Request fields (JSON body; the query string of a `text/csv` body takes
//! all but the calibration): `display`, `strategy`, `weight`, `a_max_um`,
//! `ultrasonic_calibration` (the calibration CSV's text,
//! `amplitude_um,relative_friction`, at most [`MAX_CALIBRATION_BYTES`]).
//! Every error names its field; a calibration error also its line and
//! column, as the command line's reader does.

use haptex_core::combined::{Channels, Strategy};
use haptex_core::io::TableError;
use haptex_core::ranges;
use haptex_core::ultrasonic::{Calibration, UltrasonicDevice, UltrasonicError};
use serde::Deserialize;

use crate::error::{ApiError, quote};
use crate::fields;

/// Longest calibration text accepted, in bytes: 256 KiB, room for the
/// core's [`haptex_core::ultrasonic::MAX_CALIBRATION_ROWS`] rows of two
/// numbers (a measured calibration has tens of rows).
pub const MAX_CALIBRATION_BYTES: usize = 256 * 1024;

/// The weight of the `weighted` strategy when none is given (as the
/// command line's `--weight` default).
pub const DEFAULT_WEIGHT: f64 = 1.0;

/// Which display: `display` in a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DisplayName {
    #[default]
    Electrovibration,
    Ultrasonic,
    Combined,
}

/// The combined display's strategy: `strategy` in a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StrategyName {
    Split,
    Bias,
    Weighted,
}

/// The display fields of a request, as given.
#[derive(Debug, Clone, Default)]
pub struct DisplayRequest {
    pub display: Option<DisplayName>,
    pub strategy: Option<StrategyName>,
    pub weight: Option<f64>,
    pub a_max_um: Option<f64>,
    /// The calibration CSV's text.
    pub ultrasonic_calibration: Option<String>,
}

/// A checked display: the ultrasonic device and the strategy, for the
/// ultrasonic and combined displays.
#[derive(Debug, Clone)]
pub struct DisplayDesign {
    pub ultrasonic: UltrasonicDevice,
    /// `None` for the ultrasonic display alone.
    pub strategy: Option<Strategy>,
}

impl DisplayDesign {
    /// The channels for [`haptex_core::combined::map_display`].
    pub fn channels(&self) -> Channels<'_> {
        match self.strategy {
            Some(strategy) => Channels::Combined(&self.ultrasonic, strategy),
            None => Channels::Ultrasonic(&self.ultrasonic),
        }
    }
}

impl DisplayRequest {
    /// Reads the display fields of a query string (`text/csv` bodies).
    pub fn from_query(query: &mut crate::input::Query) -> Result<Self, ApiError> {
        if query.take("ultrasonic_calibration").is_some() {
            return Err(ApiError::bad_request(
                "the ultrasonic calibration is a file: send it in a JSON body (ultrasonic_calibration, the CSV's \
                 text), not in the query string",
                Some("ultrasonic_calibration"),
            ));
        }
        let display = query.take("display").map(|t| parse_name(&t, "display")).transpose()?;
        let strategy = query.take("strategy").map(|t| parse_name(&t, "strategy")).transpose()?;
        let weight = query.take("weight").map(|t| crate::input::parse_number(&t, "weight")).transpose()?;
        let a_max_um = query.take("a_max_um").map(|t| crate::input::parse_number(&t, "a_max_um")).transpose()?;
        Ok(Self { display, strategy, weight, a_max_um, ultrasonic_calibration: None })
    }

    /// Whether the request asks for the electrovibration display (given
    /// or by default).
    pub fn is_electrovibration(&self) -> bool {
        self.display.unwrap_or_default() == DisplayName::Electrovibration
    }

    /// Checks the fields: `None` for the electrovibration display (which
    /// refuses the others' fields rather than ignoring them), else the
    /// ultrasonic device (the calibration given, or the literature
    /// default, a placeholder) and the strategy.
    pub fn design(&self) -> Result<Option<DisplayDesign>, ApiError> {
        let display = self.display.unwrap_or_default();
        if display == DisplayName::Electrovibration {
            for (given, field) in [
                (self.strategy.is_some(), "strategy"),
                (self.weight.is_some(), "weight"),
                (self.a_max_um.is_some(), "a_max_um"),
                (self.ultrasonic_calibration.is_some(), "ultrasonic_calibration"),
            ] {
                if given {
                    return Err(ApiError::bad_request(
                        format!(
                            "{field} is for an ultrasonic or combined display: give display ultrasonic or combined"
                        ),
                        Some(field),
                    ));
                }
            }
            return Ok(None);
        }
        if display != DisplayName::Combined {
            for (given, field) in [(self.strategy.is_some(), "strategy"), (self.weight.is_some(), "weight")] {
                if given {
                    return Err(ApiError::bad_request(
                        format!("{field} shares a target between two channels: give display combined"),
                        Some(field),
                    ));
                }
            }
        }
        if self.weight.is_some() && self.strategy != Some(StrategyName::Weighted) {
            return Err(ApiError::bad_request(
                "weight is the weighted strategy's: give strategy weighted",
                Some("weight"),
            ));
        }
        let weight = self.weight.map(|w| fields::check(ranges::STRATEGY_WEIGHT, w, "weight")).transpose()?;
        let a_max_um = self.a_max_um.map(|a| fields::check(ranges::A_MAX_UM, a, "a_max_um")).transpose()?;
        let ultrasonic = match &self.ultrasonic_calibration {
            Some(text) => {
                if text.len() > MAX_CALIBRATION_BYTES {
                    return Err(ApiError::too_large(
                        format!(
                            "the calibration is {} bytes, more than the limit of {MAX_CALIBRATION_BYTES}",
                            text.len()
                        ),
                        Some("ultrasonic_calibration"),
                    ));
                }
                let calibration =
                    Calibration::read_csv(text.as_bytes(), "ultrasonic_calibration").map_err(ultrasonic_error)?;
                UltrasonicDevice::calibrated(calibration, a_max_um)
            }
            None => UltrasonicDevice::literature_default(a_max_um),
        }
        .map_err(ultrasonic_error)?;
        let strategy = (display == DisplayName::Combined).then(|| match self.strategy.unwrap_or(StrategyName::Split) {
            StrategyName::Split => Strategy::Split,
            StrategyName::Bias => Strategy::Bias,
            StrategyName::Weighted => Strategy::Weighted { weight: weight.unwrap_or(DEFAULT_WEIGHT) },
        });
        Ok(Some(DisplayDesign { ultrasonic, strategy }))
    }
}

/// Parses `display` or `strategy` given as text (a query parameter).
fn parse_name<T: serde::de::DeserializeOwned>(text: &str, field: &str) -> Result<T, ApiError> {
    let known = if field == "display" { "electrovibration, ultrasonic or combined" } else { "split, bias or weighted" };
    serde_json::from_value(serde_json::Value::String(text.to_string()))
        .map_err(|_| ApiError::bad_request(format!("unknown {field} {}: use {known}", quote(text)), Some(field)))
}

/// An ultrasonic device error: the calibration's (with its line and
/// column) or a_max's. Messages written for the command line name the
/// page's controls instead ([`crate::explain::for_page`]).
pub(crate) fn ultrasonic_error(error: UltrasonicError) -> ApiError {
    match error {
        UltrasonicError::Table(t) => calibration_table_error(t),
        UltrasonicError::Invalid { .. } => {
            ApiError::bad_request(crate::explain::for_page(&error.to_string()), Some("ultrasonic_calibration"))
        }
        UltrasonicError::OutOfRange(_) | UltrasonicError::BeyondModel { .. } => {
            ApiError::bad_request(crate::explain::for_page(&error.to_string()), Some("a_max_um"))
        }
    }
}

/// A calibration CSV error: the field is `ultrasonic_calibration`, with
/// the line and the column (the message names both, as the command line's
/// reader says them).
fn calibration_table_error(error: TableError) -> ApiError {
    let column = error.column.clone();
    ApiError::bad_request(error.to_string(), Some("ultrasonic_calibration")).with_line(error.line).with_column(column)
}
