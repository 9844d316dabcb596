//! `rhier inspect FILE.rhier [--json]`: header, sections (stored and raw bytes),
//! time chunks with their element counts, solve statistics, and the memory needed to
//! play one frame ([`rhier::store::MemoryReport`], the counters `solve --stats` prints).

use std::path::{Path, PathBuf};

use rhier::store::{MemoryReport, Reader};
use serde::Serialize;

/// Arguments of `rhier inspect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The `.rhier` file.
    pub file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Skip checking every chunk (checksums, decompression, leaves): only the header,
    /// table and metadata sections are validated, as when playing.
    #[arg(long)]
    pub no_verify: bool,
}

#[derive(Serialize)]
struct HeaderJson {
    version: u32,
    min_reader_version: u32,
    flags: u32,
    moving: bool,
    links: bool,
    compressed: bool,
    table_offset: u64,
    sections: u32,
    file_bytes: u64,
}

#[derive(Serialize)]
struct SceneJson {
    time: [f64; 2],
    materials: usize,
    objects: usize,
    moving_objects: usize,
    patches: usize,
    camera: bool,
}

#[derive(Serialize)]
struct StatsJson {
    seconds: f64,
    iterations: u32,
    elements: u64,
    links_active: u64,
    links_passive: u64,
    estimated_error: f64,
    residual: f64,
}

/// The provenance section (a space-time solve's file, format version 2).
#[derive(Serialize)]
struct ProvenanceJson {
    /// Windows `first..end` of the solve's `windows`.
    windows: [u32; 3],
    /// Shard `shard` of `shards`.
    shard: [u32; 2],
    time: [f64; 2],
    /// CRC-32 of the solve's fingerprint text (parts of one solve share it).
    fingerprint_crc32: String,
}

/// What `inspect` reports, in the order it prints it; `rhier view` serves the same.
#[derive(Serialize)]
pub(crate) struct Inspect {
    file: String,
    header: HeaderJson,
    scene: SceneJson,
    stats: StatsJson,
    provenance: Option<ProvenanceJson>,
    /// Leaves checked in every chunk (`None` with `--no-verify`).
    verified_leaves: Option<u64>,
    memory: MemoryReport,
}

/// Runs `rhier inspect`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let r = Reader::open(&args.file)?;
    let report = report(&args.file, &r, !args.no_verify)?;
    if args.json {
        let mut text = serde_json::to_string_pretty(&report)?;
        text.push('\n');
        return super::probe::print_stdout(&text);
    }
    super::probe::print_stdout(&text(&report, r.chunks().len())?)
}

/// The report of an opened file; `verify` checks every chunk first (an error if one
/// is corrupt).
pub(crate) fn report(file: &Path, r: &Reader, verify: bool) -> anyhow::Result<Inspect> {
    use rhier::store::format::{FLAG_COMPRESSED, FLAG_LINKS, FLAG_MOVING};
    let verified_leaves = if verify { Some(r.verify()?) } else { None };
    let h = r.header();
    let s = r.stats();
    let td = r.time_domain();
    let report = Inspect {
        file: file.display().to_string(),
        header: HeaderJson {
            version: h.version,
            min_reader_version: h.min_reader_version,
            flags: h.flags,
            moving: h.flags & FLAG_MOVING != 0,
            links: h.flags & FLAG_LINKS != 0,
            compressed: h.flags & FLAG_COMPRESSED != 0,
            table_offset: h.table_offset,
            sections: h.table_count,
            file_bytes: h.file_len,
        },
        scene: SceneJson {
            time: [td.start, td.end],
            materials: r.materials().len(),
            objects: r.objects().len(),
            moving_objects: r.objects().iter().filter(|o| o.is_moving()).count(),
            patches: r.patches().len(),
            camera: r.camera().is_some(),
        },
        stats: StatsJson {
            seconds: s.seconds,
            iterations: s.iterations,
            elements: s.elements,
            links_active: s.links_active,
            links_passive: s.links_passive,
            estimated_error: s.estimated_error,
            residual: s.residual,
        },
        provenance: r.provenance().map(|p| ProvenanceJson {
            windows: [p.first, p.end, p.windows],
            shard: [p.shard, p.shards],
            time: p.time,
            fingerprint_crc32: format!("{:#010x}", crc32fast::hash(p.fingerprint.as_bytes())),
        }),
        verified_leaves,
        memory: MemoryReport::from_reader(r),
    };
    Ok(report)
}

/// The text form of a report (`chunks`: the file's chunk count).
pub(crate) fn text(report: &Inspect, chunks: usize) -> anyhow::Result<String> {
    use std::fmt::Write;
    let mut text = String::new();
    let hj = &report.header;
    writeln!(text, "file: {}", report.file)?;
    writeln!(
        text,
        "header: version {} (readable by version >= {}), flags {:#x} [moving: {}, links: {}, compressed: {}], {} sections, table at byte {}",
        hj.version,
        hj.min_reader_version,
        hj.flags,
        hj.moving,
        hj.links,
        hj.compressed,
        hj.sections,
        hj.table_offset
    )?;
    let sc = &report.scene;
    writeln!(
        text,
        "scene: time [{}, {}] s, {} materials, {} objects ({} moving), {} patches, camera: {}",
        sc.time[0], sc.time[1], sc.materials, sc.objects, sc.moving_objects, sc.patches, sc.camera
    )?;
    let st = &report.stats;
    writeln!(
        text,
        "solve: {:.3} s, {} iterations, {} elements, {} active + {} passive links, estimated error {}, residual {:.3e}",
        st.seconds,
        st.iterations,
        st.elements,
        st.links_active,
        st.links_passive,
        rhier::solver::report::estimate_text(st.estimated_error),
        st.residual
    )?;
    if let Some(p) = &report.provenance {
        writeln!(
            text,
            "provenance: windows {}..{} of {}, shard {} of {}, time [{}, {}], fingerprint crc32 {}",
            p.windows[0],
            p.windows[1],
            p.windows[2],
            p.shard[0],
            p.shard[1],
            p.time[0],
            p.time[1],
            p.fingerprint_crc32
        )?;
    }
    match report.verified_leaves {
        Some(n) => writeln!(
            text,
            "verified: {chunks} chunks, {n} leaves, all checksums and records valid"
        ),
        None => writeln!(
            text,
            "verified: header, table and metadata only (--no-verify)"
        ),
    }?;
    write!(text, "{}", report.memory)?;
    Ok(text)
}
