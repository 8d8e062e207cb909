//! The `aloha-sim` family of `omcbsa bench-online`: the grippers' poses of ALOHA's scripted
//! bimanual tasks (transfer cube, insertion), recorded at 50 Hz in its MuJoCo simulation by
//! `scripts/aloha/record.py` (files in `data/aloha_sim`, described in its README), embodied
//! on our arms.
//!
//! How a recorded hand becomes one of ours (a fixed transform, the same for every episode
//! and every cell):
//! - **Place.** ALOHA's two arms stand at x = ±0.469 m, y = 0.5 m on a table whose top is
//!   at z = 0, facing each other along x; the objects and the meeting point lie around
//!   (0, 0.5). The recording is moved by (0, -0.5, 0): the task lands on the centre of the
//!   bimanual family's table (its top at z = 0 too), the line of ALOHA's arms on the table's
//!   x axis. Nothing is scaled or turned: an object is as large, a motion as fast, as in
//!   the simulation. Where our arms stand is the [`Layout`]'s.
//! - **Tool.** The recorded frame is the one the policy's mocap drives, a point between
//!   ALOHA's fingertips (0.135 m beyond its gripper_link). It becomes our hand's pose: the
//!   point between the fingertips too (the Gen3's TCP 0.12 m beyond its flange, as in the
//!   bimanual family; the Panda's hand TCP), with the tool's z axis along the fingers and
//!   its y axis along the fingers' closing direction, both as the index gives them per hand
//!   (`finger_axis`, `closing_axis`, in the recorded frame).
//!
//! Every episode of the index is read and embodied; none is left out for being hard. An
//! episode with a pose that no arm of a cell can reach is still run (and fails); it is also
//! counted apart ([`super::reach::out_of_reach`]).

use std::io::Read;
use std::path::{Path, PathBuf};

use omcbsa_core::model::Frame;
use omcbsa_core::nalgebra::{Matrix3, Vector3};
use serde::Deserialize;

use super::bimanual::{self, Episode};
use super::Setup;
use crate::error::{Errors, InputError};
use crate::format::{Pose, RobotSpec, ToleranceSpec, DT_RANGE};
use crate::load;
use crate::models::ModelKind;
use crate::pose::{from_frame, to_frame};
use crate::suite::frames::{aligned, v3};
use crate::suite::witness::retract;
use crate::suite::MIXED_MODELS;

pub const INDEX_FORMAT: &str = "omcbsa-aloha-sim/1";
pub const EPISODE_FORMAT: &str = "omcbsa-aloha-episode/1";
/// Where the family is in the repository (relative to its root).
pub const DEFAULT_DIR: &str = "data/aloha_sim";
const INDEX_FILE: &str = "index.json";

/// ALOHA's arms stand on this line of its world, y = 0.5 m; it becomes the table's centre line.
const ALOHA_CENTRE_Y: f64 = 0.5;
/// How far the axes of a hand's frame may be from unit length and from square (they are
/// written to 1e-6).
const AXIS_TOLERANCE: f64 = 1e-5;

/// `index.json`: what was recorded, how, and the episodes.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Index {
    pub format: String,
    /// Time between steps, s.
    pub dt: f64,
    /// Poses per hand in every episode.
    pub steps: usize,
    pub recorder: Recorder,
    /// The hands, in the order every episode lists them.
    pub hands: Vec<HandFrame>,
    pub episodes: Vec<Entry>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recorder {
    pub script: String,
    pub commit: String,
    /// The recorder's folder differed from `commit`.
    pub dirty: bool,
    /// Versions of the packages the simulation ran on.
    pub packages: std::collections::BTreeMap<String, String>,
}

/// A hand's recorded frame: the weld that drives it and which of its axes are the gripper's.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HandFrame {
    pub name: String,
    /// The weld's offset in the simulation (information: the recorded frame is gripper_link's
    /// pose composed with its inverse).
    pub weld_offset: WeldOffset,
    /// The direction along the fingers, in the recorded frame.
    pub finger_axis: [f64; 3],
    /// The direction the fingers close along, in the recorded frame.
    pub closing_axis: [f64; 3],
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeldOffset {
    pub position: [f64; 3],
    pub quat_wxyz: [f64; 4],
}

/// One episode as the index lists it.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    pub file: String,
    pub task: String,
    pub seed: u64,
    /// The task's maximum reward was reached in the simulation (information only).
    pub success: bool,
    pub max_reward: f64,
    /// Farthest the reached pose was from the policy's command, m.
    pub max_position_error_m: f64,
}

