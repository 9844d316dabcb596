//! `rhier play FILE.rhier (--time T | --frames A..B --fps F) -o DIR`: frames of a stored
//! solution as PNG (software rasterizer, [`rhier::playback::raster`]) or, with
//! `--export gltf`, as glTF meshes with `COLOR_0` vertex colours.
//!
//! Frames are named `frame_NNNNN.png` / `.gltf` in time order. The exposure is
//! `--exposure`, else chosen on the first frame (99th-percentile luminance → 1) and
//! kept for the whole sequence so that brightness does not flicker. The camera is
//! chosen on the first frame too: `--camera` of `--scene`, the file's, one inside an
//! interior ([`rhier::playback::raster::interior_camera`]), else the bounding box seen down `-z`; `--eye`,
//! `--target` and `--fov` replace its parts. An all-black first frame is warned of.

use std::path::PathBuf;

use anyhow::Context;
use glam::DVec3;
use rhier::playback::Frame;
use rhier::playback::export::write_gltf;
use rhier::playback::raster::{
    DEFAULT_SIZE, FrameMesh, Shading, auto_exposure, default_camera, render, tone_map,
};
use rhier::scene::Camera;
use rhier::store::Reader;

/// Output kind of `rhier play`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Export {
    /// PNG pictures.
    Png,
    /// glTF 2.0 (.gltf, embedded buffer) with COLOR_0 vertex colours.
    Gltf,
}

/// Arguments of `rhier play`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("when").required(true).args(["time", "frames"])))]
pub struct Args {
    /// The `.rhier` file.
    pub file: PathBuf,
    /// One frame at this time (seconds).
    #[arg(long)]
    pub time: Option<f64>,
    /// A frame range `A..B` in seconds (both included), with `--fps`.
    #[arg(long, requires = "fps")]
    pub frames: Option<String>,
    /// Frames per second for `--frames`.
    #[arg(long)]
    pub fps: Option<f64>,
    /// Output directory (created if missing).
    #[arg(short = 'o', long = "out")]
    pub out: PathBuf,
    /// Picture width in pixels (1..=4096).
    #[arg(long, default_value_t = DEFAULT_SIZE[0])]
    pub width: u32,
    /// Picture height in pixels (1..=4096).
    #[arg(long, default_value_t = DEFAULT_SIZE[1])]
    pub height: u32,
    /// Exposure multiplier (default: automatic, 99th-percentile luminance → 1).
    #[arg(long)]
    pub exposure: Option<f64>,
    /// Flat shading (one value per leaf) instead of smooth vertex radiosity.
    #[arg(long)]
    pub flat: bool,
    /// Output kind.
    #[arg(long, value_enum, default_value = "png")]
    pub export: Export,
    /// Eye position `X,Y,Z` (world units).
    ///
    /// Overrides the eye of the camera otherwise used (the scene's, else the
    /// automatic one); keeps its viewing direction unless `--target` is given.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    pub eye: Option<[f64; 3]>,
    /// Point looked at `X,Y,Z` (world units).
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    pub target: Option<[f64; 3]>,
    /// Vertical field of view in degrees (0 < DEG < 180).
    #[arg(long)]
    pub fov: Option<f64>,
    /// A camera of the glTF scene file given with `--scene`, by name.
    ///
    /// The `.rhier` file keeps one camera (the first of a glTF file); this picks
    /// another of the same file. `--eye`, `--target` and `--fov` still override it.
    #[arg(long, requires = "scene")]
    pub camera: Option<String>,
    /// The glTF scene file whose cameras `--camera` names.
    #[arg(long)]
    pub scene: Option<PathBuf>,
}

/// Parses `X,Y,Z`.
fn parse_point(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let values: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    match values[..] {
        [x, y, z] if values.iter().all(|v| v.is_finite()) && parts.len() == 3 => Ok([x, y, z]),
        _ => Err(format!("expected three finite numbers X,Y,Z, found {s:?}")),
    }
}

/// The camera of the frames: `--camera` of `--scene`, else the file's, else one
/// inside an interior, else the bounding box seen down `-z`; then `--eye`,
/// `--target` and `--fov` replace their parts.
fn choose_camera(
    args: &Args,
    named: Option<Camera>,
    stored: Option<Camera>,
    frame: &Frame,
    mesh: &FrameMesh,
) -> anyhow::Result<Camera> {
    let mut camera = named.unwrap_or_else(|| default_camera(stored, frame, mesh));
    let direction = camera.target - camera.eye;
    if let Some(e) = args.eye {
        camera.eye = DVec3::from_array(e);
        camera.target = camera.eye + direction;
    }
    if let Some(t) = args.target {
        camera.target = DVec3::from_array(t);
    }
    if let Some(f) = args.fov {
        camera.fov_y = f.to_radians();
    }
    let d = camera.target - camera.eye;
    if d.length() == 0.0 || !d.is_finite() {
        anyhow::bail!(
            "--eye/--target: expected two different points, found both at {}",
            camera.eye
        );
    }
    if d.normalize().cross(camera.up).length() < 1e-6 {
        // Looking straight along the up vector: any other up will do.
        camera.up = if d.x.abs() < 0.9 { DVec3::X } else { DVec3::Z };
    }
    Ok(camera)
}

