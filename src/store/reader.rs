//! The `.rhier` reader: maps a file (memmap2) or takes bytes in memory, validates it,
//! and hands out the scene, patches and the leaves live at a time `t`.
//!
//! How it works: [`Reader::open`] checks, in this order and before any rkyv access, the
//! header (magic, CRC, version range, flags, stated file length), the section table's
//! CRC and every entry's bounds, then the CRCs of the small metadata sections (scene,
//! patches, chunk index, stats), which it decodes through rkyv's validating `access`.
//! Chunks are checked (CRC, bounded decompression, rkyv validation, leaf invariants)
//! only when a time that needs them is asked for, so opening and playing one frame
//! touch the metadata and the few chunks live at that time, never the whole file.
//!
//! What it does not do: it never trusts a length before comparing it to the bytes that
//! exist; decompression grows its buffer with the data actually produced and stops at
//! the stated raw length, so a lying length cannot cause a huge allocation. It keeps
//! only the chunks decoded by the last live set it read (so that playing frames in
//! order decodes the long-lived chunks once) and the last few live sets with the
//! stretch of time over which each holds ([`super::live`], [`Reader::live_at`]), so
//! that frames inside one stretch find their leaves without reading or filtering;
//! memory stays that of a few frames.

use std::io::Read;
use std::path::{Path, PathBuf};

use glam::DAffine3;
use rkyv::rancor;

use super::format::{Codec, ENTRY_LEN, HEADER_LEN, Header, SectionEntry, SectionKind, crc32};
use super::live::{Live, Stretch};
use super::records::{
    ArchivedChunkIndexRecord, ArchivedLeafRecord, ArchivedPatchRecord, ArchivedSceneRecord,
    ArchivedStatsRecord, ChunkRecord, ProvenanceRecord,
};
use crate::error::{Error, Result};
use crate::scene::{
    Camera, Material, MaterialId, MotionKey, MotionTrack, Object, Polygon, Scene, TimeDomain,
};
use crate::solution::{Leaf, PatchGeometry, Solution, SolveStats};

/// Live sets a reader keeps ([`Reader::live_at`]): the frames a viewer asks for
/// around one time, and a mesh asked for with its frame, find theirs kept.
const KEPT_SETS: usize = 4;

/// Largest zstd window (log2 bytes) a reader accepts: bounds the decoder's memory.
pub const ZSTD_WINDOW_LOG_MAX: u32 = 27;

/// The bytes of an opened file.
enum Backing {
    Mapped(memmap2::Mmap),
    Memory(Vec<u8>),
}

impl Backing {
    fn bytes(&self) -> &[u8] {
        match self {
            Backing::Mapped(m) => m,
            Backing::Memory(v) => v,
        }
    }
}

/// An object as stored: name and motion (the keys of an object that moves, the one
/// key that places a static object off the identity, else none).
#[derive(Clone, Debug, PartialEq)]
pub struct StoredObject {
    /// Name.
    pub name: String,
    /// Motion track; `None` = static at the identity placement.
    pub motion: Option<MotionTrack>,
}

impl StoredObject {
    /// Object → world map at `t`.
    pub fn to_world(&self, t: f64) -> DAffine3 {
        self.motion.as_ref().map_or(DAffine3::IDENTITY, |m| m.at(t))
    }

    /// True if the object's track moves it (a placement alone does not).
    pub fn is_moving(&self) -> bool {
        self.motion.as_ref().is_some_and(MotionTrack::is_moving)
    }
}

/// A validated, opened `.rhier` file.
pub struct Reader {
    path: PathBuf,
    data: Backing,
    header: Header,
    sections: Vec<SectionEntry>,
    time: TimeDomain,
    materials: Vec<Material>,
    objects: Vec<StoredObject>,
    camera: Option<Camera>,
    patches: Vec<PatchGeometry>,
    chunks: Vec<ChunkRecord>,
    stats: SolveStats,
    /// The provenance section's record (a space-time solve of version 2 or later).
    provenance: Option<ProvenanceRecord>,
    /// Chunks decoded by the last set read: `(chunk, leaves)`.
    recent: std::sync::Mutex<Vec<(usize, std::sync::Arc<Vec<Leaf>>)>>,
    /// The last few live sets found, most recently used last.
    live: std::sync::Mutex<Vec<Live>>,
}

