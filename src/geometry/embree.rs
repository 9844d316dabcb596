//! Occlusion rays through Embree 3 (Wald et al., "Embree: a kernel framework for
//! efficient CPU ray tracing", 2014): the second visibility backend of
//! [`super::SceneBvh`], in every build, chosen at run time by [`super::Rays::ENV`].
//!
//! A hand-written FFI over the dozen calls of Debian's Embree 3.13 that an occlusion
//! query needs (`rtcore.h`), so that no unmaintained binding crate is pulled in.
//! The library is not linked: it is opened at run time ([`LIBRARIES`], with
//! `dlopen` through `libloading`) the first time Embree is asked for, so that a
//! machine without it builds and runs rhier on obvhs, and one with it (Debian:
//! `apt-get install libembree3-3`, or `libembree-dev`) runs the same binary on
//! Embree. Embree only finds the candidates: each triangle is given to it dilated
//! in its plane by the part's f32 round-off ([`EmbreeScene::new`]), and a filter
//! called on every candidate hit decides in f64, on the triangle's f64 corners, as
//! the obvhs backend does ([`super::SceneBvh::occluded_cached`]). The answers are
//! then the f64 test's on either backend, up to a ray grazing a triangle's edge at
//! under ~1° (see [`EmbreeScene::new`]).
//!
//! What it does not do: closest hits and box queries (the path tracer's bounces,
//! the shafts' culling) stay on obvhs. Nor is it faster than the default in a
//! solve: every occlusion query goes through it, one ray per `rtcOccluded1`, but
//! the solver's rays are short segments between surfaces in scenes whose BVH sits
//! in the L2 cache, and Embree casts them at about the 4-wide BVH's cost per ray
//! (~120–135 ns on `gen_cubes 20`); packets of a bundle's rays
//! (`rtcOccluded4/8/16`) were slower still (BENCHMARKS.md, "Occlusion rays").

use std::ffi::{c_char, c_int, c_uint, c_void};
use std::sync::OnceLock;

use glam::DVec3;

/// Embree's opaque handles.
type RtcDevice = *mut c_void;
type RtcScene = *mut c_void;
type RtcGeometry = *mut c_void;

/// `RTC_GEOMETRY_TYPE_TRIANGLE`.
const GEOMETRY_TYPE_TRIANGLE: c_int = 0;
/// `RTC_BUFFER_TYPE_INDEX`, `RTC_BUFFER_TYPE_VERTEX`.
const BUFFER_TYPE_INDEX: c_int = 0;
const BUFFER_TYPE_VERTEX: c_int = 1;
/// `RTC_FORMAT_UINT3`, `RTC_FORMAT_FLOAT3`.
const FORMAT_UINT3: c_int = 0x5003;
const FORMAT_FLOAT3: c_int = 0x9003;
/// `RTC_SCENE_FLAG_NONE`. Not `RTC_SCENE_FLAG_ROBUST` (a watertight triangle
/// test): the dilated triangles overlap their neighbours by far more than Embree's
/// round-off, and robust mode cost 8% of a solve's CPU on `gen_cubes 10`.
const SCENE_FLAG_NONE: c_int = 0;
/// `RTC_BUILD_QUALITY_MEDIUM` (Embree's default): `HIGH` (spatial splits) cast no
/// faster on `gen_cubes 10`.
const BUILD_QUALITY_MEDIUM: c_int = 1;
/// `RTC_INVALID_GEOMETRY_ID`.
const INVALID_GEOMETRY_ID: c_uint = u32::MAX;

/// `struct RTCIntersectContext` (`rtcore_common.h`, with `RTC_MAX_INSTANCE_LEVEL_COUNT`
/// 1 and no `RTC_MIN_WIDTH`, as Debian's `rtcore_config.h` has them).
#[repr(C)]
struct RtcIntersectContext {
    flags: c_int,
    filter: Option<FilterFn>,
    inst_id: [c_uint; 1],
}

/// `struct RTCRay` (`rtcore_ray.h`).
#[repr(C, align(16))]
struct RtcRay {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: c_uint,
    id: c_uint,
    flags: c_uint,
}

