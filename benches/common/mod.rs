//! What the benchmarks share.

use std::path::Path;

/// Reads `path` to the end in 128 KiB blocks (what GNU `cat` does), returning
/// the bytes read: the floor a reader of a page-cached file is measured by.
pub fn cat(path: &Path) -> u64 {
    use std::io::Read;
    let mut f = std::fs::File::open(path).unwrap();
    let mut block = vec![0u8; 128 << 10];
    let mut n = 0u64;
    loop {
        let k = f.read(&mut block).unwrap();
        if k == 0 {
            return n;
        }
        n += k as u64;
    }
}
