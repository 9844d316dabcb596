//! Byte layout of the `.rhier` file: header and section-table constants, mirrored from
//! `formats/rhier.md` (the spec owns the layout; every offset here is derived from it).
//!
//! This module only encodes and decodes the two fixed-layout parts of the file, the
//! 64-byte [`Header`] at offset 0 and the [`SectionEntry`] table; the sections' own
//! contents are rkyv archives described in [`super::records`]. It performs no I/O.
//! Decoding checks the magic, the version range and the CRC-32 before any field is
//! trusted, and reports what was expected and what was found.

use std::path::Path;

use crate::error::{Error, Result};

/// The file's first 10 bytes: `\x89 R H I E R \r \n \x1a \n` (PNG style: the high
/// byte catches 7-bit transfers, CR LF and LF catch newline conversion, `\x1a` stops
/// `type` on DOS).
pub const MAGIC: [u8; 10] = [0x89, b'R', b'H', b'I', b'E', b'R', 0x0D, 0x0A, 0x1A, 0x0A];

/// Newest format version this code reads and writes (2: the optional provenance
/// section; 3: the optional hierarchy section).
pub const VERSION: u32 = 3;
/// The version written in a file without a hierarchy section: such a file is
/// byte for byte what a version-2 writer made.
pub const BASE_VERSION: u32 = 2;
/// Oldest format version this code still reads.
pub const OLDEST_READABLE: u32 = 1;
/// The version a reader must have at least to read what this code writes without
/// a provenance section: a version-1 reader reads such a file as it is.
pub const MIN_READER_VERSION: u32 = 1;
/// The version a reader must have at least to read a file with a provenance
/// section (a section kind version 1 does not know).
pub const PROVENANCE_READER_VERSION: u32 = 2;
/// The version a reader must have at least to read a file with a hierarchy
/// section (`rhier solve --keep-links --movable`; a section kind version 2 does
/// not know). Such a file's version is 3 too.
pub const HIERARCHY_READER_VERSION: u32 = 3;

/// Size of the header in bytes.
pub const HEADER_LEN: usize = 64;
/// Size of one section-table entry in bytes.
pub const ENTRY_LEN: usize = 48;

// Header field offsets (formats/rhier.md, "Header").
const OFF_MAGIC: usize = 0;
const OFF_HEADER_LEN: usize = 10;
const OFF_VERSION: usize = 12;
const OFF_MIN_READER: usize = 16;
const OFF_FLAGS: usize = 20;
const OFF_TABLE_OFFSET: usize = 24;
const OFF_TABLE_COUNT: usize = 32;
const OFF_TABLE_CRC: usize = 36;
const OFF_FILE_LEN: usize = 40;
const OFF_RESERVED: usize = 48;
const OFF_HEADER_CRC: usize = 60;

/// Flag: the scene has at least one moving object (a motion-track section is present
/// inside the scene record).
pub const FLAG_MOVING: u32 = 1 << 0;
/// Flag: a links section is present (`--keep-links`).
pub const FLAG_LINKS: u32 = 1 << 1;
/// Flag: at least one section is zstd-compressed.
pub const FLAG_COMPRESSED: u32 = 1 << 2;
/// All flags a version-1 reader knows; others make the file unreadable.
pub const KNOWN_FLAGS: u32 = FLAG_MOVING | FLAG_LINKS | FLAG_COMPRESSED;

/// Largest number of sections a reader accepts (bounds the table allocation).
pub const MAX_SECTIONS: u32 = 1 << 24;

/// Kind of a section (the `kind` field of a [`SectionEntry`]).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub enum SectionKind {
    /// Scene record: time domain, materials, objects, motion of moving objects, camera.
    Scene = 1,
    /// Patch records, in patch order.
    Patches = 2,
    /// Leaf records of one time chunk.
    Chunk = 3,
    /// Chunk index: one record per chunk, in time order.
    ChunkIndex = 4,
    /// Solve statistics.
    Stats = 5,
    /// Link records (only with `--keep-links`).
    Links = 6,
    /// Where a space-time file's windows come from (version 2; at most one).
    Provenance = 7,
    /// The element pool and the links' transports of an interactive session's
    /// start-up solve (version 3; at most one; `rhier solve --keep-links --movable`).
    Hierarchy = 8,
}

