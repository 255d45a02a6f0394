//! Lofting a blade into a 3D point cloud: sections at the stations or interpolated between
//! them (monotone cubic), placed by chord, pitch axis, twist and offsets, with optional
//! seeded Gaussian noise and shuffling to imitate an unordered scan.
//!
//! Axes ([`Axes::Section`]): z is the span (radius), x runs along the chord (leading edge →
//! trailing edge at zero twist), y is the thickness direction (upper surface towards +y). A
//! unit-chord section point `(u, v)` of station `(r, c, θ, a, prebend, sweep, n)` (`n` the
//! normal offset) goes to `x = sweep + c (u - a) cos θ + (c v + n) sin θ`,
//! `y = prebend - c (u - a) sin θ + (c v + n) cos θ`, `z = r`: scaled by the chord about the
//! pitch axis `(a, 0)`, shifted by `n` along the thickness direction, then turned by the twist θ
//! so that a positive twist raises the leading edge (a rotation by -θ about +z), then offset.
//! Blades in [`Axes::Turbine`] are placed the same way and then have x and y swapped.

use super::blade::{Axes, Blade, Blend};
use super::gaussian::Gaussian;
use super::interp::{Pchip, ShapePchip};
use super::points::{Cloud, Grid};
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// The largest cloud `loft` builds (24 bytes a point: 2.4 GB).
pub const MAX_CLOUD_POINTS: usize = 100_000_000;

/// The fewest points a lofted section may have.
pub const MIN_SECTION_POINTS: usize = 5;

/// How to loft a blade.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoftOptions {
    /// Points per section. Default `None`: 82 for NACA sections, a file aerofoil's own count
    /// (the largest of them when stations use different aerofoils). At least 5.
    pub points_per_section: Option<usize>,
    /// Number of sections, spaced uniformly in radius from the first station to the last.
    /// Default `None`: one section at every station. At least 2.
    pub sections: Option<usize>,
    /// Standard deviation of the Gaussian noise added to every coordinate, as a fraction of
    /// the largest chord. Default 0 (no noise).
    pub noise: f64,
    /// Randomise the order of the points (the cloud then has no grid). Default false.
    pub shuffle: bool,
    /// Seed of the noise and the shuffle. Default 0.
    pub seed: u64,
}

impl Default for LoftOptions {
    fn default() -> Self {
        LoftOptions {
            points_per_section: None,
            sections: None,
            noise: 0.0,
            shuffle: false,
            seed: 0,
        }
    }
}

/// Everything that places one section.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Placement {
    radius: f64,
    chord: f64,
    twist_deg: f64,
    pitch_axis: f64,
    prebend: f64,
    sweep: f64,
    normal_offset: f64,
}

impl Placement {
    /// Place the unit-chord `shape` in space (see the module doc for the formula).
    fn place(&self, shape: &[DVec2], axes: Axes, out: &mut [DVec3]) {
        let (s, c) = self.twist_deg.to_radians().sin_cos();
        for (o, q) in out.iter_mut().zip(shape) {
            let u = (q.x - self.pitch_axis) * self.chord;
            let v = q.y * self.chord + self.normal_offset;
            let (x, y) = (self.sweep + u * c + v * s, self.prebend - u * s + v * c);
            *o = match axes {
                Axes::Section => DVec3::new(x, y, self.radius),
                Axes::Turbine => DVec3::new(y, x, self.radius),
            };
        }
    }
}

/// Spanwise interpolants of the placement values.
struct Profile {
    chord: Pchip,
    twist_deg: Pchip,
    pitch_axis: Pchip,
    prebend: Pchip,
    sweep: Pchip,
    normal_offset: Pchip,
}