/// An episode file (its `success`, rewards and error repeat its index entry's).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EpisodeFile {
    pub format: String,
    pub task: String,
    pub seed: u64,
    pub dt: f64,
    pub success: bool,
    pub max_reward: f64,
    /// The task's highest reward: `success` is reaching it.
    pub task_max_reward: f64,
    pub max_position_error_m: f64,
    pub hands: Vec<RecordedHand>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordedHand {
    pub name: String,
    /// The recorded frame at every step, in ALOHA's world frame.
    pub poses: Vec<Pose>,
}

/// One recorded episode: `hands[j][k]`, hand `j`'s frame at step `k` in ALOHA's world.
#[derive(Clone, Debug)]
pub struct Recorded {
    pub entry: Entry,
    pub hands: Vec<Vec<Frame>>,
}

/// The family as read: the index, and every episode it lists, in its order.
#[derive(Clone, Debug)]
pub struct Family {
    pub index: Index,
    /// Per hand of the index, the rotation from its recorded frame to our tool frame.
    tool: Vec<Matrix3<f64>>,
    pub episodes: Vec<Recorded>,
}

/// An error about one file of the family: every line names the file, then the field.
fn in_file(path: &Path, e: InputError) -> String {
    (e.errors.iter())
        .map(|f| format!("{}: {f}", path.display()))
        .collect::<Vec<_>>()
        .join("\n")
}

/// A file's text, gunzipped when its name ends in `.gz`; at most
/// [`load::DEFAULT_MAX_INPUT_BYTES`] of text (refused beyond, not cut).
fn read_text(path: &Path) -> Result<String, String> {
    if path.extension().is_none_or(|e| e != "gz") {
        return load::read_text(path).map_err(|e| in_file(path, e));
    }
    let cannot = |e: std::io::Error| format!("{}: cannot read: {e}", path.display());
    let file = std::fs::File::open(path).map_err(cannot)?;
    let max = load::DEFAULT_MAX_INPUT_BYTES;
    let mut bytes = Vec::new();
    (flate2::read::GzDecoder::new(file).take(max + 1))
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > max {
        return Err(format!(
            "{}: more than {max} bytes of text once unzipped (refused, not truncated)",
            path.display()
        ));
    }
    load::decode_text(bytes).map_err(|e| in_file(path, e))
}

/// Reads the family in `dir`: its index and every episode the index lists. Every value is
/// checked; the error names the file and the field.
pub fn read_family(dir: &Path) -> Result<Family, String> {
    let (index, tool) = read_index(dir)?;
    let index_path = dir.join(INDEX_FILE);
    let mut episodes = Vec::with_capacity(index.episodes.len());
    for (i, entry) in index.episodes.iter().enumerate() {
        let path = episode_path(dir, entry)
            .map_err(|e| in_file(&index_path, e.within(&format!("episodes[{i}].file")).into()))?;
        episodes.push(read_recorded(&index, entry, &path)?);
    }
    Ok(Family {
        index,
        tool,
        episodes,
    })
}

/// Reads one episode of a family, from its file (`<task>_<seed>.json.gz`) in the family's
/// directory, beside the index that lists it: a family of that one episode. Every value is
/// checked; the error names the file and the field.
pub fn read_episode(path: &Path) -> Result<Family, String> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let (index, tool) = read_index(dir)?;
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default();
    let entry = (index.episodes.iter().find(|e| e.file == name)).ok_or_else(|| {
        format!(
            "{}: not an episode that {} lists",
            path.display(),
            dir.join(INDEX_FILE).display()
        )
    })?;
    let recorded = read_recorded(&index, entry, path)?;
    Ok(Family {
        index,
        tool,
        episodes: vec![recorded],
    })
}

/// The family's index in `dir`, checked, and per hand the rotation to our tool frame.
fn read_index(dir: &Path) -> Result<(Index, Vec<Matrix3<f64>>), String> {
    let index_path = dir.join(INDEX_FILE);
    let index: Index =
        load::parse(&read_text(&index_path)?, INDEX_FORMAT).map_err(|e| in_file(&index_path, e))?;
    let tool = check_index(&index).map_err(|e| in_file(&index_path, e))?;
    Ok((index, tool))
}

