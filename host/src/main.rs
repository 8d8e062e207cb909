//! `omcbsa`: the command-line program. One module per subcommand under `cli/`.

mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "omcbsa",
    version,
    about = "Multi-arm on-manifold planning (Ω-CBSA)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Bench(cli::bench::Args),
    BenchOnline(cli::bench_online::Args),
    Demo(cli::demo::Args),
    Doctor(cli::doctor::Args),
    Execute(cli::execute::Args),
    Fk(cli::fk::Args),
    GenBench(cli::gen_bench::Args),
    Ik(cli::ik::Args),
    ImportProblems(cli::import::Args),
    Online(cli::online::Args),
    Plan(cli::plan::Args),
    Validate(cli::validate::Args),
    View(cli::view::Args),
}

fn main() -> ExitCode {
    match Cli::parse().command {
        Command::Bench(args) => cli::bench::run(&args),
        Command::BenchOnline(args) => cli::bench_online::run(&args),
        Command::Demo(args) => cli::demo::run(&args),
        Command::Doctor(args) => cli::doctor::run(&args),
        Command::Execute(args) => cli::execute::run(&args),
        Command::Fk(args) => cli::fk::run(&args),
        Command::GenBench(args) => cli::gen_bench::run(&args),
        Command::Ik(args) => cli::ik::run(&args),
        Command::ImportProblems(args) => cli::import::run(&args),
        Command::Online(args) => cli::online::run(&args),
        Command::Plan(args) => cli::plan::run(&args),
        Command::Validate(args) => cli::validate::run(&args),
        Command::View(args) => cli::view::run(&args),
    }
}
