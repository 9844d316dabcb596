//! The shaft store (paper 000, section 3.3): shafts kept per link only where a move
//! or a predicted move needed them, each with an age that every use resets; a
//! collector (Fig. 2) that ages them after each move and removes the old ones, and
//! keeps the resident bytes under a budget; evicted shafts compressed with zstd in
//! memory and restored bit for bit when a link needs its shaft again.
//!
//! How it works: resident shafts live in a map link → ([`Shaft`], age). A shaft a
//! traversal asks for is resident (age reset), restored from the compressed store,
//! or built. The budget (`--shaft-budget`) is held within one block: when an
//! insertion takes the resident bytes past `budget + BLOCK_BYTES` the oldest shafts
//! are evicted down to the budget, so resident bytes never exceed the budget by
//! more than [`BLOCK_BYTES`]. After each move [`ShaftStore::collect`] runs Fig. 2:
//! with the paper's thresholds only while `P = N_shafts / N_links > T_shafts` (down
//! to `T_min`), otherwise every move; every resident shaft ages by one, and those
//! older than `max_age` go. Evicting sends a shaft to the compressed store
//! (`--shaft-store zstd`) or drops it (`none`: rebuilt when needed, the paper's
//! way). Restoring is timed against building (the "use the cheaper"): once
//! both have [`COST_SAMPLES`] timings, a shaft is restored only while restoring is
//! on average the faster.

use std::time::Instant;

use crate::shafts::Shaft;
use crate::solver::FastMap;

/// Resident bytes one stored shaft counts for: the shaft and its map entry.
pub const SHAFT_BYTES: u64 = (std::mem::size_of::<Shaft>() + 16) as u64;

/// Shafts in a block: the most the resident bytes may exceed a budget by.
pub const BLOCK_SHAFTS: u64 = 64;

/// Bytes in a block.
pub const BLOCK_BYTES: u64 = BLOCK_SHAFTS * SHAFT_BYTES;

/// Timings of each kind before restore and build are compared.
pub const COST_SAMPLES: u64 = 16;

/// zstd level of evicted shafts.
const LEVEL: i32 = 3;

/// Where evicted shafts go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keep {
    /// Dropped, rebuilt when needed.
    Drop,
    /// zstd-compressed in memory.
    Zstd,
}

/// When the collector removes shafts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Policy {
    /// Resident bytes held within one block of this ceiling.
    pub budget: Option<u64>,
    /// The paper's `(T_shafts, T_min)`: collect only while the fraction of links
    /// with a shaft is above `T_shafts`, down to `T_min`.
    pub thresholds: Option<(f64, f64)>,
    /// A shaft unused for more moves than this is removed.
    pub max_age: u32,
    /// Where evicted shafts go.
    pub keep: Keep,
}

impl Default for Policy {
    fn default() -> Self {
        Policy {
            budget: None,
            thresholds: None,
            max_age: 8,
            keep: Keep::Zstd,
        }
    }
}

/// What the store did since the last [`ShaftStore::begin_move`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Shafts built because a traversal needed them now (on the fly).
    pub built: u64,
    /// Shafts built for a predicted position.
    pub predicted: u64,
    /// Shafts found resident.
    pub existing: u64,
    /// Shafts restored from the compressed store.
    pub restored: u64,
    /// Shafts removed from residence (by age, threshold or budget).
    pub collected: u64,
    /// Of those, shafts sent to the compressed store.
    pub evicted: u64,
}

/// Resident shaft and its age (moves since last use).
#[derive(Clone, Copy, Debug)]
struct Resident {
    shaft: Shaft,
    age: u32,
}

/// The store of shafts by link id.
#[derive(Debug, Default)]
pub struct ShaftStore {
    resident: FastMap<u32, Resident>,
    compressed: FastMap<u32, Vec<u8>>,
    compressed_bytes: u64,
    policy: Policy,
    /// The counters of the current move.
    pub counters: Counters,
    /// Seconds spent building, restoring (summed) and how many of each.
    build_cost: (f64, u64),
    restore_cost: (f64, u64),
    /// Seconds spent building and restoring in the current move.
    pub seconds: f64,
}

impl ShaftStore {
    /// An empty store with `policy`.
    pub fn new(policy: Policy) -> Self {
        ShaftStore {
            policy,
            ..ShaftStore::default()
        }
    }

    /// Zeroes the per-move counters.
    pub fn begin_move(&mut self) {
        self.counters = Counters::default();
        self.seconds = 0.0;
    }

