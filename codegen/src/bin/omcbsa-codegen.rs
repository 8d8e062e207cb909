//! Command-line entry to the code generator's offline tools.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use omcbsa_codegen::fit;
use omcbsa_codegen::manifest::Folder;

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
    /// Fit enclosing collision capsules to a model's link meshes and write its collision file:
    /// the folder's model.json names the URDF, the chain's ends, the meshes, the SRDF (whose
    /// `disable_collisions` pairs are recorded too) and the output file.
    FitCapsules {
        /// The model's folder, e.g. robots/franka_panda.
        folder: PathBuf,
    },
}

fn main() -> ExitCode {
    let Command::FitCapsules { folder } = Cli::parse().command;
    let folder = match Folder::read(&folder) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let Some(meshes) = folder.meshes() else {
        eprintln!(
            "error: {}: the manifest names no mesh folder (capsules.meshes): nothing to fit",
            folder.dir.display()
        );
        return ExitCode::FAILURE;
    };
    let output = folder.collision();
    let fitted = match fit::fit_robot(
        &folder.urdf(),
        &meshes,
        folder.srdf().as_deref(),
        &folder.manifest.name,
        Some(folder.ends()),
    ) {
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
