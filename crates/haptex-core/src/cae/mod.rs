//! Conditional average estimator (CAE): Gaussian-kernel conditional
//! averaging over a model matrix (paper section 2.4, eqs. 10-12; Perus,
//! Poljansek & Fajfar 2006), with kernel widths chosen by leave-one-out.
//!
//! The pieces, one per module:
//!
//! - [`ModelMatrix`] (`matrix`): the database X = {B, C} read from a CSV
//!   table, inputs and outputs stored row by row (eq. 10);
//! - [`Normalization`] (`normalize`): each input mapped to [0, 1] over the
//!   database, constant inputs set aside;
//! - [`Widths`], [`Density`] and [`Kernel`] (`widths`): the kernel widths
//!   w_nl, constant or between w_min and w_max by the local density of model
//!   vectors, and the log-space Gaussian of eq. (12);
//! - [`Cae`] (`predict`): prediction by eq. (11) into a caller's buffer,
//!   without allocation, with a per-query extrapolation diagnostic; its
//!   outputs also laid out for one sequential read (`panels`) and the rows
//!   that cannot matter left out (`prune`);
//! - [`Loo`] and [`optimize_widths`] (`loo`): leave-one-out error and the
//!   search for the widths that minimize it;
//! - `nelder_mead`: the simplex minimizer that search uses.
//!
//! Widths are in normalized input units (the database spans [0, 1] in every
//! input). `docs/cae.md` states the equations, the width rule and the
//! extrapolation threshold.

mod loo;
mod matrix;
pub mod nelder_mead;
mod normalize;
mod panels;
mod predict;
mod prune;
mod widths;

pub use loo::{
    DEFAULT_LOO_MEMORY_BYTES, Loo, LooErrors, LooReport, OptimizeOptions, OptimizerReport, ScanPoint, WidthOptimum,
    optimize_widths,
};
pub use matrix::ModelMatrix;
pub use normalize::Normalization;
pub use predict::{
    BATCH_BLOCK, BatchScratch, Cae, Diagnostics, EXTRAPOLATION_KERNEL_DISTANCE, LOG_WEIGHT_CUTOFF, Scratch,
};
pub use prune::PRUNE_RELATIVE;
pub use widths::{Density, Kernel, Widths};

use crate::io::TableError;

/// A model matrix, a width or a query is invalid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CaeError {
    /// A problem in the model file, located by file, line and column.
    #[error(transparent)]
    Table(#[from] TableError),
    /// The list of input names is unusable (empty, a name given twice).
    #[error("{0}")]
    Inputs(String),
    /// In-memory model data failed validation.
    #[error("{0}")]
    Invalid(String),
    /// A kernel width is not a positive finite number, or w_min > w_max.
    #[error("{0}")]
    Width(String),
    /// A query has the wrong number of inputs or a non-finite value.
    #[error("{0}")]
    Query(String),
    /// Query `index` (0-based) of a batch has the wrong number of inputs
    /// or a non-finite value.
    #[error("query {}: {message}", index + 1)]
    BatchQuery { index: usize, message: String },
    /// The work asked for needs more memory than its budget.
    #[error("{0}")]
    TooLarge(String),
}
