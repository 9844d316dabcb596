//! The statistics of one move: one JSON line per move in `--stats FILE.jsonl`
//! (keys specified in `formats/interactive.md`; the columns of Table 2 of paper 000
//! and what a user tunes the shaft budget by), and a short human line.

/// What one move did and cost. Counts are of this move unless they say "total".
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct MoveStats {
    /// Move number, from 1.
    pub r#move: u32,
    /// Shafts that met a moved object's box before the move.
    pub shafts_at_old: u64,
    /// Shafts that met a moved object's box after the move.
    pub shafts_at_new: u64,
    /// Shaft-against-box tests.
    pub shaft_tests: u64,
    /// Shafts built on the fly (needed by this move and not stored).
    pub shafts_built: u64,
    /// Shafts built ahead for predicted positions.
    pub shafts_predicted: u64,
    /// Shafts found stored when asked for.
    pub shafts_existing: u64,
    /// Shafts the collector and the budget removed from memory.
    pub shafts_collected: u64,
    /// Of those, shafts sent to the compressed store.
    pub shafts_evicted: u64,
    /// Shafts restored from the compressed store.
    pub shafts_restored: u64,
    /// Shafts resident after the move.
    pub shafts_total: u64,
    /// Bytes of the resident shafts.
    pub resident_shaft_bytes: u64,
    /// Bytes of the compressed store.
    pub compressed_shaft_bytes: u64,
    /// Bytes if every link's shaft were stored.
    pub all_shaft_bytes: u64,
    /// Links the traversal found affected.
    pub links_affected: u64,
    /// Active links evaluated again.
    pub links_reevaluated: u64,
    /// Links added where a refined link's dropped children exchange light now.
    pub links_added: u64,
    /// Links refined (made passive) by the move's passes.
    pub links_refined: u64,
    /// Passive links made active again.
    pub links_reactivated: u64,
    /// Links in the pool after the move.
    pub links_total: u64,
    /// Leaf rows computed by the move (the others kept from the move before).
    pub rows_recomputed: u64,
    /// Leaves in the leaf system after the move.
    pub leaves_total: u64,
    /// Of `solve_s`, seconds computing and copying leaf rows (`--update local`).
    pub rows_s: f64,
    /// Of `solve_s`, seconds in the linear solves (`--update local`).
    pub gmres_s: f64,
    /// Shafts the budget evicted during the traversal (before the collector).
    pub evicted_during_move: u64,
    /// Seconds of the traversal, shaft building and restoring left out.
    pub traversal_s: f64,
    /// Seconds building and restoring shafts.
    pub shaft_s: f64,
    /// Seconds evaluating links again, refining and solving.
    pub solve_s: f64,
    /// Seconds of the whole move (without the final gather of a probe or `-o`).
    pub total_s: f64,
    /// Relative residual of the leaf system's last solve.
    pub residual: f64,
}

impl MoveStats {
    /// The JSON line (no newline).
    pub fn json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// The short line printed on stderr.
    pub fn summary(&self) -> String {
        format!(
            "move {:4}  {:8.4} s (traverse {:.4}, shafts {:.4}, solve {:.4}: rows {:.4}, gmres {:.4})  {} links affected, {} refined, {} of {} rows  shafts: {} built, {} existing, {} restored, {} resident ({} KiB of {} KiB for all)",
            self.r#move,
            self.total_s,
            self.traversal_s,
            self.shaft_s,
            self.solve_s,
            self.rows_s,
            self.gmres_s,
            self.links_affected,
            self.links_refined,
            self.rows_recomputed,
            self.leaves_total,
            self.shafts_built,
            self.shafts_existing,
            self.shafts_restored,
            self.shafts_total,
            self.resident_shaft_bytes / 1024,
            self.all_shaft_bytes / 1024
        )
    }
}
