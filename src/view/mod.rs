//! `rhier view`'s server: one opened `.rhier` file served to a browser page that
//! orbits, scrubs time and probes by clicking (web/, formats/view.md).
//!
//! How it works: a [`Viewer`] owns the one [`Reader`] (the file mapped once, shared
//! by every request and every client) and answers a request path with a [`Reply`]
//! ([`Viewer::handle`], no I/O, so tests call it directly); [`serve`] runs it on a
//! `tiny_http` server with a few worker threads. Everything it evaluates goes through
//! playback's one code path: frames are [`Frame::build`], colours the
//! [`crate::playback::raster::FrameMesh`] `rhier play` draws ([`wire`]), clicks
//! [`probe_frame_hits`] (the answer of `rhier probe`), the start camera and exposure
//! those of `play` ([`default_camera`], [`auto_exposure`] on a
//! [`DEFAULT_SIZE`] picture). Meshes are per span of time ([`span`], [`Viewer::span_at`]):
//! a space-time file's live leaves change every frame, its mesh once per span, and
//! a frame carries only the live leaves' colours. A frame's live leaves are found
//! among its span's ([`span::Span::live`]), not among every leaf of its chunks. The
//! last few frames and spans built are kept, so several requests or clients at one
//! time build them once; the last colours are kept while what they depend on holds
//! ([`Viewer::frame_message`]).
//!
//! What it serves (an exact match on the path, nothing decoded, nothing from the
//! disk): the embedded page ([`assets`]) and `/api/info`, `/api/inspect`,
//! `/api/mesh?t=`, `/api/frame?t=&shading=`, `/api/probe?t=&p=&n=`. Any other path is
//! 404; a target that is not a path 400; a method other than GET 405; a bad or missing parameter 400, and a time
//! outside the file's domain 400 with the store's message.

pub mod assets;
mod server;
pub mod span;
pub mod wire;

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

use glam::{DAffine3, DVec3};
use serde_json::{Value, json};

use crate::error::Result;
use crate::playback::frame::Frame;
use crate::playback::probe::{ProbePoint, probe_frame_hits};
use crate::playback::raster::{
    DEFAULT_SIZE, FrameMesh, Shading, auto_exposure, default_camera, render,
};
use crate::scene::Camera;
use crate::store::Reader;

pub use server::serve;

/// Frames kept for requests at the same time (the mesh and colours of one time).
const KEPT_FRAMES: usize = 12;
/// Span meshes kept: the one playing, the next one asked for ahead, one more.
const KEPT_SPANS: usize = 3;
/// Chunk ranges whose span plans are kept (each holds its chunks' leaves): the one
/// playing and the next.
const KEPT_PLANS: usize = 2;

/// An answer: HTTP status, media type and body.
#[derive(Clone, Debug, PartialEq)]
pub struct Reply {
    /// HTTP status code.
    pub status: u16,
    /// `Content-Type`.
    pub content_type: &'static str,
    /// Body.
    pub body: Vec<u8>,
}

impl Reply {
    fn text(status: u16, message: impl Into<String>) -> Reply {
        let mut body = message.into().into_bytes();
        body.push(b'\n');
        Reply {
            status,
            content_type: "text/plain; charset=utf-8",
            body,
        }
    }

    fn json(value: &Value) -> Reply {
        Reply {
            status: 200,
            content_type: "application/json",
            body: value.to_string().into_bytes(),
        }
    }

    fn binary(body: Vec<u8>) -> Reply {
        Reply {
            status: 200,
            content_type: "application/octet-stream",
            body,
        }
    }
}

/// The colours of the last frame message, and what they depend on.
struct Colors {
    /// Colour id: the same id, the same colours.
    id: u32,
    /// The span's key and the live set's id.
    key: u64,
    live: u64,
    shading: Shading,
    /// Each object's object → world map relative to the first object's, by columns.
    relative: Vec<[f64; 12]>,
    scale: f32,
    bytes: Arc<Vec<u8>>,
}

