//! PLY reader (ascii, binary little and big endian).

use super::PointReader;
use crate::{Error, Result};
use std::path::Path;

/// Opens a PLY file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    Err(Error::format(path, "PLY reading is not implemented yet"))
}
