//! The journal of a space-time solve in progress: what `solve --resume` continues from.
//!
//! A space-time solve writes its `.rhier` file through a [`super::Writer`], which only
//! makes the file valid at the end. So that an interrupted solve loses at most the
//! window it was working on, every finished window but the last is also written to
//! the directory `<out>.partial/` as one file `window-NNNNN.bin` (the last one's
//! leaves go to the writer, which finishes the file right after; a solve
//! interrupted there solves that window again). A window depends on no other, so
//! the windows are all a resumed solve needs:
//!
//! | bytes | field |
//! |---|---|
//! | 0..8 | magic `RHIERWIN` |
//! | 8..12 | version `1` (u32 LE) |
//! | 12..16 | window index (u32 LE) |
//! | 16..24, 24..32 | `t0`, `t1` (f64 LE) |
//! | 32..40 | leaf count `n` (u64 LE) |
//! | 40..48 | the window's frame-cell count (u64 LE) |
//! | 48..52 | CRC-32 of the leaf bytes (u32 LE) |
//! | 52..56 | zero |
//! | 56.. | `n` leaves as [`Leaf`] records (96 bytes each, little-endian) |
//!
//! Each is written to a temporary name, fsynced and renamed, so a window file is
//! either whole or absent. The file `solve.key` holds a fingerprint of the scene and
//! the settings ([`fingerprint`]: the caller's option structs serialized whole, so
//! that a new setting is in it unless the solver leaves it out on purpose, with the
//! reason, `solver::spacetime::result_settings`); `--resume` refuses a journal made by a different
//! solve, naming the first setting that differs, counts
//! the windows `0, 1, …` up to the first missing one and reads them back one at a
//! time (memory stays at one window's leaves), checking every field and the CRC (a
//! damaged window is an error that names the file, not a silent re-solve).
//! The directory is removed when the `.rhier` file is complete. Nothing in it looks
//! like a `.rhier` file.

use std::fs::{self, File};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::format::crc32;
use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::solution::Leaf;
use bytemuck::Zeroable;

const MAGIC: &[u8; 8] = b"RHIERWIN";
const VERSION: u32 = 1;
const HEADER: usize = 56;
const LEAF: usize = std::mem::size_of::<Leaf>();

/// First line of a fingerprint; a journal keyed by another version of the text is
/// refused as another solve's.
const KEY_HEAD: &str = "rhier space-time journal 5";

/// What makes two space-time solves write the same windows, as the text `solve.key`
/// holds: the version of rhier, the scene's content (CRC-32 and length of its
/// native JSON) and `settings`, named JSON objects (one field a line) that the
/// caller serializes from its option structs whole but for the fields that change
/// how a solve runs and not what it writes (`solver::spacetime::result_settings`).
/// The store reads no option struct itself: it keys what it is given.
///
/// The thread count is not in it: the solver's parallel loops compute each item
/// on its own and collect in order (rays are keyed by element, no sum is split
/// across threads), so the windows do not depend on it, and a solve may be resumed
/// on a machine with other cores.
pub fn fingerprint(scene: &Scene, settings: &[(&str, serde_json::Value)]) -> Result<String> {
    let settings: serde_json::Map<String, serde_json::Value> = settings
        .iter()
        .map(|(name, value)| (name.to_string(), value.clone()))
        .collect();
    let settings = serde_json::to_string_pretty(&serde_json::Value::Object(settings))
        .map_err(|e| Error::Usage(format!("journal fingerprint: {e}")))?;
    let scene_text = crate::scene::to_json_string(scene);
    Ok(format!(
        "{KEY_HEAD}\nrhier {}\nscene crc32 {:#010x}, {} bytes\n{settings}\n",
        env!("CARGO_PKG_VERSION"),
        crc32fast::hash(scene_text.as_bytes()),
        scene_text.len()
    ))
}

