//! The `.rhier` writer: streams sections in file order and makes the file valid only at
//! [`Writer::finish`].
//!
//! How it works: [`Writer::create`] opens `<path>.tmp`, writes 64 zero bytes where the
//! header goes (so a partial file has no magic and is refused), then the scene and
//! patch sections. Each [`Writer::write_chunk`] appends one chunk section of leaves (in
//! time order; the leaves are checked and fed to zstd a block at a time, never
//! copied: a `Leaf` is its archived record) and remembers its index entry.
//! [`Writer::finish`] appends the links, chunk index and stats sections and the
//! section table, writes the header at offset 0, fsyncs, renames `<path>.tmp` to
//! `<path>` and fsyncs the directory. Dropping an unfinished writer removes the
//! temporary file. Nothing is ever rewritten except the header, so memory stays at
//! one chunk's compressed bytes whatever the animation's length. A path that exists
//! and is not a regular file (`/dev/null`, a FIFO) is written in place at the end,
//! never renamed over: the file is then built in memory.
//!
//! What it stores: only what playback needs. Motion tracks only for objects that move;
//! each leaf once, in the chunk where its time range starts (a leaf that holds over
//! the whole animation is stored once); links only when
//! [`WriteOptions::keep_links`] is set. It does not merge equal leaves that the caller
//! hands in separate chunks: the solver gives each leaf its full time range.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use rkyv::rancor;

use super::format::{
    BASE_VERSION, Codec, FLAG_COMPRESSED, FLAG_LINKS, FLAG_MOVING, HEADER_LEN,
    HIERARCHY_READER_VERSION, Header, MIN_READER_VERSION, PROVENANCE_READER_VERSION, SectionEntry,
    SectionKind, VERSION, crc32,
};
use super::records::{
    CameraRecord, ChunkIndexRecord, ChunkRecord, LinkRecord, MaterialRecord, ObjectRecord,
    PatchRecord, ProvenanceRecord, SceneRecord, StatsRecord, stored_track,
};
use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::solution::{Leaf, PatchGeometry, Solution, SolveStats};

/// zstd level used for compressed sections.
pub const ZSTD_LEVEL: i32 = 3;

/// Leaves a chunk is checked, compressed and handed back in at a time
/// ([`Writer::write_chunk_paged`]).
pub use crate::solution::LEAF_BLOCK;

// A chunk's leaves are written as their bytes in memory, which are the archived
// records' (little-endian fields, the same order and size).
const _: () = assert!(
    cfg!(target_endian = "little")
        && std::mem::size_of::<Leaf>() == std::mem::size_of::<super::records::ArchivedLeafRecord>()
);

/// The 16-byte root rkyv writes after the `n` records of an archived `Vec` of
/// 96-byte records that start at byte 0: the offset from the root back to the
/// first record (`-96 n`, i64 LE) and the length (u64 LE). Checked against rkyv
/// by the test `streamed_chunks_are_the_archive`.
fn vec_root(n: usize) -> [u8; 16] {
    let mut root = [0u8; 16];
    let back = -((n * std::mem::size_of::<Leaf>()) as i64);
    root[..8].copy_from_slice(&back.to_le_bytes());
    root[8..].copy_from_slice(&(n as u64).to_le_bytes());
    root
}

/// Hands the bytes of `leaves` to `write` a block of [`LEAF_BLOCK`] at a time,
/// calling `after_block` after each (the chunk writer's raw sections, the resume
/// journal); returns the CRC-32 state over them.
pub(crate) fn leaf_blocks(
    leaves: &[Leaf],
    mut write: impl FnMut(&[u8]) -> Result<()>,
    mut after_block: impl FnMut(),
) -> Result<crc32fast::Hasher> {
    let mut crc = crc32fast::Hasher::new();
    for block in leaves.chunks(LEAF_BLOCK) {
        let bytes: &[u8] = bytemuck::cast_slice(block);
        crc.update(bytes);
        write(bytes)?;
        after_block();
    }
    Ok(crc)
}

/// Choices of the writer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WriteOptions {
    /// zstd-compress chunk sections (and the patch section) when it makes them smaller.
    pub compress: bool,
    /// Keep a links section (`--keep-links`); without it [`Writer::write_links`] is a
    /// no-op.
    pub keep_links: bool,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            compress: true,
            keep_links: false,
        }
    }
}