/// The episode of `entry`, read from `path` and checked against the index.
fn read_recorded(index: &Index, entry: &Entry, path: &Path) -> Result<Recorded, String> {
    let file: EpisodeFile =
        load::parse(&read_text(path)?, EPISODE_FORMAT).map_err(|e| in_file(path, e))?;
    let hands = check_episode(index, entry, &file).map_err(|e| in_file(path, e))?;
    Ok(Recorded {
        entry: entry.clone(),
        hands,
    })
}

/// An episode's file: a plain name in the family's directory.
fn episode_path(dir: &Path, entry: &Entry) -> Result<PathBuf, crate::error::FieldError> {
    let plain = Path::new(&entry.file).file_name() == Some(entry.file.as_ref());
    if !plain || entry.file.is_empty() {
        return Err(crate::error::FieldError::new(
            "",
            format!(
                "{}: a file name in the family's directory, without a path",
                crate::error::quoted(&entry.file)
            ),
        ));
    }
    Ok(dir.join(&entry.file))
}

/// `|x|` at most [`AXIS_TOLERANCE`] (not NaN).
fn within_tolerance(x: f64) -> bool {
    x.abs() <= AXIS_TOLERANCE
}

/// The index's values; per hand, the rotation from its recorded frame to our tool frame.
fn check_index(index: &Index) -> Result<Vec<Matrix3<f64>>, InputError> {
    let mut errors = Errors::default();
    if !(index.dt.is_finite() && DT_RANGE.contains(&index.dt)) {
        errors.push(
            "dt",
            format!(
                "{} s: must be {} to {} s",
                index.dt,
                DT_RANGE.start(),
                DT_RANGE.end()
            ),
        );
    }
    if index.steps == 0 {
        errors.push("steps", "must be at least 1");
    }
    if index.hands.is_empty() || index.hands.len() > bimanual::MAX_ARMS {
        errors.push(
            "hands",
            format!(
                "{} hands: 1 to {} are embodied",
                index.hands.len(),
                bimanual::MAX_ARMS
            ),
        );
    }
    if index.episodes.is_empty() {
        errors.push("episodes", "empty: the family has no episode");
    }
    let mut tool = Vec::new();
    for (j, hand) in index.hands.iter().enumerate() {
        let finger = Vector3::from(hand.finger_axis);
        let closing = Vector3::from(hand.closing_axis);
        for (name, axis) in [("finger_axis", finger), ("closing_axis", closing)] {
            if !within_tolerance(axis.norm() - 1.0) {
                errors.push(
                    format!("hands[{j}].{name}"),
                    format!("length {}: must be a unit vector", axis.norm()),
                );
            }
        }
        if !within_tolerance(finger.dot(&closing)) {
            errors.push(
                format!("hands[{j}].closing_axis"),
                "must be square to finger_axis",
            );
        }
        // Tool z along the fingers, y along their closing (orthonormal within rounding).
        let x = closing.cross(&finger);
        tool.push(aligned(Vector3::zeros(), finger, x).rot);
    }
    let mut files = std::collections::HashSet::new();
    for (i, e) in index.episodes.iter().enumerate() {
        if !files.insert(&e.file) {
            errors.push(
                format!("episodes[{i}].file"),
                format!("{} is listed twice", crate::error::quoted(&e.file)),
            );
        }
    }
    errors.finish()?;
    Ok(tool)
}

