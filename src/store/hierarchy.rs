//! [`Hierarchy`]: the element and link pools of an interactive session's start-up
//! solve, as a `.rhier` file keeps them (the hierarchy section, formats/rhier.md),
//! so that `rhier interact --from` starts without solving again (issue 49: "the
//! persisted hierarchy"). This module only converts between the typed columns and
//! the section's record and checks the columns' sizes; what the records mean is
//! checked against the scene by [`crate::solver::Solver::from_hierarchy`].

use std::path::Path;

use bytemuck::Pod;

use super::records::{ArchivedHierarchyRecord, HierarchyRecord};
use crate::pools::elements::{Emission, Geom, Node};
use crate::pools::links::{Ends, Transport};
use crate::{Error, Result};

/// An element pool and a link pool, in pool order (link ends are element ids of
/// this pool), with what a session needs to take them up again.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hierarchy {
    /// Names of the objects the session may move, in scene order.
    pub movable: Vec<String>,
    /// The solve settings as JSON (`SolveOptions` without its storage): a session
    /// refuses to continue a hierarchy refined at other settings.
    pub options: String,
    /// Element tree links.
    pub nodes: Vec<Node>,
    /// Element geometry.
    pub geoms: Vec<Geom>,
    /// Element time ranges.
    pub times: Vec<[f32; 2]>,
    /// Element radiosities when the last leaf rows were built (the rows' cluster
    /// parts aim their rays by them; the last solve starts from them).
    pub radiosities: Vec<[f32; 3]>,
    /// Element emission directions when the last leaf rows were built.
    pub directions: Vec<Emission>,
    /// Link ends.
    pub ends: Vec<Ends>,
    /// Link transports.
    pub transports: Vec<Transport>,
    /// The leaf system's rows as the solve's last round built them (CSR over the
    /// leaves in id order; empty: not kept, the session builds them again): the
    /// start of each leaf's entries (leaves + 1).
    pub row_start: Vec<u32>,
    /// Each row entry's source element.
    pub row_sources: Vec<u32>,
    /// Each row entry's coefficient.
    pub row_coefs: Vec<f64>,
    /// Each row's entries by chain link, `[leaf, link, first, count]` (`first`
    /// counted from the row's start), sorted by leaf then link: what a session's
    /// first move keeps of the rows it does not touch.
    pub row_links: Vec<[u32; 4]>,
}

impl Hierarchy {
    /// The section's record.
    pub fn to_record(&self) -> HierarchyRecord {
        fn bytes<T: Pod>(v: &[T]) -> Vec<u8> {
            bytemuck::cast_slice::<T, u8>(v).to_vec()
        }
        HierarchyRecord {
            movable: self.movable.clone(),
            options: self.options.clone(),
            elements: self.nodes.len() as u64,
            links: self.ends.len() as u64,
            nodes: bytes(&self.nodes),
            geoms: bytes(&self.geoms),
            times: bytes(&self.times),
            radiosities: bytes(&self.radiosities),
            directions: bytes(&self.directions),
            ends: bytes(&self.ends),
            transports: bytes(&self.transports),
            row_start: bytes(&self.row_start),
            row_sources: bytes(&self.row_sources),
            row_coefs: bytes(&self.row_coefs),
            row_links: bytes(&self.row_links),
        }
    }

    /// The typed columns of an archived record read from `path` at `place`; a
    /// column whose length is not its count times its record size is an error
    /// naming the column, what was expected and what was found.
    pub fn from_archived(
        path: &Path,
        place: &str,
        r: &ArchivedHierarchyRecord,
    ) -> Result<Hierarchy> {
        let elements = r.elements.to_native();
        let links = r.links.to_native();
        let column = |name: &str, b: &[u8], count: u64, size: usize| -> Result<()> {
            match count.checked_mul(size as u64) {
                Some(want) if want == b.len() as u64 => Ok(()),
                _ => Err(Error::invalid(
                    path,
                    format!("{place}, column {name}"),
                    format!("{count} records of {size} bytes"),
                    format!("{} bytes", b.len()),
                )),
            }
        };
        fn typed<T: Pod>(b: &[u8]) -> Vec<T> {
            bytemuck::pod_collect_to_vec::<u8, T>(b)
        }
        let e = |name, b: &[u8], size| column(name, b, elements, size);
        e("nodes", &r.nodes, size_of::<Node>())?;
        e("geoms", &r.geoms, size_of::<Geom>())?;
        e("times", &r.times, size_of::<[f32; 2]>())?;
        e("radiosities", &r.radiosities, size_of::<[f32; 3]>())?;
        e("directions", &r.directions, size_of::<Emission>())?;
        column("ends", &r.ends, links, size_of::<Ends>())?;
        column("transports", &r.transports, links, size_of::<Transport>())?;
        let multiple = |name: &str, b: &[u8], size: usize| -> Result<u64> {
            if b.len() % size == 0 {
                Ok((b.len() / size) as u64)
            } else {
                Err(Error::invalid(
                    path,
                    format!("{place}, column {name}"),
                    format!("a whole number of records of {size} bytes"),
                    format!("{} bytes", b.len()),
                ))
            }
        };
        multiple("row_start", &r.row_start, 4)?;
        let entries = multiple("row_sources", &r.row_sources, 4)?;
        column("row_coefs", &r.row_coefs, entries, 8)?;
        multiple("row_links", &r.row_links, 16)?;
        if elements >= u64::from(u32::MAX) || links >= u64::from(u32::MAX) {
            return Err(Error::invalid(
                path,
                place.to_string(),
                "fewer than 2^32 - 1 elements and links",
                format!("{elements} elements, {links} links"),
            ));
        }
        Ok(Hierarchy {
            movable: r.movable.iter().map(|s| s.to_string()).collect(),
            options: r.options.to_string(),
            nodes: typed(&r.nodes),
            geoms: typed(&r.geoms),
            times: typed(&r.times),
            radiosities: typed(&r.radiosities),
            directions: typed(&r.directions),
            ends: typed(&r.ends),
            transports: typed(&r.transports),
            row_start: typed(&r.row_start),
            row_sources: typed(&r.row_sources),
            row_coefs: typed(&r.row_coefs),
            row_links: typed(&r.row_links),
        })
    }
}
