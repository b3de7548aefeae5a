//! Third-party decoders on a thread of their own: a [`Producer`] runs a
//! reader body on a background thread and hands blocks of points over a
//! bounded channel (for crates whose readers are not `Send` or borrow
//! themselves, and to overlap decoding with the caller's work), and
//! [`on_reader_thread`] runs a one-off parse there. A panic inside a
//! decoder becomes the file's one-line error instead of ending the process.

use super::{CloudInfo, Format, PointReader, ReadStats};
use crate::{Error, Point, Result};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

/// A message from a reader thread.
pub(super) enum Msg {
    /// Header facts, sent first, and whether the chunks carry intensities.
    Info(CloudInfo, bool),
    /// A block of finite points, their intensities (empty when the cloud has
    /// none), the non-finite/invalid points skipped while producing it, and
    /// the bytes of the file consumed so far.
    Chunk(Vec<Point>, Vec<f32>, u64, u64),
    /// The cloud is exhausted; skipped points since the last chunk.
    Done(u64),
    /// Reading failed.
    Err(Error),
}

/// The sending side given to a reader thread's body.
pub(super) struct Tx {
    tx: SyncSender<Msg>,
    recycle: Receiver<Vec<Point>>,
}

impl Tx {
    /// Sends a message; false when the consumer has gone away (stop reading).
    pub(super) fn send(&self, m: Msg) -> bool {
        self.tx.send(m).is_ok()
    }
    /// An empty buffer to fill, reusing one the consumer handed back.
    pub(super) fn buffer(&self) -> Vec<Point> {
        let mut v = self.recycle.try_recv().unwrap_or_default();
        v.clear();
        v
    }
}

/// A [`PointReader`] fed by a background thread (for crates whose readers are not
/// `Send` or borrow themselves). A panic in the thread becomes an error.
pub(super) struct Producer {
    path: PathBuf,
    info: CloudInfo,
    rx: Receiver<Msg>,
    recycle: SyncSender<Vec<Point>>,
    stats: ReadStats,
    bytes: u64,
    done: bool,
    /// The chunks carry intensities.
    intensity: bool,
}

/// Name of the threads that run third-party decoders.
pub(super) const READER_THREAD: &str = "mapgauge-reader";

/// A rayon pool of reader-named threads, as large as the caller's pool, for a
/// decoder crate that parallelises on rayon (the `laz` crate): run inside it
/// (`install`), a panic on one of its workers (laz 0.13 indexes out of bounds
/// on some malformed chunks) stays quiet like any reader thread's, and rayon
/// hands it back to the reader thread, where it becomes the file's error. On
/// the global pool every panic hook sees it first, and a hook that aborts
/// (libFuzzer's) ends the process before the panic can be caught. One pool
/// per reader: a shared one could run one reader's whole body inside another's
/// wait. `None` when threads cannot be started (then decode on the global pool).
pub(super) fn reader_pool() -> Option<rayon::ThreadPool> {
    quiet_reader_panics();
    rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .thread_name(|_| READER_THREAD.into())
        .build()
        .ok()
}

/// Runs `f` on a reader thread and waits for it: a panic inside a third-party
/// parser becomes `path`'s one-line error instead of ending the process.
pub(super) fn on_reader_thread<T: Send>(
    path: &Path,
    f: impl FnOnce() -> Result<T> + Send,
) -> Result<T> {
    quiet_reader_panics();
    std::thread::scope(|s| {
        let handle = std::thread::Builder::new()
            .name(READER_THREAD.into())
            .spawn_scoped(s, f)
            .map_err(|e| Error::io(path, e))?;
        handle.join().unwrap_or_else(|panic| {
            Err(Error::format(
                path,
                format!(
                    "the decoder failed on malformed data ({})",
                    panic_text(&*panic)
                ),
            ))
        })
    })
}

/// The message of a caught panic.
pub(super) fn panic_text(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown cause".into())
}

