//! # mapgauge
//!
//! Measures how accurate a 3D point-cloud map built by LiDAR(-inertial) SLAM is,
//! from L-shaped targets whose corners were surveyed with RTK GNSS.
//!
//! Data flows one way: map → crop → locate → align → metrics → report.
#![deny(missing_docs)]

pub mod align;
pub mod cloud;
pub mod crop;
mod error;
pub mod eval;
pub mod locate;
pub mod metrics;
pub mod result;
pub mod survey;
pub mod synth;

pub use error::{Error, Result};

/// A point in a map or survey frame, metres, always f64.
pub type Point = nalgebra::Point3<f64>;
