//! haptex errors as Python exceptions: the classes of `haptex._errors`
//! (`HaptexError`, under `ValueError` for bad input and `OSError` for a
//! file that cannot be read or written), with the message the command line
//! prints after `error: `.

use std::error::Error;

use pyo3::prelude::*;
use pyo3::types::PyType;

/// Which `haptex._errors` class an error is raised as.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// A value, file content or combination of options haptex refuses:
    /// `InvalidInputError` (a `ValueError`).
    Input,
    /// A file that cannot be opened, read or written: `HaptexOSError` (an
    /// `OSError`).
    Os,
    /// A computation that did not reach its result (an FE run that does
    /// not converge): `ComputationError`.
    Computation,
    /// The user stopped the work (a progress callback returned False):
    /// `CancelledError`.
    Cancelled,
}

impl Kind {
    fn class_name(self) -> &'static str {
        match self {
            Kind::Input => "InvalidInputError",
            Kind::Os => "HaptexOSError",
            Kind::Computation => "ComputationError",
            Kind::Cancelled => "CancelledError",
        }
    }
}

/// The exception `kind` with `message`.
pub fn raise(kind: Kind, message: impl Into<String>) -> PyErr {
    let message = message.into();
    Python::attach(|py| match class(py, kind) {
        Ok(class) => PyErr::from_type(class, message),
        Err(e) => e,
    })
}

fn class(py: Python<'_>, kind: Kind) -> PyResult<Bound<'_, PyType>> {
    Ok(py.import("haptex._errors")?.getattr(kind.class_name())?.cast_into::<PyType>()?)
}

/// A bad-input error with `message`.
pub fn input(message: impl Into<String>) -> PyErr {
    raise(Kind::Input, message)
}

/// The error and its causes as the command line prints them (`haptex`'s
/// `describe`): each cause whose text the message does not already
/// contain, after `: `.
pub fn describe(error: &(dyn Error + 'static)) -> String {
    let mut text = error.to_string();
    let mut cause = error.source();
    while let Some(c) = cause {
        let c_text = c.to_string();
        if !text.contains(&c_text) {
            text.push_str(": ");
            text.push_str(&c_text);
        }
        cause = c.source();
    }
    text
}

/// Whether an I/O error (not a content error read through one) is in the
/// chain: the file could not be opened, read or written.
fn is_os(error: &(dyn Error + 'static)) -> bool {
    let mut cause = Some(error);
    while let Some(c) = cause {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            return !matches!(io.kind(), std::io::ErrorKind::InvalidData | std::io::ErrorKind::InvalidInput);
        }
        cause = c.source();
    }
    false
}

/// A library error as the exception it is: `OSError` when a file could
/// not be reached, else bad input.
pub fn to_py(error: impl Error + 'static) -> PyErr {
    let kind = if is_os(&error) { Kind::Os } else { Kind::Input };
    raise(kind, describe(&error))
}

/// `map_err(err)`: a library result's error as its exception.
pub trait OrRaise<T> {
    fn or_raise(self) -> PyResult<T>;
}

impl<T, E: Error + 'static> OrRaise<T> for Result<T, E> {
    fn or_raise(self) -> PyResult<T> {
        self.map_err(to_py)
    }
}
