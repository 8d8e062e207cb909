//! The benchmark's statistics on small cases computed by hand: path quality of a plan
//! (length, speed and acceleration against the limits, clearances, search cost) on a toy
//! one-joint arm whose geometry is a single stick, and the planning-time spread (mean, σ, min,
//! max) and path-quality summary of a handful of rows.

use std::f64::consts::{FRAC_PI_2, PI};

use omcbsa::bench::{path_quality, PathQuality, Row, Summary};
use omcbsa_core::geometry::{Obstacle, Shape};
use omcbsa_core::model::{Frame, LinkCapsule, Model};
use omcbsa_core::nalgebra::{Rotation3, SMatrix, Vector3};
use omcbsa_core::problem::{Problem, Robot, Tolerance};
use omcbsa_core::tool::Tool;

/// One revolute joint about z at the base; link 1 is a stick of length 1 along its x axis,
/// radius 0.1, and the tool frame sits at its tip.
struct Stick;

const VMAX: f64 = 4.0;
const AMAX: f64 = 20.0;

fn turn(q: f64) -> Frame {
    Frame {
        rot: Rotation3::from_axis_angle(&Vector3::z_axis(), q).into_inner(),
        pos: Vector3::zeros(),
    }
}

impl Model<1> for Stick {
    const NAME: &'static str = "stick";
    const LINK_NAMES: &'static [&'static str] = &["base", "stick"];
    const JOINT_NAMES: [&'static str; 1] = ["turn"];
    const LOWER: [f64; 1] = [-10.0];
    const UPPER: [f64; 1] = [10.0];
    const VELOCITY: [f64; 1] = [VMAX];
    const ACCELERATION: [f64; 1] = [AMAX];
    const CAPSULES: &'static [LinkCapsule] = &[LinkCapsule {
        link: 1,
        a: [0.0; 3],
        b: [1.0, 0.0, 0.0],
        radius: 0.1,
    }];
    const SELF_PAIRS: &'static [(u8, u8)] = &[];
    const REACH: [f64; 1] = [1.1];

    fn fk(q: &[f64; 1]) -> Frame {
        turn(q[0]).compose(&Frame {
            rot: SMatrix::identity(),
            pos: Vector3::new(1.0, 0.0, 0.0),
        })
    }

    fn link_frames(q: &[f64; 1], out: &mut [Frame]) -> Frame {
        out[0] = Frame::IDENTITY;
        out[1] = turn(q[0]);
        Self::fk(q)
    }

    fn jacobian(q: &[f64; 1]) -> (Frame, SMatrix<f64, 6, 1>) {
        let mut j = SMatrix::zeros();
        (j[0], j[1], j[5]) = (-q[0].sin(), q[0].cos(), 1.0);
        (Self::fk(q), j)
    }
}

fn at(x: f64, y: f64) -> Frame {
    Frame {
        rot: SMatrix::identity(),
        pos: Vector3::new(x, y, 0.0),
    }
}

