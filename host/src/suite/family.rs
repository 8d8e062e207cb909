//! The motion families: hand trajectories shaped like what a manipulation policy emits. Each
//! task family designs one hand per arm that takes part (the arm it was designed for is only
//! the witness search's first guess; the problem file does not say it).

use std::f64::consts::PI;

use omcbsa_core::model::Frame;
use omcbsa_core::nalgebra::Matrix3;
use omcbsa_core::rng::Rng;

use super::frames::{aligned, atan2, ease, heading, rot, sin, v3, yaw, V3};
use super::layout::{self, obstacle_box, post, Layout, LayoutKind};
use super::witness::Hand;
use crate::models::ModelKind;

/// The benchmark suite's motion families.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Every hand moves right to left under a shelf.
    Sweep,
    /// Hands on the faces of a box while it rotates.
    BoxFlip,
    /// Hands on a circle that turns, holding a cloth.
    ClothRotation,
    /// Hands on the table top, pushing.
    Pushing,
    /// Two hands per torso carrying an object.
    Bimanual,
    /// Smooth random joint motions mapped to the hands.
    Random,
    /// The random family's motions, with every arm standing where a straight bridge to its
    /// hand collides (see `standing`): the approach is the hard part.
    Approach,
    /// The random family's motions on a mixed fleet: the arms alternate between the models of
    /// `MIXED_MODELS` (2 + 2 and 3 + 3).
    Mixed,
}

/// The models the mixed family alternates, by the names problem files use.
pub const MIXED_MODELS: [&str; 2] = ["kinova_gen3", "franka_panda"];
/// How much higher than the layout's the hands of each of [`MIXED_MODELS`] work, metres.
const MIXED_LIFT: [f64; 2] = [0.0, 0.3];

impl Family {
    /// Every family, in the suite's order.
    pub const ALL: [Family; 8] = [
        Family::Sweep,
        Family::BoxFlip,
        Family::ClothRotation,
        Family::Pushing,
        Family::Bimanual,
        Family::Random,
        Family::Approach,
        Family::Mixed,
    ];

    /// The family called `name`, or an error listing them.
    pub fn parse(name: &str) -> Result<Family, String> {
        (Self::ALL.into_iter().find(|f| f.name() == name)).ok_or_else(|| {
            let known: Vec<&str> = Self::ALL.iter().map(|f| f.name()).collect();
            format!("unknown family {name:?} (known: {})", known.join(", "))
        })
    }

