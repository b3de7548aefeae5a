//! Cropping: the loose crop (every map point near a target's expected position,
//! one streaming pass for all targets) and the automatic tight crop (ground
//! removed, the target's plates isolated).

mod loose;
mod tight;

pub use loose::{LooseCrop, LooseParams, Shape, loose_crop, loose_crop_each};
pub use tight::{TightCrop, TightError, TightParams, tight_crop};