impl Profile {
    fn new(blade: &Blade) -> Profile {
        let r: Vec<f64> = blade.stations.iter().map(|s| s.radius).collect();
        let col = |f: fn(&super::blade::Station) -> f64| {
            Pchip::new(&r, &blade.stations.iter().map(f).collect::<Vec<_>>())
        };
        Profile {
            chord: col(|s| s.chord),
            twist_deg: col(|s| s.twist_deg),
            pitch_axis: col(|s| s.pitch_axis),
            prebend: col(|s| s.prebend),
            sweep: col(|s| s.sweep),
            normal_offset: col(|s| s.normal_offset),
        }
    }

    fn at(&self, radius: f64) -> Placement {
        Placement {
            radius,
            // PCHIP never overshoots, so the chord stays >= 0; the max guards the last ulp.
            chord: self.chord.eval(radius).max(0.0),
            twist_deg: self.twist_deg.eval(radius),
            pitch_axis: self.pitch_axis.eval(radius),
            prebend: self.prebend.eval(radius),
            sweep: self.sweep.eval(radius),
            normal_offset: self.normal_offset.eval(radius),
        }
    }
}

/// Where each section's shape comes from.
enum Shapes {
    /// Every section uses this one.
    One(Vec<DVec2>),
    /// Section `k` is station `k`'s shape.
    PerStation(Vec<Vec<DVec2>>),
    /// Interpolated over radius between the stations' shapes.
    Blend(ShapePchip),
    /// Interpolated over relative thickness between master shapes (section `k` at `rthick[k]`),
    /// then normalised (leading edge at the origin, unit x extent).
    Thickness { masters: ShapePchip, rthick: Vec<f64> },
}

/// `m` sections of `n` points, when a cloud may have that many.
fn bounded_total(m: usize, n: usize) -> Result<usize> {
    m.checked_mul(n)
        .filter(|&t| t <= MAX_CLOUD_POINTS)
        .ok_or_else(|| {
            Error::invalid(format!(
                "{m} sections x {n} points is more than the {MAX_CLOUD_POINTS} points a cloud may have"
            ))
        })
}

/// Move the leading edge (the point of smallest x) of a blended shape to the origin and scale
/// its x extent to 1, as WISDEM does after blending by thickness.
fn normalise(shape: &mut [DVec2]) {
    let le = shape
        .iter()
        .copied()
        .min_by(|a, b| a.x.total_cmp(&b.x))
        .unwrap_or(DVec2::ZERO);
    let hi = shape.iter().map(|p| p.x).fold(f64::MIN, f64::max);
    let extent = hi - le.x;
    if extent > 0.0 {
        for p in shape.iter_mut() {
            *p = (*p - le) / extent;
        }
    }
}

impl Blade {
    /// The number of points per section `opts` gives for this blade.
    #[must_use]
    pub fn points_per_section(&self, opts: &LoftOptions) -> usize {
        opts.points_per_section.unwrap_or_else(|| {
            let used = |a: usize| match &self.blend {
                Blend::Radius => self.stations.iter().any(|s| s.aerofoil == a),
                Blend::Thickness { masters, .. } => masters.iter().any(|m| m.1 == a),
            };
            (0..self.aerofoils.len())
                .filter(|&a| used(a))
                .map(|a| self.aerofoils[a].native_points())
                .max()
                .unwrap_or(super::blade::DEFAULT_NACA_POINTS)
        })
    }

    /// Re-check what [`Blade::from_json`] validated, for blades built or edited in code.
    fn check(&self) -> Result<()> {
        let st = &self.stations;
        let finite = st.iter().all(|s| {
            [
                s.radius,
                s.chord,
                s.twist_deg,
                s.pitch_axis,
                s.prebend,
                s.sweep,
                s.normal_offset,
            ]
            .iter()
            .all(|v| v.is_finite())
        });
        let ok = st.len() >= 2
            && finite
            && st.windows(2).all(|w| w[0].radius < w[1].radius)
            && st
                .iter()
                .all(|s| s.chord >= 0.0 && s.aerofoil < self.aerofoils.len())
            && self.max_chord() > 0.0
            && match &self.blend {
                Blend::Radius => true,
                Blend::Thickness { masters, rthick } => {
                    !masters.is_empty()
                        && rthick.len() == st.len()
                        && rthick.iter().all(|t| t.is_finite())
                        && masters.iter().all(|m| m.1 < self.aerofoils.len())
                        && masters.windows(2).all(|w| w[0].0 < w[1].0)
                }
            };
        if ok {
            Ok(())
        } else {
            Err(Error::invalid(
                "a blade needs at least 2 stations with finite values, increasing radii, \
                 chords >= 0 (not all zero) and known aerofoils",
            ))
        }
    }

