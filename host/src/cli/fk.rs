//! `omcbsa fk`: forward kinematics over stdin.

use std::process::ExitCode;

use omcbsa::models::{Fleet, ModelKind, DOF};
use omcbsa::pose;
use omcbsa_core::model::Models;

use super::{configuration, lines};

/// Forward kinematics: reads one JSON array of joint values per line on stdin and writes the
/// tool frame's pose (base at identity) per line, {"position":[x,y,z],"quat_xyzw":[x,y,z,w]}.
/// A bad line is answered with {"error":"line N: ..."}; exit code 1 if any line failed.
#[derive(clap::Args)]
pub struct Args {
    /// Robot model.
    #[arg(long, value_parser = ModelKind::parse)]
    model: ModelKind,
}

pub fn run(args: &Args) -> ExitCode {
    let model = args.model.id();
    lines::answer_each(|line| {
        let q = configuration::<Fleet, DOF>(model, line, "q")?;
        serde_json::to_value(pose::from_frame(&Fleet::fk(model, &q))).map_err(|e| e.to_string())
    })
}
