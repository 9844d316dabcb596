//! `rhier flatland`: exact 2D radiosity with the visibility complex (Orti et al. 1996),
//! at one time or along a motion (`--times` / `--fps`), with an SVG picture.
//!
//! The result file (`--out`) is specified in `formats/flatland.md`. With several times
//! the form factors are updated between times (only those the motion changes, see
//! `rhier::flatland::dynamic`) and each frame reports what the update did.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde_json::{Value, json};

use rhier::flatland::complex::sweep;
use rhier::flatland::dynamic::Dynamic;
use rhier::flatland::mesh::Mesh;
use rhier::flatland::radiosity::form_factors;
use rhier::flatland::scene::{FlatScene, load};
use rhier::flatland::{FlatSolution, solve_with, svg};

/// Arguments of `rhier flatland`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Flatland scene (`formats/flatland.md`).
    pub scene: PathBuf,
    /// Result file (JSON).
    #[arg(short = 'o', long = "out")]
    pub out: PathBuf,
    /// Elements: none (the input segments), discontinuity, or uniform:N.
    #[arg(long, default_value = "none", value_parser = parse_mesh)]
    pub mesh: Mesh,
    /// Draw the scene coloured by radiosity to this SVG file, or PNG if the name ends
    /// in `.png` (one file per frame, suffixed `_NNN`, when there are several times).
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Also draw the visibility complex in the dual plane (faces related to moving
    /// objects in red).
    #[arg(long)]
    pub dual: bool,
    /// Times to solve, comma separated (default: the first keyframe time, or 0).
    #[arg(long, value_delimiter = ',', conflicts_with = "fps")]
    pub times: Option<Vec<f64>>,
    /// Solve at this frame rate over the keyframes' time range.
    #[arg(long)]
    pub fps: Option<f64>,
    /// After every update, recompute from scratch and report the largest differences.
    #[arg(long)]
    pub verify: bool,
}

/// Largest number of elements solved (dense matrix of 8 * N^2 bytes: 128 MB).
const MAX_ELEMENTS: usize = 4000;

fn parse_mesh(s: &str) -> Result<Mesh, String> {
    s.parse()
}

fn mesh_name(m: Mesh) -> String {
    match m {
        Mesh::None => "none".to_string(),
        Mesh::Discontinuity => "discontinuity".to_string(),
        Mesh::Uniform(n) => format!("uniform:{n}"),
    }
}

/// Runs `rhier flatland`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let scene = load(&args.scene)?;
    let times = frame_times(&scene, &args)?;
    for &t in &times {
        scene.check_at(&args.scene, t)?;
    }
    // The solve is dense (N^2 form factors, N^3 elimination) and the sweep visits all
    // point pairs: refuse sizes that would exhaust memory rather than abort.
    let elements = rhier::flatland::geometry_at(&scene, times[0], args.mesh)
        .elements
        .len();
    if elements > MAX_ELEMENTS {
        anyhow::bail!(
            "{}: expected at most {MAX_ELEMENTS} elements for the dense exact solve, found {elements} \
             (with --mesh {}); use a coarser mesh",
            args.scene.display(),
            mesh_name(args.mesh)
        );
    }
    let (mut dynamic, mut report) = Dynamic::new(&scene, args.mesh, times[0]);
    let mut frames = Vec::with_capacity(times.len());
    for (k, &t) in times.iter().enumerate() {
        if k > 0 {
            report = dynamic.step(t);
        }
        let ff = dynamic.form_factors();
        let sol = solve_with(&scene, t, dynamic.geometry().clone(), &ff);
        let mut update = json!({
            "full": report.full,
            "events": report.events,
            "event_candidates": report.event_candidates,
            "event_groups": report.event_groups,
            "triples_tested": report.triples_tested,
            "views_spliced": report.views_spliced,
            "views_reswept": report.views_reswept,
            "points_evaluated": report.points_evaluated,
            "edges_visited": report.edges_visited,
            "faces_visited": report.faces_visited,
            "form_factors_recomputed": report.ff_recomputed,
            "form_factors_total": report.ff_total,
            "pairs_appeared": report.pairs_appeared,
            "pairs_vanished": report.pairs_vanished,
            "seconds": report.seconds,
        });
        if args.verify {
            let scratch = rhier::flatland::solve(&scene, t, args.mesh);
            let (ff2, _) = form_factors(&scratch.geom);
            let df = max_ff_diff(&ff, &ff2, sol.geom.elements.len());
            let db = sol
                .element_b
                .iter()
                .zip(&scratch.element_b)
                .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
                .fold(0.0, f64::max);
            update["verify"] = json!({"max_abs_dF": df, "max_abs_dB": db});
        }
        let what = if report.full {
            format!("full solve, {} complex edges", report.edges_visited)
        } else {
            format!(
                "update: {} events ({} candidates), {} recomputed, {} faces ({} edges) visited",
                report.events,
                report.event_candidates,
                report.ff_recomputed,
                report.faces_visited,
                report.edges_visited
            )
        };
        let _ = writeln!(
            std::io::stdout(),
            "t = {t}: {} elements, {} non-zero form factors; {what}, {:.3} ms",
            sol.geom.elements.len(),
            report.ff_total,
            report.seconds * 1e3
        );
        if let Some(path) = &args.svg {
            let path = if times.len() > 1 {
                suffixed(path, k)
            } else {
                path.clone()
            };
            write_svg(&scene, &sol, &path, args.dual)?;
        }
        let mut frame = json!({"t": t, "elements": sol.geom.elements.len(),
            "segments": segments_json(&scene, &sol)});
        if k > 0 || times.len() > 1 {
            frame["update"] = update;
        }
        frames.push(frame);
    }
    let mesh = mesh_name(args.mesh);
    let doc = if frames.len() == 1 {
        let mut f = frames.pop().unwrap_or_default();
        f["rhier_flatland_result"] = json!(1);
        f["mesh"] = json!(mesh);
        f
    } else {
        json!({"rhier_flatland_result": 1, "mesh": mesh, "frames": frames})
    };
    let text = serde_json::to_string_pretty(&doc)?;
    std::fs::write(&args.out, text).with_context(|| format!("writing {}", args.out.display()))?;
    Ok(())
}

