//! omcbsa's side of the side-by-side comparison with other planners' collision checkers and
//! kinematics libraries (docs/bench/collision.md): one Panda scene, written once in a JSON file
//! that the peers' harnesses read too, measured with the scalar checks (one configuration at a
//! time) and the batched ones (`_batched` rows: [`LANES`] configurations per call, or a rake of
//! placings per call along a motion; the same answers).
//!
//! ```text
//! cargo run --release -p omcbsa --example peer_scene -- run core/benches/scenes/panda_vamp.json
//! cargo run --release -p omcbsa --example peer_scene -- generate core/benches/scenes/panda_vamp.json
//! cargo run --release -p omcbsa --example peer_scene -- fk-configs /tmp/fk_configs.json
//! ```
//!
//! `run` prints one tab-separated row per case: `system case items hits median_ns min_ns
//! max_ns`, the time per item (configuration or motion) over `--passes` timed passes. Every
//! pass goes over all items, repeated so that it lasts about `--pass-ms`; the first,
//! untimed pass counts the hits. Peers time their rows the same way.
//!
//! `generate` fills the scene's configuration lists from its `generate` settings,
//! deterministically: `random`, uniform within the joint limits; `free`, those among further
//! uniform draws that keep `free_obstacle_margin_m` from every obstacle and
//! `free_self_margin_m` between the arm's own capsule pairs (a margin, so that a peer with
//! other collision geometry of the same arm finds them free too); `motions`, per length, straight
//! joint-space motions of that Euclidean length from a free configuration to another, within
//! the limits, that this checker finds valid.
//!
//! `fk-configs` writes the configurations the FK rows use (those of
//! core/benches/kinematics.rs: 1000 draws within the limits from seed 42, per model) with
//! each one's tool pose, for a peer to time the same configurations and check its chain.

use std::cell::RefCell;
use std::fmt::Write as _;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Parser, Subcommand};
use omcbsa::error::Errors;
use omcbsa::format::ObstacleSpec;
use omcbsa::load;
use omcbsa_core::collision::{ArmLanes, ArmPose, Placing, Scene as Surroundings, Sweep};
use omcbsa_core::geometry::{Aabb, Obstacle};
use omcbsa_core::lanes::{F64s, Mask, LANES};
use omcbsa_core::model::{Frame, FrankaPanda, KinovaGen3, Model};
use omcbsa_core::motion::MOTION_STEP;
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::Tool;
use serde::{Deserialize, Serialize};

const D: usize = 7;
type Panda = FrankaPanda;
/// The model the scene file names.
const SCENE_MODEL: &str = "franka_panda";
/// FK configurations: core/benches/kinematics.rs's seed and count.
const FK_SEED: u64 = 42;
const FK_CASES: usize = 1000;
/// How many uniform draws `generate` may make per configuration it needs before it gives up.
const MAX_DRAWS_PER_ITEM: usize = 100_000;

