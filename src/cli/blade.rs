//! `bezchain blade`: loft a blade definition into a point cloud.

use super::{warn_all, Target};
use anyhow::Result;
use bezchain::geometry::{write_csv_to, Axes, Blade, Blend, LoftOptions};
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
    let blade = Blade::from_file(&args.blade)?;
    warn_all(&args.blade, &blade.warnings);
    let opts = LoftOptions {
        points_per_section: args.points_per_section,
        sections: args.sections,
        noise: args.noise,
        shuffle: args.shuffle,
        seed: args.seed,
    };
    let cloud = blade.loft(&opts)?;
    let mut text = Vec::with_capacity(cloud.points.len() * 64);
    write_csv_to(&mut text, &cloud.points, cloud.grid)?;
    Target::parse(&args.output).write(&text)?;
    let shape = match cloud.grid {
        Some(g) => format!("{} sections × {} points", g.sections, g.per_section),
        None => "unordered".to_string(),
    };
    let to = match Target::parse(&args.output) {
        Target::Stdout => "standard output".to_string(),
        Target::File(path) => path.display().to_string(),
    };
    let blend = match blade.blend {
        Blend::Radius => "each station its own aerofoil",
        Blend::Thickness { .. } => "aerofoils blended by relative thickness",
    };
    let axes = match blade.axes {
        Axes::Section => "section axes",
        Axes::Turbine => "blade-root axes",
    };
    eprintln!(
        "{}: {}, {} stations, {blend}, {axes}: {} points ({shape}) → {to}",
        args.blade.display(),
        blade.format,
        blade.stations.len(),
        cloud.points.len()
    );
    Ok(())
}
