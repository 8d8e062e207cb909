//! `omcbsa fk`: forward kinematics over stdin.

use std::process::ExitCode;

use omcbsa::models::{ModelKind, ModelVisitor};
use omcbsa::pose;
use omcbsa_core::model::Model;
use serde_json::Value;

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
    struct Fk;
    impl ModelVisitor for Fk {
        type Output = ExitCode;
        fn visit<M: Model<D>, const D: usize>(self) -> ExitCode {
            lines::answer_each(fk_line::<M, D>)
        }
    }
    args.model.visit(Fk)
}

fn fk_line<M: Model<D>, const D: usize>(line: &str) -> Result<Value, String> {
    let q = configuration::<M, D>(line, "q")?;
    serde_json::to_value(pose::from_frame(&M::fk(&q))).map_err(|e| e.to_string())
}
