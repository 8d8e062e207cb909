//! A VAMP-MR environment's scene, read from the checkout: which arms and planning groups
//! (`make_environment_config`), where the arms stand (`default_base_transforms`, or for the
//! two-arm layout the data file VAMP-MR keeps of it), the boxes of its tables and bins
//! (`add_environment_obstacles` and the functions it calls) and the rods the arms hold
//! (`add_environment_attachments`), all in `vamp_env_factory.cpp`. VAMP-MR builds these in
//! code, so the importer reads that code's literal tables ([`crate::import::cpp`]) and knows
//! what each builder function makes; a builder it does not know is refused by name.

use std::path::{Path, PathBuf};

use omcbsa_core::model::Frame;
use omcbsa_core::nalgebra::{Rotation3, Vector3};
use serde::Deserialize;

use crate::format::Pose;
use crate::import::cpp::{self, Tree, Value};
use crate::import::error::ImportError;
use crate::pose;

/// A box of the scene: centre and full sizes along world x, y, z (VAMP-MR's `length`,
/// `width`, `height`).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneBox {
    /// Named in messages.
    pub name: String,
    /// Centre, m.
    pub center: [f64; 3],
    /// Full sizes, m.
    pub size: [f64; 3],
}

/// A cylinder an arm holds: its axis is the z axis of the frame `translation`, `rpy` (roll,
/// pitch, yaw) in VAMP's end-effector frame; `length` is its full length.
#[derive(Clone, Debug, PartialEq)]
pub struct Rod {
    /// Its name in VAMP-MR.
    pub name: String,
    /// m.
    pub radius: f64,
    /// Full length, m.
    pub length: f64,
    /// Its centre in the end-effector frame, m.
    pub translation: [f64; 3],
    /// Its rotation in the end-effector frame: roll, pitch, yaw (rad).
    pub rpy: [f64; 3],
}

/// How an environment is configured: its planning groups and which arms (VAMP-MR's
/// `VampVariant`, e.g. `PandaQuad`, `DualGp4`).
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// The SRDF group of all arms.
    pub move_group: String,
    /// The SRDF group of each arm, in arm order.
    pub robot_groups: Vec<String>,
    /// The `VampVariant` (without `VampVariant::`).
    pub variant: String,
}

impl Config {
    /// Whether the arms are Franka Pandas (VAMP's `vamp::robots::Panda`).
    pub fn is_panda(&self) -> bool {
        self.variant.starts_with("Panda")
    }
}

/// What stands around the arms and what they hold.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// World poses of the arms' bases, in `robot_groups` order.
    pub bases: Vec<Frame>,
    /// Boxes of tables and bins.
    pub boxes: Vec<SceneBox>,
    /// Per arm, the rod it holds, if any.
    pub rods: Vec<Option<Rod>>,
}

/// The parsed factory source and where it came from.
pub struct Factory {
    /// The source file.
    pub path: PathBuf,
    /// Its token trees.
    pub trees: Vec<Tree>,
}