/// A chunk range: its index, its `f32` bounds `[lo, hi)` and its chunks' leaves.
type ChunkRange = (u32, (f32, f32), Vec<Arc<Vec<crate::solution::Leaf>>>);

/// The file seen through one span: the reader's patches and objects, and the
/// leaves live at a time found among the span's leaves alone ([`span::Span::live`]),
/// so that [`Frame::build`] (playback's one evaluation path) reads no chunk.
struct SpanView<'a> {
    reader: &'a Reader,
    span: &'a span::Span,
}

impl crate::playback::SolutionView for SpanView<'_> {
    fn name(&self) -> &std::path::Path {
        self.reader.path()
    }

    fn time_domain(&self) -> crate::scene::TimeDomain {
        self.reader.time_domain()
    }

    fn camera(&self) -> Option<Camera> {
        self.reader.camera()
    }

    fn patches(&self) -> &[crate::solution::PatchGeometry] {
        self.reader.patches()
    }

    fn object_to_world(&self, object: u32, t: f64) -> DAffine3 {
        crate::playback::SolutionView::object_to_world(self.reader, object, t)
    }

    fn live_at(&self, t: f64) -> Result<crate::store::Live> {
        let td = self.reader.time_domain();
        crate::store::reader::check_time(self.reader.path(), td, t)?;
        if !self.span.contains(t) {
            return self.reader.live_at(t);
        }
        Ok(self.span.live(t, td.end))
    }
}

/// A span ([`span::Span`]) and its mesh message.
pub struct SpanMesh {
    /// The span.
    pub span: span::Span,
    /// Its mesh message ([`wire::mesh_bytes`]).
    pub bytes: Vec<u8>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The server's state: the opened file, what the page starts from, recent frames.
pub struct Viewer {
    reader: Reader,
    camera: Camera,
    exposure: f64,
    /// The diagonal of the first frame's bounds: the scene's size.
    extent: f64,
    inspect: Value,
    /// Frames built last, newest last.
    recent: Mutex<Vec<Arc<Frame>>>,
    /// Colours of the last frame message.
    colors: Mutex<Option<Colors>>,
    /// Span meshes built last, newest last.
    spans: Mutex<Vec<Arc<SpanMesh>>>,
    /// Span plans of the chunk ranges seen last.
    plans: Mutex<Vec<Arc<span::Plan>>>,
    /// Held while a span is built.
    building: Mutex<()>,
    /// The next colour id (0 is no colours).
    next_id: AtomicU32,
}

impl Viewer {
    /// Serves `reader`; `inspect` is what `rhier inspect --json` reports of it
    /// (`json`) and its text (`text`). Builds the first frame to choose the camera
    /// and exposure as `rhier play` does.
    pub fn new(reader: Reader, inspect: Value) -> Result<Viewer> {
        let t = reader.time_domain().start;
        let frame = Frame::build(&reader, t)?;
        let mesh = FrameMesh::build(&frame, Shading::Smooth);
        let camera = default_camera(reader.camera(), &frame, &mesh);
        let exposure = auto_exposure(&render(&mesh, &camera, DEFAULT_SIZE[0], DEFAULT_SIZE[1]));
        let extent = frame.bounds().map_or(1.0, |(lo, hi)| (hi - lo).length());
        let viewer = Viewer {
            reader,
            camera,
            exposure,
            extent,
            inspect,
            recent: Mutex::new(Vec::new()),
            colors: Mutex::new(None),
            spans: Mutex::new(Vec::new()),
            plans: Mutex::new(Vec::new()),
            building: Mutex::new(()),
            next_id: AtomicU32::new(1),
        };
        // The page's first requests, the mesh and colours at the start, find them
        // ready: from the mesh just built, not a second one.
        let span = viewer.span_at(t)?;
        let live = span.span.live(t, viewer.reader.time_domain().end);
        let (scale, bytes) = wire::color_section(&frame, &mesh, viewer.reader.patches());
        *lock(&viewer.colors) = Some(Colors {
            id: viewer.next_id.fetch_add(1, Ordering::Relaxed),
            key: span.span.key,
            live: live.stretch.id(),
            shading: Shading::Smooth,
            relative: viewer.relative(t),
            scale,
            bytes: Arc::new(bytes),
        });
        lock(&viewer.recent).push(Arc::new(frame));
        Ok(viewer)
    }