/// What the writer needs before the first chunk: the scene and its patches.
#[derive(Clone, Copy, Debug)]
pub struct SolutionHeader<'a> {
    /// The solved scene (time domain, materials, objects, motion, camera).
    pub scene: &'a Scene,
    /// Patches in solver order; leaves refer to them by index.
    pub patches: &'a [PatchGeometry],
}

impl<'a> SolutionHeader<'a> {
    /// The header of a complete solution.
    pub fn of(solution: &'a Solution) -> Self {
        SolutionHeader {
            scene: &solution.scene,
            patches: &solution.patches,
        }
    }
}

/// Where the bytes go: a temporary file renamed at the end, memory, or memory written
/// at the end to an existing device or FIFO (renaming over it would replace it).
enum Sink {
    File {
        out: BufWriter<File>,
        tmp: PathBuf,
        done: bool,
    },
    Memory(Vec<u8>),
    Device(Vec<u8>),
}

/// Streams a `.rhier` file; see the module header.
pub struct Writer {
    path: PathBuf,
    sink: Sink,
    pos: u64,
    options: WriteOptions,
    flags: u32,
    time: [f64; 2],
    patch_corners: Vec<u32>,
    entries: Vec<SectionEntry>,
    chunks: Vec<ChunkRecord>,
    links: Vec<LinkRecord>,
    provenance: Option<ProvenanceRecord>,
    /// The hierarchy section, if any ([`Writer::write_hierarchy`]).
    hierarchy: Option<super::records::HierarchyRecord>,
}

impl std::fmt::Debug for Writer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Writer")
            .field("path", &self.path)
            .field("pos", &self.pos)
            .field("chunks", &self.chunks.len())
            .finish()
    }
}

/// Temporary name used while writing `path`.
pub fn temp_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".tmp");
    PathBuf::from(s)
}

/// The sink of a file written through `<path>.tmp`.
fn file_sink(path: &Path) -> Result<Sink> {
    let tmp = temp_path(path);
    let file = OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(&tmp)
        .map_err(|e| Error::io(&tmp, e))?;
    // Sections arrive whole (a chunk in one write, which bypasses the buffer):
    // the buffer only gathers the small ones, and a solve keeps it resident.
    Ok(Sink::File {
        out: BufWriter::with_capacity(64 << 10, file),
        tmp,
        done: false,
    })
}