/// `struct RTCFilterFunctionNArguments` (`rtcore_common.h`).
#[repr(C)]
struct FilterArgs {
    valid: *mut c_int,
    geometry_user_ptr: *mut c_void,
    context: *mut RtcIntersectContext,
    ray: *mut c_void,
    hit: *mut c_void,
    n: c_uint,
}

/// `RTCFilterFunctionN`.
type FilterFn = unsafe extern "C" fn(args: *const FilterArgs);

/// The shared objects tried in turn: Debian's runtime package `libembree3-3` has
/// the first, `libembree-dev` adds the second.
pub const LIBRARIES: [&str; 2] = ["libembree3.so.3", "libembree3.so"];

/// How to get Embree when [`LIBRARIES`] cannot be opened.
const INSTALL: &str = "Debian: apt-get install libembree3-3, or libembree-dev";

/// Declares [`Api`], the table of Embree's entry points (each field the C function
/// of its name, with `rtcore.h`'s signature), and [`Api::load`], which looks each up.
macro_rules! embree_api {
    ($($name:ident: fn($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)?;)*) => {
        /// Embree's entry points, from the library [`Api::lib`] keeps open.
        #[allow(non_snake_case)]
        struct Api {
            $($name: unsafe extern "C" fn($($arg: $ty),*) $(-> $ret)?,)*
            /// The opened library, never closed while the pointers are used (the
            /// table lives in a `static`).
            #[allow(dead_code)]
            lib: libloading::Library,
        }

        impl Api {
            /// The table of `lib`'s entry points; errors with the first one missing.
            fn load(lib: libloading::Library) -> Result<Api, libloading::Error> {
                // SAFETY: each symbol is looked up with the type `rtcore.h` 3.13
                // declares for it (above); the pointers are copied out of `lib`,
                // which the table then owns, so they never outlive the library.
                unsafe {
                    Ok(Api {
                        $($name: *lib.get::<unsafe extern "C" fn($($ty),*) $(-> $ret)?>(
                            concat!(stringify!($name), "\0").as_bytes(),
                        )?,)*
                        lib,
                    })
                }
            }
        }
    };
}

embree_api! {
    rtcNewDevice: fn(config: *const c_char) -> RtcDevice;
    rtcGetDeviceError: fn(device: RtcDevice) -> c_int;
    rtcNewScene: fn(device: RtcDevice) -> RtcScene;
    rtcSetSceneFlags: fn(scene: RtcScene, flags: c_int);
    rtcSetSceneBuildQuality: fn(scene: RtcScene, quality: c_int);
    rtcCommitScene: fn(scene: RtcScene);
    rtcReleaseScene: fn(scene: RtcScene);
    rtcNewGeometry: fn(device: RtcDevice, kind: c_int) -> RtcGeometry;
    rtcSetNewGeometryBuffer: fn(
        geometry: RtcGeometry,
        kind: c_int,
        slot: c_uint,
        format: c_int,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    rtcSetGeometryOccludedFilterFunction: fn(geometry: RtcGeometry, filter: Option<FilterFn>);
    rtcCommitGeometry: fn(geometry: RtcGeometry);
    rtcAttachGeometry: fn(scene: RtcScene, geometry: RtcGeometry) -> c_uint;
    rtcReleaseGeometry: fn(geometry: RtcGeometry);
    rtcOccluded1: fn(scene: RtcScene, context: *mut RtcIntersectContext, ray: *mut RtcRay);
}

/// Opens the first of `names` that loads and looks up Embree's entry points in
/// it; the error names every library tried, why each failed and how to install
/// Embree.
fn open(names: &[&str]) -> Result<Api, String> {
    let mut why = Vec::with_capacity(names.len());
    for name in names {
        // SAFETY: opening a library runs its initialisers; Embree's only set up
        // its own state (no other library given here is loaded by rhier).
        match unsafe { libloading::Library::new(name) } {
            Ok(lib) => match Api::load(lib) {
                Ok(api) => return Ok(api),
                Err(e) => why.push(format!("{name}: {e}")),
            },
            Err(e) => why.push(format!("{name}: {e}")),
        }
    }
    Err(format!(
        "cannot load Embree 3 ({}); install it ({INSTALL})",
        why.join("; ")
    ))
}

/// Embree's entry points, the library opened on first use ([`LIBRARIES`]) and
/// kept open; or why it could not be.
fn api() -> Result<&'static Api, String> {
    static API: OnceLock<Result<Api, String>> = OnceLock::new();
    API.get_or_init(|| open(&LIBRARIES))
        .as_ref()
        .map_err(Clone::clone)
}

