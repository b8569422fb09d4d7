//! Recorded finger strokes to location-domain friction profiles (paper
//! section 2.4), and synthetic recordings for testing and the demo library.
//!
//! - [`bundle`]: recordings from files held in memory (an upload);
//! - [`format`]: the raw recording format (metadata JSON + force and
//!   position streams in CSV or NPY) and its validation;
//! - [`filter`]: the anti-alias FIR filter and resampling to the position
//!   rate;
//! - [`sliding`]: finger velocity and sliding-phase detection;
//! - [`location`]: time-to-location resampling onto a uniform x grid;
//! - [`pipeline`]: the steps in order, with their parameters in
//!   [`ProcessingConfig`];
//! - [`synth`]: the stochastic model behind the shipped demo recordings;
//! - [`rng`]: the fixed random generator that makes them reproducible.

pub mod bundle;
pub mod error;
pub mod filter;
pub mod format;
pub mod location;
pub mod pipeline;
pub mod rng;
pub mod sliding;
pub mod synth;

pub use error::{Location, Place, RecordingError};
pub use format::{ForceStream, PositionStream, Recording, RecordingMeta, StreamFormat, StreamMeta, Units};
pub use pipeline::{DirectionFilter, ProcessedStroke, ProcessingConfig, friction_coefficient, process};
pub use sliding::{Direction, DroppedRun, SlidingSegment};