impl Factory {
    /// Reads and tokenises the source at `path`.
    pub fn read(path: &Path) -> Result<Factory, ImportError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ImportError::new(path, "", format!("cannot read: {e}")))?;
        let trees = cpp::parse(&text).map_err(|e| ImportError::new(path, "", e))?;
        Ok(Factory {
            path: path.to_path_buf(),
            trees,
        })
    }

    fn error(&self, at: impl Into<String>, message: impl Into<String>) -> ImportError {
        ImportError::new(&self.path, at, message)
    }

    fn function(&self, name: &str) -> Result<cpp::Definition<'_>, ImportError> {
        cpp::function(&self.trees, name)
            .ok_or_else(|| self.error(format!("function {name}"), "not found"))
    }

    /// `environment`'s configuration, from `make_environment_config`'s
    /// `EnvironmentConfig{name, move_group, {robot groups}, {hand groups}, VampVariant::V, ..}`.
    pub fn config(&self, environment: &str) -> Result<Config, ImportError> {
        let at = format!("function make_environment_config, environment {environment:?}");
        let body = self.function("make_environment_config")?.body;
        let block = cpp::branch(body, environment)
            .ok_or_else(|| self.error(&at, "no branch for this environment"))?;
        let fields = (block.windows(2))
            .find_map(|w| match w {
                [Tree::Ident(t), Tree::Group('{', f)] if t == "EnvironmentConfig" => Some(f),
                _ => None,
            })
            .ok_or_else(|| self.error(&at, "no EnvironmentConfig{...} returned"))?;
        let fields: Vec<&[Tree]> = fields.split(|t| *t == Tree::Punct(',')).collect();
        let string = |t: &Tree| match t {
            Tree::Str(s) => Some(s.clone()),
            _ => None,
        };
        let move_group = match fields.get(1) {
            Some([t]) => string(t),
            _ => None,
        };
        let robot_groups: Option<Vec<String>> = match fields.get(2) {
            Some([Tree::Group('{', groups)]) => (groups.iter())
                .filter(|t| **t != Tree::Punct(','))
                .map(string)
                .collect(),
            _ => None,
        };
        let variant = (fields.iter()).find_map(|f| match f {
            [Tree::Ident(v), Tree::Punct(':'), Tree::Punct(':'), Tree::Ident(name)]
                if v == "VampVariant" =>
            {
                Some(name.clone())
            }
            _ => None,
        });
        match (move_group, robot_groups, variant) {
            (Some(move_group), Some(robot_groups), Some(variant)) if !robot_groups.is_empty() => {
                Ok(Config {
                    move_group,
                    robot_groups,
                    variant,
                })
            }
            _ => Err(self.error(
                at,
                "expected EnvironmentConfig{name, \"move group\", {\"robot groups\"}, {...}, \
                 VampVariant::..., ...}",
            )),
        }
    }

    /// The scene of `environment` with `config`'s arms; `pair_bases` is the two-arm layout's
    /// data file.
    pub fn scene(
        &self,
        environment: &str,
        config: &Config,
        pair_bases: &Path,
    ) -> Result<Scene, ImportError> {
        let n = config.robot_groups.len();
        let bases = match config.variant.as_str() {
            "PandaPair" => read_transforms(pair_bases, n)?,
            "PandaQuad" => self.yawed_bases(environment, "PandaQuad", n)?,
            other => {
                return Err(self.error(
                    format!("function default_base_transforms, case VampVariant::{other}"),
                    "the importer reads the base poses of PandaPair (from its data file) and \
                     PandaQuad only",
                ))
            }
        };
        Ok(Scene {
            bases,
            boxes: self.boxes(environment)?,
            rods: self.rods(environment, n)?,
        })
    }

    /// `yaws` and `translations` of `environment`'s branch in `case VampVariant::variant`.
    fn yawed_bases(&self, env: &str, variant: &str, n: usize) -> Result<Vec<Frame>, ImportError> {
        let at = format!(
            "function default_base_transforms, case VampVariant::{variant}, environment {env:?}"
        );
        let body = self.function("default_base_transforms")?.body;
        let block = cpp::case(body, variant)
            .and_then(|c| cpp::branch(c, env))
            .ok_or_else(|| self.error(&at, "not found"))?;
        if !cpp::identifiers(block).contains(&"UnitZ") {
            return Err(self.error(&at, "the yaws are not about the z axis"));
        }
        let read = |name: &str| cpp::variable(block, name).map_err(|e| self.error(&at, e));
        let yaws = read("yaws")?
            .numbers(n)
            .map_err(|e| self.error(&at, format!("yaws: {e}")))?;
        let translations = (read("translations")?.rows(3))
            .map_err(|e| self.error(&at, format!("translations: {e}")))?;
        if translations.len() != n {
            let message = format!("{} translations for {n} arms", translations.len());
            return Err(self.error(&at, message));
        }
        Ok((yaws.iter().zip(&translations))
            .map(|(&yaw, t)| frame(&[t[0], t[1], t[2]], &[0.0, 0.0, yaw]))
            .collect())
    }

    /// The boxes `add_environment_obstacles` adds for `env` (none if it has no branch).
    fn boxes(&self, env: &str) -> Result<Vec<SceneBox>, ImportError> {
        let at = format!("function add_environment_obstacles, environment {env:?}");
        let body = self.function("add_environment_obstacles")?.body;
        let Some(block) = cpp::branch(body, env) else {
            return Ok(Vec::new());
        };
        let mut boxes = Vec::new();
        let known = [
            "add_panda_table_segments",
            "add_panda_four_table_segments",
            "add_hollow_box_obstacles",
        ];
        for id in cpp::identifiers(block) {
            let builds = id.starts_with("add") || id.contains("Object") || id.starts_with("make_");
            if builds && !known.contains(&id) {
                return Err(self.error(
                    &at,
                    format!("{id}: a scene builder the importer does not read"),
                ));
            }
        }
        if !cpp::calls(block, "add_panda_table_segments").is_empty() {
            let f = "add_panda_table_segments";
            let rows = self.table(f, "segments", 6)?;
            boxes.extend(rows.iter().enumerate().map(|(i, r)| SceneBox {
                name: format!("table_segment_{i}"),
                center: [r[0], r[1], r[2]],
                size: [r[3], r[4], r[5]],
            }));
        }
        if !cpp::calls(block, "add_panda_four_table_segments").is_empty() {
            let f = "add_panda_four_table_segments";
            let z = self.number(f, "z")?;
            let thickness = self.number(f, "thickness")?;
            let rows = self.table(f, "segments", 4)?;
            boxes.extend(rows.iter().enumerate().map(|(i, r)| SceneBox {
                name: format!("table_segment_{i}"),
                center: [r[0], r[1], z],
                size: [r[2], r[3], thickness],
            }));
        }
        let bins = cpp::calls(block, "add_hollow_box_obstacles");
        if !bins.is_empty() {
            if bins.iter().any(|args| args.len() != 4) {
                return Err(self.error(&at, "add_hollow_box_obstacles with other than 4 arguments (instance, name, centre, size)"));
            }
            let params = self.function("add_hollow_box_obstacles")?.params;
            let thickness =
                (cpp::variable(params, "thickness").and_then(|v| v.num())).map_err(|e| {
                    self.error("function add_hollow_box_obstacles, parameter thickness", e)
                })?;
            let read = |name: &str, k: usize| {
                cpp::variable(block, name)
                    .and_then(|v| v.rows(k).or_else(|_| v.numbers(k).map(|r| vec![r])))
                    .map_err(|e| self.error(&at, format!("{name}: {e}")))
            };
            let centers = read("centers", 3)?;
            let size = read("size", 3)?;
            let [size] = &size[..] else {
                return Err(self.error(&at, "size: expected one size for every bin"));
            };
            for (i, c) in centers.iter().enumerate() {
                boxes.extend(hollow_box(&format!("bin_{i}"), c, size, thickness));
            }
        }
        Ok(boxes)
    }

    /// Numbers `name` of function `f`, in rows of `k`.
    fn table(&self, f: &str, name: &str, k: usize) -> Result<Vec<Vec<f64>>, ImportError> {
        let body = self.function(f)?.body;
        (cpp::variable(body, name).and_then(|v| v.rows(k)))
            .map_err(|e| self.error(format!("function {f}"), e))
    }

    fn number(&self, f: &str, name: &str) -> Result<f64, ImportError> {
        let body = self.function(f)?.body;
        (cpp::variable(body, name).and_then(|v| v.num()))
            .map_err(|e| self.error(format!("function {f}"), format!("{name}: {e}")))
    }

    /// The rods `add_environment_attachments` gives the arms in `env`:
    /// `add_cylinder_attachment(instance, robot, name, radius, length, translation, rotation)`
    /// with a literal robot index, or a loop variable for every arm.
    fn rods(&self, env: &str, n: usize) -> Result<Vec<Option<Rod>>, ImportError> {
        let at = format!("function add_environment_attachments, environment {env:?}");
        let body = self.function("add_environment_attachments")?.body;
        let mut rods = vec![None; n];
        let Some(block) = cpp::branch(body, env) else {
            return Ok(rods);
        };
        let calls = cpp::calls(block, "add_cylinder_attachment");
        if calls.is_empty()
            && cpp::identifiers(block)
                .iter()
                .any(|id| id.contains("attach"))
        {
            return Err(self.error(&at, "an attachment other than add_cylinder_attachment"));
        }
        for args in calls {
            let err = |e: String| self.error(&at, format!("add_cylinder_attachment: {e}"));
            let [_, robot, name, radius, length, translation, rotation] = &args[..] else {
                return Err(err(format!("{} arguments, expected 7", args.len())));
            };
            let rpy = match rotation {
                [Tree::Ident(var)] => cpp::variable(block, var),
                expr => cpp::eval(expr),
            }
            .map_err(&err)?;
            let Value::Call(f, rpy) = rpy else {
                return Err(err(
                    "rotation: expected quaternion_from_rpy(roll, pitch, yaw)".into(),
                ));
            };
            if f != "quaternion_from_rpy" || rpy.len() != 3 {
                return Err(err(format!("rotation: {f} with {} arguments: expected quaternion_from_rpy(roll, pitch, yaw)", rpy.len())));
            }
            let num = |t: &[Tree]| cpp::eval(t).and_then(|v| v.num());
            let rod = Rod {
                name: match name {
                    [Tree::Str(s)] => s.clone(),
                    _ => "rod".to_string(),
                },
                radius: num(radius).map_err(|e| err(format!("radius: {e}")))?,
                length: num(length).map_err(|e| err(format!("length: {e}")))?,
                translation: (cpp::eval(translation).and_then(|v| v.numbers(3)))
                    .map_err(|e| err(format!("translation: {e}")))?
                    .try_into()
                    .map_err(|_| err("translation".into()))?,
                rpy: [
                    rpy[0].num().map_err(&err)?,
                    rpy[1].num().map_err(&err)?,
                    rpy[2].num().map_err(&err)?,
                ],
            };
            match robot {
                [Tree::Num(i)] => {
                    let slot =
                        (rods.get_mut(*i as usize)).filter(|_| i.fract() == 0.0 && *i >= 0.0);
                    *slot.ok_or_else(|| err(format!("robot {i}: there are {n} arms")))? = Some(rod);
                }
                // A loop over the arms.
                [Tree::Ident(_)] => rods.iter_mut().for_each(|r| *r = Some(rod.clone())),
                _ => return Err(err("robot: expected an index or a loop variable".into())),
            }
        }
        Ok(rods)
    }
}