impl std::fmt::Debug for Reader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reader")
            .field("path", &self.path)
            .field("header", &self.header)
            .field("sections", &self.sections.len())
            .finish()
    }
}

fn rkyv_err(path: &Path, place: String, what: &str, e: rancor::Error) -> Error {
    Error::invalid(
        path,
        place,
        format!("a valid rkyv archive of {what}"),
        e.to_string(),
    )
}

impl Reader {
    /// Maps and validates `path`.
    pub fn open(path: &Path) -> Result<Reader> {
        let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        // SAFETY: the map is read-only and private to this reader; every byte read from
        // it is validated (CRC, bounds, rkyv checks) before use. Another process
        // truncating the file while mapped is outside what any mmap reader can guard.
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(|e| Error::io(path, e))?;
        Reader::validate(path.to_path_buf(), Backing::Mapped(map))
    }

    /// Validates a file's bytes held in memory (`name` is used in errors).
    pub fn from_bytes(name: &Path, bytes: Vec<u8>) -> Result<Reader> {
        Reader::validate(name.to_path_buf(), Backing::Memory(bytes))
    }

    fn validate(path: PathBuf, data: Backing) -> Result<Reader> {
        let bytes = data.bytes();
        // 1. Header: magic, CRC, versions, flags, lengths.
        let header = Header::decode(&path, bytes)?;
        // 2. Section table: CRC, then each entry's kind, codec and bounds.
        let range = header.table_range();
        let table = &bytes[range.clone()];
        let crc = crc32(table);
        if crc != header.table_crc {
            return Err(Error::invalid(
                &path,
                format!("byte {} (section table)", range.start),
                format!("CRC-32 {:#010x} stated in the header", header.table_crc),
                format!("{crc:#010x}"),
            ));
        }
        let mut sections = Vec::with_capacity(header.table_count as usize);
        for (i, b) in table.chunks_exact(ENTRY_LEN).enumerate() {
            let at = range.start + i * ENTRY_LEN;
            sections.push(SectionEntry::decode(&path, i, at, b, header.table_offset)?);
        }
        for (i, e) in sections.iter().enumerate() {
            if let Err(expected) = check_raw_len(e.kind, e.items, e.raw_len) {
                return Err(Error::invalid(
                    &path,
                    format!(
                        "byte {} (section {i}, raw length)",
                        range.start + i * ENTRY_LEN + 24
                    ),
                    expected,
                    format!("{} bytes, {} records", e.raw_len, e.items),
                ));
            }
        }
        let single = |kind: SectionKind| -> Result<usize> {
            let mut found = sections.iter().enumerate().filter(|(_, e)| e.kind == kind);
            match (found.next(), found.next()) {
                (Some((i, _)), None) => Ok(i),
                _ => Err(Error::invalid(
                    &path,
                    format!("byte {} (section table)", range.start),
                    format!("exactly one {} section", kind.name()),
                    format!("{}", sections.iter().filter(|e| e.kind == kind).count()),
                )),
            }
        };
        let (i_scene, i_patches, i_index, i_stats) = (
            single(SectionKind::Scene)?,
            single(SectionKind::Patches)?,
            single(SectionKind::ChunkIndex)?,
            single(SectionKind::Stats)?,
        );
        let mut reader = Reader {
            path,
            data,
            header,
            sections,
            time: TimeDomain::default(),
            materials: Vec::new(),
            objects: Vec::new(),
            camera: None,
            patches: Vec::new(),
            chunks: Vec::new(),
            stats: SolveStats::default(),
            provenance: None,
            recent: std::sync::Mutex::new(Vec::new()),
            live: std::sync::Mutex::new(Vec::new()),
        };
        reader.load_scene(i_scene)?;
        reader.load_patches(i_patches)?;
        reader.load_index(i_index)?;
        reader.load_stats(i_stats)?;
        let mut provenance = reader
            .sections
            .iter()
            .enumerate()
            .filter(|(_, e)| e.kind == SectionKind::Provenance);
        match (provenance.next(), provenance.next()) {
            (Some((i, _)), None) => reader.load_provenance(i)?,
            (None, _) => {}
            (Some(_), Some(_)) => {
                return Err(Error::invalid(
                    &reader.path,
                    format!("byte {} (section table)", range.start),
                    "at most one provenance section",
                    "two or more",
                ));
            }
        }
        Ok(reader)
    }