    /// Resident shafts.
    pub fn len(&self) -> usize {
        self.resident.len()
    }

    /// True if no shaft is resident.
    pub fn is_empty(&self) -> bool {
        self.resident.is_empty()
    }

    /// Bytes the resident shafts count for ([`SHAFT_BYTES`] each).
    pub fn resident_bytes(&self) -> u64 {
        self.resident.len() as u64 * SHAFT_BYTES
    }

    /// Bytes of the compressed store.
    pub fn compressed_bytes(&self) -> u64 {
        self.compressed_bytes
    }

    /// True if link `l` has a shaft resident.
    pub fn holds(&self, l: u32) -> bool {
        self.resident.contains_key(&l)
    }

    /// The shaft of link `l`, resident (age reset), restored or made by `build`;
    /// `now`: needed by the current move (a build counts as on the fly), else
    /// for a predicted position.
    pub fn get(&mut self, l: u32, now: bool, build: impl FnOnce() -> Shaft) -> Shaft {
        if let Some(r) = self.resident.get_mut(&l) {
            r.age = 0;
            // Table 2's "already existing": found when a move needed it.
            if now {
                self.counters.existing += 1;
            }
            return r.shaft;
        }
        let start = Instant::now();
        let restored = self.restore(l);
        let shaft = match restored {
            Some(s) => {
                self.restore_cost.0 += start.elapsed().as_secs_f64();
                self.restore_cost.1 += 1;
                self.counters.restored += 1;
                s
            }
            None => {
                let s = build();
                self.build_cost.0 += start.elapsed().as_secs_f64();
                self.build_cost.1 += 1;
                if now {
                    self.counters.built += 1;
                } else {
                    self.counters.predicted += 1;
                }
                s
            }
        };
        self.seconds += start.elapsed().as_secs_f64();
        if let Some(b) = self.policy.budget
            && self.resident_bytes() + SHAFT_BYTES > b + BLOCK_BYTES
        {
            self.evict_to(b.saturating_sub(SHAFT_BYTES));
        }
        self.resident.insert(l, Resident { shaft, age: 0 });
        shaft
    }

    /// Forgets link `l`'s shaft everywhere (its ends moved: it no longer holds).
    pub fn forget(&mut self, l: u32) {
        self.resident.remove(&l);
        if let Some(c) = self.compressed.remove(&l) {
            self.compressed_bytes -= c.len() as u64;
        }
    }

    /// The shaft of `l` from the compressed store, if it is there and restoring is
    /// not measured slower than building; removed from the store either way.
    fn restore(&mut self, l: u32) -> Option<Shaft> {
        let bytes = self.compressed.remove(&l)?;
        self.compressed_bytes -= bytes.len() as u64;
        let measured = self.build_cost.1 >= COST_SAMPLES && self.restore_cost.1 >= COST_SAMPLES;
        let mean = |c: (f64, u64)| c.0 / c.1.max(1) as f64;
        if measured && mean(self.restore_cost) > mean(self.build_cost) {
            return None;
        }
        let raw = zstd::bulk::decompress(&bytes, 64 * 1024).ok()?;
        Shaft::from_bytes(&raw)
    }

    /// The collector of Fig. 2, run after each move: ages every resident shaft and
    /// removes those older than `max_age`; with thresholds, only while the fraction
    /// of the `links` links holding a shaft is above `T_shafts`, then the oldest
    /// until it is at `T_min`.
    pub fn collect(&mut self, links: usize) {
        let fraction = |s: &Self| s.resident.len() as f64 / links.max(1) as f64;
        if let Some((t, _)) = self.policy.thresholds
            && fraction(self) <= t
        {
            return;
        }
        for r in self.resident.values_mut() {
            r.age += 1;
        }
        let max_age = self.policy.max_age;
        let old: Vec<u32> = self
            .resident
            .iter()
            .filter(|(_, r)| r.age > max_age)
            .map(|(&l, _)| l)
            .collect();
        for l in old {
            self.evict(l);
        }
        if let Some((_, t_min)) = self.policy.thresholds {
            let keep = (t_min * links as f64).floor() as u64;
            self.evict_to(keep * SHAFT_BYTES);
        }
        if let Some(b) = self.policy.budget {
            self.evict_to(b);
        }
    }

