//! `learner`: train, evaluate and serve Buridan policies.

use anyhow::Result;
use buridan_cli as cli;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "learner",
    version,
    about = "Buridan: multi-agent RL for deadlock handling among mobile robots"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Train a policy: learner and actors in one process (the embedded default).
    Train(cli::train::TrainArgs),
    /// Serve a run to `actor` processes over gRPC (same options and outputs as train).
    Serve(cli::serve::ServeArgs),
    /// Evaluate a controller (planner, random or trained policy) on seeded episodes.
    Eval(cli::eval::EvalArgs),
    /// Run a benchmark of the field: our controllers beside published results on the same instances.
    #[command(subcommand)]
    Bench(cli::bench::BenchCommand),
    /// Draw one evaluation episode as an animated GIF (robots, goals, trails, jams).
    Replay(cli::replay::ReplayArgs),
    /// Search hyperparameters: a study file's trials, in parallel, resumable (or on a cluster).
    Tune(cli::tune::TuneArgs),
    /// Run a declarative experiment: layouts x methods x seeds, planners, evaluation, report.
    Study(cli::study::StudyArgs),
    /// Redraw a run's learning curves (PNG) from its metrics.csv.
    Curves {
        /// A `learner train --out` directory.
        #[arg(long)]
        out: std::path::PathBuf,
        /// Chart title.
        #[arg(long, default_value = "training run")]
        title: String,
    },
    /// List the bundled reference models and the map generators, or write a generated map.
    Maps(cli::maps::MapsArgs),
}

fn main() -> Result<()> {
    // candle reads its thread count once, before any other thread starts:
    // actors and learner share the cores, so each candle call stays on one.
    buridan_policy::threads::pin_threads(1);
    let cli = Cli::parse();
    // A server's joins and faults are worth seeing; elsewhere the progress bar says enough.
    let default_level = match cli.command {
        Command::Serve(_) => "info",
        _ => "warn",
    };
    // Progress lines stand in for the bars off a terminal; imitation's
    // rounds (minutes each with crowds) have no bar.
    buridan_serving::logging::init(&format!(
        "{default_level},{}=info,buridan_imitate=info",
        cli::heartbeat::TARGET
    ));
    match cli.command {
        Command::Train(args) => cli::train::run(&args).map(|_| ()),
        Command::Serve(args) => cli::serve::run(&args).map(|_| ()),
        Command::Eval(args) => cli::eval::run(&args).map(|_| ()),
        Command::Bench(command) => cli::bench::run(&command),
        Command::Replay(args) => cli::replay::run(&args).map(|_| ()),
        Command::Tune(args) => cli::tune::run(&args).map(|_| ()),
        Command::Study(args) => cli::study::run(&args).map(|_| ()),
        Command::Curves { out, title } => cli::train::write_curves(&out, &title),
        Command::Maps(args) => cli::maps::run(&args),
    }
}