/// A bin as `add_hollow_box_obstacles` builds it: a floor of `thickness` centred at `c`, and
/// four walls of `size[2]` height standing on it, centred on the floor's edges.
fn hollow_box(name: &str, c: &[f64], size: &[f64], thickness: f64) -> Vec<SceneBox> {
    let (l, w, h) = (size[0], size[1], size[2]);
    let wall_z = c[2] + thickness / 2.0 + h / 2.0;
    let b = |part: &str, center: [f64; 3], size: [f64; 3]| SceneBox {
        name: format!("{name}_{part}"),
        center,
        size,
    };
    vec![
        b("bottom", [c[0], c[1], c[2]], [l, w, thickness]),
        b("front", [c[0], c[1] + w / 2.0, wall_z], [l, thickness, h]),
        b("back", [c[0], c[1] - w / 2.0, wall_z], [l, thickness, h]),
        b("left", [c[0] - l / 2.0, c[1], wall_z], [thickness, w, h]),
        b("right", [c[0] + l / 2.0, c[1], wall_z], [thickness, w, h]),
    ]
}

/// The frame at `t` rotated by roll, pitch, yaw (`Rz(yaw) Ry(pitch) Rx(roll)`, as VAMP-MR's
/// `quaternion_from_rpy`).
pub fn frame(t: &[f64; 3], rpy: &[f64; 3]) -> Frame {
    Frame {
        rot: Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]).into_inner(),
        pos: Vector3::from(*t),
    }
}