    /// The stored bytes of section `i` after the CRC check, decompressed if needed.
    fn section_bytes(&self, i: usize) -> Result<std::borrow::Cow<'_, [u8]>> {
        let e = &self.sections[i];
        let stored = self.stored_section(i)?;
        match e.codec {
            Codec::Raw => Ok(std::borrow::Cow::Borrowed(stored)),
            Codec::Zstd => {
                let place = || format!("byte {} ({} section {i}, zstd)", e.offset, e.kind.name());
                let mut dec = zstd::stream::read::Decoder::with_buffer(stored).map_err(|err| {
                    Error::invalid(&self.path, place(), "a zstd frame", err.to_string())
                })?;
                dec.window_log_max(ZSTD_WINDOW_LOG_MAX).map_err(|err| {
                    Error::invalid(&self.path, place(), "a zstd frame", err.to_string())
                })?;
                // Grow with the data actually produced, never by the stated length.
                let mut out = Vec::new();
                dec.take(e.raw_len.saturating_add(1))
                    .read_to_end(&mut out)
                    .map_err(|err| {
                        Error::invalid(&self.path, place(), "a valid zstd frame", err.to_string())
                    })?;
                if out.len() as u64 != e.raw_len {
                    return Err(Error::invalid(
                        &self.path,
                        place(),
                        format!("{} bytes once decompressed", e.raw_len),
                        if out.len() as u64 > e.raw_len {
                            "more".to_string()
                        } else {
                            format!("{}", out.len())
                        },
                    ));
                }
                Ok(std::borrow::Cow::Owned(out))
            }
        }
    }

    fn place(&self, i: usize) -> String {
        let e = &self.sections[i];
        format!("byte {} ({} section {i})", e.offset, e.kind.name())
    }

    fn load_scene(&mut self, i: usize) -> Result<()> {
        let bytes = self.section_bytes(i)?;
        let s = rkyv::access::<ArchivedSceneRecord, rancor::Error>(&bytes)
            .map_err(|e| rkyv_err(&self.path, self.place(i), "the scene record", e))?;
        let time = TimeDomain {
            start: s.time[0].to_native(),
            end: s.time[1].to_native(),
        };
        let materials: Vec<Material> = s
            .materials
            .iter()
            .map(|m| Material {
                name: m.name.to_string(),
                rho: m.rho.map(|x| x.to_native()),
                emission: m.emission.map(|x| x.to_native()),
            })
            .collect();
        let mut objects = Vec::with_capacity(s.objects.len());
        for (k, o) in s.objects.iter().enumerate() {
            let motion = o.motion.as_ref().map(|keys| MotionTrack {
                keys: keys.iter().map(MotionKey::from).collect(),
            });
            if let Some(m) = &motion {
                let sorted = m.keys.windows(2).all(|w| w[0].t < w[1].t);
                let finite = m.keys.iter().all(|k| {
                    k.t.is_finite()
                        && k.translation.is_finite()
                        && k.rotation.is_finite()
                        && k.scale.is_finite()
                });
                if m.keys.is_empty() || !sorted || !finite {
                    return Err(Error::invalid(
                        &self.path,
                        format!("{}, object {k} motion", self.place(i)),
                        "at least one finite key, strictly increasing in time",
                        format!("{} keys", m.keys.len()),
                    ));
                }
            }
            objects.push(StoredObject {
                name: o.name.to_string(),
                motion,
            });
        }
        let camera = s.camera.as_ref().map(Camera::from);
        drop(bytes);
        if !(time.start.is_finite() && time.end.is_finite() && time.start <= time.end) {
            return Err(Error::invalid(
                &self.path,
                format!("{}, time domain", self.place(i)),
                "finite start <= end",
                format!("[{}, {}]", time.start, time.end),
            ));
        }
        self.time = time;
        self.materials = materials;
        self.objects = objects;
        self.camera = camera;
        Ok(())
    }

    fn load_patches(&mut self, i: usize) -> Result<()> {
        let bytes = self.section_bytes(i)?;
        let v = rkyv::access::<rkyv::vec::ArchivedVec<ArchivedPatchRecord>, rancor::Error>(&bytes)
            .map_err(|e| rkyv_err(&self.path, self.place(i), "the patch records", e))?;
        let mut patches = Vec::with_capacity(v.len());
        for (k, p) in v.iter().enumerate() {
            let p = PatchGeometry::from(p);
            let ok = (p.object as usize) < self.objects.len()
                && (p.material as usize) < self.materials.len()
                && (p.corners == 3 || p.corners == 4)
                && p.vertices.iter().all(|v| v.is_finite());
            if !ok {
                return Err(Error::invalid(
                    &self.path,
                    format!("{}, patch {k}", self.place(i)),
                    format!(
                        "object < {}, material < {}, 3 or 4 finite corners",
                        self.objects.len(),
                        self.materials.len()
                    ),
                    format!(
                        "object {}, material {}, {} corners",
                        p.object, p.material, p.corners
                    ),
                ));
            }
            patches.push(p);
        }
        drop(bytes);
        self.patches = patches;
        Ok(())
    }

    fn load_index(&mut self, i: usize) -> Result<()> {
        let bytes = self.section_bytes(i)?;
        let idx = rkyv::access::<ArchivedChunkIndexRecord, rancor::Error>(&bytes)
            .map_err(|e| rkyv_err(&self.path, self.place(i), "the chunk index", e))?;
        let mut chunks = Vec::with_capacity(idx.chunks.len());
        for (k, c) in idx.chunks.iter().enumerate() {
            let c = ChunkRecord {
                t0: c.t0.to_native(),
                t1: c.t1.to_native(),
                reach: c.reach.to_native(),
                section: c.section.to_native(),
                leaves: c.leaves.to_native(),
                carry_from: c.carry_from.to_native(),
            };
            let prev_t1 = chunks
                .last()
                .map_or(self.time.start, |p: &ChunkRecord| p.t1);
            let entry = self.sections.get(c.section as usize);
            let ok = c.t0.is_finite()
                && c.t1.is_finite()
                && c.reach.is_finite()
                && c.t0 >= prev_t1
                && c.t1 >= c.t0
                && c.t1 <= self.time.end
                && c.reach >= c.t0
                && (c.carry_from as usize) <= k
                && entry
                    .is_some_and(|e| e.kind == SectionKind::Chunk && e.items == c.leaves as u64);
            if !ok {
                return Err(Error::invalid(
                    &self.path,
                    format!("{}, chunk {k}", self.place(i)),
                    format!(
                        "a chunk in time order inside [{}, {}] naming a chunk section with its leaf count",
                        self.time.start, self.time.end
                    ),
                    format!(
                        "[{}, {}] reach {} section {} leaves {} carry_from {}",
                        c.t0, c.t1, c.reach, c.section, c.leaves, c.carry_from
                    ),
                ));
            }
            chunks.push(c);
        }
        drop(bytes);
        self.chunks = chunks;
        Ok(())
    }

    fn load_stats(&mut self, i: usize) -> Result<()> {
        let bytes = self.section_bytes(i)?;
        let s = rkyv::access::<ArchivedStatsRecord, rancor::Error>(&bytes)
            .map_err(|e| rkyv_err(&self.path, self.place(i), "the stats record", e))?;
        let stats = SolveStats::from(s);
        drop(bytes);
        self.stats = stats;
        Ok(())
    }

    fn load_provenance(&mut self, i: usize) -> Result<()> {
        let bytes = self.section_bytes(i)?;
        let p = rkyv::access::<super::records::ArchivedProvenanceRecord, rancor::Error>(&bytes)
            .map_err(|e| rkyv_err(&self.path, self.place(i), "the provenance record", e))?;
        let p = ProvenanceRecord {
            fingerprint: p.fingerprint.to_string(),
            windows: p.windows.to_native(),
            first: p.first.to_native(),
            end: p.end.to_native(),
            shard: p.shard.to_native(),
            shards: p.shards.to_native(),
            time: p.time.map(|x| x.to_native()),
        };
        drop(bytes);
        let ok = p.first <= p.end
            && p.end <= p.windows
            && p.shard < p.shards
            && p.time[0] <= p.time[1]
            && p.time[0] >= self.time.start
            && p.time[1] <= self.time.end;
        if !ok {
            return Err(Error::invalid(
                &self.path,
                self.place(i),
                format!(
                    "windows first <= end <= windows, shard < shards, a time range inside [{}, {}]",
                    self.time.start, self.time.end
                ),
                format!(
                    "windows {}..{} of {}, shard {} of {}, time [{}, {}]",
                    p.first, p.end, p.windows, p.shard, p.shards, p.time[0], p.time[1]
                ),
            ));
        }
        self.provenance = Some(p);
        Ok(())
    }

    /// Where the file's windows come from: the fingerprint of the space-time solve
    /// and the run of its windows the file holds (`None`: a static or per-frame
    /// solve, or a file older than version 2).
    pub fn provenance(&self) -> Option<&ProvenanceRecord> {
        self.provenance.as_ref()
    }

    /// The stored (possibly compressed) bytes of section `i` of the table, after
    /// their CRC-32 is checked: what `rhier merge` copies without decoding.
    pub fn stored_section(&self, i: usize) -> Result<&[u8]> {
        let e = self.sections.get(i).ok_or_else(|| {
            Error::Usage(format!(
                "{}: section {i} requested, the file has {}",
                self.path.display(),
                self.sections.len()
            ))
        })?;
        let stored = &self.data.bytes()[e.offset as usize..(e.offset + e.stored_len) as usize];
        let crc = crc32(stored);
        if crc != e.crc {
            return Err(Error::invalid(
                &self.path,
                format!("byte {} ({} section {i})", e.offset, e.kind.name()),
                format!("CRC-32 {:#010x} stated in the section table", e.crc),
                format!("{crc:#010x}"),
            ));
        }
        Ok(stored)
    }

    /// The file's path (or in-memory name).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The decoded header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The section table.
    pub fn sections(&self) -> &[SectionEntry] {
        &self.sections
    }

    /// The chunk index, in time order.
    pub fn chunks(&self) -> &[ChunkRecord] {
        &self.chunks
    }

    /// The scene's time domain.
    pub fn time_domain(&self) -> TimeDomain {
        self.time
    }

    /// Materials.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Objects (name and motion).
    pub fn objects(&self) -> &[StoredObject] {
        &self.objects
    }

    /// Camera, if the scene had one.
    pub fn camera(&self) -> Option<Camera> {
        self.camera
    }

    /// Patches.
    pub fn patches(&self) -> &[PatchGeometry] {
        &self.patches
    }

    /// Statistics of the solve that wrote the file.
    pub fn stats(&self) -> &SolveStats {
        &self.stats
    }

    /// Total length of the file in bytes.
    pub fn file_len(&self) -> u64 {
        self.header.file_len
    }

    /// The leaves stored in chunk `k`, validated.
    pub fn chunk_leaves(&self, k: usize) -> Result<Vec<Leaf>> {
        let c = *self.chunks.get(k).ok_or_else(|| {
            Error::Usage(format!(
                "{}: chunk {k} requested, the file has {} chunks",
                self.path.display(),
                self.chunks.len()
            ))
        })?;
        let i = c.section as usize;
        let bytes = self.section_bytes(i)?;
        let v = rkyv::access::<rkyv::vec::ArchivedVec<ArchivedLeafRecord>, rancor::Error>(&bytes)
            .map_err(|e| rkyv_err(&self.path, self.place(i), "the leaf records", e))?;
        let (t0, t1) = (c.t0 as f32, c.t1 as f32);
        let mut leaves = Vec::with_capacity(v.len());
        for (n, l) in v.iter().enumerate() {
            let l = Leaf::from(l);
            let corners = self.patches.get(l.patch as usize).map(|p| p.corners);
            let finite = l.values_finite();
            let timely = l.time[0] >= t0 && l.time[0] <= t1 && l.time[1] >= l.time[0];
            if corners != Some(l.corners) || !finite || !timely || l.time[1] as f64 > c.reach {
                return Err(Error::invalid(
                    &self.path,
                    format!("{}, leaf {n}", self.place(i)),
                    format!(
                        "a leaf of one of {} patches with its corner count, finite values, starting in [{}, {}] and ending by {}",
                        self.patches.len(),
                        c.t0,
                        c.t1,
                        c.reach
                    ),
                    format!(
                        "patch {}, {} corners, time [{}, {}]",
                        l.patch, l.corners, l.time[0], l.time[1]
                    ),
                ));
            }
            leaves.push(l);
        }
        if leaves.len() != c.leaves as usize {
            return Err(Error::invalid(
                &self.path,
                self.place(i),
                format!("{} leaves (chunk index)", c.leaves),
                format!("{}", leaves.len()),
            ));
        }
        Ok(leaves)
    }

    /// The leaves of chunk `k` as [`Reader::chunk_leaves`] gives them, shared with the
    /// reader's own copy when the last live set read decoded that chunk (so that a
    /// caller going over the chunks of the time it just played decodes nothing).
    pub fn chunk_leaves_shared(&self, k: usize) -> Result<std::sync::Arc<Vec<Leaf>>> {
        let kept = self
            .recent
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .iter()
            .find(|(j, _)| *j == k)
            .map(|(_, l)| l.clone());
        match kept {
            Some(l) => Ok(l),
            None => Ok(std::sync::Arc::new(self.chunk_leaves(k)?)),
        }
    }

    /// Indices of the chunks that may hold leaves live at `t` (see
    /// [`super::records::ChunkRecord`]): a binary search plus the carried chunks. Times
    /// are compared in `f32`, as [`Leaf::is_live`] compares them: a time just under a
    /// chunk's start that rounds to it finds that chunk's leaves starting there.
    pub fn chunks_for(&self, t: f64) -> Vec<usize> {
        let n = self.chunks.partition_point(|c| c.t0 as f32 <= t as f32);
        if n == 0 {
            return Vec::new();
        }
        let i = n - 1;
        let from = self.chunks[i].carry_from as usize;
        // Same test as Leaf::is_live on the chunk's latest leaf end, in f32.
        let (tf, end) = (t as f32, self.time.end as f32);
        (from..=i)
            .filter(|&j| {
                let reach = self.chunks[j].reach as f32;
                j == i || reach > tf || (reach >= tf && reach >= end)
            })
            .collect()
    }

    /// The leaves live at `t` ([`Leaf::is_live`]), reading only the chunks that need it,
    /// in canonical order ([`super::live::canonical_order`]).
    pub fn leaves_at(&self, t: f64) -> Result<Vec<Leaf>> {
        Ok(self.live_at(t)?.leaves.to_vec())
    }

    /// The leaves live at `t` and the stretch of time over which they are
    /// ([`super::live`]): taken from the last few sets found when one of their
    /// stretches holds `t`, else read from the chunks that may hold them
    /// ([`Reader::chunks_for`]) and kept.
    pub fn live_at(&self, t: f64) -> Result<Live> {
        check_time(&self.path, self.time, t)?;
        // A poisoned lock only means another thread panicked mid-update: start afresh.
        let kept = |m: &'_ std::sync::Mutex<Vec<Live>>| {
            let mut g = m.lock().unwrap_or_else(|p| {
                let mut g = p.into_inner();
                g.clear();
                g
            });
            let hit = g.iter().position(|l| l.stretch.contains(t));
            hit.map(|i| {
                // Most recently used last.
                let l = g.remove(i);
                g.push(l.clone());
                l
            })
        };
        if let Some(l) = kept(&self.live) {
            return Ok(l);
        }
        let live = self.read_live(t)?;
        let mut g = self.live.lock().unwrap_or_else(|p| p.into_inner());
        if g.len() >= KEPT_SETS {
            g.remove(0);
        }
        g.push(live.clone());
        Ok(live)
    }

    /// [`Reader::live_at`] read from the chunks.
    fn read_live(&self, t: f64) -> Result<Live> {
        let mut recent = self.recent.lock().unwrap_or_else(|p| {
            let mut g = p.into_inner();
            g.clear();
            g
        });
        // The chunk range of `t`, as chunks_for finds it.
        let tf = t as f32;
        let t_end = self.time.end as f32;
        let n = self.chunks.partition_point(|c| c.t0 as f32 <= tf);
        let mut stretch = Stretch::whole(n as u32);
        if let Some(c) = self.chunks.get(n) {
            stretch.cut_start(tf, c.t0 as f32);
        }
        if let Some(i) = n.checked_sub(1) {
            stretch.cut_start(tf, self.chunks[i].t0 as f32);
            // The chunks chunks_for drops or keeps by their reach.
            for c in &self.chunks[self.chunks[i].carry_from as usize..i] {
                stretch.cut_end(tf, c.reach as f32, t_end);
            }
        }
        let mut kept = Vec::new();
        let mut out = Vec::new();
        for k in self.chunks_for(t) {
            let leaves = match recent.iter().find(|(j, _)| *j == k) {
                Some((_, l)) => l.clone(),
                None => std::sync::Arc::new(self.chunk_leaves(k)?),
            };
            for l in leaves.iter() {
                stretch.cut(tf, l.time, t_end);
                if l.is_live(t, self.time.end) {
                    out.push(*l);
                }
            }
            kept.push((k, leaves));
        }
        *recent = kept;
        Ok(Live::new(stretch, out))
    }

    /// Validates every chunk (checksum, decompression, rkyv, leaf invariants) and
    /// returns the number of leaves checked; reads the whole file.
    pub fn verify(&self) -> Result<u64> {
        let mut n = 0u64;
        for k in 0..self.chunks.len() {
            n += self.chunk_leaves(k)?.len() as u64;
        }
        Ok(n)
    }

    /// The links section (written with `--keep-links`), or an empty list when the file
    /// has none.
    pub fn links(&self) -> Result<Vec<super::records::LinkRecord>> {
        let Some(i) = self
            .sections
            .iter()
            .position(|e| e.kind == SectionKind::Links)
        else {
            return Ok(Vec::new());
        };
        let bytes = self.section_bytes(i)?;
        let v = rkyv::access::<
            rkyv::vec::ArchivedVec<super::records::ArchivedLinkRecord>,
            rancor::Error,
        >(&bytes)
        .map_err(|e| rkyv_err(&self.path, self.place(i), "the link records", e))?;
        Ok(v.iter()
            .map(|l| super::records::LinkRecord {
                receiver: l.receiver.to_native(),
                source: l.source.to_native(),
                time: l.time.map(|x| x.to_native()),
                coefficient: l.coefficient.map(|x| x.to_native()),
                error: l.error.to_native(),
                active: l.active.to_native(),
                reserved: l.reserved.to_native(),
            })
            .collect())
    }

    /// The hierarchy section (written by `rhier solve --keep-links --movable`), or
    /// `None` when the file has none. Its columns' sizes are checked here; what
    /// they hold, against the scene, by [`crate::solver::Solver::from_hierarchy`].
    pub fn hierarchy(&self) -> Result<Option<super::Hierarchy>> {
        let mut found = self
            .sections
            .iter()
            .enumerate()
            .filter(|(_, e)| e.kind == SectionKind::Hierarchy);
        let i = match (found.next(), found.next()) {
            (None, _) => return Ok(None),
            (Some((i, _)), None) => i,
            (Some(_), Some((j, _))) => {
                return Err(Error::invalid(
                    &self.path,
                    self.place(j),
                    "at most one hierarchy section",
                    "two or more",
                ));
            }
        };
        let bytes = self.section_bytes(i)?;
        let r = rkyv::access::<super::records::ArchivedHierarchyRecord, rancor::Error>(&bytes)
            .map_err(|e| rkyv_err(&self.path, self.place(i), "the hierarchy record", e))?;
        super::Hierarchy::from_archived(&self.path, &self.place(i), r).map(Some)
    }

    /// Every leaf of every chunk, validated (reads the whole file).
    pub fn all_leaves(&self) -> Result<Vec<Leaf>> {
        let mut out = Vec::new();
        for k in 0..self.chunks.len() {
            out.extend(self.chunk_leaves(k)?);
        }
        Ok(out)
    }

    /// How many link records the links section holds (0 when the file has none), from
    /// the section table, which [`Reader::open`] checked against the section's size;
    /// the records themselves are not read.
    pub fn link_count(&self) -> u64 {
        self.sections
            .iter()
            .filter(|e| e.kind == SectionKind::Links)
            .map(|e| e.items)
            .sum()
    }

    /// The scene rebuilt from the stored objects and patches (polygons dropped by the
    /// solver are not stored), without reading any leaf.
    pub fn scene(&self) -> Scene {
        let mut objects: Vec<Object> = self
            .objects
            .iter()
            .map(|o| Object {
                name: o.name.clone(),
                polygons: Vec::new(),
                motion: o.motion.clone(),
            })
            .collect();
        for p in &self.patches {
            objects[p.object as usize].polygons.push(Polygon {
                vertices: p.vertices[..p.corners as usize].to_vec(),
                material: MaterialId(p.material),
            });
        }
        Scene {
            time: self.time,
            materials: self.materials.clone(),
            objects,
            camera: self.camera,
            warnings: Vec::new(),
        }
    }

    /// The whole solution in memory: [`Reader::scene`], every leaf, the stats.
    pub fn to_solution(&self) -> Result<Solution> {
        Ok(Solution {
            scene: self.scene(),
            patches: self.patches.clone(),
            leaves: self.all_leaves()?,
            stats: self.stats.clone(),
        })
    }

    /// Bytes of the header and section table.
    pub fn table_bytes(&self) -> u64 {
        (HEADER_LEN + self.sections.len() * ENTRY_LEN) as u64
    }
}

