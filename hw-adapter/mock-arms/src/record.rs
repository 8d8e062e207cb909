//! What a Python mock arm recorded (JSON lines, one per frame it received), and the check that
//! it is exactly the streamed trajectory: the hardware-in-the-loop tests and `omcbsa demo` use
//! it to confirm what the arms were actually sent.

use omcbsa_hw::cia402::{counts_to_rad, CW_DISABLE_OPERATION, CW_ENABLE_OPERATION};
use omcbsa_hw::plan::{check_commands, JointLimits};
use omcbsa_hw::run::{Command, JOINTS};
use serde_json::Value;
use std::path::Path;

/// Largest allowed difference between a recorded target and the interpolated plan, rad.
pub const TOLERANCE: f64 = 1e-6;

/// Reads a mock's record file.
pub fn read(path: &Path) -> Result<Vec<Value>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read mock record {}: {e}", path.display()))?;
    text.lines()
        .enumerate()
        .map(|(i, l)| {
            serde_json::from_str(l)
                .map_err(|e| format!("{} line {}: not JSON: {e}", path.display(), i + 1))
        })
        .collect()
}

/// How many entries of `kind` (`rpdo`, `sync`, `nmt`, `sdo`, `violation`, `pdo_length`,
/// `other`) a record holds.
pub fn kinds(record: &[Value], kind: &str) -> usize {
    record.iter().filter(|e| e["kind"] == kind).count()
}

/// One target position a drive received.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// SYNCs the mock had received before it.
    pub sync: u64,
    /// The target, counts.
    pub counts: i32,
    /// The controlword that came with it.
    pub controlword: u16,
}

/// The targets a mock received, per node 1..=7, in order.
pub fn targets(record: &[Value]) -> Result<[Vec<Target>; JOINTS], String> {
    let mut out: [Vec<Target>; JOINTS] = Default::default();
    for e in record.iter().filter(|e| e["kind"] == "rpdo") {
        let field = |name: &str| {
            e[name]
                .as_i64()
                .ok_or_else(|| format!("record entry {e}: no integer {name:?}"))
        };
        let node = field("node")?;
        let slot = usize::try_from(node - 1)
            .ok()
            .and_then(|i| out.get_mut(i))
            .ok_or_else(|| format!("record entry {e}: node {node} is not 1..={JOINTS}"))?;
        let number = |v: i64, what: &str| format!("record entry {e}: {what} {v} out of range");
        let (sync, counts, cw) = (field("sync")?, field("counts")?, field("cw")?);
        slot.push(Target {
            sync: u64::try_from(sync).map_err(|_| number(sync, "sync"))?,
            counts: i32::try_from(counts).map_err(|_| number(counts, "counts"))?,
            controlword: u16::try_from(cw).map_err(|_| number(cw, "cw"))?,
        });
    }
    Ok(out)
}

/// Checks that a mock received exactly `cmds` (one arm's interpolated trajectory) followed by
/// `settle_cycles` holds of its last command, each within [`TOLERANCE`]; that the run ended by
/// disabling operation; and that no received command breaks `limits` (neither by the mock's own
/// check, recorded as `violation`, nor by the executor's check re-run on what was received).
/// Returns the number of cycles received.
pub fn check_followed(
    record: &[Value],
    cmds: &[Command],
    settle_cycles: usize,
    limits: &[JointLimits; JOINTS],
    period: f64,
) -> Result<usize, String> {
    let last = cmds.last().ok_or("the trajectory is empty")?;
    let refused = kinds(record, "violation");
    if refused > 0 {
        return Err(format!(
            "the mock refused {refused} commands as breaking a limit"
        ));
    }
    let per_node = targets(record)?;
    let want = cmds.len() + settle_cycles;
    // streamed[j][k]: the motion command joint j received in cycle k.
    let mut streamed: Vec<Vec<i32>> = Vec::with_capacity(JOINTS);
    for (j, received) in per_node.iter().enumerate() {
        let motion: Vec<i32> = received
            .iter()
            .filter(|t| t.controlword == CW_ENABLE_OPERATION)
            .map(|t| t.counts)
            .collect();
        if motion.len() != want {
            return Err(format!(
                "joint {}: received {} motion commands, {want} were streamed",
                j + 1,
                motion.len()
            ));
        }
        for (k, &got) in motion.iter().enumerate() {
            let planned = cmds.get(k).unwrap_or(last)[j];
            if (counts_to_rad(got) - counts_to_rad(planned)).abs() > TOLERANCE {
                return Err(format!(
                    "joint {} cycle {k}: received {} rad, planned {} rad",
                    j + 1,
                    counts_to_rad(got),
                    counts_to_rad(planned)
                ));
            }
        }
        if received.last().map(|t| t.controlword) != Some(CW_DISABLE_OPERATION) {
            return Err(format!(
                "joint {}: the run did not end by disabling operation",
                j + 1
            ));
        }
        streamed.push(motion);
    }
    // What was received, cycle by cycle, starting from rest.
    let received: Vec<Command> = (0..want)
        .map(|k| std::array::from_fn(|j| streamed[j][k]))
        .collect();
    check_commands(limits, &received, period)
        .map_err(|(k, e)| format!("received command of cycle {k} breaks a limit: {e}"))?;
    Ok(want)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// The record of a drive set that received `cmds` (node 1..=7 each) and then a disable.
    fn record_of(cmds: &[Command]) -> Vec<Value> {
        let rpdo = |sync: usize, counts: i32, cw: u16, node: usize| json!({"kind": "rpdo", "node": node, "sync": sync, "counts": counts, "cw": cw});
        let mut r = Vec::new();
        for (k, c) in cmds.iter().enumerate() {
            r.extend((0..JOINTS).map(|j| rpdo(k, c[j], CW_ENABLE_OPERATION, j + 1)));
        }
        let last = cmds[cmds.len() - 1];
        r.extend((0..JOINTS).map(|j| rpdo(cmds.len(), last[j], CW_DISABLE_OPERATION, j + 1)));
        r
    }

    #[test]
    fn finds_every_way_a_record_can_differ() {
        let limits = crate::testing::arm_limits();
        let cmds: Vec<Command> = (0..5).map(|k| [k * 10; JOINTS]).collect();
        let ok = record_of(&cmds);
        assert_eq!(check_followed(&ok, &cmds, 0, &limits, 0.002), Ok(5));
        // one count (1e-7 rad) off is within the tolerance, eleven are not
        let mut near = cmds.clone();
        near[2][3] += 1;
        assert!(check_followed(&record_of(&near), &cmds, 0, &limits, 0.002).is_ok());
        near[2][3] += 10;
        let e = check_followed(&record_of(&near), &cmds, 0, &limits, 0.002).unwrap_err();
        assert!(e.starts_with("joint 4 cycle 2"), "{e}");
        let e = check_followed(&ok, &cmds, 1, &limits, 0.002).unwrap_err();
        assert!(e.contains("received 5 motion commands, 6"), "{e}");
        let mut refused = ok.clone();
        refused.push(json!({"kind": "violation"}));
        assert!(check_followed(&refused, &cmds, 0, &limits, 0.002).is_err());
        // a jump the executor would never send: 1 rad/s on joint 1
        let jump = [[0; JOINTS], [20_000; JOINTS]];
        let e = check_followed(&record_of(&jump), &jump, 0, &limits, 0.002).unwrap_err();
        assert!(
            e.contains("cycle 1 breaks a limit: joint 1: velocity"),
            "{e}"
        );
    }
}