    /// Each object's object → world map at `t` relative to the first object's, by
    /// columns (what smooth shading's colours depend on, with the live leaves).
    fn relative(&self, t: f64) -> Vec<[f64; 12]> {
        let objects = self.reader.objects();
        let first = objects
            .first()
            .map_or(DAffine3::IDENTITY, |o| o.to_world(t));
        let inverse = first.inverse();
        objects
            .iter()
            .map(|o| (inverse * o.to_world(t)).to_cols_array())
            .collect()
    }

    /// The opened file.
    pub fn reader(&self) -> &Reader {
        &self.reader
    }

    /// The start camera.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// The start exposure.
    pub fn exposure(&self) -> f64 {
        self.exposure
    }

    /// The frame at `t`, built once while it is among the last few asked for, from
    /// the leaves of its span (no other leaf of the chunks is read).
    pub fn frame(&self, t: f64) -> Result<Arc<Frame>> {
        let kept = |recent: &Vec<Arc<Frame>>| {
            recent
                .iter()
                .find(|f| f.t.to_bits() == t.to_bits())
                .cloned()
        };
        if let Some(f) = kept(&self.recent.lock().unwrap_or_else(|p| p.into_inner())) {
            return Ok(f);
        }
        let span = self.span_at(t)?;
        let view = SpanView {
            reader: &self.reader,
            span: &span.span,
        };
        let f = Arc::new(Frame::build(&view, t)?);
        let mut recent = self.recent.lock().unwrap_or_else(|p| p.into_inner());
        if recent.len() >= KEPT_FRAMES {
            recent.remove(0);
        }
        recent.push(f.clone());
        Ok(f)
    }

    /// `t`'s chunk range `n`, its `f32` bounds, and the leaves of the chunks
    /// [`Reader::chunks_for`] looks at in it, shared with the reader's copy when it
    /// holds them.
    fn chunk_range(&self, t: f64) -> Result<ChunkRange> {
        let chunks = self.reader.chunks();
        let tf = t as f32;
        let n = chunks.partition_point(|c| c.t0 as f32 <= tf);
        let lo = n
            .checked_sub(1)
            .map_or(f32::NEG_INFINITY, |i| chunks[i].t0 as f32);
        let hi = chunks.get(n).map_or(f32::INFINITY, |c| c.t0 as f32);
        let held = match n.checked_sub(1) {
            Some(i) => (chunks[i].carry_from as usize..=i)
                .map(|k| self.reader.chunk_leaves_shared(k))
                .collect::<Result<Vec<_>>>()?,
            None => Vec::new(),
        };
        Ok((n as u32, (lo, hi), held))
    }

    /// The span plan of `t`'s chunk range ([`span::Plan`]), made once per range
    /// while it is among the last few.
    fn plan(&self, t: f64) -> Result<Arc<span::Plan>> {
        let tf = t as f32;
        let chunks = self.reader.chunks();
        let n = chunks.partition_point(|c| c.t0 as f32 <= tf) as u32;
        let kept = lock(&self.plans).iter().find(|p| p.part == n).cloned();
        if let Some(p) = kept {
            return Ok(p);
        }
        let (_, bounds, held) = self.chunk_range(t)?;
        let plan = Arc::new(span::Plan::new(n, bounds, held));
        let mut plans = lock(&self.plans);
        if plans.len() >= KEPT_PLANS {
            plans.remove(0);
        }
        plans.push(plan.clone());
        Ok(plan)
    }

