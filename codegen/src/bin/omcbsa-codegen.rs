//! Command-line entry to the code generator's offline tools.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use omcbsa_codegen::fit;

#[derive(Parser)]
#[command(
    name = "omcbsa-codegen",
    about = "Offline tools of the omcbsa code generator"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Fit enclosing collision capsules to a URDF's link meshes and write collision.json.
    FitCapsules {
        /// The robot's URDF.
        #[arg(long)]
        urdf: PathBuf,
        /// Folder holding the mesh files, looked up by file name.
        #[arg(long)]
        meshes: PathBuf,
        /// MoveIt SRDF (or its xacro) whose `disable_collisions` pairs are recorded too.
        #[arg(long)]
        srdf: Option<PathBuf>,
        /// Model name written to the file; by default the output's folder name
        /// (`robots/kinova_gen3/collision.json` -> `kinova_gen3`).
        #[arg(long)]
        model: Option<String>,
        /// Output JSON file.
        #[arg(short, long)]
        output: PathBuf,
    },
}

fn main() -> ExitCode {
    let Command::FitCapsules {
        urdf,
        meshes,
        srdf,
        model,
        output,
    } = Cli::parse().command;
    let model = model.or_else(|| {
        let folder = output.canonicalize().ok().unwrap_or_else(|| output.clone());
        folder.parent()?.file_name()?.to_str().map(String::from)
    });
    let Some(model) = model.filter(|m| !m.is_empty()) else {
        eprintln!(
            "error: cannot tell the model name from {}; pass --model",
            output.display()
        );
        return ExitCode::FAILURE;
    };
    let fitted = match fit::fit_robot(&urdf, &meshes, srdf.as_deref(), &model) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    if let Err(e) = std::fs::write(&output, fitted.file.to_json()) {
        eprintln!("error: {}: {e}", output.display());
        return ExitCode::FAILURE;
    }
    print!("{}", fitted.table());
    println!("\ndisabled pairs:");
    for (pair, reason) in fitted
        .file
        .disabled_pairs
        .iter()
        .zip(&fitted.file.disabled_reasons)
    {
        println!("  {} - {}: {reason}", pair[0], pair[1]);
    }
    println!("wrote {}", output.display());
    ExitCode::SUCCESS
}