#[derive(Parser)]
#[command(about = "omcbsa's side of the peer comparison on one Panda scene")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Time the checks and FK on the scene; one tab-separated row per case.
    Run {
        scene: PathBuf,
        /// Timed passes per case.
        #[arg(long, default_value_t = 21)]
        passes: usize,
        /// About how long one pass lasts, ms.
        #[arg(long, default_value_t = 5.0)]
        pass_ms: f64,
        /// Only the cases whose name contains this (all when not given).
        #[arg(long)]
        only: Option<String>,
        /// Repetitions of the items per pass, in place of `--pass-ms` (a fixed amount of work,
        /// for counting cycles or instructions with a profiler).
        #[arg(long)]
        reps: Option<usize>,
    },
    /// Fill the scene's configuration lists from its `generate` settings (rewrites the file).
    Generate { scene: PathBuf },
    /// Write the FK rows' configurations and their tool poses as JSON.
    FkConfigs { out: PathBuf },
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Scene {
    about: String,
    model: String,
    obstacles: Vec<ObstacleSpec>,
    generate: Generate,
    #[serde(default)]
    random: Vec<Vec<f64>>,
    #[serde(default)]
    free: Vec<Vec<f64>>,
    #[serde(default)]
    motions: Vec<MotionSet>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Generate {
    seed: u64,
    random: usize,
    free: usize,
    motions_per_length: usize,
    motion_lengths_rad: Vec<f64>,
    decimals: i32,
    free_obstacle_margin_m: f64,
    free_self_margin_m: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MotionSet {
    length_rad: f64,
    /// `[from, to]` per motion.
    pairs: Vec<[Vec<f64>; 2]>,
}

/// A scene read and checked: the obstacles in the core's form, the configurations as arrays.
struct Checked {
    obstacles: Vec<Obstacle>,
    random: Vec<[f64; D]>,
    free: Vec<[f64; D]>,
    motions: Vec<(f64, Vec<[[f64; D]; 2]>)>,
}

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn read_scene(path: &Path) -> Result<(Scene, Checked)> {
    let text = load::read_text(path)?;
    let de = &mut serde_json::Deserializer::from_str(&text);
    let scene: Scene = serde_path_to_error::deserialize(de)
        .map_err(|e| format!("{}: {}: {}", path.display(), e.path(), e.inner()))?;
    let mut errors = Errors::default();
    if scene.model != SCENE_MODEL {
        errors.push(
            "model",
            format!("only {SCENE_MODEL} is measured, got {:?}", scene.model),
        );
    }
    let obstacles: Vec<_> = (scene.obstacles.iter().enumerate())
        .filter_map(|(i, o)| load::obstacle(i, o, &mut errors))
        .collect();
    let mut list = |name: &str, qs: &[Vec<f64>]| {
        (qs.iter().enumerate())
            .filter_map(|(i, q)| config(q, &format!("{name}[{i}]"), &mut errors))
            .collect::<Vec<_>>()
    };
    let random = list("random", &scene.random);
    let free = list("free", &scene.free);
    let mut motions = Vec::new();
    for (m, set) in scene.motions.iter().enumerate() {
        let mut pairs = Vec::new();
        for (i, [a, b]) in set.pairs.iter().enumerate() {
            let at = format!("motions[{m}].pairs[{i}]");
            let from = config(a, &format!("{at}[0]"), &mut errors);
            let to = config(b, &format!("{at}[1]"), &mut errors);
            pairs.extend(from.zip(to).map(|(from, to)| [from, to]));
        }
        motions.push((set.length_rad, pairs));
    }
    let g = &scene.generate;
    if !(0..=15).contains(&g.decimals) {
        errors.push(
            "generate.decimals",
            format!("must be within 0..=15, got {}", g.decimals),
        );
    }
    for (field, v) in [
        ("free_obstacle_margin_m", g.free_obstacle_margin_m),
        ("free_self_margin_m", g.free_self_margin_m),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            errors.push(
                format!("generate.{field}"),
                format!("must be >= 0, got {v}"),
            );
        }
    }
    for (i, &l) in g.motion_lengths_rad.iter().enumerate() {
        if !(l.is_finite() && l > 0.0) {
            errors.push(
                format!("generate.motion_lengths_rad[{i}]"),
                format!("must be > 0, got {l}"),
            );
        }
    }
    errors
        .finish()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let checked = Checked {
        obstacles,
        random,
        free,
        motions,
    };
    Ok((scene, checked))
}

/// Configuration `at` of the scene, checked (length, finite values, limits).
fn config(q: &[f64], at: &str, errors: &mut Errors) -> Option<[f64; D]> {
    load::joint_values::<Panda, D>(0, q, at, errors)
}

/// Whether the arm at `q` hits an obstacle or itself, as the planners' state check asks it,
/// placing into storage reused from one call to the next.
fn collides(pose: &mut ArmPose, obstacles: &[Obstacle], q: &[f64; D]) -> bool {
    pose.place::<Panda, D>(0, &Frame::IDENTITY, &Tool::NONE, q);
    pose.obstacle_hit(obstacles, 0.0).is_some() || pose.self_hit(0.0).is_some()
}

/// Whether the motion is valid, the arm placed between its ends as `placing` says (the same
/// answer either way).
fn motion_free(obstacles: &[Obstacle], [from, to]: &[[f64; D]; 2], placing: Placing) -> bool {
    let sweep = Sweep::<Panda, D>::new(0, &Tool::NONE, from, to, MOTION_STEP);
    !sweep
        .with_placing(placing)
        .arm_collides(&Frame::IDENTITY, obstacles)
}

/// How the cases are timed, and which: those whose name contains `only`.
struct Timer {
    passes: usize,
    pass_ms: f64,
    only: Option<String>,
    reps: Option<usize>,
}

impl Timer {
    /// Times `op` over `items` as case `case` of `n` items and prints its row, unless the case
    /// is left out. Each of `items` stands for `per` items of the row (a batch), the time per
    /// item; `hits`, when given, counts the hits instead of `op`'s true answers.
    fn case<T>(
        &self,
        case: &str,
        n: usize,
        items: &[T],
        per: f64,
        hits: impl FnOnce() -> Option<usize>,
        op: impl FnMut(&T) -> bool,
    ) {
        if self
            .only
            .as_ref()
            .is_some_and(|o| !case.contains(o.as_str()))
        {
            return;
        }
        let counted = hits();
        let (found, ns) = measure(items, self.passes, (self.pass_ms, self.reps), op);
        let [median, min, max] = ns.map(|t| t / per);
        let hits = counted.unwrap_or(found);
        println!("omcbsa\t{case}\t{n}\t{hits}\t{median:.1}\t{min:.1}\t{max:.1}");
    }
}

/// Time per item of `op` over `items`: median, least and most over `passes` passes, after an
/// untimed pass that counts the items for which `op` is true. A pass repeats the items `reps`
/// times, or as often as lasts about `pass_ms`.
fn measure<T>(
    items: &[T],
    passes: usize,
    (pass_ms, reps): (f64, Option<usize>),
    mut op: impl FnMut(&T) -> bool,
) -> (usize, [f64; 3]) {
    let hits = items.iter().filter(|x| op(black_box(x))).count();
    let mut pass = |reps: usize| {
        let start = Instant::now();
        let mut n = 0usize;
        for _ in 0..reps {
            for x in items {
                n += usize::from(op(black_box(x)));
            }
        }
        black_box(n);
        start.elapsed().as_secs_f64() * 1e9
    };
    let reps = reps.unwrap_or_else(|| {
        let once = pass(1).max(1.0);
        ((pass_ms * 1e6 / once).ceil() as usize).max(1)
    });
    let mut ns: Vec<f64> = (0..passes.max(1))
        .map(|_| pass(reps) / (reps * items.len().max(1)) as f64)
        .collect();
    ns.sort_by(f64::total_cmp);
    (hits, [ns[ns.len() / 2], ns[0], ns[ns.len() - 1]])
}

fn fk_configs<M: Model<D>>() -> Vec<[f64; D]> {
    let mut rng = Rng::new(FK_SEED);
    (0..FK_CASES)
        .map(|_| rng.configuration(&M::LOWER, &M::UPPER))
        .collect()
}

fn fk_rows<M: Model<D>>(timer: &Timer) {
    let qs = fk_configs::<M>();
    // No hits; the pose goes through black_box so that FK is not optimised away.
    timer.case(
        &format!("fk_{}", M::NAME),
        qs.len(),
        &qs,
        1.0,
        || None,
        |q| {
            black_box(M::fk(q));
            false
        },
    );
    let batches: Vec<[F64s; D]> = (qs.chunks_exact(LANES))
        .map(|b| core::array::from_fn(|j| F64s::new(core::array::from_fn(|k| b[k][j]))))
        .collect();
    let name = format!("fk_{}_batched", M::NAME);
    timer.case(
        &name,
        qs.len(),
        &batches,
        LANES as f64,
        || None,
        |q| {
            black_box(M::fk_lanes(q));
            false
        },
    );
}

fn run(path: &Path, timer: &Timer) -> Result<()> {
    let (_, s) = read_scene(path)?;
    let obstacles = &s.obstacles[..];
    println!("system\tcase\titems\thits\tmedian_ns\tmin_ns\tmax_ns");
    let mut pose = ArmPose::EMPTY;
    let lanes = RefCell::new(ArmLanes::EMPTY);
    // The obstacles' boxes, made once as a planner makes them.
    let boxes: Vec<Aabb> = obstacles.iter().map(Obstacle::aabb).collect();
    for (case, qs) in [("check_random", &s.random), ("check_free", &s.free)] {
        timer.case(
            case,
            qs.len(),
            qs,
            1.0,
            || None,
            |q| collides(&mut pose, obstacles, q),
        );
        // The same configurations LANES at a time (time and hits per configuration), a lane
        // left alone once it hits.
        let batches = lane_batches(&qs.chunks(LANES).collect::<Vec<_>>());
        let collides = |(q, live): &([F64s; D], Mask)| {
            let mut lanes = lanes.borrow_mut();
            lanes.place_lanes::<Panda, D>(0, &Frame::IDENTITY, &Tool::NONE, q, *live, u32::MAX);
            let hit = lanes.obstacle_hits_boxed(&Surroundings {
                obstacles,
                boxes: &boxes,
                margin: 0.0,
            });
            lanes.keep(!hit);
            hit | lanes.self_hits(0.0)
        };
        let hits = || {
            Some(
                batches
                    .iter()
                    .map(|b| collides(b).count_ones() as usize)
                    .sum(),
            )
        };
        let per = qs.len() as f64 / batches.len() as f64;
        let name = format!("{case}_batched");
        timer.case(&name, qs.len(), &batches, per, hits, |b| collides(b) != 0);
    }
    // What one batched call of a peer answers: whether any of 8 collides (stopping at the
    // first that does), per configuration.
    let eights: Vec<&[[f64; D]]> = s.random.chunks_exact(8).collect();
    timer.case(
        "any8_random",
        eights.len(),
        &eights,
        8.0,
        || None,
        |qs| qs.iter().any(|q| collides(&mut pose, obstacles, q)),
    );
    // The same question asked of one batch, which stops at its first hit in any lane.
    let batches = lane_batches(&eights);
    timer.case(
        "any8_random_batched",
        eights.len(),
        &batches,
        8.0,
        || None,
        |(q, live)| {
            let mut lanes = lanes.borrow_mut();
            let scene = Surroundings {
                obstacles,
                boxes: &boxes,
                margin: 0.0,
            };
            lanes.place_any_hit::<Panda, D>(0, &Frame::IDENTITY, &Tool::NONE, q, *live, &scene)
        },
    );
    for (length, pairs) in &s.motions {
        for (suffix, placing) in [("", Placing::Single), ("_batched", Placing::Rake)] {
            let name = format!("motion_{length}{suffix}");
            timer.case(
                &name,
                pairs.len(),
                pairs,
                1.0,
                || None,
                |m| !motion_free(obstacles, m, placing),
            );
        }
    }
    fk_rows::<Panda>(timer);
    fk_rows::<KinovaGen3>(timer);
    Ok(())
}

/// Each group of at most [`LANES`] configurations as one batch: a lane per configuration
/// (the last repeated in the lanes left over) and the lanes holding one.
fn lane_batches(groups: &[&[[f64; D]]]) -> Vec<([F64s; D], Mask)> {
    (groups.iter())
        .map(|qs| {
            let last = qs.len().min(LANES) - 1;
            let q =
                core::array::from_fn(|j| F64s::new(core::array::from_fn(|k| qs[k.min(last)][j])));
            (q, ((1u16 << (last + 1)) - 1) as Mask)
        })
        .collect()
}

/// `q` rounded to `decimals`, or `None` when rounding takes it outside the limits.
fn rounded(q: [f64; D], decimals: i32) -> Option<[f64; D]> {
    let scale = 10f64.powi(decimals);
    let r = q.map(|v| (v * scale).round() / scale);
    (0..D)
        .all(|j| r[j] >= Panda::LOWER[j] && r[j] <= Panda::UPPER[j])
        .then_some(r)
}

/// The scene file at `path` with its configuration lists as its `generate` settings make them.
fn generated(path: &Path) -> Result<String> {
    let (mut scene, s) = read_scene(path)?;
    let g = &scene.generate;
    let obstacles = &s.obstacles[..];
    let mut rng = Rng::new(g.seed);
    // A configuration within the limits once rounded (`None`: rounding left them).
    let draw = |rng: &mut Rng| rounded(rng.configuration(&Panda::LOWER, &Panda::UPPER), g.decimals);
    let clear = |q: &[f64; D]| {
        let pose = ArmPose::new::<Panda, D>(0, &Frame::IDENTITY, &Tool::NONE, q);
        pose.obstacle_hit(obstacles, g.free_obstacle_margin_m)
            .is_none()
            && pose.self_hit(g.free_self_margin_m).is_none()
    };
    let random = find("random configurations", g.random, || draw(&mut rng))?;
    let free = find("free configurations", g.free, || {
        let q = draw(&mut rng)?;
        clear(&q).then_some(q)
    })?;
    let mut motions = Vec::new();
    for &length in &g.motion_lengths_rad {
        let what = format!("valid {length}-rad motions");
        let pairs = find(&what, g.motions_per_length, || {
            let from = draw(&mut rng)?;
            let dir: [f64; D] = core::array::from_fn(|_| rng.uniform(-1.0, 1.0));
            let norm = dir.iter().map(|v| v * v).sum::<f64>().sqrt();
            let to = core::array::from_fn(|j| from[j] + length * dir[j] / norm);
            let to = rounded(to, g.decimals)?;
            let valid =
                clear(&from) && clear(&to) && motion_free(obstacles, &[from, to], Placing::Single);
            valid.then_some([from, to])
        })?;
        motions.push(MotionSet {
            length_rad: length,
            pairs: pairs
                .iter()
                .map(|[a, b]| [a.to_vec(), b.to_vec()])
                .collect(),
        });
    }
    scene.random = random.iter().map(|q| q.to_vec()).collect();
    scene.free = free.iter().map(|q| q.to_vec()).collect();
    scene.motions = motions;
    scene_text(&scene)
}

/// Calls `draw` until it gave `want` items, refusing to loop for ever on a scene that has too
/// few.
fn find<T>(what: &str, want: usize, mut draw: impl FnMut() -> Option<T>) -> Result<Vec<T>> {
    let mut found = Vec::with_capacity(want);
    let most = want * MAX_DRAWS_PER_ITEM;
    for _ in 0..most {
        if found.len() == want {
            return Ok(found);
        }
        found.extend(draw());
    }
    if found.len() == want {
        return Ok(found);
    }
    Err(format!(
        "generate: found {} of {want} {what} in {most} draws",
        found.len()
    )
    .into())
}

/// The scene as JSON with one configuration (or motion) per line.
fn scene_text(scene: &Scene) -> Result<String> {
    let mut t = String::from("{\n");
    let field = |t: &mut String, name: &str, value: String| writeln!(t, "  {name:?}: {value},");
    field(&mut t, "about", serde_json::to_string(&scene.about)?)?;
    field(&mut t, "model", serde_json::to_string(&scene.model)?)?;
    let obstacles: Vec<String> = (scene.obstacles.iter())
        .map(serde_json::to_string)
        .collect::<std::result::Result<_, _>>()?;
    field(&mut t, "obstacles", lines(&obstacles, "    "))?;
    let g = serde_json::to_string_pretty(&scene.generate)?.replace('\n', "\n  ");
    field(&mut t, "generate", g)?;
    let configs = |qs: &[Vec<f64>]| -> Result<String> {
        let rows: Vec<String> = qs
            .iter()
            .map(serde_json::to_string)
            .collect::<std::result::Result<_, _>>()?;
        Ok(lines(&rows, "    "))
    };
    field(&mut t, "random", configs(&scene.random)?)?;
    field(&mut t, "free", configs(&scene.free)?)?;
    let sets: Vec<String> = (scene.motions.iter())
        .map(|m| -> Result<String> {
            let rows: Vec<String> = m
                .pairs
                .iter()
                .map(serde_json::to_string)
                .collect::<std::result::Result<_, _>>()?;
            Ok(format!(
                "{{\"length_rad\": {}, \"pairs\": {}}}",
                m.length_rad,
                lines(&rows, "      ")
            ))
        })
        .collect::<Result<_>>()?;
    writeln!(t, "  \"motions\": {}\n}}", lines(&sets, "    "))?;
    Ok(t)
}

/// `[` rows one per line at `indent`, `]`.
fn lines(rows: &[String], indent: &str) -> String {
    if rows.is_empty() {
        return "[]".into();
    }
    let outer = &indent[..indent.len() - 2];
    format!(
        "[\n{indent}{}\n{outer}]",
        rows.join(&format!(",\n{indent}"))
    )
}

fn write_fk_configs(out: &Path) -> Result<()> {
    let model = |name: &str, qs: Vec<[f64; D]>, fk: fn(&[f64; D]) -> Frame| {
        let tools: Vec<_> = qs
            .iter()
            .map(|q| {
                let f = fk(q);
                serde_json::json!({"position": f.pos.as_slice(), "rotation_col_major": f.rot.as_slice()})
            })
            .collect();
        let entry = serde_json::json!({"configurations": qs, "tool": tools});
        (name.to_string(), entry)
    };
    let doc = serde_json::json!({
        "about": "FK configurations of host/examples/peer_scene.rs (seed 42, uniform within the limits, as core/benches/kinematics.rs) and each one's tool pose in the base frame, per model",
        "models": serde_json::Map::from_iter([
            model(KinovaGen3::NAME, fk_configs::<KinovaGen3>(), KinovaGen3::fk),
            model(Panda::NAME, fk_configs::<Panda>(), Panda::fk),
        ]),
    });
    std::fs::write(out, serde_json::to_string(&doc)?)?;
    Ok(())
}

fn main() -> ExitCode {
    let done = match Cli::parse().command {
        Command::Run {
            scene,
            passes,
            pass_ms,
            only,
            reps,
        } => run(
            &scene,
            &Timer {
                passes,
                pass_ms,
                only,
                reps,
            },
        ),
        Command::Generate { scene } => {
            generated(&scene).and_then(|text| Ok(std::fs::write(&scene, text)?))
        }
        Command::FkConfigs { out } => write_fk_configs(&out),
    };
    match done {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("peer_scene: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The committed scene is what `generate` writes today: its free configurations are free
    /// and its motions valid for today's Panda model and checks (a refitted model that
    /// changed that would fail here until the file is generated again).
    #[test]
    fn committed_scene_is_what_generate_writes() {
        let path = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../core/benches/scenes/panda_vamp.json"
        ));
        let committed = std::fs::read_to_string(path).unwrap();
        assert!(
            generated(path).unwrap() == committed,
            "core/benches/scenes/panda_vamp.json differs from what `peer_scene generate` writes"
        );
    }
}