    /// The span holding `t` and its mesh, built once while it is among the last few
    /// asked for.
    pub fn span_at(&self, t: f64) -> Result<Arc<SpanMesh>> {
        let kept = || {
            lock(&self.spans)
                .iter()
                .find(|s| s.span.contains(t))
                .cloned()
        };
        if let Some(s) = kept() {
            return Ok(s);
        }
        // One build at a time: several requests into a new span make it once.
        let _building = lock(&self.building);
        if let Some(s) = kept() {
            return Ok(s);
        }
        let plan = self.plan(t)?;
        let (j, _) = plan.span_of(t as f32);
        let span = plan.span(j, self.reader.patches());
        let bytes = wire::mesh_bytes(&span, self.reader.patches());
        let out = Arc::new(SpanMesh { span, bytes });
        let mut spans = lock(&self.spans);
        if spans.len() >= KEPT_SPANS {
            spans.remove(0);
        }
        spans.push(out.clone());
        Ok(out)
    }

    /// Answers a request: `method` and the request target `url` (path and query).
    pub fn handle(&self, method: &str, url: &str) -> Reply {
        if !url.starts_with('/') || url.bytes().any(|b| b <= b' ' || b == 0x7f) {
            return Reply::text(
                400,
                format!("request target: expected a path starting with /, found {url:?}"),
            );
        }
        let (path, query) = url.split_once('?').unwrap_or((url, ""));
        let api = matches!(
            path,
            "/api/info" | "/api/inspect" | "/api/mesh" | "/api/frame" | "/api/probe"
        );
        let Some(asset) = assets::asset(path).filter(|_| query.is_empty()) else {
            if !api {
                return Reply::text(404, format!("not found: {path}"));
            }
            if method != "GET" {
                return Reply::text(405, format!("method {method} not allowed: GET only"));
            }
            return match self.api(path, query) {
                Ok(r) => r,
                Err(e) => e,
            };
        };
        if method != "GET" {
            return Reply::text(405, format!("method {method} not allowed: GET only"));
        }
        Reply {
            status: 200,
            content_type: asset.0,
            body: asset.1.to_vec(),
        }
    }

    fn api(&self, path: &str, query: &str) -> std::result::Result<Reply, Reply> {
        let params = Params::parse(query)?;
        let allowed: &[&str] = match path {
            "/api/mesh" => &["t"],
            "/api/frame" => &["t", "shading", "have"],
            "/api/probe" => &["t", "p", "n"],
            _ => &[],
        };
        params.only(allowed)?;
        match path {
            "/api/info" => Ok(Reply::json(&self.info())),
            "/api/inspect" => Ok(Reply::json(&self.inspect)),
            "/api/mesh" => {
                let t = params.time(&self.reader)?;
                let span = self.span_at(t).map_err(|e| {
                    Reply::text(500, format!("evaluating the mesh at t = {t}: {e}"))
                })?;
                Ok(Reply::binary(span.bytes.clone()))
            }
            "/api/frame" => {
                let shading = match params.get("shading") {
                    None | Some("smooth") => Shading::Smooth,
                    Some("flat") => Shading::Flat,
                    Some(s) => {
                        return Err(bad(format!(
                            "shading: expected smooth or flat, found {s:?}"
                        )));
                    }
                };
                let have = match params.get("have") {
                    None => 0,
                    Some(s) => s.parse().map_err(|_| {
                        bad(format!(
                            "have: expected a colour id (a whole number), found {s:?}"
                        ))
                    })?,
                };
                let t = params.time(&self.reader)?;
                self.frame_message(t, shading, have)
                    .map(Reply::binary)
                    .map_err(|e| Reply::text(500, format!("evaluating the frame at t = {t}: {e}")))
            }
            _ => self.probe(&params).map(|v| Reply::json(&v)),
        }
    }

