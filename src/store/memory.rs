//! Named memory counters: where the bytes of a `.rhier` file (or of a run in progress)
//! go, and what playing one frame costs.
//!
//! [`MemoryReport`] is filled by [`MemoryReport::from_reader`] for `rhier inspect`, and
//! by the solver for `solve --stats` (it pushes [`PoolBytes`] rows and chunk counts as
//! it goes); both print it with `Display` or serialise it to JSON. It estimates, it
//! does not measure the allocator: the frame cost is computed from the stored lengths.

use serde::Serialize;

use super::format::{Codec, SectionEntry, SectionKind};
use super::reader::Reader;
use super::records::ChunkRecord;
use crate::solution::{Leaf, PatchGeometry};

/// Bytes of one section of a file.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SectionBytes {
    /// Position in the section table.
    pub index: usize,
    /// Section kind name.
    pub kind: &'static str,
    /// `raw` or `zstd`.
    pub codec: &'static str,
    /// Byte offset in the file.
    pub offset: u64,
    /// Bytes on disk.
    pub stored_bytes: u64,
    /// Bytes once decompressed.
    pub raw_bytes: u64,
    /// Records in the section.
    pub items: u64,
}

/// Resident bytes of one pool of a run in progress (filled by the solver).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PoolBytes {
    /// Pool name (`elements`, `links`, `shafts`...).
    pub name: String,
    /// Records in the pool.
    pub items: u64,
    /// Resident bytes.
    pub bytes: u64,
}

/// One time chunk.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChunkCount {
    /// Chunk index.
    pub index: usize,
    /// Start time.
    pub t0: f64,
    /// End time.
    pub t1: f64,
    /// Leaves (elements) stored in the chunk.
    pub leaves: u64,
    /// Leaves live at the chunk's start, over all chunks it reads.
    pub live_upper_bound: u64,
    /// Bytes on disk.
    pub stored_bytes: u64,
    /// Bytes once decompressed.
    pub raw_bytes: u64,
}

/// Named counters of a file or a run: bytes per section and per pool, elements per
/// chunk, and the memory needed to play one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MemoryReport {
    /// File name or run label.
    pub source: String,
    /// Total file bytes (0 for a run in progress).
    pub file_bytes: u64,
    /// Header and section table bytes.
    pub table_bytes: u64,
    /// Sections in file order.
    pub sections: Vec<SectionBytes>,
    /// Solver pools (empty for a file).
    pub pools: Vec<PoolBytes>,
    /// Time chunks.
    pub chunks: Vec<ChunkCount>,
    /// Patches.
    pub patches: u64,
    /// Bytes always resident once a file is open (decoded patches, scene, index).
    pub open_bytes: u64,
    /// Worst case over chunks of the bytes needed to play one frame: `open_bytes`, the
    /// decompressed chunks read for it, the decoded leaves, and the per-frame world
    /// geometry.
    pub frame_bytes: u64,
    /// Chunk at whose start `frame_bytes` is reached.
    pub frame_worst_chunk: Option<usize>,
}

/// Bytes per patch of a frame's world geometry (corners, normal, bounds) as playback
/// builds it.
pub const FRAME_BYTES_PER_PATCH: u64 = 4 * 24 + 24 + 48 + 8;

impl MemoryReport {
    /// An empty report for a run in progress named `source`.
    pub fn for_run(source: &str) -> MemoryReport {
        MemoryReport {
            source: source.to_string(),
            ..MemoryReport::default()
        }
    }

    /// Adds a pool row (name, records, resident bytes).
    pub fn add_pool(&mut self, name: &str, items: u64, bytes: u64) {
        self.pools.push(PoolBytes {
            name: name.to_string(),
            items,
            bytes,
        });
    }

    /// The report of an opened file.
    pub fn from_reader(r: &Reader) -> MemoryReport {
        let mut m = MemoryReport::from_parts(
            &r.path().display().to_string(),
            r.file_len(),
            r.sections(),
            r.chunks(),
            r.patches().len() as u64,
        );
        m.table_bytes = r.table_bytes();
        m
    }