/// Checks that Embree can be loaded (the library opened, every entry point found),
/// loading it if it is not yet; the error names the libraries tried and how to
/// install Embree.
pub fn load() -> Result<(), String> {
    api().map(|_| ())
}

/// The process's Embree device, made on first use and never released (it owns
/// Embree's build threads).
struct Device(RtcDevice);

// SAFETY: an `RTCDevice` may be used from any thread (Embree 3 API docs,
// "Thread safety": all API calls are thread safe but for the modification of one
// object from several threads at once, and rhier never modifies the device).
unsafe impl Send for Device {}
// SAFETY: as for `Send`.
unsafe impl Sync for Device {}

/// Embree's entry points and the shared device, or why Embree could not be loaded
/// or could not make its device.
fn device() -> Result<(&'static Api, RtcDevice), String> {
    static DEVICE: OnceLock<Result<Device, String>> = OnceLock::new();
    let api = api()?;
    DEVICE
        .get_or_init(|| {
            // SAFETY: a null configuration string asks for the defaults; the call
            // has no other precondition.
            let d = unsafe { (api.rtcNewDevice)(std::ptr::null()) };
            if d.is_null() {
                // SAFETY: `rtcGetDeviceError(NULL)` reports the error of the
                // failed `rtcNewDevice` (Embree docs, rtcGetDeviceError).
                let e = unsafe { (api.rtcGetDeviceError)(std::ptr::null_mut()) };
                Err(format!("Embree: rtcNewDevice failed (RTCError {e})"))
            } else {
                Ok(Device(d))
            }
        })
        .as_ref()
        .map(|d| (api, d.0))
        .map_err(Clone::clone)
}

/// One part's triangles in an Embree scene (one triangle-mesh geometry whose
/// primitive `i` is the part's triangle `i`).
pub struct EmbreeScene {
    /// The entry points of the library the scene was made by.
    api: &'static Api,
    scene: RtcScene,
}

// SAFETY: a committed scene is only read: `rtcOccluded1` on it may be called from
// any number of threads at once (Embree 3 API docs, rtcCommitScene: "the scene can
// be used for ray queries ... from multiple threads"), and the scene is released
// once, by `Drop`, when no query can hold it.
unsafe impl Send for EmbreeScene {}
// SAFETY: as for `Send`; `&EmbreeScene` only casts rays.
unsafe impl Sync for EmbreeScene {}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: `scene` came from `rtcNewScene` and this is its only owner.
        unsafe { (self.api.rtcReleaseScene)(self.scene) };
    }
}

/// What an occlusion query carries to its filter: Embree's context first, so that
/// the context pointer Embree hands the filter is this record's (the "extended
/// intersection context" of the Embree docs).
#[repr(C)]
struct QueryContext<'a> {
    ctx: RtcIntersectContext,
    /// Decides a candidate triangle: true if it blocks the ray.
    accept: &'a mut dyn FnMut(u32) -> bool,
}

