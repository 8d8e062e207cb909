//! Where the arms stand and what stands around them: a row, two facing rows, a ring around a
//! round table, and torsos with two arms each. Every layout has a table whose top is the work
//! surface; the random extras (walls, posts) vary from problem to problem.

use std::f64::consts::PI;

use omcbsa_core::geometry::{Obstacle, Shape};
use omcbsa_core::model::Frame;
use omcbsa_core::rng::Rng;

use super::frames::{aligned, at, cos, heading, sin, v3, yaw, V3};
use crate::models::ModelKind;

/// How the arms of a problem stand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutKind {
    /// Side by side along a line.
    Row,
    /// Two rows facing each other across the work area.
    FacingRows,
    /// On a ring around the work area, facing its centre.
    Ring,
    /// Two arms per torso, shoulder to shoulder.
    Torso,
}

impl LayoutKind {
    /// The name used in problem names and the suite index.
    pub fn name(self) -> &'static str {
        match self {
            LayoutKind::Row => "row",
            LayoutKind::FacingRows => "facing_rows",
            LayoutKind::Ring => "ring",
            LayoutKind::Torso => "torso",
        }
    }
}

/// The model of arms whose family names none.
fn default_model() -> u8 {
    ModelKind::default().id()
}

/// A named obstacle, as it goes into the problem file.
pub type NamedObstacle = (String, Obstacle);

/// Where one arm works: the horizontal direction it faces and a comfortable hand position.
#[derive(Clone, Copy, Debug)]
pub struct Station {
    pub front: V3,
    pub point: V3,
}

pub struct Layout {
    pub kind: LayoutKind,
    pub bases: Vec<Frame>,
    /// Each arm's model (an index into [`crate::models::Fleet`]): the default model unless
    /// the family mixes models.
    pub models: Vec<u8>,
    pub stations: Vec<Station>,
    pub obstacles: Vec<NamedObstacle>,
    /// Height of the table top.
    pub surface: f64,
    /// Centre of the table top.
    pub centre: V3,
    /// Torso frames (x forward, z up), arms `2k` (left) and `2k + 1` (right) on torso `k`.
    pub torsos: Vec<Frame>,
}

/// Gap between the two rows of [`LayoutKind::FacingRows`] when the hands point down at the
/// table between them.
pub const ROW_GAP: f64 = 1.05;
/// The gap when the hands point at each other: a hand pointing forward needs about 0.55 m
/// from its base, or the elbow cannot fold enough to bring the wrist back.
pub const WIDE_ROW_GAP: f64 = 1.4;
/// Height of the torsos' shoulder mounts and of their table top.
const SHOULDER_Z: f64 = 1.0;
const TORSO_TABLE_Z: f64 = 0.65;

pub fn obstacle_box(name: &str, centre: V3, half_extents: [f64; 3]) -> NamedObstacle {
    (
        name.to_string(),
        Obstacle {
            shape: Shape::Box { half_extents },
            pose: at(centre),
        },
    )
}

/// A vertical cylinder standing on `z0`, `height` tall.
pub fn post(name: &str, x: f64, y: f64, z0: f64, height: f64, radius: f64) -> NamedObstacle {
    let shape = Shape::Cylinder {
        radius,
        half_length: 0.5 * height,
    };
    (
        name.to_string(),
        Obstacle {
            shape,
            pose: at(v3(x, y, z0 + 0.5 * height)),
        },
    )
}

/// An arm on the floor (z = 0) at `pos`, upright, facing the horizontal direction `front`.
fn upright(pos: V3, front: V3, reach: f64, hand_z: f64) -> (Frame, Station) {
    let base = aligned(pos, v3(0.0, 0.0, 1.0), front);
    let point = pos + front * reach + v3(0.0, 0.0, hand_z);
    (base, Station { front, point })
}

/// Arms at `positions` with `fronts`, with a rectangular table `x0..x1` by `y0..y1` whose top
/// is at z = 0.
fn on_floor(kind: LayoutKind, arms: Vec<(Frame, Station)>, table: ([f64; 2], [f64; 2])) -> Layout {
    let ([x0, x1], [y0, y1]) = table;
    let centre = v3(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0);
    let (bases, stations): (Vec<Frame>, _) = arms.into_iter().unzip();
    Layout {
        kind,
        models: vec![default_model(); bases.len()],
        bases,
        stations,
        obstacles: vec![obstacle_box(
            "table",
            centre - v3(0.0, 0.0, 0.02),
            [0.5 * (x1 - x0), 0.5 * (y1 - y0), 0.02],
        )],
        surface: 0.0,
        centre,
        torsos: Vec::new(),
    }
}