    /// The family's name (`sweep`, `box_flip`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Family::Sweep => "sweep",
            Family::BoxFlip => "box_flip",
            Family::ClothRotation => "cloth_rotation",
            Family::Pushing => "pushing",
            Family::Bimanual => "bimanual",
            Family::Random => "random",
            Family::Approach => "approach",
            Family::Mixed => "mixed",
        }
    }

    /// Whether the family's hands are those of random joint motions (the others' are
    /// designed for a task, and their witnesses track them).
    pub fn random_motions(self) -> bool {
        matches!(self, Family::Random | Family::Approach | Family::Mixed)
    }

    /// The (layout, number of arms) combinations this family is generated on.
    pub fn cells(self) -> Vec<(LayoutKind, usize)> {
        use LayoutKind::*;
        let on = |kinds: &[LayoutKind], arms: &[usize]| -> Vec<(LayoutKind, usize)> {
            arms.iter()
                .flat_map(|&n| kinds.iter().map(move |&k| (k, n)))
                .collect()
        };
        match self {
            Family::Sweep => on(&[Row, FacingRows], &[2, 3, 4, 5, 6]),
            Family::BoxFlip => {
                let mut cells = on(&[FacingRows], &[2, 3, 4, 5, 6]);
                cells.extend(on(&[Ring], &[2, 3, 4]));
                cells.push((Torso, 2));
                cells
            }
            Family::ClothRotation => on(&[Ring, FacingRows], &[2, 3, 4, 5, 6]),
            Family::Pushing => on(&[Row, FacingRows, Ring], &[2, 3, 4, 5, 6]),
            Family::Bimanual => on(&[Torso], &[2, 3, 4, 5, 6]),
            Family::Random | Family::Approach => {
                on(&[Row, FacingRows, Ring, Torso], &[2, 3, 4, 5, 6])
            }
            Family::Mixed => {
                // Six arms of two models in one row leave no room to move.
                let mut cells = on(&[Row, FacingRows, Ring], &[4]);
                cells.extend(on(&[FacingRows, Ring], &[6]));
                cells
            }
        }
    }

    /// The layout of `n` arms of `kind` this family works in (a box flip on a ring puts the
    /// arms at the box's faces).
    pub fn layout(self, kind: LayoutKind, n: usize, rng: &mut Rng) -> Layout {
        let mut layout = self.places(kind, n, rng);
        if self == Family::Mixed {
            let ids = MIXED_MODELS.map(|m| ModelKind::parse(m).map_or(0, |k| k.id()));
            layout.models = (0..n).map(|i| ids[i % ids.len()]).collect();
            // The Panda's shoulder is higher than the Gen3's and its forearm hangs low when the
            // hand works near the table: its hands work higher.
            for (station, lift) in layout.stations.iter_mut().zip(MIXED_LIFT.iter().cycle()) {
                station.point.z += lift;
            }
        }
        layout
    }

    /// Where the arms of [`Family::layout`] stand.
    fn places(self, kind: LayoutKind, n: usize, rng: &mut Rng) -> Layout {
        match kind {
            LayoutKind::Row => layout::row(n, rng),
            LayoutKind::FacingRows if matches!(self, Family::Sweep | Family::BoxFlip) => {
                layout::facing_rows(n, layout::WIDE_ROW_GAP, rng)
            }
            LayoutKind::FacingRows => layout::facing_rows(n, layout::ROW_GAP, rng),
            LayoutKind::Ring if self == Family::BoxFlip => {
                let a0 = rng.uniform(0.0, 2.0 * PI);
                let faces: Vec<f64> = [0.0, PI, 0.5 * PI, 1.5 * PI][..n].to_vec();
                let mut angles: Vec<f64> = faces.iter().map(|f| a0 + f).collect();
                // Keep the ring order (angles increasing) for the posts between arms.
                angles.sort_by(f64::total_cmp);
                layout::ring(&angles, rng)
            }
            LayoutKind::Ring => layout::ring(&layout::ring_angles(n, rng), rng),
            LayoutKind::Torso => layout::torsos(n, rng),
        }
    }

    /// The hands of a task family over `h` steps; adds the obstacles the task brings (a
    /// shelf) to `layout`. `None` for [`Family::Random`], which is made in joint space.
    pub fn hands(self, layout: &mut Layout, h: usize, rng: &mut Rng) -> Option<Vec<Hand>> {
        let steps = |f: &mut dyn FnMut(f64) -> Frame| -> Vec<Frame> {
            (0..h)
                .map(|t| f(t as f64 / (h - 1).max(1) as f64))
                .collect()
        };
        let hands = match self {
            Family::Sweep => sweep(layout, rng, &steps),
            Family::BoxFlip => box_flip(layout, rng, &steps),
            Family::ClothRotation => cloth(layout, rng, &steps),
            Family::Pushing => pushing(layout, rng, &steps),
            Family::Bimanual => bimanual(layout, rng, &steps),
            Family::Random | Family::Approach | Family::Mixed => return None,
        };
        Some(hands)
    }
}

type Steps<'a> = &'a dyn Fn(&mut dyn FnMut(f64) -> Frame) -> Vec<Frame>;

/// Hands pointing away from their arm at a low height, all moving +y (right to left seen from
/// the first row) under a shelf plate on four posts.
fn sweep(layout: &mut Layout, rng: &mut Rng, steps: Steps) -> Vec<Hand> {
    let surface = layout.surface;
    let hand_z = surface + rng.uniform(0.15, 0.22);
    let shelf_z = hand_z + rng.uniform(0.28, 0.35);
    // Far enough out for the wrist to fold back (see `layout::WIDE_ROW_GAP`).
    let reach = rng.uniform(0.6, 0.65);
    let starts: Vec<V3> = (layout.bases.iter().zip(&layout.stations))
        .map(|(b, s)| b.pos + s.front * reach)
        .collect();
    let (xs, ys): (Vec<f64>, Vec<f64>) = starts.iter().map(|p| (p.x, p.y)).unzip();
    let fold = |v: &[f64], f: fn(f64, f64) -> f64, init: f64| v.iter().copied().fold(init, f);
    let (x0, x1) = (
        fold(&xs, f64::min, f64::INFINITY) - 0.15,
        fold(&xs, f64::max, f64::NEG_INFINITY) + 0.15,
    );
    let (y0, y1) = (
        fold(&ys, f64::min, f64::INFINITY) - 0.5,
        fold(&ys, f64::max, f64::NEG_INFINITY) + 0.5,
    );
    layout.obstacles.push(obstacle_box(
        "shelf",
        v3(0.5 * (x0 + x1), 0.5 * (y0 + y1), shelf_z + 0.01),
        [0.5 * (x1 - x0), 0.5 * (y1 - y0), 0.01],
    ));
    for (k, (x, y)) in [(x0, y0), (x0, y1), (x1, y0), (x1, y1)]
        .into_iter()
        .enumerate()
    {
        layout.obstacles.push(post(
            &format!("shelf_post_{k}"),
            x,
            y,
            surface,
            shelf_z - surface,
            0.02,
        ));
    }
    let length = rng.uniform(0.3, 0.5);
    (layout.stations.iter().zip(&starts).enumerate())
        .map(|(arm, (station, start))| {
            let start = v3(start.x, start.y - 0.5 * length, hand_z);
            let wobble = rng.uniform(-0.03, 0.03);
            let pitch = rng.uniform(-0.3, 0.3);
            let poses = steps(&mut |s| {
                let p = start
                    + v3(
                        wobble * sin(PI * s),
                        length * ease(s),
                        0.02 * sin(2.0 * PI * s),
                    );
                let side = station.front.cross(&v3(0.0, 0.0, 1.0));
                aligned(p, rot(side, pitch) * station.front, v3(0.0, 0.0, -1.0))
            });
            Hand { arm, poses }
        })
        .collect()
}