/// The occlusion filter: asks the query's `accept` about every candidate hit and
/// rejects those it refuses (`valid = 0`), so the traversal goes on past them.
unsafe extern "C" fn occlusion_filter(args: *const FilterArgs) {
    // SAFETY: Embree passes a valid argument record for the duration of the call.
    let args = unsafe { &*args };
    // SAFETY: every query casts with the context of a live `QueryContext`
    // (`EmbreeScene::occluded`), whose first field is the context Embree passes on.
    let query = unsafe { &mut *(args.context as *mut QueryContext) };
    let n = args.n as usize;
    for i in 0..n {
        // SAFETY: `valid` has `n` entries (RTCFilterFunctionNArguments).
        let valid = unsafe { &mut *args.valid.add(i) };
        if *valid == 0 {
            continue;
        }
        // SAFETY: `hit` is an `RTCHitN` of width `n` in SoA layout: `Ng_x, Ng_y,
        // Ng_z, u, v, primID, ...`, each `n` 32-bit values (RTCHitN_primID).
        let prim = unsafe { *(args.hit as *const c_uint).add(5 * n + i) };
        if !(query.accept)(prim) {
            *valid = 0;
        }
    }
}

impl EmbreeScene {
    /// An Embree scene of the triangles `tris` (f64, part space), each dilated in
    /// its plane by `pad` (every edge moved out by `pad`) before its corners round
    /// to f32, so that a ray the f64 test finds within round-off of an edge is a
    /// candidate: the f32 ray strays from the f64 one by a few ulps of the part's
    /// coordinates (~2·10⁻⁷ of them), and a crossing at angle `θ` to the plane
    /// moves by that over `tan θ`, which the caller's `pad` (10⁻⁵ of the part's
    /// reach) covers above `θ ≈ 1°`. A corner's shift is capped at `100 pad`
    /// (angles under ~1°, slivers). Errors if Embree cannot make its device.
    pub fn new(tris: &[[DVec3; 3]], pad: f64) -> Result<EmbreeScene, String> {
        let (api, device) = device()?;
        let n = tris.len();
        // SAFETY: `device` is live (never released).
        let scene = unsafe { (api.rtcNewScene)(device) };
        if scene.is_null() {
            return Err("Embree: rtcNewScene failed".into());
        }
        let out = EmbreeScene { api, scene };
        // SAFETY: `scene` is live and owned here.
        unsafe {
            (api.rtcSetSceneFlags)(scene, SCENE_FLAG_NONE);
            (api.rtcSetSceneBuildQuality)(scene, BUILD_QUALITY_MEDIUM);
        }
        if n == 0 {
            // SAFETY: as above; an empty scene commits to one that no ray hits.
            unsafe { (api.rtcCommitScene)(scene) };
            return Ok(out);
        }
        // SAFETY: `device` is live.
        let geom = unsafe { (api.rtcNewGeometry)(device, GEOMETRY_TYPE_TRIANGLE) };
        if geom.is_null() {
            return Err("Embree: rtcNewGeometry failed".into());
        }
        // SAFETY: `geom` is a live triangle geometry; the buffers Embree allocates
        // hold `3 n` float3 vertices (12-byte stride, padded by Embree for its
        // 16-byte loads) and `n` uint3 triangles, written below before the commit.
        let (vb, ib) = unsafe {
            (
                (api.rtcSetNewGeometryBuffer)(geom, BUFFER_TYPE_VERTEX, 0, FORMAT_FLOAT3, 12, 3 * n)
                    as *mut [f32; 3],
                (api.rtcSetNewGeometryBuffer)(geom, BUFFER_TYPE_INDEX, 0, FORMAT_UINT3, 12, n)
                    as *mut [u32; 3],
            )
        };
        if vb.is_null() || ib.is_null() {
            // SAFETY: `geom` is owned here and attached nowhere.
            unsafe { (api.rtcReleaseGeometry)(geom) };
            return Err("Embree: rtcSetNewGeometryBuffer failed".into());
        }
        // SAFETY: the buffers hold `3 n` and `n` items (above), are aligned for f32
        // and u32 (Embree aligns them to 16 bytes), and nothing else uses them yet.
        let (verts, idx) = unsafe {
            (
                std::slice::from_raw_parts_mut(vb, 3 * n),
                std::slice::from_raw_parts_mut(ib, n),
            )
        };
        for (i, t) in tris.iter().enumerate() {
            let d = dilate(t, pad);
            for k in 0..3 {
                verts[3 * i + k] = [d[k].x as f32, d[k].y as f32, d[k].z as f32];
            }
            let b = 3 * i as u32;
            idx[i] = [b, b + 1, b + 2];
        }
        // SAFETY: `geom`'s buffers are filled; the filter is an `extern "C"`
        // function with Embree's filter signature; attaching hands the scene a
        // reference, so releasing ours leaves the geometry to the scene.
        unsafe {
            (api.rtcSetGeometryOccludedFilterFunction)(geom, Some(occlusion_filter));
            (api.rtcCommitGeometry)(geom);
            (api.rtcAttachGeometry)(scene, geom);
            (api.rtcReleaseGeometry)(geom);
            (api.rtcCommitScene)(scene);
        }
        Ok(out)
    }

