//! [`ElementPool`]: the hierarchy's elements as columns.
//!
//! An element is either a **cluster** (a group of patches, Smits/Sillion clustering:
//! no plane, a bounding box) or a **surface** element (a parametric sub-domain of one
//! patch: the patch's root element or one of its descendants). Every element has a time
//! range `[t0, t1]` (a static solve gives every element the whole time domain).
//! Children of an element are contiguous (`first_child .. first_child + child_count`),
//! so the tree needs no pointers: a surface element splits into 4, a cluster has 2 or
//! more children.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use super::column::{Column, Storage};
use super::ids::ElementId;
use crate::{Error, Result};

/// What an element is.
#[repr(u8)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ElementKind {
    /// A group of patches (bounding box in `geom.corners[0..2]`, area centroid in
    /// `geom.corners[2]`).
    Cluster = 0,
    /// A parametric sub-domain of one patch.
    Surface = 1,
}

/// Tree links of an element. `repr(C)`, Pod, 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Node {
    /// Parent, or `u32::MAX` for a root.
    pub parent: u32,
    /// First child (valid when `child_count > 0`).
    pub first_child: u32,
    /// Number of children.
    pub child_count: u32,
    /// [`ElementKind`] as u8.
    pub kind: u8,
    /// Depth below the patch root (surface) or the scene root (cluster).
    pub depth: u8,
    /// Unused, zero.
    pub pad: [u8; 2],
}

const _: () = assert!(std::mem::size_of::<Node>() == 16);

/// Geometry of an element. `repr(C)`, Pod, 168 bytes.
///
/// Surface: world corners (3 or 4) counter-clockwise seen from the front, their
/// parameter-space positions, the unit normal, the area. Cluster: `corners[0]` and
/// `corners[1]` are the box's min and max, `corners[2]` the area centroid of its
/// patches (where a cluster estimate places the cluster), `corners[3][0]` the radius
/// of the sphere about that centroid that holds the box ([`Geom::set_cluster_box`]),
/// `area` the summed area of its patches, `normal` zero, and `uv` the cone that holds
/// its patches' normals ([`Geom::cluster_cone`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Geom {
    /// World corners.
    pub corners: [[f64; 3]; 4],
    /// Unit normal (zero for clusters).
    pub normal: [f64; 3],
    /// Area.
    pub area: f64,
    /// Parameter-space corners in the patch.
    pub uv: [[f32; 2]; 4],
    /// Patch index (`u32::MAX` for clusters).
    pub patch: u32,
    /// Number of valid corners (3 or 4; 2 for clusters).
    pub n: u32,
}

const _: () = assert!(std::mem::size_of::<Geom>() == 168);

impl Geom {
    /// Sets a cluster's box `lo`–`hi` and area centroid `centroid`, and the radius of
    /// the sphere about the centroid that holds the box, kept in `corners[3][0]`
    /// (read by [`crate::oracle::sphere`], which every walk into a cluster calls
    /// at every node it visits: 4.5% of a cluttered scene's run when recomputed
    /// per visit, BENCHMARKS.md "Scale").
    pub fn set_cluster_box(&mut self, lo: DVec3, hi: DVec3, centroid: DVec3) {
        let far = (centroid - lo).abs().max((hi - centroid).abs());
        self.corners = [
            lo.to_array(),
            hi.to_array(),
            centroid.to_array(),
            [far.length(), 0.0, 0.0],
        ];
    }

    /// A cluster's normal cone ([`Cone`]), kept in `uv` (`[ax, ay], [az, cos],
    /// [coherence, 0]`), which a cluster has no use for otherwise.
    pub fn cluster_cone(&self) -> Cone {
        let [[x, y], [z, cos], [coherence, _], _] = self.uv;
        Cone {
            axis: DVec3::new(x as f64, y as f64, z as f64),
            cos: cos as f64,
            coherence: coherence as f64,
        }
    }

    /// Sets [`Geom::cluster_cone`]; the cosine is rounded down, so that the cone
    /// stored in `f32` still holds every normal.
    pub fn set_cluster_cone(&mut self, c: &Cone) {
        let cos = if c.cos > -1.0 {
            (c.cos - 1e-6).max(-1.0)
        } else {
            -1.0
        };
        self.uv[0] = [c.axis.x as f32, c.axis.y as f32];
        self.uv[1] = [c.axis.z as f32, cos as f32];
        self.uv[2] = [c.coherence as f32, 0.0];
    }
}