/// Hands on the faces of a box turning about a horizontal axis by up to about 55 degrees.
fn box_flip(layout: &mut Layout, rng: &mut Rng, steps: Steps) -> Vec<Hand> {
    let n = layout.bases.len();
    let size = rng.uniform(0.08, 0.11);
    // Box frame at the start, flip axis (box frame), and for each arm the face normal and an
    // offset within the face (box frame).
    let (frame0, axis, half, faces): (Frame, V3, V3, Vec<(V3, V3)>) = match layout.kind {
        LayoutKind::Torso => {
            let t = layout.torsos[0];
            let frame0 = Frame {
                rot: t.rot,
                pos: t.apply(&v3(0.45, 0.0, 0.95)),
            };
            let faces = vec![
                (v3(0.0, 1.0, 0.0), V3::zeros()),
                (v3(0.0, -1.0, 0.0), V3::zeros()),
            ];
            (
                frame0,
                v3(1.0, 0.0, 0.0),
                v3(size, rng.uniform(0.12, 0.16), size),
                faces,
            )
        }
        LayoutKind::Ring => {
            // Arm k faces the centre from heading(a_k): it takes the face whose normal points
            // back at it. The box's x axis points at arm 0.
            let a0 = atan2(layout.bases[0].pos.y, layout.bases[0].pos.x);
            let frame0 = Frame {
                rot: yaw(a0),
                pos: layout.centre + v3(0.0, 0.0, 0.3),
            };
            let faces = (layout.bases.iter())
                .map(|b| {
                    (
                        frame0.rot.transpose() * v3(b.pos.x, b.pos.y, 0.0).normalize(),
                        V3::zeros(),
                    )
                })
                .map(|(n, o)| (n.map(|c| c.round()), o))
                .collect();
            (frame0, v3(0.0, 1.0, 0.0), V3::repeat(size), faces)
        }
        _ => {
            // Facing rows: a board between the rows, each arm on the face toward it at its
            // own y.
            let pos = v3(
                0.5 * (layout.bases[0].pos.x + layout.bases[n - 1].pos.x),
                0.0,
                0.0,
            );
            let ys: Vec<f64> = layout.stations.iter().map(|s| s.point.y).collect();
            let (lo, hi) = ys
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &y| {
                    (a.min(y), b.max(y))
                });
            let centre = v3(pos.x, 0.5 * (lo + hi), layout.surface + 0.35);
            let half = v3(size, 0.5 * (hi - lo) + 0.08, size);
            let faces = (layout.bases.iter().zip(&layout.stations))
                .map(|(b, s)| {
                    (
                        v3(-(pos.x - b.pos.x).signum(), 0.0, 0.0),
                        v3(0.0, s.point.y - centre.y, 0.0),
                    )
                })
                .collect();
            (
                Frame {
                    rot: Matrix3::identity(),
                    pos: centre,
                },
                v3(0.0, 1.0, 0.0),
                half,
                faces,
            )
        }
    };
    let angle = rng.uniform(0.6, 0.95) * if rng.next_f64() < 0.5 { 1.0 } else { -1.0 };
    let lift = rng.uniform(0.0, 0.08);
    (faces.iter().enumerate())
        .map(|(arm, &(normal, offset))| {
            let poses = steps(&mut |s| {
                let r = frame0.rot * rot(axis, angle * ease(s));
                let p = frame0.pos
                    + v3(0.0, 0.0, lift * ease(s))
                    + r * (half.component_mul(&normal) + offset);
                let up = if normal.z.abs() > 0.5 {
                    v3(1.0, 0.0, 0.0)
                } else {
                    v3(0.0, 0.0, 1.0)
                };
                aligned(p, -(r * normal), r * up)
            });
            Hand { arm, poses }
        })
        .collect()
}