/// The first line where two fingerprints differ, as `"that" there, "this" here`
/// (trimmed, without a trailing comma); `None` if no line does.
pub(crate) fn first_difference(there: &str, here: &str) -> Option<String> {
    let clean = |l: Option<&str>| {
        l.map_or("nothing".to_string(), |l| {
            format!("`{}`", l.trim().trim_end_matches(','))
        })
    };
    let (mut a, mut b) = (there.lines(), here.lines());
    loop {
        let (x, y) = (a.next(), b.next());
        if x.is_none() && y.is_none() {
            return None;
        }
        if x != y {
            return Some(format!("{} there, {} here", clean(x), clean(y)));
        }
    }
}

/// One finished window as kept in the journal.
#[derive(Clone, Debug, PartialEq)]
pub struct JournalWindow {
    /// Window index.
    pub index: u32,
    /// Time range.
    pub t0: f64,
    /// End of the time range.
    pub t1: f64,
    /// Leaves starting in the window.
    pub leaves: Vec<Leaf>,
    /// Cells over the window's frames (statistics).
    pub frame_cells: u64,
}

/// The journal directory of one output file.
#[derive(Debug)]
pub struct Journal {
    dir: PathBuf,
}

/// Journal directory of the output `out`: `<out>.partial`.
pub fn journal_dir(out: &Path) -> PathBuf {
    let mut name = out.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

impl Journal {
    /// Starts a fresh journal for `out` with fingerprint `key` (an old one is removed).
    pub fn create(out: &Path, key: &str) -> Result<Journal> {
        let dir = journal_dir(out);
        if dir.exists() {
            fs::remove_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        }
        fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let j = Journal { dir };
        j.write_atomic("solve.key", key.as_bytes())?;
        Ok(j)
    }

    /// Opens the journal of `out` to resume: checks the fingerprint and returns the
    /// number of finished windows `0, 1, …` it holds (none if there is no journal: a
    /// fresh start). [`Journal::read`] reads them one at a time, so resuming a long
    /// solve holds one window's leaves, not all of them.
    pub fn resume(out: &Path, key: &str) -> Result<(Journal, u32)> {
        Journal::resume_from(out, key, 0)
    }

    /// [`Journal::resume`] for a solve whose first window is `first` (a shard of a
    /// farm solve, `rhier solve --shard K/N`): counts the finished windows `first,
    /// first + 1, …` up to the first missing one.
    pub fn resume_from(out: &Path, key: &str, first: u32) -> Result<(Journal, u32)> {
        let dir = journal_dir(out);
        if !dir.exists() {
            return Ok((Journal::create(out, key)?, 0));
        }
        let key_path = dir.join("solve.key");
        let found = fs::read_to_string(&key_path).map_err(|e| Error::io(&key_path, e))?;
        if found != key {
            let differs =
                first_difference(&found, key).map_or_else(String::new, |d| format!(" ({d})"));
            return Err(Error::invalid(
                &key_path,
                "fingerprint",
                "the scene and settings of this solve (delete the directory or solve without --resume)",
                format!("a journal of a different solve{differs}"),
            ));
        }
        let mut count = 0;
        while dir.join(window_name(first + count)).exists() {
            count += 1;
        }
        Ok((Journal { dir }, count))
    }

    /// The journal's directory (a space-time solve's default scratch directory).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Reads finished window `index`, checking every field and the CRC.
    pub fn read(&self, index: u32) -> Result<JournalWindow> {
        read_window(&self.dir.join(window_name(index)), index)
    }

    /// Records a finished window held in memory.
    pub fn append(&self, w: &JournalWindow) -> Result<()> {
        self.append_leaves(w.index, [w.t0, w.t1], w.frame_cells, &w.leaves, || {})
    }

    /// Records finished window `index` over `time` with its `leaves`, calling
    /// `after_block` after each block of them is written (so that memory-mapped
    /// leaves can hand their pages back, as [`super::Writer::write_chunk_paged`]).
    /// The leaves are written a block at a time and the header last, so leaves on
    /// memory-mapped storage are never copied.
    pub fn append_leaves(
        &self,
        index: u32,
        time: [f64; 2],
        frame_cells: u64,
        leaves: &[Leaf],
        after_block: impl FnMut(),
    ) -> Result<()> {
        self.write_headed(&window_name(index), HEADER, |f, io| {
            let crc =
                super::writer::leaf_blocks(leaves, |b| f.write_all(b).map_err(io), after_block)?;
            let mut head = Vec::with_capacity(HEADER);
            head.extend_from_slice(MAGIC);
            head.extend_from_slice(&VERSION.to_le_bytes());
            head.extend_from_slice(&index.to_le_bytes());
            head.extend_from_slice(&time[0].to_le_bytes());
            head.extend_from_slice(&time[1].to_le_bytes());
            head.extend_from_slice(&(leaves.len() as u64).to_le_bytes());
            head.extend_from_slice(&frame_cells.to_le_bytes());
            head.extend_from_slice(&crc.finalize().to_le_bytes());
            head.extend_from_slice(&0u32.to_le_bytes());
            Ok(head)
        })
    }

    /// Removes the journal (the output file is complete).
    pub fn finish(self) -> Result<()> {
        fs::remove_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))
    }

    /// Writes `bytes` to `name` through a temporary file and a rename (a crash
    /// leaves the old file or the new one, never a torn one).
    fn write_atomic(&self, name: &str, bytes: &[u8]) -> Result<()> {
        let path = self.dir.join(name);
        let tmp = self.dir.join(format!("{name}.tmp"));
        let mut f = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        f.write_all(bytes).map_err(|e| Error::io(&tmp, e))?;
        self.commit(f, &tmp, &path)
    }

    /// Writes `name` through a temporary file whose first `header` bytes are left
    /// zero while `body` writes what follows and returns the header (which holds
    /// the body's length and CRC), then written in place before the commit: a crash
    /// leaves no file by that name, or a whole one.
    fn write_headed(
        &self,
        name: &str,
        header: usize,
        body: impl FnOnce(
            &mut std::io::BufWriter<File>,
            &dyn Fn(std::io::Error) -> Error,
        ) -> Result<Vec<u8>>,
    ) -> Result<()> {
        let path = self.dir.join(name);
        let tmp = self.dir.join(format!("{name}.tmp"));
        let io = |e| Error::io(&tmp, e);
        let mut f = std::io::BufWriter::new(File::create(&tmp).map_err(io)?);
        f.write_all(&vec![0u8; header]).map_err(io)?;
        let head = body(&mut f, &io)?;
        debug_assert_eq!(head.len(), header);
        let mut f = f.into_inner().map_err(|e| io(e.into_error()))?;
        f.seek(SeekFrom::Start(0)).map_err(io)?;
        f.write_all(&head).map_err(io)?;
        self.commit(f, &tmp, &path)
    }

    /// Fsyncs the finished temporary file `f` (`tmp`), renames it to `path` and
    /// fsyncs the directory.
    fn commit(&self, f: File, tmp: &Path, path: &Path) -> Result<()> {
        f.sync_all().map_err(|e| Error::io(tmp, e))?;
        fs::rename(tmp, path).map_err(|e| Error::io(path, e))?;
        if let Ok(d) = File::open(&self.dir) {
            let _ = d.sync_all();
        }
        Ok(())
    }
}