/// The normals of a set of surfaces ([`Geom::cluster_cone`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Unit axis: the direction of the summed vector area `Σ A n`.
    pub axis: DVec3,
    /// Cosine of the half-angle about `axis` that holds every normal (`-1`: any).
    pub cos: f64,
    /// `|Σ A n| / Σ A`, in `[0, 1]` (1 for coplanar surfaces facing one way), so
    /// that `area · coherence · axis` is the summed vector area.
    pub coherence: f64,
}

impl Cone {
    /// The cone of one surface of unit normal `n`.
    pub fn of_normal(n: DVec3) -> Self {
        Cone {
            axis: n,
            cos: 1.0,
            coherence: 1.0,
        }
    }

    /// The cone holding the cones of `parts`, each with its area: the axis of the
    /// summed vector area, the widest part's angle from it plus its own half-angle
    /// (cosine `-1` where that passes `π`, or where the vector areas cancel).
    pub fn merge(parts: impl Iterator<Item = (Cone, f64)> + Clone) -> Self {
        let sum: DVec3 = parts.clone().map(|(c, a)| c.axis * c.coherence * a).sum();
        let area: f64 = parts.clone().map(|(_, a)| a).sum();
        let len = sum.length();
        if len.is_nan() || len <= 1e-12 * area {
            return Cone {
                axis: DVec3::Z,
                cos: -1.0,
                coherence: 0.0,
            };
        }
        let axis = sum / len;
        let mut widest = 0.0f64;
        for (c, _) in parts {
            let angle = axis.dot(c.axis).clamp(-1.0, 1.0).acos() + c.cos.clamp(-1.0, 1.0).acos();
            widest = widest.max(angle);
        }
        Cone {
            axis,
            cos: if widest >= std::f64::consts::PI {
                -1.0
            } else {
                widest.cos()
            },
            coherence: (len / area).min(1.0),
        }
    }
}

/// How an element's power leaves it by direction, summed over its surfaces (`B̄` a
/// surface's largest channel, `A` its area, `n` its unit normal). `repr(C)`, Pod,
/// 36 bytes. Set by the solver's pull; read by [`crate::oracle::cluster_emission`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Emission {
    /// Power-weighted normal `Σ A B̄ n`: the part of the power that leaves as from
    /// one surface.
    pub normal: [f32; 3],
    /// Power by axis, `Σ A B̄ n_k²` over the surfaces facing `+k` (slot `2k`) and
    /// `−k` (slot `2k + 1`), `k` = x, y, z: where the rest goes (`Σ n_k² = 1`, so
    /// the slots sum to the power).
    pub axes: [f32; 6],
}

const _: () = assert!(std::mem::size_of::<Emission>() == 36);

impl Emission {
    /// The normal part and the axis powers of a surface of area `area`,
    /// largest-channel radiosity `b` and unit normal `n`, in `f64` (a pull sums
    /// them before storing [`Emission::from_parts`]).
    pub fn surface_parts(area: f64, b: f64, n: [f64; 3]) -> ([f64; 3], [f64; 6]) {
        let p = area * b;
        let mut axes = [0.0; 6];
        for k in 0..3 {
            axes[2 * k + usize::from(n[k] < 0.0)] = p * n[k] * n[k];
        }
        (n.map(|x| p * x), axes)
    }

    /// The record of summed parts.
    pub fn from_parts(normal: [f64; 3], axes: [f64; 6]) -> Self {
        Emission {
            normal: normal.map(|x| x as f32),
            axes: axes.map(|x| x as f32),
        }
    }

    /// `self + alpha · (o − self)`, slot by slot.
    pub fn lerp(&self, o: &Emission, alpha: f32) -> Self {
        Emission {
            normal: std::array::from_fn(|k| {
                self.normal[k] + alpha * (o.normal[k] - self.normal[k])
            }),
            axes: std::array::from_fn(|k| self.axes[k] + alpha * (o.axes[k] - self.axes[k])),
        }
    }
}

/// The element arena.
#[derive(Debug)]
pub struct ElementPool {
    /// Tree links.
    pub nodes: Column<Node>,
    /// Geometry.
    pub geoms: Column<Geom>,
    /// Time range `[t0, t1]`.
    pub times: Column<[f32; 2]>,
    /// Radiosity `B` (RGB): at leaves the solution, above the area average (pull).
    pub radiosities: Column<[f32; 3]>,
    /// How the element's power leaves it by direction ([`Emission`]): how
    /// directional a cluster's emission is (see [`crate::oracle`], links with a
    /// cluster). Set by the solver's pull.
    pub directions: Column<Emission>,
    /// Irradiance gathered through the element's own links in the last gather.
    pub irradiances: Column<[f32; 3]>,
}