    /// The report of a file (finished or being written) from its table and chunk
    /// index: `file_bytes` is the bytes written so far.
    pub fn from_parts(
        source: &str,
        file_bytes: u64,
        entries: &[SectionEntry],
        index: &[ChunkRecord],
        patches: u64,
    ) -> MemoryReport {
        let sections: Vec<SectionBytes> = entries
            .iter()
            .enumerate()
            .map(|(index, e)| SectionBytes {
                index,
                kind: e.kind.name(),
                codec: match e.codec {
                    Codec::Raw => "raw",
                    Codec::Zstd => "zstd",
                },
                offset: e.offset,
                stored_bytes: e.stored_len,
                raw_bytes: e.raw_len,
                items: e.items,
            })
            .collect();
        let open_bytes = patches * std::mem::size_of::<PatchGeometry>() as u64
            + index.len() as u64 * std::mem::size_of::<ChunkRecord>() as u64
            + entries
                .iter()
                .filter(|e| e.kind == SectionKind::Scene)
                .map(|e| e.raw_len)
                .sum::<u64>();
        let mut chunks = Vec::new();
        let mut worst = (0u64, None);
        for (i, c) in index.iter().enumerate() {
            let Some(e) = entries.get(c.section as usize) else {
                continue;
            };
            // Chunks read to play the chunk's first instant: carry_from..=i whose
            // reach gets there (an upper bound of what Reader::chunks_for reads).
            let (mut decoded, mut live) = (0u64, 0u64);
            let from = (c.carry_from as usize).min(i);
            for (j, cj) in index.iter().enumerate().take(i + 1).skip(from) {
                // Leaves are live on [t0, t1): a chunk whose leaves all end by t0 is
                // not read (Reader::chunks_for), unless it is chunk i itself.
                if j != i && cj.reach <= c.t0 {
                    continue;
                }
                if let Some(ej) = entries.get(cj.section as usize)
                    && ej.codec == Codec::Zstd
                {
                    decoded += ej.raw_len;
                }
                live += cj.leaves as u64;
            }
            let frame = open_bytes
                + decoded
                + live * std::mem::size_of::<Leaf>() as u64
                + patches * FRAME_BYTES_PER_PATCH;
            if frame > worst.0 {
                worst = (frame, Some(i));
            }
            chunks.push(ChunkCount {
                index: i,
                t0: c.t0,
                t1: c.t1,
                leaves: c.leaves as u64,
                live_upper_bound: live,
                stored_bytes: e.stored_len,
                raw_bytes: e.raw_len,
            });
        }
        MemoryReport {
            source: source.to_string(),
            file_bytes,
            table_bytes: (super::format::HEADER_LEN + entries.len() * super::format::ENTRY_LEN)
                as u64,
            sections,
            pools: Vec::new(),
            chunks,
            patches,
            open_bytes,
            frame_bytes: worst.0.max(open_bytes),
            frame_worst_chunk: worst.1,
        }
    }
}

fn human(b: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

impl std::fmt::Display for MemoryReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "memory report: {}", self.source)?;
        if self.file_bytes > 0 {
            writeln!(
                f,
                "  file bytes        {:>12}  ({})",
                self.file_bytes,
                human(self.file_bytes)
            )?;
            writeln!(f, "  header + table    {:>12}", self.table_bytes)?;
        }
        if !self.sections.is_empty() {
            writeln!(f, "  sections:")?;
            writeln!(
                f,
                "    {:>4}  {:<12} {:<5} {:>12} {:>12} {:>12} {:>10}",
                "#", "kind", "codec", "offset", "stored", "raw", "items"
            )?;
            for s in &self.sections {
                writeln!(
                    f,
                    "    {:>4}  {:<12} {:<5} {:>12} {:>12} {:>12} {:>10}",
                    s.index, s.kind, s.codec, s.offset, s.stored_bytes, s.raw_bytes, s.items
                )?;
            }
        }
        if !self.pools.is_empty() {
            writeln!(f, "  pools:")?;
            for p in &self.pools {
                writeln!(
                    f,
                    "    {:<16} {:>12} items {:>12} bytes ({})",
                    p.name,
                    p.items,
                    p.bytes,
                    human(p.bytes)
                )?;
            }
        }
        if !self.chunks.is_empty() {
            writeln!(f, "  time chunks: {}", self.chunks.len())?;
            writeln!(
                f,
                "    {:>5}  {:>10} {:>10} {:>10} {:>12} {:>12} {:>12}",
                "#", "t0", "t1", "leaves", "live<=", "stored", "raw"
            )?;
            for c in &self.chunks {
                writeln!(
                    f,
                    "    {:>5}  {:>10.4} {:>10.4} {:>10} {:>12} {:>12} {:>12}",
                    c.index, c.t0, c.t1, c.leaves, c.live_upper_bound, c.stored_bytes, c.raw_bytes
                )?;
            }
        }
        writeln!(f, "  patches           {:>12}", self.patches)?;
        writeln!(
            f,
            "  open (resident)   {:>12}  ({})",
            self.open_bytes,
            human(self.open_bytes)
        )?;
        write!(
            f,
            "  play one frame    {:>12}  ({})",
            self.frame_bytes,
            human(self.frame_bytes)
        )?;
        if let Some(c) = self.frame_worst_chunk {
            write!(f, "  worst at chunk {c}")?;
        }
        writeln!(f)
    }
}