impl SectionKind {
    /// Decodes a kind; `None` for unknown values.
    pub fn from_u32(v: u32) -> Option<Self> {
        Some(match v {
            1 => SectionKind::Scene,
            2 => SectionKind::Patches,
            3 => SectionKind::Chunk,
            4 => SectionKind::ChunkIndex,
            5 => SectionKind::Stats,
            6 => SectionKind::Links,
            7 => SectionKind::Provenance,
            8 => SectionKind::Hierarchy,
            _ => return None,
        })
    }

    /// Lower-case name used by `inspect`.
    pub fn name(self) -> &'static str {
        match self {
            SectionKind::Scene => "scene",
            SectionKind::Patches => "patches",
            SectionKind::Chunk => "chunk",
            SectionKind::ChunkIndex => "chunk_index",
            SectionKind::Stats => "stats",
            SectionKind::Links => "links",
            SectionKind::Provenance => "provenance",
            SectionKind::Hierarchy => "hierarchy",
        }
    }
}

/// How a section's bytes are stored.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Codec {
    /// Stored as is.
    Raw = 0,
    /// One zstd frame.
    Zstd = 1,
}

impl Codec {
    /// Decodes a codec; `None` for unknown values.
    pub fn from_u32(v: u32) -> Option<Self> {
        match v {
            0 => Some(Codec::Raw),
            1 => Some(Codec::Zstd),
            _ => None,
        }
    }
}

/// The fixed 64-byte header at offset 0 (formats/rhier.md, "Header").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Format version of the writer.
    pub version: u32,
    /// Oldest reader version able to read the file.
    pub min_reader_version: u32,
    /// `FLAG_*` bits.
    pub flags: u32,
    /// Byte offset of the section table.
    pub table_offset: u64,
    /// Number of entries in the section table.
    pub table_count: u32,
    /// CRC-32 of the section table bytes.
    pub table_crc: u32,
    /// Length of the whole file in bytes.
    pub file_len: u64,
}

/// One entry of the section table, 48 bytes (formats/rhier.md, "Section table").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SectionEntry {
    /// What the section holds.
    pub kind: SectionKind,
    /// How its bytes are stored.
    pub codec: Codec,
    /// Byte offset of the stored bytes.
    pub offset: u64,
    /// Stored (possibly compressed) length.
    pub stored_len: u64,
    /// Length after decompression (the rkyv archive's length).
    pub raw_len: u64,
    /// Number of records in the section (leaves, patches, chunks; 1 for single records).
    pub items: u64,
    /// CRC-32 (IEEE) of the stored bytes.
    pub crc: u32,
}

/// CRC-32 (IEEE 802.3) of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

fn u32_at(b: &[u8], off: usize) -> u32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&b[off..off + 4]);
    u32::from_le_bytes(a)
}

fn u64_at(b: &[u8], off: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[off..off + 8]);
    u64::from_le_bytes(a)
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