/// Installs (once) a panic hook that stays silent for reader threads, whose
/// panics are caught and reported as one-line errors; every other panic is
/// reported by the previous hook as usual.
pub(super) fn quiet_reader_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let prev = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if std::thread::current().name() != Some(READER_THREAD) {
                prev(info);
            }
        }));
    });
}

impl Producer {
    /// Runs `body` on a new thread; it must send `Msg::Info` first, then chunks,
    /// then `Msg::Done` (or `Msg::Err`). Waits for the header.
    pub(super) fn spawn(path: &Path, body: impl FnOnce(Tx) + Send + 'static) -> Result<Self> {
        let (tx, rx) = sync_channel(1);
        let (recycle, back) = sync_channel(2);
        let p = path.to_path_buf();
        quiet_reader_panics();
        std::thread::Builder::new()
            .name(READER_THREAD.into())
            .spawn(move || {
                let err = tx.clone();
                // A decoder crate that panics on a malformed file (the `laz`
                // crate asserts on some lying headers) must not take the process
                // down: its panic becomes this file's error.
                let run = std::panic::AssertUnwindSafe(move || body(Tx { tx, recycle: back }));
                if let Err(panic) = std::panic::catch_unwind(run) {
                    let _ = err.send(Msg::Err(Error::format(
                        &p,
                        format!(
                            "the decoder failed on malformed data ({})",
                            panic_text(&*panic)
                        ),
                    )));
                }
            })
            .map_err(|e| Error::io(path, e))?;
        let mut p = Producer {
            path: path.to_path_buf(),
            info: CloudInfo {
                format: Format::Las,
                declared_points: None,
                file_bytes: 0,
            },
            rx,
            recycle,
            stats: ReadStats::default(),
            bytes: 0,
            done: false,
            intensity: false,
        };
        match p.rx.recv() {
            Ok(Msg::Info(info, intensity)) => (p.info, p.intensity) = (info, intensity),
            Ok(Msg::Err(e)) => return Err(e),
            _ => return Err(p.died()),
        }
        Ok(p)
    }

    fn died(&self) -> Error {
        Error::format(
            &self.path,
            "the reader stopped unexpectedly (malformed file?)",
        )
    }
}

impl PointReader for Producer {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        self.receive(buf, None)
    }

    fn has_intensity(&self) -> bool {
        self.intensity
    }

    fn next_chunk_intensity(&mut self, buf: &mut Vec<Point>, inten: &mut Vec<f32>) -> Result<bool> {
        self.receive(buf, Some(inten))
    }

    fn stats(&self) -> ReadStats {
        self.stats
    }

    fn bytes_read(&self) -> u64 {
        self.bytes
    }
}

impl Producer {
    /// The next block, and its intensities into `inten` (cleared first;
    /// left empty without them) when given.
    fn receive(&mut self, buf: &mut Vec<Point>, mut inten: Option<&mut Vec<f32>>) -> Result<bool> {
        buf.clear();
        if let Some(v) = inten.as_deref_mut() {
            v.clear();
        }
        if self.done {
            return Ok(false);
        }
        match self.rx.recv() {
            Ok(Msg::Chunk(mut v, mut iv, skipped, bytes)) => {
                if let Some(inten) = inten {
                    std::mem::swap(inten, &mut iv);
                    if !self.intensity {
                        inten.clear();
                    }
                }
                std::mem::swap(buf, &mut v);
                let _ = self.recycle.try_send(v);
                self.stats.points += buf.len() as u64;
                self.stats.skipped_nonfinite += skipped;
                self.bytes = bytes;
                Ok(true)
            }
            Ok(Msg::Done(skipped)) => {
                self.stats.skipped_nonfinite += skipped;
                self.bytes = self.info.file_bytes;
                self.done = true;
                Ok(false)
            }
            Ok(Msg::Err(e)) => {
                self.done = true;
                Err(e)
            }
            Ok(Msg::Info(..)) | Err(_) => {
                self.done = true;
                Err(self.died())
            }
        }
    }
}