impl ElementPool {
    /// An empty pool on `storage`.
    pub fn new(storage: &Storage) -> Result<Self> {
        Ok(ElementPool {
            nodes: Column::new(storage, "elem-nodes")?,
            geoms: Column::new(storage, "elem-geoms")?,
            times: Column::new(storage, "elem-times")?,
            radiosities: Column::new(storage, "elem-b")?,
            directions: Column::new(storage, "elem-dir")?,
            irradiances: Column::new(storage, "elem-h")?,
        })
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True if empty.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Appends an element with no children.
    pub fn push(&mut self, node: Node, geom: Geom, time: [f32; 2]) -> Result<ElementId> {
        let id = self.nodes.push(node)?;
        self.geoms.push(geom)?;
        self.times.push(time)?;
        self.radiosities.push([0.0; 3])?;
        self.directions.push(Emission::default())?;
        self.irradiances.push([0.0; 3])?;
        Ok(ElementId(id))
    }

    /// Drops the elements from `len` on (see [`Column::truncate`]).
    pub fn truncate(&mut self, len: usize) {
        self.nodes.truncate(len);
        self.geoms.truncate(len);
        self.times.truncate(len);
        self.radiosities.truncate(len);
        self.directions.truncate(len);
        self.irradiances.truncate(len);
    }

    /// Children of `e` as a range of ids.
    #[inline]
    pub fn children(&self, e: ElementId) -> std::ops::Range<u32> {
        let n = &self.nodes.as_slice()[e.ix()];
        n.first_child..n.first_child + n.child_count
    }

    /// Kind of `e`.
    #[inline]
    pub fn kind(&self, e: ElementId) -> ElementKind {
        if self.nodes.as_slice()[e.ix()].kind == ElementKind::Cluster as u8 {
            ElementKind::Cluster
        } else {
            ElementKind::Surface
        }
    }

    /// Bytes held by all columns.
    pub fn bytes(&self) -> usize {
        self.nodes.bytes()
            + self.geoms.bytes()
            + self.times.bytes()
            + self.radiosities.bytes()
            + self.directions.bytes()
            + self.irradiances.bytes()
    }

    /// Checks the tree's invariants: equal column lengths, children in range with
    /// `parent` pointing back, positive finite areas, finite radiosity, a surface
    /// child's area summing to its parent's within round-off.
    pub fn validate(&self) -> Result<()> {
        let n = self.len();
        let bad = |place: String, expected: &str, found: String| {
            Err(Error::invalid("<element pool>", place, expected, found))
        };
        for len in [
            self.geoms.len(),
            self.times.len(),
            self.radiosities.len(),
            self.directions.len(),
            self.irradiances.len(),
        ] {
            if len != n {
                return bad(
                    "columns".into(),
                    &format!("{n} records in every column"),
                    len.to_string(),
                );
            }
        }
        let nodes = self.nodes.as_slice();
        let geoms = self.geoms.as_slice();
        for (i, node) in nodes.iter().enumerate() {
            let g = &geoms[i];
            if !(g.area.is_finite() && g.area >= 0.0) {
                return bad(
                    format!("element {i}"),
                    "finite area >= 0",
                    g.area.to_string(),
                );
            }
            if self.radiosities.as_slice()[i]
                .iter()
                .any(|b| !b.is_finite())
            {
                return bad(
                    format!("element {i}"),
                    "finite radiosity",
                    format!("{:?}", self.radiosities.as_slice()[i]),
                );
            }
            let end = node.first_child as usize + node.child_count as usize;
            if node.child_count > 0 && end > n {
                return bad(
                    format!("element {i}"),
                    &format!("children below {n}"),
                    format!("{}..{end}", node.first_child),
                );
            }
            let mut child_area = 0.0;
            for c in node.first_child as usize..if node.child_count > 0 {
                end
            } else {
                node.first_child as usize
            } {
                if nodes[c].parent != i as u32 {
                    return bad(
                        format!("element {c}"),
                        &format!("parent {i}"),
                        nodes[c].parent.to_string(),
                    );
                }
                child_area += geoms[c].area;
            }
            if node.child_count > 0 && node.kind == ElementKind::Surface as u8 {
                let rel = (child_area - g.area).abs() / g.area.max(f64::MIN_POSITIVE);
                if rel > 1e-9 {
                    return bad(
                        format!("element {i}"),
                        "children's areas summing to the parent's",
                        format!("relative difference {rel:e}"),
                    );
                }
            }
        }
        Ok(())
    }
}