/// Hands pointing down on a circle over the table centre, each on the side of its arm, while
/// the circle turns (and lifts a little in the middle of the motion).
fn cloth(layout: &mut Layout, rng: &mut Rng, steps: Steps) -> Vec<Hand> {
    let n = layout.bases.len();
    let centre = layout.centre + v3(0.0, 0.0, rng.uniform(0.1, 0.2));
    let radius = rng.uniform(0.18, 0.24) + 0.015 * n as f64;
    let turn = rng.uniform(0.4, 0.9) * if rng.next_f64() < 0.5 { 1.0 } else { -1.0 };
    let lift = rng.uniform(0.0, 0.08);
    (layout.bases.iter().enumerate())
        .map(|(arm, base)| {
            let a0 = atan2(base.pos.y - centre.y, base.pos.x - centre.x);
            let poses = steps(&mut |s| {
                let radial = heading(a0 + turn * ease(s));
                let p = centre + radial * radius + v3(0.0, 0.0, lift * sin(PI * s));
                aligned(p, v3(0.0, 0.0, -1.0), radial)
            });
            Hand { arm, poses }
        })
        .collect()
}

/// Hands pointing down just above the table, pushing: all in one direction, or all toward the
/// table centre.
fn pushing(layout: &mut Layout, rng: &mut Rng, steps: Steps) -> Vec<Hand> {
    let z = layout.surface + 0.03;
    let common = if rng.next_f64() < 0.5 {
        Some(heading(rng.uniform(0.0, 2.0 * PI)))
    } else {
        None
    };
    let length = rng.uniform(0.15, 0.3);
    (layout.bases.iter().zip(&layout.stations).enumerate())
        .map(|(arm, (base, station))| {
            let side = station.front.cross(&v3(0.0, 0.0, 1.0));
            let start =
                base.pos + station.front * rng.uniform(0.4, 0.5) + side * rng.uniform(-0.05, 0.05);
            let start = v3(start.x, start.y, z);
            let dir = common.unwrap_or_else(|| {
                let to_centre = layout.centre - start;
                v3(to_centre.x, to_centre.y, 0.0).normalize()
            });
            // Keep the end within comfortable reach of the base.
            let mut end = start + dir * length;
            let flat = |p: V3| v3(p.x - base.pos.x, p.y - base.pos.y, 0.0).norm();
            while flat(end) > 0.68 || flat(end) < 0.3 {
                end = start + (end - start) * 0.8;
            }
            let bend = side * rng.uniform(-0.05, 0.05);
            let turn = rng.uniform(-0.3, 0.3);
            let poses = steps(&mut |s| {
                let e = ease(s);
                let p = start + (end - start) * e + bend * sin(PI * e);
                aligned(p, v3(0.0, 0.0, -1.0), yaw(turn * e) * dir)
            });
            Hand { arm, poses }
        })
        .collect()
}

/// Each torso's two hands hold an object between them and carry it: lifted, moved, turned.
/// The odd arm of an odd count has no hand (it holds).
fn bimanual(layout: &mut Layout, rng: &mut Rng, steps: Steps) -> Vec<Hand> {
    let mut hands = Vec::new();
    for (k, torso) in layout.torsos.iter().enumerate() {
        if 2 * k + 1 >= layout.bases.len() {
            break;
        }
        let width = rng.uniform(0.26, 0.36);
        let start = torso.apply(&v3(0.45, 0.0, rng.uniform(0.85, 0.95)));
        let shift = torso.rot
            * v3(
                rng.uniform(-0.08, 0.08),
                rng.uniform(-0.1, 0.1),
                rng.uniform(0.0, 0.15),
            );
        let turn = rng.uniform(-0.35, 0.35);
        let roll = rng.uniform(-0.25, 0.25);
        for (arm, side) in [(2 * k, 1.0), (2 * k + 1, -1.0)] {
            let poses = steps(&mut |s| {
                let e = ease(s);
                let r = yaw(turn * e) * torso.rot * rot(v3(1.0, 0.0, 0.0), roll * e);
                let inward = r * v3(0.0, -side, 0.0);
                aligned(
                    start + shift * e - inward * (0.5 * width),
                    inward,
                    r * v3(1.0, 0.0, 0.0),
                )
            });
            hands.push(Hand { arm, poses });
        }
    }
    hands
}
