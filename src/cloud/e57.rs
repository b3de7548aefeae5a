//! E57 reader.

use super::PointReader;
use crate::{Error, Result};
use std::path::Path;

/// Opens a E57 file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    Err(Error::format(path, "E57 reading is not implemented yet"))
}