/// True if `path` exists and is neither a regular file nor a directory (a device such
/// as `/dev/null`, a FIFO): [`Writer::create`] writes such a path in place at the end
/// instead of renaming a temporary file over it.
pub fn writes_in_place(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

impl Writer {
    /// Starts writing `path` (through `<path>.tmp`): writes the placeholder header, the
    /// scene section and the patch section. An existing `path` that is neither a
    /// regular file nor a directory (a device, a FIFO) gets the whole file at
    /// [`Writer::finish`], built in memory until then.
    pub fn create(
        path: &Path,
        header: &SolutionHeader<'_>,
        options: WriteOptions,
    ) -> Result<Writer> {
        if writes_in_place(path) {
            return Writer::start(
                path.to_path_buf(),
                Sink::Device(Vec::new()),
                header,
                options,
            );
        }
        Writer::start(path.to_path_buf(), file_sink(path)?, header, options)
    }

    /// Starts writing `path` (as [`Writer::create`]) with the scene and patch
    /// sections of `src` copied as they are stored, for chunks copied from files of
    /// the same solve ([`Writer::copy_chunk`], `rhier merge`).
    pub fn create_copying(path: &Path, src: &super::Reader) -> Result<Writer> {
        let sink = if writes_in_place(path) {
            Sink::Device(Vec::new())
        } else {
            file_sink(path)?
        };
        let td = src.time_domain();
        let mut w = Writer {
            path: path.to_path_buf(),
            sink,
            pos: 0,
            options: WriteOptions::default(),
            flags: src.header().flags & FLAG_MOVING,
            time: [td.start, td.end],
            patch_corners: src.patches().iter().map(|p| p.corners).collect(),
            entries: Vec::new(),
            chunks: Vec::new(),
            links: Vec::new(),
            provenance: None,
            hierarchy: None,
        };
        w.emit(&[0u8; HEADER_LEN])?;
        for kind in [SectionKind::Scene, SectionKind::Patches] {
            let i = src
                .sections()
                .iter()
                .position(|e| e.kind == kind)
                .ok_or_else(|| {
                    Error::invalid(
                        src.path(),
                        "section table",
                        format!("a {} section", kind.name()),
                        "none",
                    )
                })?;
            w.copy_section(src, i)?;
        }
        Ok(w)
    }

    /// Appends section `i` of `src` as it is stored (CRC checked) with its table
    /// entry; returns the new section's index.
    fn copy_section(&mut self, src: &super::Reader, i: usize) -> Result<u32> {
        let stored = src.stored_section(i)?;
        let e = src.sections()[i];
        if e.codec == Codec::Zstd {
            self.flags |= FLAG_COMPRESSED;
        }
        let section = self.entries.len() as u32;
        self.entries.push(SectionEntry {
            offset: self.pos,
            ..e
        });
        self.emit(stored)?;
        Ok(section)
    }

    /// Appends chunk `k` of `src` as it is stored: its section's bytes are copied,
    /// not decoded or re-encoded (their CRC is checked), and its index entry gets the
    /// new section and the chunk that carries into it. `src` must have this file's
    /// patches (the caller checks it is a file of the same solve); chunks come in
    /// time order as for [`Writer::write_chunk`].
    pub fn copy_chunk(&mut self, src: &super::Reader, k: usize) -> Result<()> {
        let c = *src.chunks().get(k).ok_or_else(|| {
            Error::Usage(format!(
                "{}: chunk {k} requested, the file has {} chunks",
                src.path().display(),
                src.chunks().len()
            ))
        })?;
        self.check_chunk_time(c.t0, c.t1)?;
        let section = self.copy_section(src, c.section as usize)?;
        self.push_chunk(c.t0, c.t1, c.reach, section, c.leaves);
        Ok(())
    }

    /// Records where the file's windows come from (a space-time solve): written as
    /// the provenance section, which makes the file need a version-2 reader.
    pub fn set_provenance(&mut self, provenance: ProvenanceRecord) {
        self.provenance = Some(provenance);
    }

    /// Starts writing into memory; [`Writer::finish_to_bytes`] returns the file's bytes
    /// (identical to what [`Writer::create`] + [`Writer::finish`] put on disk).
    pub fn in_memory(
        name: &Path,
        header: &SolutionHeader<'_>,
        options: WriteOptions,
    ) -> Result<Writer> {
        Writer::start(
            name.to_path_buf(),
            Sink::Memory(Vec::new()),
            header,
            options,
        )
    }

    fn start(
        path: PathBuf,
        sink: Sink,
        header: &SolutionHeader<'_>,
        options: WriteOptions,
    ) -> Result<Writer> {
        let scene = header.scene;
        let mut w = Writer {
            path,
            sink,
            pos: 0,
            options,
            flags: 0,
            time: [scene.time.start, scene.time.end],
            patch_corners: header.patches.iter().map(|p| p.corners).collect(),
            entries: Vec::new(),
            chunks: Vec::new(),
            links: Vec::new(),
            provenance: None,
            hierarchy: None,
        };
        if !(scene.time.start.is_finite() && scene.time.end.is_finite())
            || scene.time.end < scene.time.start
        {
            return Err(Error::invalid(
                &w.path,
                "scene time domain",
                "finite start <= end",
                format!("[{}, {}]", scene.time.start, scene.time.end),
            ));
        }
        for (i, p) in header.patches.iter().enumerate() {
            let ok_obj = (p.object as usize) < scene.objects.len();
            let ok_mat = (p.material as usize) < scene.materials.len();
            if !ok_obj || !ok_mat || !(p.corners == 3 || p.corners == 4) {
                return Err(Error::invalid(
                    &w.path,
                    format!("patch {i}"),
                    format!(
                        "object < {}, material < {}, 3 or 4 corners",
                        scene.objects.len(),
                        scene.materials.len()
                    ),
                    format!(
                        "object {}, material {}, {} corners",
                        p.object, p.material, p.corners
                    ),
                ));
            }
        }
        w.emit(&[0u8; HEADER_LEN])?;
        let record = SceneRecord {
            time: w.time,
            materials: scene.materials.iter().map(MaterialRecord::from).collect(),
            objects: scene
                .objects
                .iter()
                .map(|o| ObjectRecord {
                    name: o.name.clone(),
                    motion: o.motion.as_ref().and_then(stored_track),
                })
                .collect(),
            camera: scene.camera.as_ref().map(CameraRecord::from),
        };
        if scene.has_motion() {
            w.flags |= FLAG_MOVING;
        }
        let bytes = archive(&w.path, &record)?;
        w.section(SectionKind::Scene, &bytes, 1, false)?;
        let patches: Vec<PatchRecord> = header.patches.iter().map(PatchRecord::from).collect();
        let bytes = archive(&w.path, &patches)?;
        w.section(
            SectionKind::Patches,
            &bytes,
            patches.len() as u64,
            options.compress,
        )?;
        Ok(w)
    }

    /// Appends the chunk `[t0, t1]` holding `leaves`, each of which starts in it.
    /// Chunks come in time order (`t0` >= the previous chunk's `t1`).
    pub fn write_chunk(&mut self, t0: f64, t1: f64, leaves: &[Leaf]) -> Result<()> {
        self.write_chunk_paged(t0, t1, leaves, || {})
    }

    /// [`Writer::write_chunk`], calling `after_block` each time a block of
    /// [`LEAF_BLOCK`] leaves has been read, so that a caller whose leaves are
    /// memory-mapped can hand their pages back as the chunk is written.
    ///
    /// The leaves are never copied: the archive of a `Vec<LeafRecord>` is the
    /// records' bytes (a `Leaf` is a `LeafRecord` in memory, little-endian) followed
    /// by the 16-byte root (`vec_root`), and zstd takes them as a stream, with the
    /// size pledged so that the frame is the one a single call would make. The leaves
    /// are checked in the same pass; nothing reaches the file before all are.
    pub fn write_chunk_paged(
        &mut self,
        t0: f64,
        t1: f64,
        leaves: &[Leaf],
        mut after_block: impl FnMut(),
    ) -> Result<()> {
        let index = self.chunks.len();
        self.check_chunk_time(t0, t1)?;
        let root = vec_root(leaves.len());
        let raw_len = std::mem::size_of_val(leaves) + root.len();
        let mut reach = t0;
        let io = |e| Error::io(&self.path, e);
        let mut encoder = if self.options.compress {
            let mut z = zstd::stream::Encoder::new(Vec::new(), ZSTD_LEVEL).map_err(io)?;
            z.set_pledged_src_size(Some(raw_len as u64)).map_err(io)?;
            Some(z)
        } else {
            None
        };
        for (k, block) in leaves.chunks(LEAF_BLOCK).enumerate() {
            reach = self.check_leaves(index, t0, t1, k * LEAF_BLOCK, block, reach)?;
            if let Some(z) = &mut encoder {
                z.write_all(bytemuck::cast_slice(block)).map_err(io)?;
            }
            after_block();
        }
        let packed = match encoder {
            Some(mut z) => {
                z.write_all(&root).map_err(io)?;
                let z = z.finish().map_err(io)?;
                (z.len() < raw_len).then_some(z)
            }
            None => None,
        };
        let section = self.entries.len() as u32;
        match packed {
            Some(z) => {
                self.flags |= FLAG_COMPRESSED;
                let entry = self.entry(SectionKind::Chunk, Codec::Zstd, &z, raw_len, leaves.len());
                self.emit(&z)?;
                self.entries.push(entry);
            }
            None => {
                // Stored raw: the records again, a block at a time.
                let offset = self.pos;
                let mut crc = leaf_blocks(leaves, |b| self.emit(b), &mut after_block)?;
                crc.update(&root);
                self.emit(&root)?;
                self.entries.push(SectionEntry {
                    kind: SectionKind::Chunk,
                    codec: Codec::Raw,
                    offset,
                    stored_len: raw_len as u64,
                    raw_len: raw_len as u64,
                    items: leaves.len() as u64,
                    crc: crc.finalize(),
                });
            }
        }
        self.push_chunk(t0, t1, reach, section, leaves.len() as u32);
        Ok(())
    }

    /// Refuses a chunk `[t0, t1]` outside the time domain or before the last one.
    fn check_chunk_time(&self, t0: f64, t1: f64) -> Result<()> {
        let prev_t1 = self.chunks.last().map_or(self.time[0], |c| c.t1);
        let in_domain = t0 >= self.time[0] && t1 <= self.time[1];
        if !(t0.is_finite() && t1.is_finite()) || t1 < t0 || t0 < prev_t1 || !in_domain {
            return Err(Error::invalid(
                &self.path,
                format!("chunk {}", self.chunks.len()),
                format!(
                    "a time range inside [{}, {}] starting at or after {prev_t1}",
                    self.time[0], self.time[1]
                ),
                format!("[{t0}, {t1}]"),
            ));
        }
        Ok(())
    }

    /// Adds the index entry of a chunk whose section is written.
    fn push_chunk(&mut self, t0: f64, t1: f64, reach: f64, section: u32, leaves: u32) {
        let index = self.chunks.len();
        // First chunk whose leaves may still be live at t0 (reach only matters for
        // chunks after the previous carry_from, whose reach was below an earlier t0).
        let mut carry_from = self.chunks.last().map_or(0, |c| c.carry_from);
        while (carry_from as usize) < index && self.chunks[carry_from as usize].reach < t0 {
            carry_from += 1;
        }
        self.chunks.push(ChunkRecord {
            t0,
            t1,
            reach,
            section,
            leaves,
            carry_from,
        });
    }

    /// Queues links for the links section; ignored unless
    /// [`WriteOptions::keep_links`].
    pub fn write_links(&mut self, links: &[LinkRecord]) {
        if self.options.keep_links {
            self.links.extend_from_slice(links);
        }
    }

    /// Queues the hierarchy section (`rhier solve --keep-links --movable`): the
    /// file's version becomes [`VERSION`] (3) and a reader needs version 3.
    pub fn write_hierarchy(&mut self, h: &super::Hierarchy) {
        self.hierarchy = Some(h.to_record());
    }

    /// The counters of the file so far (sections and chunks written, bytes), for
    /// `solve --stats` while the solve streams; the solver adds its pools with
    /// [`super::MemoryReport::add_pool`].
    pub fn memory_report(&self) -> super::MemoryReport {
        super::MemoryReport::from_parts(
            &self.path.display().to_string(),
            self.pos,
            &self.entries,
            &self.chunks,
            self.patch_corners.len() as u64,
        )
    }

    /// Writes the remaining sections, the table and the header, then (for a file)
    /// fsyncs and renames the temporary file to its final name.
    pub fn finish(mut self, stats: &SolveStats) -> Result<()> {
        self.write_tail(stats)?;
        let path = self.path.clone();
        match &mut self.sink {
            Sink::File { out, tmp, done } => {
                out.flush().map_err(|e| Error::io(&*tmp, e))?;
                let file = out.get_mut();
                file.sync_all().map_err(|e| Error::io(&*tmp, e))?;
                std::fs::rename(&*tmp, &path).map_err(|e| Error::io(&path, e))?;
                *done = true;
                if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                    // Make the rename durable; some platforms cannot open directories.
                    if let Ok(d) = File::open(dir) {
                        let _ = d.sync_all();
                    }
                }
                Ok(())
            }
            Sink::Device(bytes) => {
                let mut out = OpenOptions::new()
                    .write(true)
                    .open(&path)
                    .map_err(|e| Error::io(&path, e))?;
                out.write_all(bytes)
                    .and_then(|_| out.flush())
                    .map_err(|e| Error::io(&path, e))
            }
            Sink::Memory(_) => Err(Error::Usage(
                "an in-memory writer ends with finish_to_bytes".into(),
            )),
        }
    }

    /// Ends an in-memory writer and returns the file's bytes.
    pub fn finish_to_bytes(mut self, stats: &SolveStats) -> Result<Vec<u8>> {
        self.write_tail(stats)?;
        match &mut self.sink {
            Sink::Memory(v) => Ok(std::mem::take(v)),
            Sink::File { .. } | Sink::Device(_) => {
                Err(Error::Usage("a file writer ends with finish".into()))
            }
        }
    }

    fn write_tail(&mut self, stats: &SolveStats) -> Result<()> {
        if self.options.keep_links {
            self.flags |= FLAG_LINKS;
            let links = std::mem::take(&mut self.links);
            let bytes = archive(&self.path, &links)?;
            self.section(
                SectionKind::Links,
                &bytes,
                links.len() as u64,
                self.options.compress,
            )?;
        }
        let index = ChunkIndexRecord {
            chunks: self.chunks.clone(),
        };
        let bytes = archive(&self.path, &index)?;
        self.section(
            SectionKind::ChunkIndex,
            &bytes,
            self.chunks.len() as u64,
            false,
        )?;
        let bytes = archive(&self.path, &StatsRecord::from(stats))?;
        self.section(SectionKind::Stats, &bytes, 1, false)?;
        let mut min_reader_version = MIN_READER_VERSION;
        if let Some(p) = self.provenance.take() {
            let bytes = archive(&self.path, &p)?;
            self.section(SectionKind::Provenance, &bytes, 1, false)?;
            min_reader_version = PROVENANCE_READER_VERSION;
        }
        let mut version = BASE_VERSION;
        if let Some(h) = self.hierarchy.take() {
            let bytes = archive(&self.path, &h)?;
            self.section(SectionKind::Hierarchy, &bytes, 1, self.options.compress)?;
            min_reader_version = HIERARCHY_READER_VERSION;
            version = VERSION;
        }
        let table: Vec<u8> = self.entries.iter().flat_map(|e| e.encode()).collect();
        let table_offset = self.pos;
        self.emit(&table)?;
        let header = Header {
            version,
            min_reader_version,
            flags: self.flags,
            table_offset,
            table_count: self.entries.len() as u32,
            table_crc: crc32(&table),
            file_len: self.pos,
        };
        let bytes = header.encode();
        match &mut self.sink {
            Sink::File { out, tmp, .. } => {
                let r = out
                    .seek(SeekFrom::Start(0))
                    .and_then(|_| out.write_all(&bytes))
                    .and_then(|_| out.seek(SeekFrom::End(0)).map(|_| ()));
                r.map_err(|e| Error::io(&*tmp, e))
            }
            Sink::Memory(v) | Sink::Device(v) => {
                v[..HEADER_LEN].copy_from_slice(&bytes);
                Ok(())
            }
        }
    }

    /// Appends one section (compressed when asked and smaller) and its table entry.
    fn section(&mut self, kind: SectionKind, raw: &[u8], items: u64, compress: bool) -> Result<()> {
        let packed = if compress {
            let z = zstd::bulk::compress(raw, ZSTD_LEVEL).map_err(|e| Error::io(&self.path, e))?;
            (z.len() < raw.len()).then_some(z)
        } else {
            None
        };
        let (codec, stored) = match &packed {
            Some(z) => (Codec::Zstd, z.as_slice()),
            None => (Codec::Raw, raw),
        };
        if codec == Codec::Zstd {
            self.flags |= FLAG_COMPRESSED;
        }
        let entry = self.entry(kind, codec, stored, raw.len(), items as usize);
        self.emit(stored)?;
        self.entries.push(entry);
        Ok(())
    }

    /// The table entry of a section about to be emitted at the current position.
    fn entry(
        &self,
        kind: SectionKind,
        codec: Codec,
        stored: &[u8],
        raw_len: usize,
        items: usize,
    ) -> SectionEntry {
        SectionEntry {
            kind,
            codec,
            offset: self.pos,
            stored_len: stored.len() as u64,
            raw_len: raw_len as u64,
            items: items as u64,
            crc: crc32(stored),
        }
    }

    /// Checks that `leaves` (the leaves `first..` of chunk `index`, `[t0, t1]`) name
    /// a patch with their corner count and start in the chunk; returns `reach`
    /// extended by their end times.
    fn check_leaves(
        &self,
        index: usize,
        t0: f64,
        t1: f64,
        first: usize,
        leaves: &[Leaf],
        mut reach: f64,
    ) -> Result<f64> {
        for (k, l) in leaves.iter().enumerate() {
            let patch_corners = self.patch_corners.get(l.patch as usize).copied();
            let (lt0, lt1) = (l.time[0], l.time[1]);
            let starts_here = lt0 >= t0 as f32 && lt0 <= t1 as f32 && lt1 >= lt0;
            // What the reader refuses (`Reader::chunk_leaves`) is never written: a
            // solve whose radiosity overflowed fails here, not at playback.
            let finite = l.values_finite();
            if patch_corners != Some(l.corners) || !starts_here || !finite {
                return Err(Error::invalid(
                    &self.path,
                    format!("chunk {index}, leaf {}", first + k),
                    format!(
                        "a leaf of one of {} patches, with its corner count, finite values, starting in [{t0}, {t1}]",
                        self.patch_corners.len()
                    ),
                    format!(
                        "patch {}, {} corners, time [{lt0}, {lt1}]{}",
                        l.patch,
                        l.corners,
                        if finite { "" } else { ", a value not finite" }
                    ),
                ));
            }
            reach = reach.max(lt1 as f64);
        }
        Ok(reach)
    }

    fn emit(&mut self, bytes: &[u8]) -> Result<()> {
        match &mut self.sink {
            Sink::File { out, tmp, .. } => out.write_all(bytes).map_err(|e| Error::io(&*tmp, e))?,
            Sink::Memory(v) | Sink::Device(v) => v.extend_from_slice(bytes),
        }
        self.pos += bytes.len() as u64;
        Ok(())
    }
}