/// `n` arms along y at x = 0, facing +x, with a table in front.
pub fn row(n: usize, rng: &mut Rng) -> Layout {
    let spacing = rng.uniform(0.36, 0.48);
    let half = 0.5 * (n as f64 - 1.0) * spacing;
    let arms = (0..n)
        .map(|i| {
            upright(
                v3(0.0, i as f64 * spacing - half, 0.0),
                v3(1.0, 0.0, 0.0),
                0.5,
                0.25,
            )
        })
        .collect();
    let mut layout = on_floor(
        LayoutKind::Row,
        arms,
        ([0.2, 1.0], [-half - 0.4, half + 0.4]),
    );
    if rng.next_f64() < 0.5 {
        layout.obstacles.push(obstacle_box(
            "wall",
            v3(-0.35, 0.0, 0.6),
            [0.02, half + 0.6, 0.6],
        ));
    }
    if rng.next_f64() < 0.5 {
        for i in 0..n - 1 {
            let y = (i as f64 + 0.5) * spacing - half;
            layout
                .obstacles
                .push(post(&format!("post_{i}"), 0.9, y, 0.0, 0.5, 0.03));
        }
    }
    layout
}

/// `ceil(n / 2)` arms at x = 0 facing +x and the others at x = `gap` facing -x, the second
/// row shifted along y, with a table between them.
pub fn facing_rows(n: usize, gap: f64, rng: &mut Rng) -> Layout {
    let spacing = rng.uniform(0.36, 0.48);
    let shift = rng.uniform(0.0, 0.5 * spacing);
    let (na, nb) = (n.div_ceil(2), n / 2);
    let place = |count: usize, i: usize| (i as f64 - 0.5 * (count as f64 - 1.0)) * spacing;
    let mut arms = Vec::with_capacity(n);
    for i in 0..na {
        arms.push(upright(
            v3(0.0, place(na, i), 0.0),
            v3(1.0, 0.0, 0.0),
            0.5,
            0.25,
        ));
    }
    for i in 0..nb {
        arms.push(upright(
            v3(gap, place(nb, i) + shift, 0.0),
            v3(-1.0, 0.0, 0.0),
            0.5,
            0.25,
        ));
    }
    let half = 0.5 * (na as f64 - 1.0) * spacing + shift + 0.4;
    let mut layout = on_floor(
        LayoutKind::FacingRows,
        arms,
        ([0.2, gap - 0.2], [-half, half]),
    );
    for (i, x) in [-0.35, gap + 0.35].into_iter().enumerate() {
        if rng.next_f64() < 0.3 {
            layout.obstacles.push(obstacle_box(
                &format!("wall_{i}"),
                v3(x, 0.0, 0.6),
                [0.02, half + 0.2, 0.6],
            ));
        }
    }
    if rng.next_f64() < 0.5 {
        for (i, y) in [-half + 0.05, half - 0.05].into_iter().enumerate() {
            layout
                .obstacles
                .push(post(&format!("post_{i}"), 0.5 * gap, y, 0.0, 0.6, 0.03));
        }
    }
    layout
}

/// Arms at the given angles on a circle around a round table, facing its centre.
pub fn ring(angles: &[f64], rng: &mut Rng) -> Layout {
    let n = angles.len();
    let radius = if n <= 3 {
        0.6
    } else {
        0.6 + 0.04 * (n - 3) as f64
    };
    let (bases, stations): (Vec<Frame>, _) = (angles.iter())
        .map(|&a| upright(heading(a) * radius, -heading(a), 0.45, 0.2))
        .unzip();
    let table_radius = radius - 0.3;
    let mut obstacles = vec![(
        "table".to_string(),
        Obstacle {
            shape: Shape::Cylinder {
                radius: table_radius,
                half_length: 0.02,
            },
            pose: at(v3(0.0, 0.0, -0.02)),
        },
    )];
    if rng.next_f64() < 0.5 {
        for (k, &a) in angles.iter().enumerate() {
            // Between this arm and the next one round the circle.
            let next = if k + 1 < n {
                angles[k + 1]
            } else {
                angles[0] + 2.0 * PI
            };
            let p = heading(0.5 * (a + next)) * (table_radius - 0.03);
            obstacles.push(post(&format!("post_{k}"), p.x, p.y, 0.0, 0.35, 0.025));
        }
    }
    Layout {
        kind: LayoutKind::Ring,
        models: vec![default_model(); bases.len()],
        bases,
        stations,
        obstacles,
        surface: 0.0,
        centre: v3(0.0, 0.0, 0.0),
        torsos: Vec::new(),
    }
}