/// An episode file against its index entry; its hands' frames.
fn check_episode(
    index: &Index,
    entry: &Entry,
    file: &EpisodeFile,
) -> Result<Vec<Vec<Frame>>, InputError> {
    let mut errors = Errors::default();
    let differs = |what: &str, a: &dyn std::fmt::Debug, b: &dyn std::fmt::Debug| {
        format!("{a:?}, but the index says {what} {b:?}")
    };
    if file.task != entry.task {
        errors.push("task", differs("task", &file.task, &entry.task));
    }
    if file.seed != entry.seed {
        errors.push("seed", differs("seed", &file.seed, &entry.seed));
    }
    if file.success != entry.success {
        errors.push("success", differs("success", &file.success, &entry.success));
    }
    if file.max_reward != entry.max_reward {
        errors.push(
            "max_reward",
            differs("max_reward", &file.max_reward, &entry.max_reward),
        );
    }
    if file.max_position_error_m != entry.max_position_error_m {
        errors.push(
            "max_position_error_m",
            differs(
                "max_position_error_m",
                &file.max_position_error_m,
                &entry.max_position_error_m,
            ),
        );
    }
    if file.success != (file.max_reward >= file.task_max_reward) {
        errors.push(
            "success",
            format!(
                "{}, but max_reward {} against task_max_reward {} says otherwise",
                file.success, file.max_reward, file.task_max_reward
            ),
        );
    }
    if file.dt != index.dt {
        errors.push("dt", differs("dt", &file.dt, &index.dt));
    }
    if file.hands.len() != index.hands.len() {
        errors.push(
            "hands",
            format!(
                "{} hands, but the index has {}",
                file.hands.len(),
                index.hands.len()
            ),
        );
    }
    let mut frames = Vec::with_capacity(file.hands.len());
    for (j, (hand, spec)) in file.hands.iter().zip(&index.hands).enumerate() {
        if hand.name != spec.name {
            errors.push(
                format!("hands[{j}].name"),
                differs("name", &hand.name, &spec.name),
            );
        }
        if hand.poses.len() != index.steps {
            errors.push(
                format!("hands[{j}].poses"),
                format!(
                    "{} poses, but the index says {} steps",
                    hand.poses.len(),
                    index.steps
                ),
            );
        }
        let mut hand_frames = Vec::with_capacity(hand.poses.len());
        for (k, p) in hand.poses.iter().enumerate() {
            match to_frame(p) {
                Ok(f) => hand_frames.push(f),
                Err(e) => errors.add(e.within(&format!("hands[{j}].poses[{k}]"))),
            }
        }
        frames.push(hand_frames);
    }
    errors.finish()?;
    Ok(frames)
}

/// Where the arms stand around the table (`bimanual`'s table, 0.8 m along x by 0.9 m).
///
/// Not the bimanual family's arms facing each other across the table on the line of
/// ALOHA's: ALOHA's start posture holds each hand 0.16 m in front of its base, level, the
/// fingers pointing away from it, and a Gen3 on that line cannot fold so close (its wrist
/// would be 0.15 m from its shoulder) until it stands 0.85 m out, from where the far
/// side's meeting point is out of its reach. Standing off that line, to the side of the
/// hands, it reaches every recorded pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// At the table's corners beyond its ends ([`CORNERS`]), facing its centre: the first
    /// two diagonally opposite, one on each hand's side; then the other two corners; then
    /// the middles of the long edges, where the bimanual family's side arms stand.
    Corners,
    /// Side by side along the table's long edges, facing across it, as a mobile
    /// manipulator's two arms stand: the first two arms (or half of them, rounded up) in a
    /// row at y = -[`ROW_Y`], the others facing them at y = +[`ROW_Y`]; [`ROW_SPACING`]
    /// apart within a row.
    Rows,
}

/// The places of [`Layout::Corners`], in order (x, y), m.
pub const CORNERS: [(f64, f64); bimanual::MAX_ARMS] = [
    (-0.6, -0.45),
    (0.6, 0.45),
    (-0.6, 0.45),
    (0.6, -0.45),
    (0.0, -0.7),
    (0.0, 0.7),
];
const CORNER_NAMES: [&str; bimanual::MAX_ARMS] = [
    "south_west",
    "north_east",
    "north_west",
    "south_east",
    "south",
    "north",
];
/// Distance of the rows of [`Layout::Rows`] from the table's centre line, m.
pub const ROW_Y: f64 = 0.6;
/// Distance between neighbours in a row of [`Layout::Rows`], m.
pub const ROW_SPACING: f64 = 0.5;

impl Layout {
    pub const ALL: [Layout; 2] = [Layout::Corners, Layout::Rows];

    pub fn name(self) -> &'static str {
        match self {
            Layout::Corners => "corners",
            Layout::Rows => "rows",
        }
    }

    pub fn parse(name: &str) -> Result<Layout, String> {
        (Self::ALL.into_iter().find(|l| l.name() == name)).ok_or_else(|| {
            let known: Vec<&str> = Self::ALL.iter().map(|l| l.name()).collect();
            format!("unknown layout {name:?} (known: {})", known.join(", "))
        })
    }

    /// The bases of `arms` arms and their names.
    fn bases(self, arms: usize) -> Vec<(Frame, String)> {
        match self {
            Layout::Corners => {
                let up = v3(0.0, 0.0, 1.0);
                (CORNERS.iter().zip(CORNER_NAMES).take(arms))
                    .map(|(&(x, y), name)| {
                        let base = aligned(v3(x, y, 0.0), up, v3(-x, -y, 0.0));
                        (base, name.to_string())
                    })
                    .collect()
            }
            Layout::Rows => {
                let first = arms.div_ceil(2).max(2);
                let up = v3(0.0, 0.0, 1.0);
                (0..arms)
                    .map(|i| {
                        let (row, k, count, side) = match i < first {
                            true => (0, i, first, -1.0),
                            false => (1, i - first, arms - first, 1.0),
                        };
                        let x = (k as f64 - (count - 1) as f64 / 2.0) * ROW_SPACING;
                        let base = aligned(v3(x, side * ROW_Y, 0.0), up, v3(0.0, -side, 0.0));
                        (base, format!("row{row}_{k}"))
                    })
                    .collect()
            }
        }
    }
}