impl Drop for Writer {
    fn drop(&mut self) {
        if let Sink::File {
            tmp, done: false, ..
        } = &self.sink
        {
            // An unfinished file must not survive: it has no header, but remove it so
            // that it cannot be mistaken for output either.
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Serializes one rkyv root.
pub(crate) fn archive<T>(path: &Path, value: &T) -> Result<rkyv::util::AlignedVec>
where
    T: for<'a> rkyv::Serialize<
            rkyv::api::high::HighSerializer<
                rkyv::util::AlignedVec,
                rkyv::ser::allocator::ArenaHandle<'a>,
                rancor::Error,
            >,
        >,
{
    rkyv::to_bytes::<rancor::Error>(value).map_err(|e| {
        Error::invalid(
            path,
            "serialising a record",
            "a serialisable record",
            e.to_string(),
        )
    })
}

/// Time chunks a static or space-time [`Solution`] is written in by
/// [`write_solution`]: one chunk over the whole time domain.
fn whole_domain(solution: &Solution) -> (f64, f64) {
    (solution.scene.time.start, solution.scene.time.end)
}

/// A `.rhier` file written one frame at a time, as a per-frame solve produces
/// them: created at the first frame from its patches, each frame one chunk over its
/// interval, in time order; the file appears only when [`FrameWriter::finish`] is
/// called after every frame. Memory holds one frame whatever the animation's length.
pub struct FrameWriter<'p> {
    path: &'p Path,
    options: WriteOptions,
    /// The writer and the patches of the first frame, once it is in.
    open: Option<(Writer, Vec<PatchGeometry>)>,
}

impl<'p> FrameWriter<'p> {
    /// A writer of `path`; nothing is created before the first frame.
    pub fn new(path: &'p Path, options: WriteOptions) -> Self {
        FrameWriter {
            path,
            options,
            open: None,
        }
    }

    /// Writes frame `index` (at time `t`, holding over `range`) of `scene`. Every
    /// frame must have the first frame's patches: the chunks' patch numbers refer
    /// to them.
    pub fn push(
        &mut self,
        scene: &Scene,
        (index, t, range): (u32, f64, [f64; 2]),
        solution: &Solution,
    ) -> Result<()> {
        let w = match &mut self.open {
            Some((w, first)) => {
                // The same patches, not only as many: a frame whose patches were
                // cut or dropped otherwise would be played back on frame 0's.
                if solution.patches.len() != first.len() {
                    return Err(Error::invalid(
                        self.path,
                        format!("frame {index} at t = {t}"),
                        format!("the {} patches of frame 0", first.len()),
                        format!("{} patches", solution.patches.len()),
                    ));
                }
                if let Some(k) = (0..first.len()).find(|&k| solution.patches[k] != first[k]) {
                    return Err(Error::invalid(
                        self.path,
                        format!("frame {index} at t = {t}, patch {k}"),
                        "frame 0's patch",
                        "another polygon",
                    ));
                }
                w
            }
            None => {
                let header = SolutionHeader {
                    scene,
                    patches: &solution.patches,
                };
                let w = Writer::create(self.path, &header, self.options)?;
                &mut self.open.insert((w, solution.patches.clone())).0
            }
        };
        w.write_chunk(range[0], range[1], &solution.leaves)
    }

    /// Finishes the file with `stats`; an error if no frame was pushed.
    pub fn finish(self, stats: &SolveStats) -> Result<()> {
        match self.open {
            Some((w, _)) => w.finish(stats),
            None => Err(Error::Usage(
                "per-frame solve: no frame was solved".to_string(),
            )),
        }
    }
}

/// Writes a complete solution as one chunk (a static solve, or a space-time solution
/// already in memory).
pub fn write_solution(path: &Path, solution: &Solution, options: WriteOptions) -> Result<()> {
    let mut w = Writer::create(path, &SolutionHeader::of(solution), options)?;
    let (t0, t1) = whole_domain(solution);
    w.write_chunk(t0, t1, &solution.leaves)?;
    w.finish(&solution.stats)
}

/// The bytes [`write_solution`] would write, built in memory.
pub fn encode_solution(name: &Path, solution: &Solution, options: WriteOptions) -> Result<Vec<u8>> {
    let mut w = Writer::in_memory(name, &SolutionHeader::of(solution), options)?;
    let (t0, t1) = whole_domain(solution);
    w.write_chunk(t0, t1, &solution.leaves)?;
    w.finish_to_bytes(&solution.stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::records::LeafRecord;
    use crate::store::samples::box_solution;

    /// The section a chunk of `leaves` becomes: `(codec, stored bytes, raw_len)`.
    fn chunk_section(sol: &Solution, leaves: &[Leaf], compress: bool) -> (Codec, Vec<u8>, u64) {
        let options = WriteOptions {
            compress,
            keep_links: false,
        };
        let mut w = Writer::in_memory(Path::new("t.rhier"), &SolutionHeader::of(sol), options)
            .expect("writer");
        let mut blocks = 0;
        w.write_chunk_paged(0.0, 0.0, leaves, || blocks += 1)
            .expect("chunk");
        let e = *w.entries.last().expect("entry");
        // Each block is read once to check (and compress) it, and once more to
        // store it raw.
        let passes = if e.codec == Codec::Raw { 2 } else { 1 };
        assert_eq!(blocks, passes * leaves.len().div_ceil(LEAF_BLOCK));
        let Sink::Memory(bytes) = &w.sink else {
            unreachable!("in-memory writer")
        };
        let stored = bytes[e.offset as usize..(e.offset + e.stored_len) as usize].to_vec();
        assert_eq!(e.crc, crc32(&stored));
        assert_eq!(e.items, leaves.len() as u64);
        (e.codec, stored, e.raw_len)
    }

    #[test]
    fn streamed_chunks_are_the_archive() {
        let sol = box_solution(6);
        assert!(sol.leaves.len() > 100);
        // Three blocks' worth, the last one partial.
        let many: Vec<Leaf> = sol
            .leaves
            .iter()
            .cycle()
            .take(2 * LEAF_BLOCK + 7)
            .copied()
            .collect();
        for leaves in [&[][..], &sol.leaves[..1], &sol.leaves[..], &many[..]] {
            let records: Vec<LeafRecord> = leaves.iter().map(LeafRecord::from).collect();
            let archived = archive(Path::new("t"), &records).expect("archive");
            // Raw: the very bytes rkyv makes.
            let (codec, raw, raw_len) = chunk_section(&sol, leaves, false);
            assert_eq!(codec, Codec::Raw);
            assert_eq!(raw, archived.as_slice(), "{} leaves", leaves.len());
            assert_eq!(raw_len, archived.len() as u64);
            // Compressed: the frame one call to zstd makes of those bytes, or raw
            // when that is not smaller (no leaves).
            let (codec, packed, raw_len) = chunk_section(&sol, leaves, true);
            assert_eq!(raw_len, archived.len() as u64);
            let bulk = zstd::bulk::compress(&archived, ZSTD_LEVEL).expect("zstd");
            if bulk.len() < archived.len() {
                assert_eq!(codec, Codec::Zstd, "{} leaves", leaves.len());
                assert_eq!(packed, bulk, "{} leaves", leaves.len());
            } else {
                assert_eq!(codec, Codec::Raw);
                assert_eq!(packed, archived.as_slice());
            }
        }
    }
}
