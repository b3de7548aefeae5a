//! Where the map is: its vertical ([`level`]), and the transform that puts the
//! survey on it when the map is in a frame of its own ([`matching`], [`hints`]).
//! Everything here runs before the targets are cropped; its product is where
//! to look and which way is up.

pub(crate) mod grid;
pub mod hints;
pub mod level;
pub mod matching;

pub use level::{GroundLevel, MapGround, ground_level};
