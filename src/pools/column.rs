//! [`Column`]: one growable array of `Pod` records on RAM or on a memory-mapped file.
//!
//! The mmap backend creates a file in the scratch directory and, on Unix, unlinks it
//! at once: the open handle and the mapping keep its pages, and the space returns to
//! the file system when the column drops or the process ends, however it ends (a
//! killed solve leaves no scratch files behind). Elsewhere the file is removed on
//! drop. It sizes the file to the capacity, maps it read-write and doubles it (remapping)
//! when full. Slices of the mapping are cast with bytemuck; the mapping is page
//! aligned, so every `Pod` type up to page alignment is correctly aligned.

use std::fs::{File, OpenOptions};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use bytemuck::Pod;
use memmap2::MmapMut;

use crate::{Error, Result};

/// Where new columns live.
#[derive(Clone, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum Storage {
    /// Plain heap memory.
    #[default]
    Ram,
    /// Files in this directory, mapped with memmap2.
    Mmap(PathBuf),
}

impl Storage {
    /// The environment variable that chooses the default backend of
    /// [`crate::solver::SolveOptions::default`] (as `RAYON_NUM_THREADS` chooses
    /// rayon's thread count): unset, empty or `ram` for RAM, `mmap` for files in the
    /// system temp directory, `mmap:DIR` for files in `DIR`. CI runs the test suite
    /// once with each, so every solver test runs on both backends.
    pub const ENV: &'static str = "RHIER_STORAGE";

    /// The backend [`Storage::ENV`] names.
    pub fn from_env() -> Result<Storage> {
        let value = std::env::var_os(Self::ENV).unwrap_or_default();
        match value.to_str() {
            Some("" | "ram") => Ok(Storage::Ram),
            Some("mmap") => Ok(Storage::Mmap(std::env::temp_dir())),
            Some(v) if v.starts_with("mmap:") && v.len() > 5 => {
                Ok(Storage::Mmap(PathBuf::from(&v[5..])))
            }
            _ => Err(Error::Usage(format!(
                "{}: expected ram, mmap or mmap:DIR, found {:?}",
                Self::ENV,
                value
            ))),
        }
    }
}

enum Backing<T: Pod> {
    Ram(Vec<T>),
    Mmap {
        file: File,
        path: PathBuf,
        map: MmapMut,
        /// Capacity in records.
        cap: usize,
    },
}

/// A growable array of `T` on a [`Storage`] backend.
pub struct Column<T: Pod> {
    backing: Backing<T>,
    len: usize,
    _t: PhantomData<T>,
}

static COLUMN_SERIAL: AtomicU64 = AtomicU64::new(0);

impl<T: Pod> Column<T> {
    /// An empty column on `storage`; `name` labels the scratch file.
    pub fn new(storage: &Storage, name: &str) -> Result<Self> {
        let backing = match storage {
            Storage::Ram => Backing::Ram(Vec::new()),
            Storage::Mmap(dir) => {
                let serial = COLUMN_SERIAL.fetch_add(1, Ordering::Relaxed);
                let path = dir.join(format!("rhier-{}-{serial}-{name}.col", std::process::id()));
                let file = OpenOptions::new()
                    .read(true)
                    .write(true)
                    .create_new(true)
                    .open(&path)
                    .map_err(|e| Error::io(&path, e))?;
                // Best effort: if the unlink fails the file is removed on drop.
                #[cfg(unix)]
                let _ = std::fs::remove_file(&path);
                let cap = (4096 / std::mem::size_of::<T>().max(1)).max(1);
                let map = map_file(&file, &path, cap * std::mem::size_of::<T>())?;
                Backing::Mmap {
                    file,
                    path,
                    map,
                    cap,
                }
            }
        };
        Ok(Column {
            backing,
            len: 0,
            _t: PhantomData,
        })
    }

    /// Number of records.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True if empty.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends a record, growing the backing store if needed; returns its index.
    pub fn push(&mut self, value: T) -> Result<u32> {
        let index = self.len;
        room_for(index + 1)?;
        match &mut self.backing {
            Backing::Ram(v) => v.push(value),
            Backing::Mmap {
                file,
                path,
                map,
                cap,
            } => {
                grow_mapped::<T>(file, path, map, cap, index + 1)?;
                let bytes: &mut [T] =
                    bytemuck::cast_slice_mut(&mut map[..*cap * std::mem::size_of::<T>()]);
                bytes[index] = value;
            }
        }
        self.len += 1;
        Ok(index as u32)
    }

