//! Property test: any mutation of a valid `.rhier` file — bit flips, overwritten
//! ranges, truncation, extension, and edits with every checksum recomputed so that
//! they reach the rkyv and semantic checks — is either refused with an error or read
//! as a valid file; never a panic, and never a large allocation (a counting global
//! allocator bounds the peak to [`ALLOC_LIMIT`] bytes above the baseline).
//!
//! The allocator counts only the thread that asked for it, and the read runs on a
//! one-thread rayon pool (`probe` evaluates points in parallel) whose thread is the
//! one counted: the other tests of the binary, running at the same time on other
//! threads, do not add to the peak.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::LazyLock;

use glam::DVec3;
use proptest::prelude::*;
use rhier::playback::{ProbePoint, probe};
use rhier::store::format::{ENTRY_LEN, HEADER_LEN, crc32};
use rhier::store::samples::animated_box;
use rhier::store::{MemoryReport, Reader, SolutionHeader, WriteOptions, Writer};

struct Counting;

thread_local! {
    /// Whether this thread's allocations are counted.
    static COUNTED: Cell<bool> = const { Cell::new(false) };
    /// Bytes this thread allocated minus bytes it freed since counting started
    /// (negative when it frees what another thread allocated).
    static CURRENT: Cell<isize> = const { Cell::new(0) };
    /// The largest `CURRENT` since counting started.
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

/// Adds `delta` bytes to the calling thread's count if it is counted. The cells are
/// `const`-initialised and have no destructor: reading them never allocates.
fn count(delta: isize) {
    if COUNTED.try_with(Cell::get).unwrap_or(false) {
        let now = CURRENT.get() + delta;
        CURRENT.set(now);
        PEAK.set(PEAK.get().max(now));
    }
}

// SAFETY: forwards every call to the system allocator unchanged; only counts bytes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size() as isize);
        // SAFETY: same layout contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        count(-(layout.size() as isize));
        // SAFETY: `ptr` was allocated by `System.alloc` with `layout`.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size as isize - layout.size() as isize);
        // SAFETY: forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The pool `peak_allocation` runs on: one thread, so that rayon work started
/// inside runs on the thread being counted.
static ONE_THREAD: LazyLock<rayon::ThreadPool> = LazyLock::new(|| {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool")
});

/// Runs `f` and returns the most bytes it held allocated at once.
fn peak_allocation(f: impl FnOnce() + Send) -> usize {
    ONE_THREAD.install(|| {
        CURRENT.set(0);
        PEAK.set(0);
        COUNTED.set(true);
        f();
        COUNTED.set(false);
        PEAK.get() as usize
    })
}

/// Most bytes a read of a ~2 KiB file may allocate at once.
const ALLOC_LIMIT: usize = 16 << 20;

fn valid_file() -> Vec<u8> {
    let sample = animated_box(1, 3);
    let name = std::path::Path::new("fuzz.rhier");
    let mut w = Writer::in_memory(
        name,
        &SolutionHeader::of(&sample.solution),
        WriteOptions::default(),
    )
    .unwrap();
    for (t0, t1, leaves) in &sample.chunks {
        w.write_chunk(*t0, *t1, leaves).unwrap();
    }
    w.finish_to_bytes(&sample.solution.stats).unwrap()
}

fn u64_at(b: &[u8], o: usize) -> u64 {
    u64::from_le_bytes(b[o..o + 8].try_into().unwrap())
}

/// Recomputes every checksum it can locate (sections, table, header).
fn reseal(b: &mut [u8]) {
    if b.len() < HEADER_LEN {
        return;
    }
    let (off, count) = (
        u64_at(b, 24) as usize,
        u32::from_le_bytes(b[32..36].try_into().unwrap()) as usize,
    );
    let table_ok = count < 1000
        && off
            .checked_add(count * ENTRY_LEN)
            .is_some_and(|e| e <= b.len());
    if table_ok {
        for i in 0..count {
            let e = off + i * ENTRY_LEN;
            let (so, sl) = (u64_at(b, e + 8) as usize, u64_at(b, e + 16) as usize);
            if so.checked_add(sl).is_some_and(|end| end <= b.len()) {
                let crc = crc32(&b[so..so + sl]);
                b[e + 40..e + 44].copy_from_slice(&crc.to_le_bytes());
            }
        }
        let crc = crc32(&b[off..off + count * ENTRY_LEN]);
        b[36..40].copy_from_slice(&crc.to_le_bytes());
    }
    let crc = crc32(&b[..60]);
    b[60..64].copy_from_slice(&crc.to_le_bytes());
}

#[derive(Clone, Debug)]
enum Mutation {
    Flip(usize, u8),
    Overwrite(usize, Vec<u8>),
    Truncate(usize),
    Extend(Vec<u8>),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(o, bit)| Mutation::Flip(o, bit)),
        (any::<usize>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(o, v)| Mutation::Overwrite(o, v)),
        any::<usize>().prop_map(Mutation::Truncate),
        prop::collection::vec(any::<u8>(), 1..64).prop_map(Mutation::Extend),
    ]
}

