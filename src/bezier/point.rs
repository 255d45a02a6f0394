//! The small point trait that lets curves and patches hold `DVec2` or `DVec3`.

use glam::{DVec2, DVec3};
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Mul, Neg, Sub};

/// A point or vector in the plane or in space, with f64 coordinates.
pub trait Vector:
    Copy
    + Debug
    + PartialEq
    + Send
    + Sync
    + Add<Output = Self>
    + AddAssign
    + Sub<Output = Self>
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
    + 'static
{
    /// Number of coordinates (2 or 3).
    const DIM: usize;
    /// The origin.
    const ZERO: Self;
    /// Dot product.
    fn dot(self, other: Self) -> f64;
    /// Coordinate `i` (`0 <= i < DIM`).
    fn coord(self, i: usize) -> f64;
    /// A point from its coordinates (`c.len() >= DIM`; extra values are ignored).
    fn from_coords(c: &[f64]) -> Self;
    /// Squared Euclidean length.
    #[inline]
    fn length_squared(self) -> f64 {
        self.dot(self)
    }
    /// Euclidean length.
    #[inline]
    fn length(self) -> f64 {
        self.dot(self).sqrt()
    }
    /// Linear interpolation `self (1 - t) + other t`, exact at both ends.
    #[inline]
    fn lerp_to(self, other: Self, t: f64) -> Self {
        self * (1.0 - t) + other * t
    }
    /// Largest absolute coordinate.
    fn max_abs(self) -> f64 {
        (0..Self::DIM).map(|i| self.coord(i).abs()).fold(0.0, f64::max)
    }
    /// True when every coordinate is finite.
    fn is_finite_point(self) -> bool {
        (0..Self::DIM).all(|i| self.coord(i).is_finite())
    }
}

impl Vector for DVec2 {
    const DIM: usize = 2;
    const ZERO: Self = DVec2::ZERO;
    #[inline]
    fn dot(self, other: Self) -> f64 {
        DVec2::dot(self, other)
    }
    #[inline]
    fn coord(self, i: usize) -> f64 {
        self[i]
    }
    #[inline]
    fn from_coords(c: &[f64]) -> Self {
        DVec2::new(c[0], c[1])
    }
}

impl Vector for DVec3 {
    const DIM: usize = 3;
    const ZERO: Self = DVec3::ZERO;
    #[inline]
    fn dot(self, other: Self) -> f64 {
        DVec3::dot(self, other)
    }
    #[inline]
    fn coord(self, i: usize) -> f64 {
        self[i]
    }
    #[inline]
    fn from_coords(c: &[f64]) -> Self {
        DVec3::new(c[0], c[1], c[2])
    }
}

/// True when `a` and `b` are the same points to `1e-9` of their largest coordinate.
pub fn same_points<P: Vector>(a: &[P], b: &[P]) -> bool {
    let scale = b.iter().fold(1.0_f64, |m, p| m.max(p.max_abs()));
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (*x - *y).max_abs() <= 1e-9 * scale)
}