impl Header {
    /// Encodes the header, CRC included.
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        b[OFF_MAGIC..OFF_MAGIC + MAGIC.len()].copy_from_slice(&MAGIC);
        b[OFF_HEADER_LEN..OFF_HEADER_LEN + 2].copy_from_slice(&(HEADER_LEN as u16).to_le_bytes());
        b[OFF_VERSION..OFF_VERSION + 4].copy_from_slice(&self.version.to_le_bytes());
        b[OFF_MIN_READER..OFF_MIN_READER + 4]
            .copy_from_slice(&self.min_reader_version.to_le_bytes());
        b[OFF_FLAGS..OFF_FLAGS + 4].copy_from_slice(&self.flags.to_le_bytes());
        b[OFF_TABLE_OFFSET..OFF_TABLE_OFFSET + 8].copy_from_slice(&self.table_offset.to_le_bytes());
        b[OFF_TABLE_COUNT..OFF_TABLE_COUNT + 4].copy_from_slice(&self.table_count.to_le_bytes());
        b[OFF_TABLE_CRC..OFF_TABLE_CRC + 4].copy_from_slice(&self.table_crc.to_le_bytes());
        b[OFF_FILE_LEN..OFF_FILE_LEN + 8].copy_from_slice(&self.file_len.to_le_bytes());
        let crc = crc32(&b[..OFF_HEADER_CRC]);
        b[OFF_HEADER_CRC..].copy_from_slice(&crc.to_le_bytes());
        b
    }

    /// Decodes and checks the header of `path`, whose full contents are `file`: magic,
    /// header length, CRC, version range, flags, and that the table and the stated
    /// length fit the actual file.
    pub fn decode(path: &Path, file: &[u8]) -> Result<Header> {
        let bad = |place: &str, expected: String, found: String| {
            Error::invalid(path, place, expected, found)
        };
        if file.len() < HEADER_LEN {
            return Err(bad(
                "byte 0 (header)",
                format!("a {HEADER_LEN}-byte header"),
                format!("a file of {} bytes", file.len()),
            ));
        }
        let b = &file[..HEADER_LEN];
        if b[..MAGIC.len()] != MAGIC {
            return Err(bad(
                "byte 0 (magic)",
                format!("magic {} (a .rhier file)", hex(&MAGIC)),
                hex(&b[..MAGIC.len()]),
            ));
        }
        let stored_crc = u32_at(b, OFF_HEADER_CRC);
        let crc = crc32(&b[..OFF_HEADER_CRC]);
        if stored_crc != crc {
            return Err(bad(
                &format!("byte {OFF_HEADER_CRC} (header checksum)"),
                format!("CRC-32 {crc:#010x} of bytes 0..{OFF_HEADER_CRC}"),
                format!("{stored_crc:#010x}"),
            ));
        }
        let header_len = u16::from_le_bytes([b[OFF_HEADER_LEN], b[OFF_HEADER_LEN + 1]]);
        if header_len as usize != HEADER_LEN {
            return Err(bad(
                &format!("byte {OFF_HEADER_LEN} (header length)"),
                format!("{HEADER_LEN}"),
                format!("{header_len}"),
            ));
        }
        let h = Header {
            version: u32_at(b, OFF_VERSION),
            min_reader_version: u32_at(b, OFF_MIN_READER),
            flags: u32_at(b, OFF_FLAGS),
            table_offset: u64_at(b, OFF_TABLE_OFFSET),
            table_count: u32_at(b, OFF_TABLE_COUNT),
            table_crc: u32_at(b, OFF_TABLE_CRC),
            file_len: u64_at(b, OFF_FILE_LEN),
        };
        if h.version < OLDEST_READABLE || h.min_reader_version > VERSION {
            return Err(bad(
                &format!("byte {OFF_VERSION} (version)"),
                format!(
                    "a file version in {OLDEST_READABLE}..={VERSION} readable by a version-{VERSION} reader"
                ),
                format!(
                    "version {} needing a reader of version {} or newer",
                    h.version, h.min_reader_version
                ),
            ));
        }
        if h.flags & !KNOWN_FLAGS != 0 {
            return Err(bad(
                &format!("byte {OFF_FLAGS} (flags)"),
                format!("only known flag bits {KNOWN_FLAGS:#x}"),
                format!("{:#x}", h.flags),
            ));
        }
        if b[OFF_RESERVED..OFF_HEADER_CRC].iter().any(|&x| x != 0) {
            return Err(bad(
                &format!("byte {OFF_RESERVED} (reserved)"),
                "zero bytes".into(),
                hex(&b[OFF_RESERVED..OFF_HEADER_CRC]),
            ));
        }
        if h.file_len != file.len() as u64 {
            return Err(bad(
                &format!("byte {OFF_FILE_LEN} (file length)"),
                format!("the actual file length {}", file.len()),
                format!("{} (truncated or extended file)", h.file_len),
            ));
        }
        if h.table_count > MAX_SECTIONS {
            return Err(bad(
                &format!("byte {OFF_TABLE_COUNT} (section count)"),
                format!("at most {MAX_SECTIONS} sections"),
                format!("{}", h.table_count),
            ));
        }
        let table_len = h.table_count as u64 * ENTRY_LEN as u64;
        let table_end = h.table_offset.checked_add(table_len);
        if h.table_offset < HEADER_LEN as u64 || table_end.is_none_or(|e| e > h.file_len) {
            return Err(bad(
                &format!("byte {OFF_TABLE_OFFSET} (table offset)"),
                format!(
                    "a table of {} entries inside the file ({HEADER_LEN}..{})",
                    h.table_count, h.file_len
                ),
                format!("offset {}", h.table_offset),
            ));
        }
        Ok(h)
    }

    /// Byte range of the section table.
    pub fn table_range(&self) -> std::ops::Range<usize> {
        let start = self.table_offset as usize;
        start..start + self.table_count as usize * ENTRY_LEN
    }
}