    /// True if a triangle `i` that the f32 ray `o + t·d`, `t ∈ [tnear, tfar]`,
    /// crosses (part space) has `accept(i)`. `accept` is asked about candidates
    /// in no set order, at most until one is accepted.
    pub fn occluded(
        &self,
        o: DVec3,
        d: DVec3,
        tnear: f64,
        tfar: f64,
        accept: &mut dyn FnMut(u32) -> bool,
    ) -> bool {
        let f = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
        let mut ray = RtcRay {
            org: f(o),
            tnear: tnear as f32,
            dir: f(d),
            time: 0.0,
            tfar: tfar as f32,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        };
        // `rtcInitIntersectContext` (an inline function of the header): incoherent
        // rays, no context filter, no instance.
        let mut query = QueryContext {
            ctx: RtcIntersectContext {
                flags: 0,
                filter: None,
                inst_id: [INVALID_GEOMETRY_ID],
            },
            accept,
        };
        // SAFETY: `scene` is committed and live for `&self`; the context is the
        // first field of `query`, which outlives the call and is what the filter
        // casts it back to; `ray` is a valid, aligned `RTCRay`.
        unsafe {
            (self.api.rtcOccluded1)(
                self.scene,
                &mut query as *mut QueryContext as *mut RtcIntersectContext,
                &mut ray,
            )
        };
        // Embree sets `tfar` to -inf on an occluded ray.
        ray.tfar == f32::NEG_INFINITY
    }
}

/// The triangle `t` with each edge moved out by `pad` in its plane: each corner
/// goes out along its angle's bisector by `pad / sin(half angle)`, capped at
/// `100 pad`. A degenerate triangle is returned as it is.
fn dilate(t: &[DVec3; 3], pad: f64) -> [DVec3; 3] {
    let mut out = *t;
    for k in 0..3 {
        let v = t[k];
        let e1 = (t[(k + 1) % 3] - v).normalize_or_zero();
        let e2 = (t[(k + 2) % 3] - v).normalize_or_zero();
        // Corner `v + w` with `w = -(e1 + e2) pad / |e1 × e2|` lies `pad` from
        // both edge lines, outside.
        let s = e1.cross(e2).length();
        if s == 0.0 {
            return *t;
        }
        let w = -(e1 + e2) * (pad / s);
        let cap = 100.0 * pad;
        out[k] = v + if w.length() > cap {
            w * (cap / w.length())
        } else {
            w
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A library that cannot be opened is an error naming every library tried, why
    /// it failed and how to install Embree, not a crash.
    #[test]
    fn a_missing_library_is_an_error_naming_it() {
        let names = ["libembree3-absent.so.3", "libembree3-absent.so"];
        let e = match open(&names) {
            Ok(_) => panic!("opened {names:?}"),
            Err(e) => e,
        };
        for name in names {
            assert!(e.contains(&format!("{name}: ")), "{e}");
        }
        assert!(e.contains("cannot open shared object file"), "{e}");
        assert!(e.contains("apt-get install libembree3-3"), "{e}");
    }

    /// A library without Embree's entry points is refused with the first one missing.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[test]
    fn a_library_without_embree_is_an_error_naming_the_symbol() {
        let e = match open(&["libm.so.6"]) {
            Ok(_) => panic!("libm.so.6 taken for Embree"),
            Err(e) => e,
        };
        assert!(e.starts_with("cannot load Embree 3 (libm.so.6: "), "{e}");
        assert!(e.contains("rtcNewDevice"), "{e}");
    }
}
