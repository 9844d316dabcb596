//! `rhier plan SCENE [solve settings] [--shards N] [--json]`: the windows a
//! space-time solve of `SCENE` makes with those settings (their frames, keyframes,
//! time spans and estimated costs) and their split into `N` shards of about equal
//! cost, as `rhier solve --shard K/N` solves them. It reads the settings through
//! the same argument groups as `rhier solve` ([`super::common`]) and solves nothing.

use rhier::solver::spacetime::{Plan, plan};
use serde::Serialize;

use super::common::{AccuracyArgs, AnimationArgs, ResourceArgs, SceneArgs};

/// Arguments of `rhier plan`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// What to solve.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// How finely the scene is refined (the settings are those of `rhier solve`).
    #[command(flatten)]
    pub accuracy: AccuracyArgs,
    /// How a moving scene is solved over time.
    #[command(flatten)]
    pub animation: AnimationArgs,
    /// Memory, files and threads (`--budget` is a result setting of a space-time
    /// solve).
    #[command(flatten)]
    pub resources: ResourceArgs,
    /// Split the windows into this many shards (contiguous runs of about equal
    /// estimated cost) for `rhier solve --shard K/N`.
    #[arg(long, default_value_t = 1, help_heading = "Farm")]
    pub shards: usize,
    /// Print one JSON object instead of text.
    #[arg(long, help_heading = "Output")]
    pub json: bool,
}

#[derive(Serialize)]
struct WindowJson {
    index: usize,
    shard: usize,
    /// First and last frame (indices in the animation).
    frames: [usize; 2],
    time: [f64; 2],
    /// Keyframes, as indices in the animation.
    keyframes: Vec<usize>,
    cost: f64,
}

#[derive(Serialize)]
struct ShardJson {
    index: usize,
    /// Windows `first..end`.
    windows: [usize; 2],
    frames: usize,
    time: [f64; 2],
    cost: f64,
}

#[derive(Serialize)]
struct PlanJson {
    scene: String,
    frames: usize,
    windows: Vec<WindowJson>,
    shards: Vec<ShardJson>,
    total_cost: f64,
    /// Costliest shard over the mean shard (1: perfectly even).
    spread: f64,
}

/// Runs `rhier plan`.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.shards == 0 {
        anyhow::bail!("--shards: expected at least 1 shard, found 0");
    }
    let (scene, stem) = args.scene.load()?;
    if !scene.has_motion() {
        anyhow::bail!("{stem} does not move: a static scene is solved whole, in no window");
    }
    let opts = args
        .accuracy
        .solve_options(args.resources.storage(false, None))?;
    let st = args.animation.space_time_options(&args.resources)?;
    rhier::solver::spacetime::static_only(&opts)?;
    let p = plan(&scene, &opts, &st)?;
    let json = plan_json(&p, &stem, args.shards);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        print!("{}", plan_text(&json));
    }
    Ok(())
}

fn plan_json(p: &Plan, stem: &str, n: usize) -> PlanJson {
    let shards = p.shards(n);
    let shard_of = |w: usize| shards.iter().position(|r| r.contains(&w)).unwrap_or(0);
    let windows = p
        .windows
        .iter()
        .enumerate()
        .map(|(i, w)| {
            let f = p.first_frames[i];
            WindowJson {
                index: i,
                shard: shard_of(i),
                frames: [f, f + w.times.len() - 1],
                time: p.spans[i],
                keyframes: w.keys.iter().map(|k| f + k).collect(),
                cost: p.costs[i],
            }
        })
        .collect();
    let shards: Vec<ShardJson> = shards
        .iter()
        .enumerate()
        .map(|(k, r)| ShardJson {
            index: k,
            windows: [r.start, r.end],
            frames: p.windows[r.clone()].iter().map(|w| w.times.len()).sum(),
            time: p.span_of(r),
            cost: p.costs[r.clone()].iter().sum(),
        })
        .collect();
    let total_cost: f64 = p.costs.iter().sum();
    let max = shards.iter().map(|s| s.cost).fold(0.0, f64::max);
    PlanJson {
        scene: stem.to_string(),
        frames: p.frames,
        windows,
        spread: max / (total_cost / n as f64).max(f64::MIN_POSITIVE),
        shards,
        total_cost,
    }
}

fn plan_text(j: &PlanJson) -> String {
    let mut s = format!(
        "{}: {} frames in {} windows, estimated cost {:.1} keyframes\n",
        j.scene,
        j.frames,
        j.windows.len(),
        j.total_cost
    );
    s.push_str("window  shard  frames        time                keyframes  cost\n");
    for w in &j.windows {
        s.push_str(&format!(
            "{:6}  {:5}  {:5}..{:<5}  [{:7.3}, {:7.3}]  {:9}  {:5.1}\n",
            w.index,
            w.shard,
            w.frames[0],
            w.frames[1],
            w.time[0],
            w.time[1],
            w.keyframes.len(),
            w.cost
        ));
    }
    s.push_str(&format!(
        "{} shards (costliest / mean {:.3}):\n",
        j.shards.len(),
        j.spread
    ));
    for sh in &j.shards {
        s.push_str(&format!(
            "shard {:3}: windows {:3}..{:<3} {:5} frames  [{:7.3}, {:7.3}]  cost {:5.1}\n",
            sh.index, sh.windows[0], sh.windows[1], sh.frames, sh.time[0], sh.time[1], sh.cost
        ));
    }
    s
}