/// One transform of VAMP-MR's base-transform files (`parse_transform` in
/// `vamp_env_factory.cpp`): `translation` or `xyz`, and `rpy` or `quaternion` (x, y, z, w).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Transform {
    translation: Option<[f64; 3]>,
    xyz: Option<[f64; 3]>,
    rpy: Option<[f64; 3]>,
    quaternion: Option<[f64; 4]>,
}

/// A base-transform file of `n` arms.
pub fn read_transforms(path: &Path, n: usize) -> Result<Vec<Frame>, ImportError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| ImportError::new(path, "", format!("cannot read: {e}")))?;
    parse_transforms(path, &text, n)
}

/// [`read_transforms`] of `text` (`path` names it in errors).
pub fn parse_transforms(path: &Path, text: &str, n: usize) -> Result<Vec<Frame>, ImportError> {
    let de = &mut serde_json::Deserializer::from_str(text);
    let list: Vec<Transform> = serde_path_to_error::deserialize(de).map_err(|e| {
        let at = e.path().to_string();
        ImportError::new(
            path,
            if at == "." { String::new() } else { at },
            e.into_inner().to_string(),
        )
    })?;
    if list.len() != n {
        return Err(ImportError::new(
            path,
            "",
            format!("{} transforms for {n} arms", list.len()),
        ));
    }
    (list.iter().enumerate())
        .map(|(i, t)| {
            let bad = |m: &str| ImportError::new(path, format!("[{i}]"), m);
            let xyz = match (t.translation, t.xyz) {
                (Some(p), None) | (None, Some(p)) => p,
                (None, None) => [0.0; 3],
                (Some(_), Some(_)) => return Err(bad("both translation and xyz")),
            };
            match (t.rpy, t.quaternion) {
                (Some(rpy), None) => Ok(frame(&xyz, &rpy)),
                (None, Some(quat_xyzw)) => {
                    let pose = Pose {
                        position: xyz,
                        quat_xyzw,
                    };
                    pose::to_frame(&pose).map_err(|e| bad(&e.to_string()))
                }
                (None, None) => Ok(frame(&xyz, &[0.0; 3])),
                (Some(_), Some(_)) => Err(bad("both rpy and quaternion")),
            }
        })
        .collect()
}
