//! XYZ / CSV text reader.

use super::PointReader;
use crate::{Error, Result};
use std::path::Path;

/// Opens a XYZ file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    Err(Error::format(path, "XYZ reading is not implemented yet"))
}
