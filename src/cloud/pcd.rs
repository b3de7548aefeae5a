//! PCD reader (v0.5-v0.7; ascii, binary, binary_compressed).

use super::PointReader;
use crate::{Error, Result};
use std::path::Path;

/// Opens a PCD file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    Err(Error::format(path, "PCD reading is not implemented yet"))
}