impl SectionEntry {
    /// Encodes the entry.
    pub fn encode(&self) -> [u8; ENTRY_LEN] {
        let mut b = [0u8; ENTRY_LEN];
        b[0..4].copy_from_slice(&(self.kind as u32).to_le_bytes());
        b[4..8].copy_from_slice(&(self.codec as u32).to_le_bytes());
        b[8..16].copy_from_slice(&self.offset.to_le_bytes());
        b[16..24].copy_from_slice(&self.stored_len.to_le_bytes());
        b[24..32].copy_from_slice(&self.raw_len.to_le_bytes());
        b[32..40].copy_from_slice(&self.items.to_le_bytes());
        b[40..44].copy_from_slice(&self.crc.to_le_bytes());
        b
    }

    /// Decodes entry `index` whose bytes start at file offset `at`, checking that its
    /// kind and codec are known and that its bytes lie inside `[HEADER_LEN, data_end)`.
    pub fn decode(path: &Path, index: usize, at: usize, b: &[u8], data_end: u64) -> Result<Self> {
        let place =
            |field: &str, off: usize| format!("byte {} (section {index}, {field})", at + off);
        let kind_raw = u32_at(b, 0);
        let kind = SectionKind::from_u32(kind_raw).ok_or_else(|| {
            Error::invalid(
                path,
                place("kind", 0),
                "a section kind in 1..=7",
                kind_raw.to_string(),
            )
        })?;
        let codec_raw = u32_at(b, 4);
        let codec = Codec::from_u32(codec_raw).ok_or_else(|| {
            Error::invalid(
                path,
                place("codec", 4),
                "codec 0 (raw) or 1 (zstd)",
                codec_raw.to_string(),
            )
        })?;
        let e = SectionEntry {
            kind,
            codec,
            offset: u64_at(b, 8),
            stored_len: u64_at(b, 16),
            raw_len: u64_at(b, 24),
            items: u64_at(b, 32),
            crc: u32_at(b, 40),
        };
        let end = e.offset.checked_add(e.stored_len);
        if e.offset < HEADER_LEN as u64 || end.is_none_or(|x| x > data_end) {
            return Err(Error::invalid(
                path,
                place("offset and length", 8),
                format!("bytes inside the data area {HEADER_LEN}..{data_end}"),
                format!("offset {} length {}", e.offset, e.stored_len),
            ));
        }
        if u32_at(b, 44) != 0 {
            return Err(Error::invalid(
                path,
                place("reserved", 44),
                "0",
                u32_at(b, 44).to_string(),
            ));
        }
        if e.codec == Codec::Raw && e.raw_len != e.stored_len {
            return Err(Error::invalid(
                path,
                place("raw length", 24),
                format!("the stored length {} for a raw section", e.stored_len),
                e.raw_len.to_string(),
            ));
        }
        Ok(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_round_trip_and_crc() {
        let h = Header {
            version: VERSION,
            min_reader_version: MIN_READER_VERSION,
            flags: FLAG_COMPRESSED,
            table_offset: 64,
            table_count: 1,
            table_crc: 7,
            file_len: 64 + ENTRY_LEN as u64,
        };
        let mut file = h.encode().to_vec();
        file.extend_from_slice(&[0u8; ENTRY_LEN]);
        assert_eq!(Header::decode(Path::new("x"), &file).ok(), Some(h));
        file[20] ^= 1;
        let err = Header::decode(Path::new("x"), &file)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(err.contains("header checksum"), "{err}");
    }
}
