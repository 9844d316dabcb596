//! [`LinkPool`]: links between elements as columns.
//!
//! A link carries light from its source element to its receiver. Its coefficient is
//! the form factor from receiver to source averaged over the receiver (and over the
//! shared time range), visibility included, so the receiver gathers `F · B_source`.
//! A link the oracle refined becomes **passive**: it stays in the pool with its
//! coefficient and error, as history of the subdivision that a later change can
//! re-activate (the line-space hierarchy of Schöffel & Pomi, paper 000, section 2).

use bytemuck::{Pod, Zeroable};

use super::column::{Column, Storage};
use super::ids::{ElementId, LinkId};
use crate::{Error, Result};

/// State of a link.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkState {
    /// Carries energy in the gather.
    Active = 0,
    /// Refined: replaced by links between children; kept as history.
    Passive = 1,
}

/// Receiver and source of a link. `repr(C)`, Pod, 8 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct Ends {
    /// Element that gathers.
    pub receiver: u32,
    /// Element gathered from.
    pub source: u32,
}

/// Transport of a link. `repr(C)`, Pod, 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Transport {
    /// Form factor receiver → source, averaged over the receiver, visibility included.
    pub f: f32,
    /// Spread of the point form factor over the receiver (the oracle's `ΔK`).
    pub spread: f32,
    /// Estimated visible fraction: 1 where a shaft proved it clear, and where the
    /// unoccluded factor at the receiver's quadrature points is 0 (no rays cast;
    /// byte 1 of `flags` then says whether the shaft is clear).
    pub visibility: f32,
    /// [`LinkState`] in byte 0; visibility class in byte 1 (0 rays, 1 shaft-clear);
    /// time class in byte 2 (0 constant in the current window, 1 varying).
    pub flags: [u8; 4],
}

const _: () = assert!(std::mem::size_of::<Transport>() == 16);

impl Transport {
    /// State of the link.
    pub fn state(&self) -> LinkState {
        if self.flags[0] == LinkState::Passive as u8 {
            LinkState::Passive
        } else {
            LinkState::Active
        }
    }

    /// True if a shaft test proved the link unoccluded.
    pub fn shaft_clear(&self) -> bool {
        self.flags[1] == 1
    }

    /// True if the link's transport changes in the current time window: an end
    /// moves, or a moving object's swept box meets its shaft (byte 2 of `flags`).
    /// Always false in a static solve.
    pub fn varying(&self) -> bool {
        self.flags[2] == 1
    }
}

/// The link arena.
#[derive(Debug)]
pub struct LinkPool {
    /// Receiver and source.
    pub ends: Column<Ends>,
    /// Coefficient, spread, visibility, state.
    pub transports: Column<Transport>,
    /// Passive links dropped by [`LinkPool::drop_passive`], still counted as passive
    /// by [`LinkPool::counts`].
    dropped: u64,
}

/// Which links [`LinkPool::drop_passive`] kept, as a map from old ids to new: a bit
/// per old link and, per 64 of them, how many were kept before (about 1.1 bits
/// per link: 9.6 MB for 68M links).
pub struct Retained {
    bits: Vec<u64>,
    before: Vec<u32>,
}

impl Retained {
    /// The new id of old link `old`, if it was kept.
    #[inline]
    pub fn new_id(&self, old: u32) -> Option<u32> {
        let (w, b) = (old as usize / 64, old % 64);
        let word = *self.bits.get(w)?;
        ((word >> b) & 1 == 1).then(|| self.before[w] + (word & ((1u64 << b) - 1)).count_ones())
    }
}

impl LinkPool {
    /// An empty pool on `storage`.
    pub fn new(storage: &Storage) -> Result<Self> {
        Ok(LinkPool {
            ends: Column::new(storage, "link-ends")?,
            transports: Column::new(storage, "link-transport")?,
            dropped: 0,
        })
    }

    /// Number of links (active and passive).
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    /// True if empty.
    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// Appends a link.
    pub fn push(&mut self, receiver: ElementId, source: ElementId, t: Transport) -> Result<LinkId> {
        let id = self.ends.push(Ends {
            receiver: receiver.0,
            source: source.0,
        })?;
        self.transports.push(t)?;
        Ok(LinkId(id))
    }

    /// Marks a link passive (refined).
    pub fn set_passive(&mut self, l: LinkId) {
        self.transports.as_mut_slice()[l.ix()].flags[0] = LinkState::Passive as u8;
    }

    /// Marks a link active again (a time window released the links that refined it).
    pub fn set_active(&mut self, l: LinkId) {
        self.transports.as_mut_slice()[l.ix()].flags[0] = LinkState::Active as u8;
    }

    /// Drops the links from `len` on (see [`super::Column::truncate`]).
    pub fn truncate(&mut self, len: usize) {
        self.ends.truncate(len);
        self.transports.truncate(len);
    }

    /// (active, passive) counts; the passive count includes those dropped.
    pub fn counts(&self) -> (u64, u64) {
        let passive = self
            .transports
            .as_slice()
            .iter()
            .filter(|t| t.state() == LinkState::Passive)
            .count() as u64;
        (self.len() as u64 - passive, passive + self.dropped)
    }

    /// Drops the passive links, the active ones keeping their order (ids shift
    /// down): a static solve never reads a refined link again, and at 100k
    /// polygons they were 40M of the 68M links (960 MB). Returns the map from old
    /// ids to new.
    pub fn drop_passive(&mut self) -> Retained {
        let n = self.len();
        let mut bits = vec![0u64; n.div_ceil(64)];
        let mut before = vec![0u32; bits.len()];
        let mut kept = 0usize;
        {
            let tr = self.transports.as_mut_slice();
            for i in 0..n {
                if i % 64 == 0 {
                    before[i / 64] = kept as u32;
                }
                if tr[i].state() == LinkState::Active {
                    bits[i / 64] |= 1 << (i % 64);
                    tr[kept] = tr[i];
                    kept += 1;
                }
            }
        }
        let ends = self.ends.as_mut_slice();
        let mut j = 0;
        for i in 0..n {
            if (bits[i / 64] >> (i % 64)) & 1 == 1 {
                ends[j] = ends[i];
                j += 1;
            }
        }
        self.dropped += (n - kept) as u64;
        self.truncate(kept);
        Retained { bits, before }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.ends.bytes() + self.transports.bytes()
    }

    /// Checks that both ends exist in a pool of `elements` elements and that every
    /// coefficient is finite and non-negative.
    pub fn validate(&self, elements: usize) -> Result<()> {
        if self.ends.len() != self.transports.len() {
            return Err(Error::invalid(
                "<link pool>",
                "columns",
                "equal lengths",
                format!("{} vs {}", self.ends.len(), self.transports.len()),
            ));
        }
        for (i, (e, t)) in self
            .ends
            .as_slice()
            .iter()
            .zip(self.transports.as_slice())
            .enumerate()
        {
            if e.receiver as usize >= elements || e.source as usize >= elements {
                return Err(Error::invalid(
                    "<link pool>",
                    format!("link {i}"),
                    format!("ends below {elements}"),
                    format!("{} -> {}", e.source, e.receiver),
                ));
            }
            if !(t.f.is_finite() && t.f >= 0.0 && t.spread.is_finite()) {
                return Err(Error::invalid(
                    "<link pool>",
                    format!("link {i}"),
                    "finite coefficient >= 0",
                    format!("{:?}", t),
                ));
            }
        }
        Ok(())
    }
}