    /// Appends `values`, growing the backing store if needed (RAM by a quarter, a
    /// mapped file by doubling: its size costs no memory).
    pub fn extend_from_slice(&mut self, values: &[T]) -> Result<()> {
        let len = self.len + values.len();
        room_for(len)?;
        match &mut self.backing {
            Backing::Ram(v) => {
                // A quarter more, not double: an arena appended to for a long time
                // (kept final-gather terms) holds at most 25% slack.
                if len > v.capacity() {
                    v.reserve_exact((len - v.len()).max(len / 4));
                }
                v.extend_from_slice(values);
            }
            Backing::Mmap {
                file,
                path,
                map,
                cap,
            } => {
                grow_mapped::<T>(file, path, map, cap, len)?;
                let size = std::mem::size_of::<T>();
                map[self.len * size..len * size].copy_from_slice(bytemuck::cast_slice(values));
            }
        }
        self.len = len;
        Ok(())
    }

    /// Bytes the column can occupy in memory: its heap capacity, or for a mapped
    /// file its length (the file's slack beyond it is never touched).
    pub fn reserved_bytes(&self) -> usize {
        let cap = match &self.backing {
            Backing::Ram(v) => v.capacity(),
            Backing::Mmap { .. } => self.len,
        };
        cap * std::mem::size_of::<T>()
    }

    /// Gives back heap capacity beyond the length (RAM; a mapped file keeps its
    /// size, see [`Column::release_resident`]).
    pub fn shrink(&mut self) {
        if let Backing::Ram(v) = &mut self.backing {
            v.shrink_to_fit();
        }
    }

    /// Hands a mapped column's resident pages back to the system: the records stay
    /// in the file (the mapping is shared) and are paged in again when next read.
    /// Nothing for RAM.
    pub fn release_resident(&self) {
        if let Backing::Mmap { map, .. } = &self.backing {
            // SAFETY: the mapping is a shared file mapping (`MmapMut::map_mut`), so
            // MADV_DONTNEED drops the pages from this process only; their contents
            // stay in the page cache and the file. No reference into the mapping
            // outlives this call's caller's borrow of `self`, and reads after it
            // fault the same bytes back in. A failure only leaves the pages resident.
            let _ = unsafe { map.unchecked_advise(memmap2::UncheckedAdvice::DontNeed) };
        }
    }

    /// The records.
    #[inline]
    pub fn as_slice(&self) -> &[T] {
        match &self.backing {
            Backing::Ram(v) => v,
            Backing::Mmap { map, .. } => {
                bytemuck::cast_slice(&map[..self.len * std::mem::size_of::<T>()])
            }
        }
    }

    /// The records, mutable.
    #[inline]
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        let n = self.len * std::mem::size_of::<T>();
        match &mut self.backing {
            Backing::Ram(v) => v,
            Backing::Mmap { map, .. } => bytemuck::cast_slice_mut(&mut map[..n]),
        }
    }

    /// Drops every record (keeps the allocation / file).
    pub fn clear(&mut self) {
        if let Backing::Ram(v) = &mut self.backing {
            v.clear();
        }
        self.len = 0;
    }

    /// Drops the records from `len` on (keeps the allocation / file): how a finished
    /// time window releases what it appended.
    pub fn truncate(&mut self, len: usize) {
        if len >= self.len {
            return;
        }
        if let Backing::Ram(v) = &mut self.backing {
            v.truncate(len);
        }
        self.len = len;
    }

    /// Bytes the column holds (its length, not its capacity).
    pub fn bytes(&self) -> usize {
        self.len * std::mem::size_of::<T>()
    }

    /// True if this column lives in a mapped file.
    pub fn is_mapped(&self) -> bool {
        matches!(self.backing, Backing::Mmap { .. })
    }
}