/// Evenly spaced ring angles starting at a random one.
pub fn ring_angles(n: usize, rng: &mut Rng) -> Vec<f64> {
    let a0 = rng.uniform(0.0, 2.0 * PI / n as f64);
    (0..n)
        .map(|k| a0 + 2.0 * PI * k as f64 / n as f64)
        .collect()
}

/// `ceil(n / 2)` torsos, each with two arms mounted on its sides with their bases tilted
/// down (the last torso has only its left arm when `n` is odd), round a table.
pub fn torsos(n: usize, rng: &mut Rng) -> Layout {
    let count = n.div_ceil(2);
    let torso_frames: Vec<Frame> = match count {
        1 => vec![at(v3(0.0, 0.0, 0.0))],
        2 => vec![
            at(v3(0.0, 0.0, 0.0)),
            Frame {
                rot: yaw(PI),
                pos: v3(1.5, 0.0, 0.0),
            },
        ],
        _ => (0..count)
            .map(|k| {
                let a = 2.0 * PI * k as f64 / count as f64;
                Frame {
                    rot: yaw(a + PI),
                    pos: heading(a) * 0.95,
                }
            })
            .collect(),
    };
    let tilt = rng.uniform(0.3, 0.6);
    let mut bases = Vec::with_capacity(n);
    let mut stations = Vec::with_capacity(n);
    let mut obstacles = Vec::new();
    for (k, t) in torso_frames.iter().enumerate() {
        let front = t.rot * v3(1.0, 0.0, 0.0);
        for side in [1.0, -1.0] {
            if bases.len() == n {
                break;
            }
            let mount = t.apply(&v3(0.0, 0.16 * side, SHOULDER_Z));
            let out = t.rot * v3(0.0, side * cos(tilt), -sin(tilt));
            bases.push(aligned(mount, out, front));
            stations.push(Station {
                front,
                point: t.apply(&v3(0.45, 0.18 * side, 0.95)),
            });
        }
        let body = (
            format!("torso_{k}"),
            Obstacle {
                shape: Shape::Box {
                    half_extents: [0.09, 0.14, 0.55],
                },
                pose: Frame {
                    rot: t.rot,
                    pos: t.apply(&v3(0.0, 0.0, 0.55)),
                },
            },
        );
        let head = (
            format!("head_{k}"),
            Obstacle {
                shape: Shape::Sphere { radius: 0.1 },
                pose: at(t.apply(&v3(0.0, 0.0, 1.25))),
            },
        );
        obstacles.extend([body, head]);
    }
    let table = match count {
        1 => obstacle_box(
            "table",
            v3(0.6, 0.0, TORSO_TABLE_Z - 0.02),
            [0.3, 0.6, 0.02],
        ),
        2 => obstacle_box(
            "table",
            v3(0.75, 0.0, TORSO_TABLE_Z - 0.02),
            [0.45, 0.6, 0.02],
        ),
        _ => (
            "table".to_string(),
            Obstacle {
                shape: Shape::Cylinder {
                    radius: 0.5,
                    half_length: 0.02,
                },
                pose: at(v3(0.0, 0.0, TORSO_TABLE_Z - 0.02)),
            },
        ),
    };
    let centre = v3(table.1.pose.pos.x, table.1.pose.pos.y, TORSO_TABLE_Z);
    obstacles.push(table);
    Layout {
        kind: LayoutKind::Torso,
        models: vec![default_model(); bases.len()],
        bases,
        stations,
        obstacles,
        surface: TORSO_TABLE_Z,
        centre,
        torsos: torso_frames,
    }
}