/// The models of a fleet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FleetKind {
    /// Every arm a Kinova Gen3.
    Gen3,
    /// The models of the suite's mixed family ([`MIXED_MODELS`]: Gen3s and Franka Pandas)
    /// alternating, the first arm a Gen3.
    Mixed,
}

impl FleetKind {
    pub const ALL: [FleetKind; 2] = [FleetKind::Gen3, FleetKind::Mixed];

    pub fn name(self) -> &'static str {
        match self {
            FleetKind::Gen3 => "gen3",
            FleetKind::Mixed => "mixed",
        }
    }

    pub fn parse(name: &str) -> Result<FleetKind, String> {
        (Self::ALL.into_iter().find(|f| f.name() == name)).ok_or_else(|| {
            let known: Vec<&str> = Self::ALL.iter().map(|f| f.name()).collect();
            format!("unknown fleet {name:?} (known: {})", known.join(", "))
        })
    }

    fn model(self, arm: usize) -> ModelKind {
        match self {
            FleetKind::Gen3 => ModelKind::default(),
            FleetKind::Mixed => {
                ModelKind::from_name(MIXED_MODELS[arm % MIXED_MODELS.len()]).unwrap_or_default()
            }
        }
    }
}

/// The Gen3's gripper of the bimanual family without its fingers: its palm. In ALOHA's
/// hand-over the taking hand, turned 90 degrees about its fingers, closes 2.8 cm from the
/// other hand's TCP, the fingers of the two grippers passing between each other; the
/// family's finger capsule (a 3 cm radius round both fingers) has two Gen3s collide there
/// in every transfer episode.
fn palm() -> crate::format::ToolSpec {
    let mut tool = crate::demo::gripper();
    tool.name = "gripper_palm".to_string();
    // The palm is the first capsule, from the flange out.
    tool.capsules.truncate(1);
    tool
}

/// Where an episode is embodied: the layout, the fleet and how many arms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cell {
    pub layout: Layout,
    pub fleet: FleetKind,
    pub arms: usize,
}

impl Cell {
    /// The arms (each at its model's retract posture) and the table.
    pub fn setup(&self, dt: f64) -> Setup {
        let robots = (self.layout.bases(self.arms).into_iter().enumerate())
            .map(|(i, (base, name))| {
                let model = self.fleet.model(i);
                // The default model (the Gen3, its tool frame the flange) carries the bimanual
                // family's gripper; the Panda's hand is part of its model, its tool frame the
                // hand's TCP.
                let gen3 = model == ModelKind::default();
                RobotSpec {
                    name,
                    model: model.name().to_string(),
                    base: from_frame(&base),
                    initial: Some(retract(model.id()).to_vec()),
                    tcp: gen3.then(|| from_frame(&bimanual::tcp())),
                    tool: gen3.then(palm),
                }
            })
            .collect();
        Setup {
            robots,
            obstacles: vec![bimanual::table()],
            tolerance: ToleranceSpec::default(),
            dt,
        }
    }
}

impl Family {
    /// Episode `i` of the family embodied in `cell`.
    pub fn episode(&self, i: usize, cell: &Cell) -> Episode {
        let recorded = &self.episodes[i];
        let shift = v3(0.0, -ALOHA_CENTRE_Y, 0.0);
        let hands = (recorded.hands.iter().zip(&self.tool))
            .map(|(frames, tool)| {
                (frames.iter())
                    .map(|f| {
                        from_frame(&Frame {
                            rot: f.rot * tool,
                            pos: f.pos + shift,
                        })
                    })
                    .collect()
            })
            .collect();
        Episode {
            name: format!(
                "aloha_{}_{}_{}_{}arms_{}",
                recorded.entry.task,
                cell.layout.name(),
                cell.fleet.name(),
                cell.arms,
                recorded.entry.seed
            ),
            setup: cell.setup(self.index.dt),
            hands,
        }
    }
}