fn apply(file: &[u8], muts: &[Mutation], seal: bool) -> Vec<u8> {
    let mut b = file.to_vec();
    for m in muts {
        match m {
            Mutation::Flip(o, bit) if !b.is_empty() => {
                let i = o % b.len();
                b[i] ^= 1 << bit;
            }
            Mutation::Overwrite(o, v) if !b.is_empty() => {
                let start = o % b.len();
                for (k, x) in v.iter().enumerate() {
                    if let Some(y) = b.get_mut(start + k) {
                        *y = *x;
                    }
                }
            }
            Mutation::Truncate(o) => {
                let n = o % (b.len() + 1);
                b.truncate(n);
            }
            Mutation::Extend(v) => b.extend_from_slice(v),
            _ => {}
        }
    }
    if seal {
        if b.len() >= HEADER_LEN {
            // Keep the stated file length in step so that edits reach deeper checks.
            let len = b.len() as u64;
            b[40..48].copy_from_slice(&len.to_le_bytes());
        }
        reseal(&mut b);
    }
    b
}

/// Everything a user can do with a file; returns whether it was accepted.
fn exercise(bytes: Vec<u8>) -> bool {
    let Ok(r) = Reader::from_bytes(std::path::Path::new("fuzz.rhier"), bytes) else {
        return false;
    };
    let _ = MemoryReport::from_reader(&r).to_string();
    let _ = r.all_leaves();
    let td = r.time_domain();
    let pts = [ProbePoint {
        p: DVec3::splat(0.5),
        n: DVec3::Z,
    }];
    for t in [td.start, 0.5 * (td.start + td.end), td.end] {
        let _ = r.leaves_at(t);
        let _ = probe(&r, &pts, t);
    }
    true
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_files_are_refused_or_read_never_panic(
        muts in prop::collection::vec(mutation(), 1..4),
        seal in any::<bool>(),
    ) {
        let file = valid_file();
        let bytes = apply(&file, &muts, seal);
        let peak = peak_allocation(|| {
            let _accepted = exercise(bytes);
        });
        prop_assert!(peak < ALLOC_LIMIT, "peak allocation {} bytes", peak);
    }
}

#[test]
fn the_unmutated_file_is_accepted() {
    assert!(exercise(valid_file()));
}

/// The bound above can fail: what `exercise` allocates through rayon, as `probe`
/// does, is counted.
#[test]
fn the_peak_counts_what_rayon_work_allocates() {
    use rayon::prelude::*;
    let peak = peak_allocation(|| {
        let blocks: Vec<Vec<u8>> = (0..4).into_par_iter().map(|_| vec![1u8; 1 << 20]).collect();
        std::hint::black_box(&blocks);
    });
    assert!(peak >= 4 << 20, "peak {peak} bytes");
}