    /// The frame message at `t`, for the mesh of its span ([`Viewer::span_at`]). Its
    /// colours are those of the last frame answered when nothing they depend on
    /// changed: the span, the live leaves (the id of their stretch of time,
    /// [`crate::store::Stretch::id`]), the shading, and the objects'
    /// placements relative to the first object's, to rounding (1e-12, and 1e-12 of
    /// the scene's size for translations: smooth shading averages corners that meet
    /// in world space; a rigid motion of everything together keeps which corners
    /// meet). Else they are computed afresh, under a new colour id. When `have` is the id of the frame's colours, the client holds them
    /// already and they are left out of the message.
    pub fn frame_message(&self, t: f64, shading: Shading, have: u32) -> Result<Vec<u8>> {
        let objects = self.reader.objects();
        // The live set's stretch names it: found among the span's leaves alone.
        let span = self.span_at(t)?;
        let key = span.span.key;
        let live = span
            .span
            .live(t, self.reader.time_domain().end)
            .stretch
            .id();
        let relative = self.relative(t);
        let hit = |c: &Option<Colors>| {
            c.as_ref()
                .filter(|c| {
                    c.key == key
                        && c.live == live
                        && c.shading == shading
                        && same_placements(&c.relative, &relative, self.extent)
                })
                .map(|c| (c.id, c.scale, c.bytes.clone()))
        };
        let kept = hit(&self.colors.lock().unwrap_or_else(|p| p.into_inner()));
        let (id, scale, bytes) = match kept {
            Some(k) => k,
            None => {
                let frame = self.frame(t)?;
                let patches = self.reader.patches();
                let mesh = FrameMesh::build(&frame, shading);
                let (scale, bytes) = wire::color_section(&frame, &mesh, patches);
                let bytes = Arc::new(bytes);
                let id = self.next_id.fetch_add(1, Ordering::Relaxed);
                *self.colors.lock().unwrap_or_else(|p| p.into_inner()) = Some(Colors {
                    id,
                    key,
                    live,
                    shading,
                    relative,
                    scale,
                    bytes: bytes.clone(),
                });
                (id, scale, bytes)
            }
        };
        let colors: &[u8] = if have == id { &[] } else { &bytes };
        Ok(wire::frame_bytes(
            objects,
            t,
            (key, live),
            (id, scale),
            colors,
        ))
    }

    fn frame_at(&self, params: &Params) -> std::result::Result<Arc<Frame>, Reply> {
        let t = params.time(&self.reader)?;
        self.frame(t)
            .map_err(|e| Reply::text(500, format!("evaluating the frame at t = {t}: {e}")))
    }

    fn info(&self) -> Value {
        let td = self.reader.time_domain();
        let c = self.camera;
        json!({
            "file": self.reader.path().display().to_string(),
            "time": [td.start, td.end],
            "moving": self.reader.objects().iter().any(|o| o.is_moving()),
            "objects": self.reader.objects().iter().map(|o| o.name.clone()).collect::<Vec<_>>(),
            "patches": self.reader.patches().len(),
            "camera": {
                "eye": c.eye.to_array(),
                "target": c.target.to_array(),
                "up": c.up.to_array(),
                "fov_y_degrees": c.fov_y.to_degrees(),
            },
            "exposure": self.exposure,
        })
    }

    /// A click: `rhier probe`'s answer at `p` facing `n`, with the patch and leaf.
    fn probe(&self, params: &Params) -> std::result::Result<Value, Reply> {
        let p = params.point("p")?;
        let n = params.point("n")?;
        if n == DVec3::ZERO {
            return Err(bad("n: expected a non-zero normal, found 0,0,0"));
        }
        let frame = self.frame_at(params)?;
        let hit = probe_frame_hits(self.reader.path(), &frame, &[ProbePoint { p, n }])
            .map_err(|e| Reply::text(400, e.to_string()))?[0];
        let patch = &self.reader.patches()[hit.patch as usize];
        let object = self
            .reader
            .objects()
            .get(patch.object as usize)
            .map_or(String::new(), |o| o.name.clone());
        let leaf = frame.leaves.get(hit.leaf as usize).map(|l| {
            let n = l.corners as usize;
            json!({
                "index": hit.leaf,
                "corners": l.corners,
                "uv": l.uv[..n],
                "b": l.b[..n],
                "time": l.time,
            })
        });
        Ok(json!({
            "t": frame.t,
            "p": p.to_array(),
            "n": n.to_array(),
            "B": hit.b,
            "patch": hit.patch,
            "object": object,
            "material": self.reader.materials().get(patch.material as usize).map(|m| m.name.clone()),
            "uv": hit.uv,
            "leaf": leaf,
        }))
    }
}

/// Placements relative to the first object's (`a`, `b`: 3×3 by columns, then the
/// translation) that agree to rounding: within 1e-12 (the matrix) and 1e-12 of the
/// scene's size `extent` (the translation), 10⁵ times under the 1e-7 of the size to
/// which smooth shading rounds positions to find corners that meet. A whole scene
/// turning together stays at the identity only to rounding, time after time.
fn same_placements(a: &[[f64; 12]], b: &[[f64; 12]], extent: f64) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| {
            x.iter().zip(y).enumerate().all(|(i, (p, q))| {
                let tol = if i < 9 { 1e-12 } else { 1e-12 * extent };
                (p - q).abs() <= tol
            })
        })
}

