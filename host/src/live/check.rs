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
