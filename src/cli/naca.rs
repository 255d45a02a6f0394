//! `bezchain naca`: generate a NACA aerofoil in Selig format.

use super::output::Outputs;
use anyhow::Result;
use bezchain::geometry::{write_selig_to, Naca, NacaOptions, Spacing, MAX_NACA_POINTS};
use std::path::PathBuf;

/// Arguments of `bezchain naca`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Designation: 4 digits (e.g. 4413) or 5 digits (e.g. 23012).
    pub code: String,
    /// Total number of contour points (upper TE → LE → lower TE).
    #[arg(long, default_value_t = 82)]
    pub points: usize,
    /// Station spacing: cosine (dense at the leading and trailing edges) or uniform (uniform in x
    /// on each surface).
    #[arg(long, default_value = "cosine", value_parser = super::parse_word::<Spacing>)]
    pub spacing: Spacing,
    /// Close the trailing edge (thickness coefficient −0.1036 instead of −0.1015).
    #[arg(long)]
    pub closed_te: bool,
    /// Output file (Selig `.dat`); standard output when omitted or `-`.
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
}

/// Generate the contour and write it.
pub fn run(args: Args) -> Result<()> {
    super::bounded(
        "--points",
        args.points as u64,
        MAX_NACA_POINTS as u64,
        "a few hundred points resolve any section",
    )?;
    let naca = Naca::parse(&args.code)?;
    let mut outs = Outputs::new();
    let out = outs.add("--output", &args.output)?;
    let points = naca.contour(&NacaOptions {
        points: args.points,
        spacing: args.spacing,
        closed_te: args.closed_te,
    })?;
    let mut text = Vec::new();
    write_selig_to(&mut text, &naca.name(), &points)?;
    outs.put(out, &text)?;
    outs.commit()
}