fn window_name(i: u32) -> String {
    format!("window-{i:05}.bin")
}

fn read_window(path: &Path, index: u32) -> Result<JournalWindow> {
    let bad = |place: &str, expected: String, found: String| {
        Err(Error::invalid(path, place.to_string(), expected, found))
    };
    let mut f = File::open(path).map_err(|e| Error::io(path, e))?;
    let file_len = f.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut bytes = [0u8; HEADER];
    if file_len < HEADER as u64 {
        return bad(
            "header",
            format!("at least {HEADER} bytes"),
            file_len.to_string(),
        );
    }
    f.read_exact(&mut bytes).map_err(|e| Error::io(path, e))?;
    let u32_at =
        |o: usize| u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let u64_at = |o: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[o..o + 8]);
        u64::from_le_bytes(b)
    };
    if &bytes[0..8] != MAGIC {
        return bad(
            "bytes 0..8",
            "magic RHIERWIN".into(),
            format!("{:?}", &bytes[0..8]),
        );
    }
    if u32_at(8) != VERSION {
        return bad("version", VERSION.to_string(), u32_at(8).to_string());
    }
    if u32_at(12) != index {
        return bad("window index", index.to_string(), u32_at(12).to_string());
    }
    let t0 = f64::from_bits(u64_at(16));
    let t1 = f64::from_bits(u64_at(24));
    if !(t0.is_finite() && t1.is_finite() && t0 <= t1) {
        return bad(
            "time range",
            "finite t0 <= t1".into(),
            format!("[{t0}, {t1}]"),
        );
    }
    let n = u64_at(32);
    let expected_len = (n as u128) * LEAF as u128 + HEADER as u128;
    if expected_len != file_len as u128 {
        return bad(
            "length",
            format!("{expected_len} bytes for {n} leaves"),
            file_len.to_string(),
        );
    }
    // The length matched the file's, so `n` leaves are there to read.
    let mut leaves = vec![Leaf::zeroed(); n as usize];
    f.read_exact(bytemuck::cast_slice_mut(&mut leaves))
        .map_err(|e| Error::io(path, e))?;
    let crc = crc32(bytemuck::cast_slice(&leaves));
    if crc != u32_at(48) {
        return bad(
            "leaves",
            format!("CRC-32 {:#010x}", u32_at(48)),
            format!("{crc:#010x}"),
        );
    }
    Ok(JournalWindow {
        index,
        t0,
        t1,
        leaves,
        frame_cells: u64_at(40),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaf(patch: u32, t: f32) -> Leaf {
        Leaf {
            patch,
            corners: 4,
            time: [t, t + 0.5],
            uv: [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            b: [[0.25, 0.5, 1.0]; 4],
        }
    }

    #[test]
    fn windows_round_trip_and_damage_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("a.rhier");
        let j = Journal::create(&out, "key-1").unwrap();
        let w0 = JournalWindow {
            index: 0,
            t0: 0.0,
            t1: 0.5,
            leaves: vec![leaf(0, 0.0), leaf(3, 0.25)],
            frame_cells: 7,
        };
        let w1 = JournalWindow {
            index: 1,
            t0: 0.5,
            t1: 1.0,
            leaves: vec![leaf(1, 0.5)],
            frame_cells: 3,
        };
        j.append(&w0).unwrap();
        j.append(&w1).unwrap();
        let (j, count) = Journal::resume(&out, "key-1").unwrap();
        assert_eq!(count, 2);
        assert_eq!(j.read(0).unwrap(), w0);
        assert_eq!(j.read(1).unwrap(), w1);
        // Another solve's journal is refused.
        let e = Journal::resume(&out, "key-2").unwrap_err().to_string();
        assert!(
            e.contains("solve.key") && e.contains("different solve"),
            "{e}"
        );
        // A flipped leaf byte is caught by the CRC and the file is named.
        let p = journal_dir(&out).join("window-00001.bin");
        let mut bytes = fs::read(&p).unwrap();
        let last = bytes.len() - 1;
        bytes[last] ^= 1;
        fs::write(&p, &bytes).unwrap();
        let read1 = || Journal::resume(&out, "key-1").and_then(|(j, _)| j.read(1));
        let e = read1().unwrap_err().to_string();
        assert!(e.contains("window-00001.bin") && e.contains("CRC"), "{e}");
        // A truncated file too, and one cut inside its leaves.
        fs::write(&p, &bytes[..40]).unwrap();
        let e = read1().unwrap_err().to_string();
        assert!(e.contains("header"), "{e}");
        fs::write(&p, &bytes[..bytes.len() - 8]).unwrap();
        let e = read1().unwrap_err().to_string();
        assert!(e.contains("length") && e.contains("for 1 leaves"), "{e}");
        // Finishing removes the directory.
        Journal::create(&out, "key-1").unwrap().finish().unwrap();
        assert!(!journal_dir(&out).exists());
    }
}