/// What the raw length of a section with `items` records must be: fixed-size records
/// then the 16-byte root (`ArchivedVec`: 8-byte relative pointer, 8-byte length);
/// one stats record; one scene record of any length. `Err` holds what was expected.
fn check_raw_len(kind: SectionKind, items: u64, raw_len: u64) -> std::result::Result<(), String> {
    use std::mem::size_of;
    let record = match kind {
        SectionKind::Patches => size_of::<super::records::ArchivedPatchRecord>(),
        SectionKind::Chunk => size_of::<ArchivedLeafRecord>(),
        SectionKind::ChunkIndex => size_of::<super::records::ArchivedChunkRecord>(),
        SectionKind::Links => size_of::<super::records::ArchivedLinkRecord>(),
        SectionKind::Stats => {
            let want = size_of::<ArchivedStatsRecord>() as u64;
            return if items == 1 && raw_len == want {
                Ok(())
            } else {
                Err(format!("1 stats record of {want} bytes"))
            };
        }
        SectionKind::Scene | SectionKind::Provenance | SectionKind::Hierarchy => {
            return if items == 1 {
                Ok(())
            } else {
                Err(format!("1 {} record", kind.name()))
            };
        }
    } as u64;
    match items.checked_mul(record).and_then(|x| x.checked_add(16)) {
        Some(want) if want == raw_len => Ok(()),
        Some(want) => Err(format!("{want} bytes for {items} {} records", kind.name())),
        None => Err(format!(
            "a record count whose size fits in 64 bits, not {items}"
        )),
    }
}

/// Refuses a time outside the scene's time domain.
pub(crate) fn check_time(path: &Path, time: TimeDomain, t: f64) -> Result<()> {
    if !(t >= time.start && t <= time.end) {
        return Err(Error::invalid(
            path,
            "requested time",
            format!(
                "a time in the scene's domain [{}, {}]",
                time.start, time.end
            ),
            format!("{t}"),
        ));
    }
    Ok(())
}
