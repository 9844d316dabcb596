//! [`Patches`]: every input polygon of a scene placed in world space at one time, as
//! columns indexed by [`PatchId`]. Patch `i` is the `i`-th polygon in scene order
//! (objects in order, polygons in order).

use glam::DVec3;

use super::polygon::Poly;
use crate::scene::Scene;

/// Index of a patch in [`Patches`].
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PatchId(pub u32);

/// World-space patch table at one time (struct of arrays).
#[derive(Clone, Debug, Default)]
pub struct Patches {
    /// World-space polygon of each patch.
    pub polys: Vec<Poly>,
    /// Unit normals.
    pub normals: Vec<DVec3>,
    /// Areas.
    pub areas: Vec<f64>,
    /// Reflectance per patch (from its material).
    pub rhos: Vec<[f64; 3]>,
    /// Exitance per patch (from its material).
    pub emissions: Vec<[f64; 3]>,
    /// Object of each patch.
    pub objects: Vec<u32>,
    /// Object-space description (what the store keeps).
    pub geometry: Vec<PatchGeometry>,
    /// Diameter of the bounding box of all patches (the solver's scale: it keeps
    /// the lit patches' box alone when some are dark, `Solver::at_time`).
    pub diameter: f64,
}

impl Patches {
    /// Places every polygon of `scene` at time `t`.
    pub fn at_time(scene: &Scene, t: f64) -> Self {
        let mut p = Patches::default();
        for (oi, obj) in scene.objects.iter().enumerate() {
            let m = obj.to_world(t);
            for poly in &obj.polygons {
                let k = poly.vertices.len().min(4);
                let mut verts = [DVec3::ZERO; 4];
                verts[..k].copy_from_slice(&poly.vertices[..k]);
                let world: Vec<DVec3> = verts[..k].iter().map(|&v| m.transform_point3(v)).collect();
                p.push(
                    scene,
                    Poly::new(&world),
                    verts,
                    k,
                    oi as u32,
                    poly.material.0,
                );
            }
        }
        p.diameter = p.scene_diameter();
        p
    }

    /// Appends a patch: its world polygon and its object-space corners.
    pub fn push(
        &mut self,
        scene: &Scene,
        world: Poly,
        object_space: [DVec3; 4],
        corners: usize,
        object: u32,
        material: u32,
    ) {
        let mat = &scene.materials[material as usize];
        self.normals.push(world.normal());
        self.areas.push(world.area());
        self.polys.push(world);
        self.rhos.push(mat.rho);
        self.emissions.push(mat.emission);
        self.objects.push(object);
        self.geometry.push(PatchGeometry {
            object,
            material,
            corners: corners as u32,
            vertices: object_space,
        });
    }

    /// Recomputes the cached diameter (after pushing patches by hand).
    pub fn finish(&mut self) {
        self.diameter = self.scene_diameter();
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.polys.len()
    }

    /// True if there are no patches.
    pub fn is_empty(&self) -> bool {
        self.polys.is_empty()
    }

    /// True if patch `i` emits light in some channel.
    pub fn emits(&self, i: usize) -> bool {
        self.emissions[i].iter().any(|&e| e > 0.0)
    }

    /// World point of patch `i` at parameter `(u, v)` ([`param_point`]).
    pub fn point(&self, i: usize, u: f64, v: f64) -> DVec3 {
        let p = &self.polys[i];
        let c = [p.v[0], p.v[1], p.v[2], p.v[3]];
        param_point(&c, p.n as u32, u, v)
    }

    /// Diameter of the bounding box of all patches (what `diameter` caches).
    fn scene_diameter(&self) -> f64 {
        self.diameter_where(|_| true)
    }

    /// Diameter of the bounding box of the patches `keep` admits (0 for none).
    pub fn diameter_where(&self, keep: impl Fn(usize) -> bool) -> f64 {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for (i, p) in self.polys.iter().enumerate() {
            if keep(i) {
                let (a, b) = p.bounds();
                lo = lo.min(a);
                hi = hi.max(b);
            }
        }
        if lo.x.is_finite() {
            (hi - lo).length()
        } else {
            0.0
        }
    }
}

/// One input polygon as stored: object, material, object-space corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchGeometry {
    /// Owning object (index in the scene's objects).
    pub object: u32,
    /// Material index.
    pub material: u32,
    /// 3 or 4.
    pub corners: u32,
    /// Object-space corners (the 4th unused for triangles).
    pub vertices: [DVec3; 4],
}

impl PatchGeometry {
    /// Point of the patch at parameter `(u, v)`, in the patch's own (object) space.
    pub fn point(&self, u: f64, v: f64) -> DVec3 {
        param_point(&self.vertices, self.corners, u, v)
    }
}

/// The patch parameterisation ([`crate::solution`]'s module docs): affine on a
/// triangle (`corners == 3`), bilinear on a quad. The one definition every module
/// uses.
pub fn param_point(p: &[DVec3; 4], corners: u32, u: f64, v: f64) -> DVec3 {
    if corners == 3 {
        p[0] + u * (p[1] - p[0]) + v * (p[2] - p[0])
    } else {
        (1.0 - u) * (1.0 - v) * p[0] + u * (1.0 - v) * p[1] + u * v * p[2] + (1.0 - u) * v * p[3]
    }
}