    /// The radii of the sections `opts` asks for: the stations', or `sections` uniformly
    /// spaced from the first station to the last (both included exactly).
    #[must_use]
    pub fn section_radii(&self, opts: &LoftOptions) -> Vec<f64> {
        let r: Vec<f64> = self.stations.iter().map(|s| s.radius).collect();
        match (opts.sections, r.first(), r.last()) {
            (None, ..) | (_, None, _) | (_, _, None) => r,
            (Some(m), Some(&a), Some(&b)) => {
                let last = m.saturating_sub(1).max(1) as f64;
                (0..m)
                    .map(|i| {
                        if i + 1 == m {
                            b
                        } else {
                            a + (b - a) * i as f64 / last
                        }
                    })
                    .collect()
            }
        }
    }

    /// Loft the blade into a cloud of `sections × points_per_section` points, section-major
    /// with a [`Grid`] unless shuffled. Noise and shuffle are reproducible from the seed
    /// (the same cloud on any number of threads).
    pub fn loft(&self, opts: &LoftOptions) -> Result<Cloud> {
        if opts.sections.is_some_and(|m| m < 2) {
            return Err(Error::invalid(format!(
                "sections must be at least 2 (got {})",
                opts.sections.unwrap_or(0)
            )));
        }
        // Bounded before the radii are made.
        if let Some(m) = opts.sections {
            bounded_total(m, self.points_per_section(opts))?;
        }
        let at = opts.sections.map(|_| self.section_radii(opts));
        self.loft_sections(at.as_deref(), opts)
    }

    /// Loft sections at the given radii (within the first and last stations', increasing),
    /// interpolated as [`LoftOptions::sections`] interpolates them; `opts.sections` is
    /// ignored. The blade between its stations: where a surface fitted to the stations is
    /// checked.
    pub fn loft_at(&self, radii: &[f64], opts: &LoftOptions) -> Result<Cloud> {
        let (first, last) = match (self.stations.first(), self.stations.last()) {
            (Some(a), Some(b)) => (a.radius, b.radius),
            _ => return Err(Error::invalid("a blade needs at least 2 stations")),
        };
        let inside = radii.iter().all(|r| r.is_finite() && (first..=last).contains(r));
        if radii.is_empty() || !inside || !radii.windows(2).all(|w| w[0] < w[1]) {
            return Err(Error::invalid(format!(
                "loft radii must be increasing and within the stations' {first} ..= {last}"
            )));
        }
        self.loft_sections(Some(radii), opts)
    }

