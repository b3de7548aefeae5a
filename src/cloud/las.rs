//! LAS/LAZ reader and LAS writer.

use super::PointReader;
use crate::{Error, Result};
use std::path::Path;

/// Opens a LAS file for streaming.
pub(super) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    Err(Error::format(path, "LAS reading is not implemented yet"))
}

/// Starts a LAS writer.
pub(super) fn las_sink(path: &Path) -> Result<Box<dyn super::Sink>> {
    Err(Error::format(path, "LAS writing is not implemented yet"))
}
