//! `omcbsa ik`: inverse kinematics over stdin.

use std::process::ExitCode;

use omcbsa::format::Pose;
use omcbsa::ik::solve;
use omcbsa::models::{Fleet, ModelKind, DOF};
use omcbsa::pose;

use super::{bad_input, configuration, lines};

/// Inverse kinematics: reads one tool pose per line on stdin,
/// {"position":[x,y,z],"quat_xyzw":[x,y,z,w]} in the model's base frame, and writes a JSON
/// array of joint values per line, or {"error":"line N: ..."} saying why there is none; exit
/// code 1 if any line failed. The answer is within 1e-5 m and 1e-4 rad of the pose and within
/// the joint limits. Deterministic: every line starts from the same random seed.
#[derive(clap::Args)]
pub struct Args {
    /// Robot model.
    #[arg(long, value_parser = ModelKind::parse)]
    model: ModelKind,
    /// A configuration (JSON array) to start from before the random starts; the answer is
    /// then usually the solution nearest to it.
    #[arg(long, value_name = "JSON")]
    seed_config: Option<String>,
    /// Seed of the random starts.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

pub fn run(args: &Args) -> ExitCode {
    let model = args.model.id();
    let start = match args
        .seed_config
        .as_deref()
        .map(|s| configuration::<Fleet, DOF>(model, s, "--seed-config"))
    {
        None => None,
        Some(Ok(q)) => Some(q),
        Some(Err(e)) => return bad_input(e),
    };
    lines::answer_each(|line| {
        let pose: Pose = serde_json::from_str(line).map_err(|e| {
            format!("not a pose {{\"position\":[x,y,z],\"quat_xyzw\":[x,y,z,w]}}: {e}")
        })?;
        let target = pose::to_frame(&pose).map_err(|e| e.to_string())?;
        let q = solve::<Fleet, DOF>(model, &target, start.as_ref(), args.seed)
            .map_err(|e| e.to_string())?;
        serde_json::to_value(q.to_vec()).map_err(|e| e.to_string())
    })
}
