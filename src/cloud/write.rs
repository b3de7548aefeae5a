//! PLY and PCD writers, atomic (temporary sibling, then rename).

use super::Sink;
use crate::{Error, Result};
use std::path::Path;

/// Starts a binary PLY writer.
pub(super) fn ply_sink(path: &Path) -> Result<Box<dyn Sink>> {
    Err(Error::format(path, "PLY writing is not implemented yet"))
}

/// Starts a binary PCD writer.
pub(super) fn pcd_sink(path: &Path) -> Result<Box<dyn Sink>> {
    Err(Error::format(path, "PCD writing is not implemented yet"))
}