fn frame_times(scene: &FlatScene, args: &Args) -> anyhow::Result<Vec<f64>> {
    let (t0, t1) = scene.time_range();
    if let Some(ts) = &args.times {
        if ts.is_empty() || ts.iter().any(|t| !t.is_finite()) {
            anyhow::bail!("--times: expected finite numbers separated by commas");
        }
        return Ok(ts.clone());
    }
    if let Some(fps) = args.fps {
        if !(fps.is_finite() && fps > 0.0) {
            anyhow::bail!("--fps: expected a positive frame rate, found {fps}");
        }
        let n = ((t1 - t0) * fps).floor() as usize;
        if n > 100_000 {
            anyhow::bail!("--fps: {n} frames is more than 100000");
        }
        return Ok((0..=n).map(|k| t0 + k as f64 / fps).collect());
    }
    Ok(vec![t0])
}

fn max_ff_diff(
    a: &rhier::flatland::radiosity::FormFactors,
    b: &rhier::flatland::radiosity::FormFactors,
    n: usize,
) -> f64 {
    let (da, db) = (a.dense(), b.dense());
    da.iter()
        .zip(&db)
        .take(n * n)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn suffixed(path: &Path, k: usize) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or("frame".into(), |s| s.to_string_lossy());
    let ext = path
        .extension()
        .map_or("svg".into(), |s| s.to_string_lossy());
    path.with_file_name(format!("{stem}_{k:03}.{ext}"))
}

fn colour(grey: bool, b: [f64; 3]) -> Value {
    if grey { json!(b[0]) } else { json!(b) }
}

fn segments_json(scene: &FlatScene, sol: &FlatSolution) -> Vec<Value> {
    let g = &sol.geom;
    let names: Vec<(&str, usize)> = scene
        .objects
        .iter()
        .flat_map(|o| (0..o.segments.len()).map(move |k| (o.name.as_str(), k)))
        .collect();
    (0..g.segments.len())
        .map(|s| {
            let (lo, hi) = (
                g.segment_elements[s] as usize,
                g.segment_elements[s + 1] as usize,
            );
            let elems: Vec<Value> = (lo..hi)
                .map(|e| {
                    let el = &g.elements[e];
                    json!({"a": el.a, "b": el.b, "B": colour(scene.grey, sol.element_b[e])})
                })
                .collect();
            json!({"object": names[s].0, "index": names[s].1,
                   "a": g.segments[s].a, "b": g.segments[s].b,
                   "B": colour(scene.grey, sol.segment_b[s]), "elements": elems})
        })
        .collect()
}

fn write_svg(scene: &FlatScene, sol: &FlatSolution, path: &Path, dual: bool) -> anyhow::Result<()> {
    let complex = dual.then(|| sweep(&sol.geom, None, true).complex.unwrap_or_default());
    let related = match &complex {
        Some(c) => {
            let movers: Vec<u32> = (0..scene.objects.len() as u32)
                .filter(|&o| !scene.objects[o as usize].motion.is_empty())
                .collect();
            let g = &sol.geom;
            let of = |s: u32| g.segments[s as usize].object;
            let elems: Vec<u32> = (0..g.elements.len() as u32)
                .filter(|&e| movers.contains(&of(g.elements[e as usize].segment)))
                .collect();
            let points: Vec<u32> = (0..g.points.len() as u32)
                .filter(|&p| {
                    g.point_segments[p as usize]
                        .iter()
                        .any(|&s| movers.contains(&of(s)))
                })
                .collect();
            c.related_faces(&elems, &points)
        }
        None => Vec::new(),
    };
    let cx = complex.as_ref().map(|c| (c, related.as_slice()));
    let png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if png {
        svg::raster(sol, cx)
            .save(path)
            .with_context(|| format!("writing {}", path.display()))
    } else {
        std::fs::write(path, svg::draw(sol, cx))
            .with_context(|| format!("writing {}", path.display()))
    }
}