    /// Loft at the stations (`at` none) or at the radii `at`.
    fn loft_sections(&self, at: Option<&[f64]>, opts: &LoftOptions) -> Result<Cloud> {
        let n = self.points_per_section(opts);
        if n < MIN_SECTION_POINTS {
            return Err(Error::invalid(match opts.points_per_section {
                Some(_) => format!("points_per_section must be at least {MIN_SECTION_POINTS} (got {n})"),
                None => format!(
                    "the aerofoils have only {n} points; ask for at least {MIN_SECTION_POINTS} points per \
                     section to resample them"
                ),
            }));
        }
        if !(opts.noise.is_finite() && opts.noise >= 0.0) {
            return Err(Error::invalid(format!(
                "noise must be a finite fraction >= 0 of the largest chord (got {})",
                opts.noise
            )));
        }
        self.check()?;
        let m = at.map_or(self.stations.len(), <[f64]>::len);
        let total = bounded_total(m, n)?;

        let alike = self.aerofoils.len() > 1;
        let sampled = self
            .aerofoils
            .iter()
            .map(|a| a.sample(n, alike))
            .collect::<Result<Vec<_>>>()?;
        let radii_of_stations: Vec<f64> = self.stations.iter().map(|s| s.radius).collect();
        let shapes = if let Blend::Thickness { masters, rthick } = &self.blend {
            if masters.len() == 1 {
                Shapes::One(sampled[masters[0].1].clone())
            } else {
                let t: Vec<f64> = masters.iter().map(|m| m.0).collect();
                let shapes = masters.iter().map(|m| sampled[m.1].clone()).collect();
                let rthick = match at {
                    None => rthick.clone(),
                    Some(radii) => {
                        let f = Pchip::new(&radii_of_stations, rthick);
                        radii.iter().map(|&r| f.eval(r)).collect()
                    }
                };
                Shapes::Thickness {
                    masters: ShapePchip::new(&t, shapes),
                    rthick,
                }
            }
        } else if self.aerofoils.len() == 1 {
            Shapes::One(sampled[0].clone())
        } else {
            let per_station: Vec<Vec<DVec2>> = self
                .stations
                .iter()
                .map(|s| sampled[s.aerofoil].clone())
                .collect();
            match at {
                None => Shapes::PerStation(per_station),
                Some(_) => Shapes::Blend(ShapePchip::new(&radii_of_stations, per_station)),
            }
        };
        let placements: Vec<Placement> = match at {
            None => self
                .stations
                .iter()
                .map(|s| Placement {
                    radius: s.radius,
                    chord: s.chord,
                    twist_deg: s.twist_deg,
                    pitch_axis: s.pitch_axis,
                    prebend: s.prebend,
                    sweep: s.sweep,
                    normal_offset: s.normal_offset,
                })
                .collect(),
            Some(radii) => {
                let profile = Profile::new(self);
                radii.iter().map(|&r| profile.at(r)).collect()
            }
        };

        let sigma = opts.noise * self.max_chord();
        let normal = Gaussian::new(sigma).map_err(|e| Error::invalid(format!("noise: {e}")))?;
        let mut points = vec![DVec3::ZERO; total];
        points.par_chunks_mut(n).enumerate().for_each_init(
            || vec![DVec2::ZERO; n],
            |buf, (k, out)| {
                let shape: &[DVec2] = match &shapes {
                    Shapes::One(s) => s,
                    Shapes::PerStation(s) => &s[k],
                    Shapes::Blend(b) => {
                        b.eval_into(placements[k].radius, buf);
                        buf
                    }
                    Shapes::Thickness { masters, rthick } => {
                        masters.eval_into(rthick[k], buf);
                        normalise(buf);
                        buf
                    }
                };
                placements[k].place(shape, self.axes, out);
                if sigma > 0.0 {
                    // One stream per section: the same noise whatever the thread count.
                    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
                    rng.set_stream(k as u64 + 1);
                    for p in out.iter_mut() {
                        *p += DVec3::new(
                            normal.sample(&mut rng),
                            normal.sample(&mut rng),
                            normal.sample(&mut rng),
                        );
                    }
                }
            },
        );
        if let Some(k) = points.iter().position(|p| !p.is_finite()) {
            return Err(Error::invalid(format!(
                "section {} of the lofted blade is not finite (station values too large or too close?)",
                k / n
            )));
        }
        if opts.shuffle {
            let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
            rng.set_stream(0);
            points.shuffle(&mut rng);
        }
        let grid = (!opts.shuffle).then_some(Grid {
            sections: m,
            per_section: n,
        });
        Ok(Cloud { points, grid })
    }
}
