//! `rhier play FILE.rhier (--time T | --frames A..B --fps F) -o DIR`: frames of a stored
//! solution as PNG (software rasterizer, [`rhier::playback::raster`]) or, with
//! `--export gltf`, as glTF meshes with `COLOR_0` vertex colours.
//!
//! Frames are named `frame_NNNNN.png` / `.gltf` in time order. The exposure is
//! `--exposure`, else chosen on the first frame (99th-percentile luminance → 1) and
//! kept for the whole sequence so that brightness does not flicker.

use std::path::PathBuf;

use anyhow::Context;
use rhier::playback::Frame;
use rhier::playback::export::write_gltf;
use rhier::playback::raster::{FrameMesh, Shading, auto_camera, auto_exposure, render, tone_map};
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
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Picture height in pixels (1..=4096).
    #[arg(long, default_value_t = 480)]
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
    let times = frame_times(&args)?;
    let reader = Reader::open(&args.file)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating output directory {}", args.out.display()))?;
    let shading = if args.flat {
        Shading::Flat
    } else {
        Shading::Smooth
    };
    let mut exposure = args.exposure;
    for (k, &t) in times.iter().enumerate() {
        let frame = Frame::build(&reader, t)?;
        let mesh = FrameMesh::build(&frame, shading);
        let camera = reader.camera().unwrap_or_else(|| auto_camera(&frame));
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
