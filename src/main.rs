//! vergence command line. In this branch only `cull-bench` is wired; the
//! other subcommands arrive with the renderer.

use clap::{Parser, Subcommand};
use vergence::cull::bench::{builtin_eyes, run, stand_in_hall_layout, CullBenchArgs};

/// Stereo VR renderer for very large enterprise scenes.
#[derive(Parser)]
#[command(name = "vergence", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Time the stereo culling strategies on a scene along a head path.
    CullBench(CullBenchArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::CullBench(args) => {
            let result = builtin_eyes(args.hmd.as_deref()).and_then(|eyes| {
                let bounds = stand_in_hall_layout(args.instances, args.seed);
                run(&args, &bounds, &eyes)
            });
            match result {
                Ok(report) => {
                    if args.json {
                        match serde_json::to_string(&report) {
                            Ok(s) => println!("{s}"),
                            Err(e) => {
                                eprintln!("error: {e}");
                                return std::process::ExitCode::FAILURE;
                            }
                        }
                    } else {
                        print!("{}", report.to_table());
                    }
                    std::process::ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    std::process::ExitCode::FAILURE
                }
            }
        }
    }
}
