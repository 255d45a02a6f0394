//! `bezchain blade`: loft a blade definition into a point cloud.

use super::output::Outputs;
use super::{note_all, usage, warn_all};
use anyhow::{Context, Result};
use bezchain::export::summary;
use bezchain::geometry::{
    check_scale, write_csv_to, Blade, LoftOptions, Precision, MAX_CLOUD_POINTS, MIN_SECTION_POINTS,
};
use std::path::PathBuf;

/// Arguments of `bezchain blade`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Blade definition: bezchain JSON, windIO v1/v2 YAML or an OpenFAST AeroDyn 15 primary
    /// file (detected from the content; see the README).
    pub blade: PathBuf,
    /// Points per section (default: 82 for NACA sections, a file aerofoil's own count).
    #[arg(long)]
    pub points_per_section: Option<usize>,
    /// Sections spaced uniformly in radius (default: one at every station).
    #[arg(long)]
    pub sections: Option<usize>,
    /// Gaussian noise, standard deviation as a fraction of the largest chord.
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
    /// Randomise the point order, like an unordered scan.
    #[arg(long)]
    pub shuffle: bool,
    /// Seed of the noise and the shuffle.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output cloud (CSV `x,y,z[,section,index]`); `-` for standard output.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
}

/// Loft the blade and write the cloud.
pub fn run(args: Args) -> Result<()> {
    // A section has at least MIN_SECTION_POINTS points, so these bound the cloud before the
    // blade is read.
    let per = args
        .points_per_section
        .unwrap_or(MIN_SECTION_POINTS)
        .max(MIN_SECTION_POINTS);
    super::bounded(
        "--points-per-section",
        args.points_per_section.unwrap_or(0) as u64,
        (MAX_CLOUD_POINTS / 2) as u64,
        "a few hundred points a section resolve an aerofoil",
    )?;
    super::bounded(
        "--sections",
        args.sections.unwrap_or(0) as u64,
        (MAX_CLOUD_POINTS / per) as u64,
        &format!(
            "a cloud has at most {MAX_CLOUD_POINTS} points (at least {per} a section); a few hundred \
             sections resolve a blade"
        ),
    )?;
    let mut outs = Outputs::new();
    let out = outs.add("--output", &args.output)?;
    let blade = Blade::from_file(&args.blade)?;
    warn_all(&args.blade, &blade.warnings);
    note_all(&args.blade, &blade.notes);
    let opts = LoftOptions {
        points_per_section: args.points_per_section,
        sections: args.sections,
        noise: args.noise,
        shuffle: args.shuffle,
        seed: args.seed,
    };
    let cloud = blade
        .loft(&opts)
        .with_context(|| format!("{}: lofting", args.blade.display()))?;
    // The cloud must be data the readers take back (its squares inside f64).
    if let Err((at, message)) = check_scale(&cloud.points, Precision::F64) {
        let at = at.map_or(String::new(), |k| format!(" (point {})", k + 1));
        return Err(usage(format!(
            "{}: the lofted cloud{at}: {message} (with --noise {})",
            args.blade.display(),
            args.noise
        )));
    }
    let mut text = Vec::with_capacity(cloud.points.len() * 64);
    write_csv_to(&mut text, &cloud.points, cloud.grid)?;
    outs.put(out, &text)?;
    let to = if outs.uses_stdout() {
        "standard output".to_string()
    } else {
        args.output.display().to_string()
    };
    outs.commit()?;
    tell!("{}", summary::lofted(&args.blade, &blade, &cloud, &to));
    Ok(())
}
