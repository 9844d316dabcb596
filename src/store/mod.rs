//! The `.rhier` file: a solved hierarchy persisted so that frames can be played back,
//! probed and inspected without the solver and without loading everything.
//!
//! The byte layout is specified in `formats/rhier.md`; this module mirrors it:
//! [`mod@format`] holds the header and section-table layout, [`records`] the rkyv records
//! of each section, [`writer`] streams a file chunk by chunk in time order and makes it
//! valid only when finished (temporary name, fsync, rename), [`reader`] maps a file and
//! validates it before any rkyv access and keeps the leaves live at recent times with
//! the stretch over which they hold ([`live`]), and [`memory`] holds the named counters that
//! `inspect` and `solve --stats` print, and [`journal`] keeps the finished windows of a space-time
//! solve in progress so that `solve --resume` can continue it; [`merge`] joins the
//! files of a solve run as shards into one.
//!
//! It does not evaluate radiosity: that is [`crate::playback`], which runs the same
//! code on a [`crate::solution::Solution`] in memory and on a [`Reader`].

pub mod format;
pub mod hierarchy;
pub mod journal;
pub mod live;
pub mod memory;
pub mod merge;
pub mod reader;
pub mod records;
pub mod samples;
pub mod writer;

pub use format::{Codec, Header, SectionEntry, SectionKind};
pub use hierarchy::Hierarchy;
pub use live::{Live, Stretch};
pub use memory::MemoryReport;
pub use reader::{Reader, StoredObject};
pub use records::LinkRecord;
pub use writer::{
    FrameWriter, SolutionHeader, WriteOptions, Writer, encode_solution, write_solution,
};
