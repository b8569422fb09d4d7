//! Errors of the recording format and pipeline. Every error on user input
//! names the file and, where it applies, the line (CSV), row (NPY) or
//! metadata field.

use std::fmt;

use crate::io::TableError;

/// Where in a file a problem is.
#[derive(Debug, Clone, PartialEq)]
pub enum Place {
    /// The whole file.
    File,
    /// 1-based line of a CSV file.
    Line(u64),
    /// 0-based row (numpy index) of an NPY array.
    Row(usize),
    /// A field of the metadata JSON, as a dotted path (`force.rate_hz`).
    Field(String),
}

/// A file, a place in it and optionally a column.
#[derive(Debug, Clone, PartialEq)]
pub struct Location {
    pub file: String,
    pub place: Place,
    pub column: Option<String>,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        match &self.place {
            Place::File => {}
            Place::Line(line) => write!(f, ", line {line}")?,
            Place::Row(row) => write!(f, ", row {row}")?,
            Place::Field(field) => write!(f, ", field '{field}'")?,
        }
        if let Some(column) = &self.column {
            write!(f, ", column '{column}'")?;
        }
        Ok(())
    }
}

/// A recording could not be read or processed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordingError {
    /// A file could not be read.
    #[error("{file}: cannot read: {message}")]
    Io { file: String, message: String },
    /// The metadata JSON is malformed (serde's message gives line and column).
    #[error("{file}: {message}")]
    Metadata { file: String, message: String },
    /// A CSV stream is malformed.
    #[error(transparent)]
    Table(#[from] TableError),
    /// The data are invalid at a place in a file.
    #[error("{at}: {message}")]
    Invalid { at: Location, message: String },
    /// The force and position streams do not belong together.
    #[error("{message}")]
    Mismatch { message: String },
    /// The pipeline found no sliding phase.
    #[error("{file}: no sliding found: {message}")]
    NoSliding { file: String, message: String },
    /// The pipeline cannot produce a profile for another reason.
    #[error("{file}: {message}")]
    Processing { file: String, message: String },
    /// A processing parameter is out of range.
    #[error("invalid processing parameter {name}: {message}")]
    Config { name: &'static str, message: String },
}

impl RecordingError {
    pub(crate) fn invalid(file: &str, place: Place, column: Option<&str>, message: impl Into<String>) -> Self {
        Self::Invalid {
            at: Location { file: file.to_string(), place, column: column.map(str::to_string) },
            message: message.into(),
        }
    }

    pub(crate) fn field(file: &str, field: &str, message: impl Into<String>) -> Self {
        Self::invalid(file, Place::Field(field.to_string()), None, message)
    }
}
