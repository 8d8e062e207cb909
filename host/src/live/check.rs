//! What is checked of a planned segment before it is sent to the arms: the Embodier's plan from
//! the waypoint the push starts at to the plan's end, with the configuration before it, as a
//! problem and solution pair the validator checks whole (joint limits, the joints' speeds at
//! every step and at the junction with what the arms already execute, tracking of the hands'
//! poses, collisions with the obstacles, the other arms and the arm itself). The first push
//! carries the approach from where the arms stand, checked the same way.

use omcbsa_core::problem::MAX_STEPS;

use crate::format::Pose;
use crate::models::{Fleet, DOF};
use crate::online::record::Window;
use crate::online::Embodier;
use crate::pose;
use crate::validate::validate;

/// Checks the Embodier's plan from timeline index `from` (>= 1) to its end; the error is the
/// validator's summary. Beyond `MAX_STEPS` steps the plan is checked in windows that overlap
/// by one step, so that every pair of consecutive steps is checked.
pub fn check_segment(embodier: &Embodier, from: usize) -> Result<(), String> {
    let setup = embodier.setup();
    let n = embodier.robot_names().len();
    let span = |r: std::ops::Range<usize>| -> Result<Vec<Vec<[f64; DOF]>>, String> {
        (0..n)
            .map(|i| {
                (r.clone())
                    .map(|k| {
                        (embodier.configuration(i, k))
                            .ok_or_else(|| format!("timeline index {k} is no longer kept"))
                    })
                    .collect()
            })
            .collect()
    };
    // Indices up to the approach's end are the approach (the first push carries it); an empty
    // approach checks the one step from the configuration before the path to its first.
    let a = embodier.approach_len();
    let mut approach = from..(a + 1).max(from);
    let end = embodier.end();
    while approach.end < end {
        let start = approach.end;
        let stop = end.min(start + MAX_STEPS - 1);
        let initial = span(approach.start - 1..approach.start)?;
        let window = Window {
            name: format!("segment_{start}"),
            initial: Some(initial.iter().map(|q| q[0]).collect()),
            approach: Some(span(approach.clone())?),
            path: span(start..stop)?,
        };
        let (problem, solution) = window.files(setup, embodier, |k| {
            let frames = embodier.target_poses(start + k)?;
            Some(frames.iter().map(pose::from_frame).collect::<Vec<Pose>>())
        });
        let core = crate::load::problem::<Fleet, DOF>(&problem).map_err(|e| e.to_string())?;
        let report = validate::<Fleet, DOF>(&problem, &core, &solution);
        if !report.is_valid() {
            let first = (report.violations.first()).map_or(String::new(), |v| format!(": {v}"));
            return Err(format!(
                "timeline indices {start} to {}: {}{first}",
                stop - 1,
                report.summary()
            ));
        }
        approach = stop..stop;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::online::testing::{self, embodier};
    use omcbsa_core::model::{KinovaGen3, Model};

    fn chunk(start: u64) -> Vec<Vec<Pose>> {
        testing::chunk(start, |k| 0.4 + 0.002 * (k % 50) as f64)
    }

    #[test]
    fn every_push_of_a_run_passes_and_a_long_hold_is_checked_in_windows() {
        let mut e = embodier();
        let first = e.push_chunk(0, &chunk(0)).unwrap();
        assert!(e.approach_len() > 0);
        check_segment(&e, 1).unwrap();
        e.commit_until(first.index + 2);
        let next = e.push_chunk(2, &chunk(2)).unwrap();
        check_segment(&e, next.index).unwrap();
        // A chunk far ahead: the arms hold for longer than one problem holds steps.
        let old_end = e.end();
        let far = e.push_chunk(2 * MAX_STEPS as u64, &chunk(2 * MAX_STEPS as u64));
        let far = far.unwrap();
        assert!(far.end - old_end > MAX_STEPS, "{} to {}", old_end, far.end);
        check_segment(&e, old_end).unwrap();
    }

    #[test]
    fn a_jump_from_where_the_arms_are_to_the_segment_is_caught() {
        let mut e = embodier();
        e.push_chunk(0, &chunk(0)).unwrap();
        let a = e.approach_len();
        let path: Vec<[f64; DOF]> = e.planned(0, a + 1).to_vec();
        let check = |before: [f64; DOF]| {
            let window = Window {
                name: "junction".to_string(),
                initial: Some(vec![before]),
                approach: Some(vec![Vec::new()]),
                path: vec![path.clone()],
            };
            let (problem, solution) = window.files(e.setup(), &e, |k| {
                let frames = e.target_poses(a + 1 + k)?;
                Some(frames.iter().map(pose::from_frame).collect())
            });
            let core = crate::load::problem::<Fleet, DOF>(&problem).unwrap();
            validate::<Fleet, DOF>(&problem, &core, &solution)
        };
        // From the approach's last configuration, where the arm is: valid, the hand where the
        // chunk puts it.
        let before = e.configuration(0, a).unwrap();
        let report = check(before);
        assert!(report.is_valid(), "{}", report.summary());
        let hand = KinovaGen3::fk(&path[0]).pos;
        assert!((hand.x - 0.5).abs() < 1e-3, "{hand:?}");
        // The arm said to stand 0.3 rad away on joint 1: one step of 0.1 s at 3 rad/s.
        let mut far = before;
        far[0] += 0.3;
        let report = check(far);
        assert!(!report.is_valid());
        let v = &report.violations[0];
        assert!(v.to_string().contains("velocity"), "{v}");
    }
}