impl<T: Pod> Drop for Column<T> {
    fn drop(&mut self) {
        if let Backing::Mmap { path, .. } = &self.backing {
            // Unlinked at creation on Unix; elsewhere, best effort: a scratch file
            // left behind is named as ours.
            if !cfg!(unix) {
                let _ = std::fs::remove_file(path);
            }
        }
    }
}

impl<T: Pod> std::ops::Deref for Column<T> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        self.as_slice()
    }
}

/// Columns are equal when their records are, wherever they live.
impl<T: Pod + PartialEq> PartialEq for Column<T> {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl<T: Pod + std::fmt::Debug> std::fmt::Debug for Column<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Column")
            .field("len", &self.len)
            .field("mapped", &self.is_mapped())
            .finish()
    }
}

/// Refuses a column of `len` records when `u32` ids could not index them all.
fn room_for(len: usize) -> Result<()> {
    if len > u32::MAX as usize {
        return Err(Error::Usage(
            "pool is full: more than 2^32 - 1 records".into(),
        ));
    }
    Ok(())
}

/// Makes a mapped column's file hold at least `len` records of `T`, doubling its
/// capacity `cap` (or more, to `len`) and remapping it when it does not.
fn grow_mapped<T>(
    file: &File,
    path: &Path,
    map: &mut MmapMut,
    cap: &mut usize,
    len: usize,
) -> Result<()> {
    if len > *cap {
        let new_cap = (*cap * 2).max(len);
        map.flush_async().map_err(|e| Error::io(path, e))?;
        *map = map_file(file, path, new_cap * std::mem::size_of::<T>())?;
        *cap = new_cap;
    }
    Ok(())
}

fn map_file(file: &File, path: &Path, bytes: usize) -> Result<MmapMut> {
    file.set_len(bytes.max(1) as u64)
        .map_err(|e| Error::io(path, e))?;
    // SAFETY: the file was created by this process with create_new in the scratch
    // directory and is only ever accessed through this one mapping; nothing else
    // truncates it while mapped (the column owns it until drop).
    unsafe { MmapMut::map_mut(file) }.map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exercise(storage: &Storage) {
        let mut c: Column<[f32; 3]> = Column::new(storage, "test").unwrap();
        for i in 0..10_000u32 {
            assert_eq!(c.push([i as f32, 1.0, 2.0]).unwrap(), i);
        }
        assert_eq!(c.len(), 10_000);
        c.as_mut_slice()[1234][1] = 7.0;
        let s = c.as_slice();
        assert_eq!(s[9999][0], 9999.0);
        assert_eq!(s[1234], [1234.0, 7.0, 2.0]);
        assert_eq!(c.bytes(), 10_000 * 12);
        // Appending a slice across a growth, then dropping resident pages, keeps
        // every record.
        let more: Vec<[f32; 3]> = (0..5000u32).map(|i| [i as f32, 3.0, 4.0]).collect();
        c.extend_from_slice(&more).unwrap();
        c.release_resident();
        assert_eq!(c.len(), 15_000);
        assert!(c.reserved_bytes() >= c.bytes());
        let s = c.as_slice();
        assert_eq!(s[1234], [1234.0, 7.0, 2.0]);
        assert_eq!(s[10_000 + 4321], [4321.0, 3.0, 4.0]);
        assert_eq!(s[9999][0], 9999.0);
    }

    #[test]
    fn ram_column_grows() {
        exercise(&Storage::Ram);
    }

    #[test]
    fn mmap_column_grows_and_cleans_up() {
        let dir = tempfile::tempdir().unwrap();
        exercise(&Storage::Mmap(dir.path().to_owned()));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    /// On Unix a live column's file is already unlinked: a process killed while it
    /// holds columns leaves nothing in the scratch directory.
    #[cfg(unix)]
    #[test]
    fn a_live_mapped_column_leaves_no_file_to_clean() {
        let dir = tempfile::tempdir().unwrap();
        let mut c = Column::<[f32; 3]>::new(&Storage::Mmap(dir.path().to_owned()), "t").unwrap();
        c.extend_from_slice(&vec![[1.0, 2.0, 3.0]; 10_000]).unwrap();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        assert_eq!(c[9_999], [1.0, 2.0, 3.0]);
        assert!(c.reserved_bytes() >= 120_000);
    }
}