fn bad(message: impl Into<String>) -> Reply {
    Reply::text(400, message)
}

/// A query string's `key=value` pairs, percent-decoded.
struct Params(Vec<(String, String)>);

impl Params {
    fn parse(query: &str) -> std::result::Result<Params, Reply> {
        let mut out = Vec::new();
        for pair in query.split('&').filter(|s| !s.is_empty()) {
            let (k, v) = pair
                .split_once('=')
                .ok_or_else(|| bad(format!("query: expected key=value, found {pair:?}")))?;
            let (k, v) = (decode(k)?, decode(v)?);
            if out.iter().any(|(j, _)| *j == k) {
                return Err(bad(format!("query: {k} given twice")));
            }
            out.push((k, v));
        }
        Ok(Params(out))
    }

    fn only(&self, allowed: &[&str]) -> std::result::Result<(), Reply> {
        match self.0.iter().find(|(k, _)| !allowed.contains(&k.as_str())) {
            Some((k, _)) => Err(bad(format!(
                "query: unknown parameter {k:?} (expected: {})",
                if allowed.is_empty() {
                    "none".to_string()
                } else {
                    allowed.join(", ")
                }
            ))),
            None => Ok(()),
        }
    }

    fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// `t`, a finite number in the file's time domain (the store's message if not).
    fn time(&self, reader: &Reader) -> std::result::Result<f64, Reply> {
        let s = self
            .get("t")
            .ok_or_else(|| bad("t: missing (a time in seconds)"))?;
        let t: f64 = s
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite())
            .ok_or_else(|| {
                bad(format!(
                    "t: expected a finite number of seconds, found {s:?}"
                ))
            })?;
        crate::store::reader::check_time(reader.path(), reader.time_domain(), t)
            .map_err(|e| bad(e.to_string()))?;
        Ok(t)
    }

    /// `key` as three finite numbers `x,y,z`.
    fn point(&self, key: &str) -> std::result::Result<DVec3, Reply> {
        let s = self
            .get(key)
            .ok_or_else(|| bad(format!("{key}: missing (x,y,z)")))?;
        let v: Vec<f64> = s.split(',').filter_map(|x| x.trim().parse().ok()).collect();
        match v[..] {
            [x, y, z] if v.iter().all(|c| c.is_finite()) && s.split(',').count() == 3 => {
                Ok(DVec3::new(x, y, z))
            }
            _ => Err(bad(format!(
                "{key}: expected three finite numbers x,y,z, found {s:?}"
            ))),
        }
    }
}

/// Percent-decodes a query component (`+` is a space); 400 if malformed.
fn decode(s: &str) -> std::result::Result<String, Reply> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'%' => {
                let hex = b
                    .get(i + 1..i + 3)
                    .and_then(|h| std::str::from_utf8(h).ok())
                    .and_then(|h| u8::from_str_radix(h, 16).ok())
                    .ok_or_else(|| bad(format!("query: bad percent escape in {s:?}")))?;
                out.push(hex);
                i += 3;
            }
            b'+' => {
                out.push(b' ');
                i += 1;
            }
            c => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).map_err(|_| bad(format!("query: {s:?} is not UTF-8")))
}
