//! The `bezchain` command line: parse arguments, call the library, write outputs, map errors to
//! exit statuses (0 success, 2 bad input or arguments, 1 anything else).

mod cli;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Chained Bezier curves and patches as compact shape-optimisation variables.
#[derive(Parser)]
#[command(name = "bezchain", version, about, long_about = None, arg_required_else_help = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Print nothing but warnings and errors: no progress, no summary (every command; the
    /// files asked for are still written, standard output included).
    #[arg(long, short, global = true)]
    quiet: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Generate a NACA 4- or 5-digit aerofoil in Selig format.
    Naca(cli::naca::Args),
    /// Fit a chain of Bezier curves to a 2D contour.
    Fit(Box<cli::fit::Args>),
    /// The paper's optimiser comparison on its three NACA 4413 cases, as one table.
    Compare(cli::compare::Args),
    /// Loft a blade definition (JSON, windIO v1/v2 or AeroDyn 15) into a 3D point cloud.
    Blade(cli::blade::Args),
    /// Find the chain with the fewest stored scalars whose offsets meet a tolerance (exit
    /// status 1, reports still written, when no layout meets it).
    Adapt(cli::adapt::Args),
    /// Find the patch grid with the fewest stored scalars whose offsets from a sectioned cloud
    /// meet a tolerance (exit status 1, reports still written, when no layout meets it).
    AdaptSurface(cli::adapt_surface::Args),
    /// Fit a grid of chained Bezier patches to a 3D point cloud.
    FitSurface(Box<cli::fit_surface::Args>),
    /// Evaluate a population of designs against data (one `sum_sq,max` line each).
    Eval(cli::eval::Args),
    /// Time the population evaluator (GA fitness kernel) on one backend.
    Bench(cli::bench::Args),
    /// Write a saved report's chain or grid as a STEP and/or IGES B-spline.
    Export(cli::export::Args),
    /// Inviscid aerodynamics (XFOIL's panel method) of an aerofoil file or curve report.
    Aero(cli::aero::Args),
    /// Optimise an aerofoil's adapted encoding for an aerodynamic objective (max-cl or
    /// inverse:TARGET) with the GA or CMA-ES on the panel-method evaluator.
    Optimise(Box<cli::optimise::Args>),
    /// Sample a fitted patch grid densely (GPU when present) into a point cloud.
    Sample(cli::sample::Args),
}

fn main() -> ExitCode {
    give_mesa_a_runtime_dir();
    // Under mpirun: every rank runs the command; only rank 0 prints and writes (§4.3).
    #[cfg(feature = "mpi")]
    let _universe = cli::mpi::start();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // Every rank parses the same arguments and fails alike: no rank waits for another.
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    cli::output::set_quiet(cli.quiet);
    let result = match cli.command {
        Command::Naca(args) => cli::naca::run(args),
        Command::Fit(args) => cli::fit::run(*args),
        Command::Compare(args) => cli::compare::run(args),
        Command::Blade(args) => cli::blade::run(args),
        Command::Adapt(args) => cli::adapt::run(args),
        Command::AdaptSurface(args) => cli::adapt_surface::run(args),
        Command::FitSurface(args) => cli::fit_surface::run(*args),
        Command::Eval(args) => cli::eval::run(args),
        Command::Bench(args) => cli::bench::run(args),
        Command::Export(args) => cli::export::run(args),
        Command::Aero(args) => cli::aero::run(args),
        Command::Optimise(args) => cli::optimise::run(*args),
        Command::Sample(args) => cli::sample::run(args),
    };
    let in_collectives = bezchain::team::size() > 1 && bezchain::team::agreed();
    let outcome = result.map_err(|e| bezchain::team::Failure {
        status: cli::exit_status(&e),
        message: cli::one_line(&e),
    });
    // Every rank reports its outcome once; one rank failing alone fails them all.
    match bezchain::team::finish(outcome) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            if in_collectives && !bezchain::team::failure_is_shared() {
                // The other ranks may be waiting for this one in a collective.
                #[cfg(feature = "mpi")]
                cli::mpi::fail_alone(&f);
            }
            if bezchain::team::is_root() {
                eprintln!("error: {}", f.message);
            }
            ExitCode::from(f.status)
        }
    }
}

/// Mesa's Vulkan drivers print `error: XDG_RUNTIME_DIR is invalid or not set` when the
/// variable is missing (headless machines, CI), which reads like one of bezchain's own errors.
/// Point it at a private directory of the user's in the temporary folder instead (created
/// once, mode 0700); an existing setting is left alone, and so is a directory we do not own.
fn give_mesa_a_runtime_dir() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let user = std::env::var("USER").unwrap_or_else(|_| "user".to_string());
    let dir = std::env::temp_dir().join(format!("bezchain-runtime-{user}"));
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        if std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).is_err() {
            return;
        }
    }
    // Still single-threaded: nothing else reads the environment yet.
    std::env::set_var("XDG_RUNTIME_DIR", &dir);
}