#[test]
fn path_quality_of_a_hand_computed_plan() {
    // Robot A at the origin turns away from everything: 0, -0.1, -0.3 rad, dt = 0.1 s.
    // Robot B at (3, 0) holds at pi: its stick lies along x from 2 to 3.
    // A sphere of radius 0.2 at (0.5, 1).
    let dt = 0.1;
    let a_path = vec![[0.0], [-0.1], [-0.3]];
    let b_path = vec![[PI]; 3];
    let mut problem = Problem::<1> {
        dt,
        robots: Default::default(),
        trajectories: Default::default(),
        obstacles: Default::default(),
        tolerance: Tolerance {
            position: 1e-3,
            orientation: 1e-2,
        },
    };
    problem
        .robots
        .push(Robot {
            model: 0,
            base: at(0.0, 0.0),
            tcp: Frame::IDENTITY,
            tool: Tool::NONE,
            start: Default::default(),
            assigned: Default::default(),
            excluded: omcbsa_core::problem::StartExclusions::NONE,
            // Tool at (0, 1); the trajectory starts at (1, 0): a start cost of sqrt(2).
            initial: Some([FRAC_PI_2]),
        })
        .unwrap();
    problem
        .robots
        .push(Robot {
            model: 0,
            base: at(3.0, 0.0),
            tcp: Frame::IDENTITY,
            tool: Tool::NONE,
            start: Default::default(),
            assigned: Default::default(),
            excluded: omcbsa_core::problem::StartExclusions::NONE,
            initial: Some([PI]),
        })
        .unwrap();
    let trajectory = a_path.iter().map(Stick::fk).collect();
    problem.trajectories.push(trajectory).unwrap();
    problem
        .obstacles
        .push(Obstacle {
            shape: Shape::Sphere { radius: 0.2 },
            pose: at(0.5, 1.0),
        })
        .unwrap();

    let q = path_quality::<Stick, 1>(&problem, &[Some(0), None], &[a_path, b_path]);
    let near = |a: f64, b: f64| (a - b).abs() < 1e-12;
    // Length: |-0.1| + |-0.2| = 0.3 rad (B does not move).
    assert!(near(q.path_length_rad, 0.3), "{q:?}");
    // Fastest: 0.2 rad in 0.1 s = 2 rad/s, half of 4.
    assert!(near(q.max_speed_frac, 0.5), "{q:?}");
    // Acceleration: (-0.3 + 0.2 + 0) / 0.01 = -10 rad/s², half of 20.
    assert!(near(q.max_accel_frac.unwrap(), 0.5), "{q:?}");
    // Arms: at step 0 the tips are 1 m apart (x = 1 and x = 2), less both radii: 0.8 m;
    // later A's tip is farther (at -0.3 rad: (0.955, -0.296), 1.086 m from (2, 0)).
    assert!(near(q.min_arm_clearance_m.unwrap(), 0.8), "{q:?}");
    // Obstacle: at step 0 the sphere's centre is 1 m above A's stick: 1 - 0.2 - 0.1 = 0.7 m
    // (B's stick is sqrt(1.5² + 1) - 0.3 = 1.50 m away).
    assert!(near(q.min_obstacle_clearance_m.unwrap(), 0.7), "{q:?}");
    // Cost: A's length 0.3 + its start cost sqrt(2); B holds and costs nothing.
    assert!(near(q.path_cost, 0.3 + 2f64.sqrt()), "{q:?}");
}

#[test]
fn a_single_arm_without_obstacles_has_no_clearance_figures() {
    let mut problem = Problem::<1> {
        dt: 0.5,
        robots: Default::default(),
        trajectories: Default::default(),
        obstacles: Default::default(),
        tolerance: Tolerance {
            position: 1e-3,
            orientation: 1e-2,
        },
    };
    let path = vec![[0.0], [1.0]];
    problem
        .robots
        .push(Robot {
            model: 0,
            base: Frame::IDENTITY,
            tcp: Frame::IDENTITY,
            tool: Tool::NONE,
            start: Default::default(),
            assigned: Default::default(),
            excluded: omcbsa_core::problem::StartExclusions::NONE,
            initial: None,
        })
        .unwrap();
    problem
        .trajectories
        .push(path.iter().map(Stick::fk).collect())
        .unwrap();
    let q = path_quality::<Stick, 1>(&problem, &[Some(0)], &[path]);
    assert_eq!(
        q,
        PathQuality {
            path_length_rad: 1.0,
            // 1 rad in 0.5 s = 2 rad/s of 4.
            max_speed_frac: 0.5,
            max_accel_frac: None,
            min_arm_clearance_m: None,
            min_obstacle_clearance_m: None,
            path_cost: 1.0,
        }
    );
}

fn row(
    planner: &str,
    robots: usize,
    success: bool,
    time_s: f64,
    quality: Option<PathQuality>,
) -> Row {
    let mut r = Row {
        problem: format!("p{time_s}"),
        family: "f".into(),
        layout: "l".into(),
        robots,
        trajectories: robots,
        horizon: 3,
        known_solvable: true,
        planner: planner.into(),
        timeout_s: 5.0,
        status: if success { "solved" } else { "timeout" }.into(),
        valid: success.then_some(true),
        success,
        time_s,
        wall_s: time_s,
        ..Row::default()
    };
    if let Some(q) = quality {
        r.set_quality(&q);
    }
    r
}

