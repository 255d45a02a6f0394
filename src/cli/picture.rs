//! The pictures of the commands: `--png`, `--svg` and `--png-size` of the surface commands
//! (`fit-surface`, `adapt-surface`), and `--png` and `--svg` of the 2D plots (`fit`, `adapt`,
//! `aero`, `optimise`).

use super::output::{Output, Outputs};
use super::{parse_pair, usage};
use anyhow::Result;
use bezchain::chain::{CurveChain, PatchGrid};
use bezchain::export::{render, render_svg, CurvePlot, Plot, RenderOptions};
use bezchain::problem::point_offsets;
use glam::{DVec2, DVec3};
use std::path::PathBuf;

/// The picture outputs of a surface.
#[derive(clap::Args, Debug, Clone)]
pub struct PictureArgs {
    /// Write a PNG picture of the surface and its control net (two views) here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Write the same views as an SVG drawing (surface iso-curves, control net, points) here.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Size of the picture (PNG and SVG), WxH pixels.
    #[arg(long, default_value = "1600x900", value_parser = parse_pair)]
    pub png_size: [usize; 2],
}

/// The picture outputs of a run, from [`PictureArgs::add`].
#[derive(Clone, Copy, Debug)]
pub struct Pictures {
    png: Option<Output>,
    svg: Option<Output>,
    size: [u32; 2],
}

impl PictureArgs {
    /// Check the size and the outputs asked for before any work, and add them to the run's
    /// outputs.
    pub fn add(&self, outs: &mut Outputs) -> Result<Pictures> {
        let [w, h] = self.png_size;
        if !(16..=16384).contains(&w) || !(16..=16384).contains(&h) {
            return Err(usage("--png-size must be between 16x16 and 16384x16384"));
        }
        Ok(Pictures {
            png: outs.add_opt("--png", self.png.as_deref())?,
            svg: outs.add_opt("--svg", self.svg.as_deref())?,
            size: [w as u32, h as u32],
        })
    }
}

impl Pictures {
    /// True when a picture is asked for.
    #[must_use]
    pub fn wanted(&self) -> bool {
        self.png.is_some() || self.svg.is_some()
    }

    /// Width and height in pixels.
    #[must_use]
    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    /// Draw `grid` as `opts` says into the outputs asked for.
    pub fn put(&self, outs: &mut Outputs, grid: &PatchGrid<DVec3>, opts: &RenderOptions) -> Result<()> {
        if let Some(o) = self.png {
            outs.put(o, &render(grid, opts)?.to_png()?)?;
        }
        if let Some(o) = self.svg {
            outs.put(o, render_svg(grid, opts)?.as_bytes())?;
        }
        Ok(())
    }
}

/// The outputs of a 2D plot: the same picture as SVG and as PNG.
#[derive(clap::Args, Debug, Clone)]
pub struct PlotArgs {
    /// Write the plot as an SVG drawing here.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Write the same plot as a PNG picture here.
    #[arg(long)]
    pub png: Option<PathBuf>,
}

/// The plot outputs of a run, from [`PlotArgs::add`].
#[derive(Clone, Copy, Debug)]
pub struct Plots {
    svg: Option<Output>,
    png: Option<Output>,
}

impl PlotArgs {
    /// Check the outputs asked for before any work, and add them to the run's outputs.
    pub fn add(&self, outs: &mut Outputs) -> Result<Plots> {
        Ok(Plots {
            svg: outs.add_opt("--svg", self.svg.as_deref())?,
            png: outs.add_opt("--png", self.png.as_deref())?,
        })
    }
}

impl Plots {
    /// True when a plot is asked for.
    #[must_use]
    pub fn wanted(&self) -> bool {
        self.png.is_some() || self.svg.is_some()
    }

    /// Draw `plot` into the outputs asked for.
    pub fn put(&self, outs: &mut Outputs, plot: &dyn Plot) -> Result<()> {
        if let Some(o) = self.svg {
            outs.put(o, plot.svg()?.as_bytes())?;
        }
        if let Some(o) = self.png {
            outs.put(o, &plot.png()?)?;
        }
        Ok(())
    }

    /// Draw `chain` over its `data` points with their closest-point offsets (a [`CurvePlot`]
    /// under `title`) into the outputs asked for.
    pub fn put_chain(
        &self,
        outs: &mut Outputs,
        title: String,
        data: &[DVec2],
        chain: &CurveChain<DVec2>,
    ) -> Result<()> {
        let offsets = point_offsets(chain, data)?;
        let plot = CurvePlot {
            title,
            data,
            chain,
            offsets: &offsets,
        };
        self.put(outs, &plot)
    }
}
