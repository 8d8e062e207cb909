use omcbsa_core::rng::Rng;
use omcbsa_tests::*;

#[test]
#[ignore]
fn search_scenarios() {
    let home = [0.0, 0.26, 3.14, -2.27, 0.0, 0.96, 1.57];
    let mut found = 0;
    for seed in 0..400u64 {
        let mut rng = Rng::new(seed);
        let gap = rng.uniform(0.7, 1.0);
        let b0 = frame([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
        let b1 = frame([gap, 0.0, 0.0], [0.0, 0.0, std::f64::consts::PI]);
        let q0: [f64; 7] = std::array::from_fn(|i| home[i] + rng.uniform(-0.5, 0.5));
        let q1: [f64; 7] = std::array::from_fn(|i| home[i] + rng.uniform(-0.5, 0.5));
        let p0 = random_path(&mut rng, &q0, 1.0, 20, 0.2);
        let p1 = random_path(&mut rng, &q1, 1.0, 20, 0.2);
        if !witness_is_valid(&[b0, b1], &[p0.clone(), p1.clone()], &[], 0.2) {
            continue;
        }
        let file = problem_json(
            &format!("s{seed}"),
            0.2,
            vec![robot_json("a", &b0, None), robot_json("b", &b1, None)],
            vec![trajectory_json("h1", &b1, &p1), trajectory_json("h0", &b0, &p0)],
            vec![],
        );
        let ik = plan_and_validate(&file, "ik-tracking", 2.0);
        let cbs = plan_and_validate(&file, "omcbsa", 5.0);
        let pp = plan_and_validate(&file, "pp", 5.0);
        eprintln!(
            "seed {seed}: ik {:?} cbs {:?} {:.1}ms {:?} pp {:?}",
            ik.status, cbs.status, cbs.planning_time_s * 1e3, cbs.stats.get("conflicts_resolved"), pp.status
        );
        found += 1;
        if found > 40 {
            break;
        }
    }
}

#[test]
#[ignore]
fn search_single_arm() {
    use omcbsa_core::kinematics::null_space_basis;
    use omcbsa_core::model::{KinovaGen3, Model, Frame};
    use omcbsa_core::search::{OthersMode, Validity};
    let home = [0.0, 0.26, 3.14, -2.27, 0.0, 0.96, 1.57];
    let mut found = 0;
    for seed in 0..3000u64 {
        let mut rng = Rng::new(seed);
        let b0 = frame([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
        let q0: [f64; 7] = std::array::from_fn(|i| home[i] + rng.uniform(-0.6, 0.6));
        let p0 = random_path(&mut rng, &q0, 0.8, 16, 0.2);
        // The other elbow family: start 0.8 rad along the null space, track by IK.
        let (_, j) = KinovaGen3::jacobian(&p0[0]);
        let n = null_space_basis::<7>(&j)[0];
        let shifted: [f64; 7] = std::array::from_fn(|i| p0[0][i] + 0.8 * n[i]);
        let free = Validity::<KinovaGen3, 7>::new(b0, &[], &[], OthersMode::Avoid, &[], 0.2, 0.04);
        let traj: omcbsa_core::problem::Trajectory = p0.iter().map(|q| KinovaGen3::fk(q)).collect();
        let mut alt = vec![[0.0; 7]; 16];
        if omcbsa_core::tracking::track::<KinovaGen3, 7>(&omcbsa_core::problem::Robot { base: b0, tcp: Frame::IDENTITY, initial: None }, &traj, &shifted, &free, &Default::default(), &mut alt).is_none() {
            continue;
        }
        let t = 8;
        let mut f = [Frame::IDENTITY; 9];
        KinovaGen3::link_frames(&alt[t], &mut f);
        let elbow = f[4].pos;
        let ball = sphere("ball", [elbow.x, elbow.y, elbow.z], 0.06);
        let obstacle = omcbsa_core::geometry::Obstacle {
            shape: omcbsa_core::geometry::Shape::Sphere { radius: 0.06 },
            pose: Frame { rot: Frame::IDENTITY.rot, pos: elbow },
        };
        if !witness_is_valid(&[b0], &[p0.clone()], &[obstacle], 0.2) {
            continue;
        }
        let file = problem_json(&format!("s{seed}"), 0.2, vec![robot_json("a", &b0, Some(&alt[0]))], vec![trajectory_json("h0", &b0, &p0)], vec![ball]);
        let om = plan_and_validate(&file, "pp", 5.0);
        eprintln!("seed {seed}: omega {:?} {:.1}ms {:?} d0 {:.2}", om.status, om.planning_time_s * 1e3, om.stats.get("expansions"),
            (0..7).map(|i| (alt[0][i]-p0[0][i]).powi(2)).sum::<f64>().sqrt());
        found += 1;
        if found > 10 {
            break;
        }
    }
}