fn quality(length: f64, speed: f64, arm_clearance: f64) -> Option<PathQuality> {
    Some(PathQuality {
        path_length_rad: length,
        max_speed_frac: speed,
        max_accel_frac: Some(2.0 * speed),
        min_arm_clearance_m: Some(arm_clearance),
        min_obstacle_clearance_m: None,
        path_cost: length + 1.0,
    })
}

#[test]
fn time_spread_and_quality_summary_by_hand() {
    let rows = vec![
        // Two arms: 1, 2, 3 and 4 ms solved, one timeout (its time is not a planning time).
        row("omcbsa", 2, true, 0.001, quality(1.0, 0.2, 0.05)),
        row("omcbsa", 2, true, 0.002, quality(2.0, 0.4, 0.03)),
        row("omcbsa", 2, true, 0.003, quality(3.0, 0.6, 0.01)),
        row("omcbsa", 2, true, 0.004, quality(4.0, 0.8, 0.02)),
        row("omcbsa", 2, false, 5.0, None),
        // Three arms: one run, 10 ms.
        row("omcbsa", 3, true, 0.010, quality(6.0, 0.5, 0.10)),
    ];
    let s = Summary::new(&rows, &["omcbsa".to_string()]);
    let two = s.cell("omcbsa", Some(2)).unwrap().time_spread().unwrap();
    // mean 2.5 ms; squares of deviations 2.25 + 0.25 + 0.25 + 2.25 = 5 (ms²) over n - 1 = 3.
    assert_eq!(two.n, 4);
    assert!((two.mean - 0.0025).abs() < 1e-15);
    assert!((two.std_dev - (5.0f64 / 3.0).sqrt() * 1e-3).abs() < 1e-15);
    assert_eq!((two.min, two.max), (0.001, 0.004));
    // One value: no spread.
    let three = s.cell("omcbsa", Some(3)).unwrap().time_spread().unwrap();
    assert_eq!(
        (three.n, three.std_dev, three.min, three.max),
        (1, 0.0, 0.010, 0.010)
    );
    // All: 1, 2, 3, 4, 10 ms: mean 4; deviations² 9 + 4 + 1 + 0 + 36 = 50, / 4 = 12.5.
    let all = s.cell("omcbsa", None).unwrap().time_spread().unwrap();
    assert!((all.mean - 0.004).abs() < 1e-15);
    assert!((all.std_dev - 12.5f64.sqrt() * 1e-3).abs() < 1e-15);

    let md = s.markdown("hand-made rows");
    // mean, σ, min, median, max in ms.
    assert!(
        md.contains("| omcbsa | 2 | 4 | 2.5 | 1.3 | 1.0 | 2.5 | 4.0 |"),
        "{md}"
    );
    assert!(
        md.contains("| omcbsa | 3 | 1 | 10.0 | 0.0 | 10.0 | 10.0 | 10.0 |"),
        "{md}"
    );
    assert!(
        md.contains("| omcbsa | all | 5 | 4.0 | 3.5 | 1.0 | 3.0 | 10.0 |"),
        "{md}"
    );
    // Path quality, two arms: length mean 2.5; cost mean 3.5; speed mean 0.5 (largest 0.8);
    // acceleration mean 1.0 (largest 1.6); arm clearance mean 27.5 mm (smallest 10.0 mm);
    // no obstacle.
    assert!(
        md.contains(
            "| omcbsa | 2 | 4 | 2.50 | 3.50 | 0.50 (0.80) | 1.00 (1.60) | 27.5 (10.0) | - |"
        ),
        "{md}"
    );
    assert!(
        md.contains(
            "| omcbsa | all | 5 | 3.20 | 4.20 | 0.50 (0.80) | 1.00 (1.60) | 42.0 (10.0) | - |"
        ),
        "{md}"
    );
}