/// Times of the frames asked for.
fn frame_times(args: &Args) -> anyhow::Result<Vec<f64>> {
    if let Some(t) = args.time {
        return Ok(vec![t]);
    }
    let spec = args.frames.as_deref().unwrap_or_default();
    let (a, b) = spec
        .split_once("..")
        .with_context(|| format!("--frames: expected A..B, found {spec:?}"))?;
    let a: f64 = a
        .trim()
        .parse()
        .with_context(|| format!("--frames: start {a:?} is not a number"))?;
    let b: f64 = b
        .trim()
        .parse()
        .with_context(|| format!("--frames: end {b:?} is not a number"))?;
    let fps = args.fps.unwrap_or(0.0);
    if !(fps.is_finite() && fps > 0.0 && a.is_finite() && b.is_finite()) || b < a {
        anyhow::bail!("--frames {spec} --fps {fps}: expected finite A <= B and fps > 0");
    }
    let n = ((b - a) * fps + 1e-9).floor() as u64 + 1;
    if n > 1_000_000 {
        anyhow::bail!("--frames {spec} --fps {fps}: {n} frames, expected at most 1000000");
    }
    Ok((0..n).map(|k| (a + k as f64 / fps).min(b)).collect())
}

/// Runs `rhier play`.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.width == 0 || args.height == 0 || args.width > 4096 || args.height > 4096 {
        anyhow::bail!(
            "--width/--height: expected 1..=4096, found {}x{}",
            args.width,
            args.height
        );
    }
    if let Some(e) = args.exposure
        && !(e.is_finite() && e > 0.0)
    {
        anyhow::bail!("--exposure: expected a positive number, found {e}");
    }
    if let Some(f) = args.fov
        && !(f > 0.0 && f < 180.0)
    {
        anyhow::bail!("--fov: expected degrees in (0, 180), found {f}");
    }
    let times = frame_times(&args)?;
    let named = match (&args.camera, &args.scene) {
        (Some(name), Some(path)) => {
            let cameras = rhier::scene::cameras(path)?;
            let Some((_, c)) = cameras.iter().find(|(n, _)| n == name) else {
                let names: Vec<&str> = cameras.iter().map(|(n, _)| n.as_str()).collect();
                anyhow::bail!(
                    "--camera {name:?}: {} has no such camera (it has: {})",
                    path.display(),
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                );
            };
            Some(*c)
        }
        _ => None,
    };
    let reader = Reader::open(&args.file)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating output directory {}", args.out.display()))?;
    let shading = if args.flat {
        Shading::Flat
    } else {
        Shading::Smooth
    };
    let mut exposure = args.exposure;
    let mut camera = None;
    for (k, &t) in times.iter().enumerate() {
        let frame = Frame::build(&reader, t)?;
        let mesh = FrameMesh::build(&frame, shading);
        if k == 0 && mesh.colors.iter().flatten().all(|&c| c == 0.0) {
            eprintln!(
                "rhier: warning: {} is black at t = {t}: the radiosity is zero everywhere (a scene with no emitter, or whose emitters light nothing); the pictures will be black",
                args.file.display()
            );
        }
        // Chosen on the first frame and kept, so that the view does not jump.
        let camera = match camera {
            Some(c) => c,
            None => *camera.insert(choose_camera(&args, named, reader.camera(), &frame, &mesh)?),
        };
        let out = match args.export {
            Export::Png => {
                let pic = render(&mesh, &camera, args.width, args.height);
                let e = *exposure.get_or_insert_with(|| auto_exposure(&pic));
                let path = args.out.join(format!("frame_{k:05}.png"));
                tone_map(&pic, e, [0, 0, 0])
                    .save(&path)
                    .with_context(|| format!("writing {}", path.display()))?;
                path
            }
            Export::Gltf => {
                let e = *exposure.get_or_insert_with(|| {
                    auto_exposure(&render(&mesh, &camera, args.width, args.height))
                });
                let path = args.out.join(format!("frame_{k:05}.gltf"));
                write_gltf(&path, &mesh, e)?;
                path
            }
        };
        super::probe::print_stdout(&format!(
            "{} (t = {t}, {} leaves)\n",
            out.display(),
            frame.leaves.len()
        ))?;
    }
    Ok(())
}