    /// Evicts the oldest resident shafts until at most `bytes` are resident.
    fn evict_to(&mut self, bytes: u64) {
        let keep = (bytes / SHAFT_BYTES) as usize;
        if self.resident.len() <= keep {
            return;
        }
        let mut by_age: Vec<(u32, u32)> = self.resident.iter().map(|(&l, r)| (r.age, l)).collect();
        // Oldest first; ties by link id, so that a run is reproducible.
        by_age.sort_unstable_by(|a, b| b.cmp(a));
        let extra = self.resident.len() - keep;
        for &(_, l) in &by_age[..extra] {
            self.evict(l);
        }
    }

    /// Removes link `l`'s shaft from residence, to the compressed store if kept.
    fn evict(&mut self, l: u32) {
        let Some(r) = self.resident.remove(&l) else {
            return;
        };
        self.counters.collected += 1;
        if self.policy.keep == Keep::Zstd
            && let Ok(c) = zstd::bulk::compress(&r.shaft.to_bytes(), LEVEL)
        {
            self.compressed_bytes += c.len() as u64;
            if let Some(old) = self.compressed.insert(l, c) {
                self.compressed_bytes -= old.len() as u64;
            }
            self.counters.evicted += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    fn quad(z: f64, x: f64) -> [DVec3; 4] {
        [
            DVec3::new(x, 0.0, z),
            DVec3::new(x + 1.0, 0.0, z),
            DVec3::new(x + 1.0, 1.0, z),
            DVec3::new(x, 1.0, z),
        ]
    }

    fn shaft(i: u32) -> Shaft {
        let x = f64::from(i) * 0.37;
        Shaft::new(&quad(0.0, x), DVec3::Z, &quad(2.0, -x), -DVec3::Z)
    }

    #[test]
    fn an_evicted_shaft_comes_back_bit_for_bit() {
        let mut s = ShaftStore::new(Policy {
            max_age: 0,
            ..Policy::default()
        });
        let a = s.get(7, true, || shaft(7));
        assert_eq!(s.counters.built, 1);
        s.collect(10);
        assert_eq!((s.len(), s.counters.evicted), (0, 1));
        assert!(s.compressed_bytes() > 0);
        let b = s.get(7, true, || panic!("restored, not built"));
        assert_eq!(s.counters.restored, 1);
        assert_eq!(a.to_bytes(), b.to_bytes());
        let probe = (DVec3::new(0.2, 0.4, 0.9), DVec3::new(0.3, 0.5, 1.1));
        assert_eq!(
            a.misses_box(probe.0, probe.1),
            b.misses_box(probe.0, probe.1)
        );
        assert_eq!(s.compressed_bytes(), 0);
    }

    #[test]
    fn resident_bytes_stay_within_one_block_of_the_budget() {
        let budget = 10 * SHAFT_BYTES + 5;
        let mut s = ShaftStore::new(Policy {
            budget: Some(budget),
            ..Policy::default()
        });
        let mut worst = 0;
        for i in 0..1000 {
            s.get(i, true, || shaft(i));
            worst = worst.max(s.resident_bytes());
            if i % 97 == 0 {
                s.collect(1000);
                assert!(s.resident_bytes() <= budget);
            }
        }
        assert!(worst <= budget + BLOCK_BYTES, "{worst} > {budget} + block");
        assert!(worst > budget, "the block was never used: {worst}");
        assert_eq!(s.counters.built, 1000);
        assert_eq!(s.counters.collected, 1000 - s.len() as u64);
    }

    #[test]
    fn ages_reset_on_use_and_the_unused_go() {
        let mut s = ShaftStore::new(Policy {
            max_age: 2,
            keep: Keep::Drop,
            ..Policy::default()
        });
        s.get(1, true, || shaft(1));
        s.get(2, true, || shaft(2));
        for _ in 0..3 {
            s.collect(2);
            s.get(1, true, || shaft(1));
        }
        assert!(s.holds(1) && !s.holds(2));
        assert_eq!((s.counters.evicted, s.compressed_bytes()), (0, 0));
    }

    #[test]
    fn thresholds_collect_only_above_t_shafts() {
        let mut s = ShaftStore::new(Policy {
            thresholds: Some((0.5, 0.2)),
            max_age: 100,
            ..Policy::default()
        });
        for i in 0..4 {
            s.get(i, true, || shaft(i));
        }
        s.collect(10);
        assert_eq!(s.len(), 4);
        for i in 4..8 {
            s.get(i, true, || shaft(i));
        }
        s.collect(10);
        assert_eq!(s.len(), 2);
    }
}
