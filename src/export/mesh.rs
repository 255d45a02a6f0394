//! Triangle meshes of patch grids, sampled by the dense evaluator ([`crate::eval::dense`]),
//! written as OBJ text or binary STL.

use crate::chain::{samples, PatchGrid};
use crate::error::{Error, Result};
use crate::eval::dense::dense_grid;
use crate::eval::Backend;
use glam::DVec3;
use std::fmt::Write as _;

/// A patch grid sampled on a regular grid in every patch: `rows × cols` vertices (rows along
/// u, columns along v, row-major), shared along the patch borders, with unit normals.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceMesh {
    /// Vertices along u.
    pub rows: usize,
    /// Vertices along v.
    pub cols: usize,
    /// The global parameters `(u, v)` of every vertex.
    pub params: Vec<[f64; 2]>,
    /// Vertex positions, on the surface to the dense evaluator's accuracy (about
    /// `4 · 2⁻²⁴ ×` the grid's extent, wherever it sits).
    pub positions: Vec<DVec3>,
    /// Unit vertex normals (`∂S/∂u × ∂S/∂v` direction; where that vanishes, e.g. at a tip
    /// collapsed to a point, the area-weighted mean of the faces around every vertex there).
    pub normals: Vec<DVec3>,
    /// Triangles as vertex indices, counter-clockwise about their normal; triangles with two
    /// corners at one point (at collapsed edges) are left out.
    pub triangles: Vec<[u32; 3]>,
}

/// Vertices that are one point: the sets of a union-find over grid neighbours closer than a
/// tolerance (collapsed edges and tips, where f32 evaluation leaves rounding-sized gaps).
struct Merged(Vec<u32>);

impl Merged {
    fn root(&mut self, mut k: u32) -> u32 {
        while self.0[k as usize] != k {
            let up = self.0[self.0[k as usize] as usize];
            self.0[k as usize] = up;
            k = up;
        }
        k
    }

    fn join(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.root(a), self.root(b));
        if ra != rb {
            self.0[ra.max(rb) as usize] = ra.min(rb);
        }
    }
}

impl SurfaceMesh {
    /// Sample `grid` with `per_patch` steps across every patch in both directions (at least 1),
    /// so patch borders and corners are vertices, on the CPU.
    pub fn from_grid(grid: &PatchGrid<DVec3>, per_patch: usize) -> Result<SurfaceMesh> {
        Self::from_grid_on(grid, per_patch, Backend::Cpu)
    }

    /// The same on `backend`. (Meshes of a fit are a few thousand vertices: the CPU is
    /// quicker than starting a GPU pipeline for them, so [`from_grid`](Self::from_grid) takes
    /// it.)
    pub fn from_grid_on(grid: &PatchGrid<DVec3>, per_patch: usize, backend: Backend) -> Result<SurfaceMesh> {
        if per_patch == 0 {
            return Err(Error::invalid("a mesh needs at least one step per patch"));
        }
        let l = grid.layout();
        let (us, vs) = (samples(l.u.breaks(), per_patch), samples(l.v.breaks(), per_patch));
        let (rows, cols) = (us.len(), vs.len());
        if rows.checked_mul(cols).is_none_or(|n| n > u32::MAX as usize / 2) {
            return Err(Error::invalid("mesh too large"));
        }
        let (points, _) = dense_grid(grid, &us, &vs, backend)?;
        let params: Vec<[f64; 2]> = us.iter().flat_map(|&u| vs.iter().map(move |&v| [u, v])).collect();
        let positions: Vec<DVec3> = points.iter().map(|p| p.position).collect();
        let extent = positions
            .iter()
            .fold((DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        let size = (extent.1 - extent.0).max_element().max(f64::MIN_POSITIVE);
        // Ten times the evaluator's rounding: neighbours this close are one point.
        let same = 1e-6 * size;
        let id = |i: usize, j: usize| (i * cols + j) as u32;
        let mut merged = Merged((0..(rows * cols) as u32).collect());
        for i in 0..rows {
            for j in 0..cols {
                let p = positions[id(i, j) as usize];
                if i + 1 < rows && p.distance(positions[id(i + 1, j) as usize]) < same {
                    merged.join(id(i, j), id(i + 1, j));
                }
                if j + 1 < cols && p.distance(positions[id(i, j + 1) as usize]) < same {
                    merged.join(id(i, j), id(i, j + 1));
                }
            }
        }
        let mut triangles = Vec::with_capacity(2 * (rows - 1) * (cols - 1));
        let mut face_sum = vec![DVec3::ZERO; rows * cols];
        for i in 0..rows - 1 {
            for j in 0..cols - 1 {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                for t in [[a, b, c], [a, c, d]] {
                    let [r0, r1, r2] = t.map(|k| merged.root(k));
                    if r0 == r1 || r1 == r2 || r0 == r2 {
                        continue;
                    }
                    let [p0, p1, p2] = t.map(|k| positions[k as usize]);
                    let n = (p1 - p0).cross(p2 - p0);
                    triangles.push(t);
                    for r in [r0, r1, r2] {
                        face_sum[r as usize] += n;
                    }
                }
            }
        }
        // Where the tangents give no direction, the faces around the merged point do.
        let normals = (0..rows * cols)
            .map(|k| {
                let root = merged.root(k as u32) as usize;
                points[k]
                    .normal
                    .or_else(|| face_sum[root].try_normalize())
                    .unwrap_or(DVec3::ZERO)
            })
            .collect();
        Ok(SurfaceMesh {
            rows,
            cols,
            params,
            positions,
            normals,
            triangles,
        })
    }

    /// The mesh as Wavefront OBJ text: positions and normals as f64 numbers, then the
    /// triangles (`f a//a b//b c//c`, 1-based).
    #[must_use]
    pub fn to_obj(&self, name: &str) -> String {
        let mut s = String::with_capacity(self.positions.len() * 100 + self.triangles.len() * 30);
        let name: String = name.chars().filter(|c| !c.is_control()).collect();
        let _ = writeln!(
            s,
            "# bezchain surface: {} x {} vertices, {} triangles",
            self.rows,
            self.cols,
            self.triangles.len()
        );
        let _ = writeln!(
            s,
            "o {}",
            if name.trim().is_empty() {
                "surface"
            } else {
                name.trim()
            }
        );
        for p in &self.positions {
            let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
        }
        for n in &self.normals {
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
        for t in &self.triangles {
            let [a, b, c] = t.map(|k| k + 1);
            let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
        }
        s
    }

    /// The mesh as binary STL: an 80-byte header, the triangle count, then per triangle its
    /// unit normal and three vertices (f32, little-endian) and a zero attribute word.
    #[must_use]
    pub fn to_stl(&self, name: &str) -> Vec<u8> {
        let mut out = Vec::with_capacity(84 + 50 * self.triangles.len());
        let mut header = [b' '; 80];
        let text = format!("bezchain surface {name}");
        for (h, b) in header.iter_mut().zip(text.bytes().filter(u8::is_ascii_graphic)) {
            *h = b;
        }
        // "solid" at the start marks ASCII STL to some readers.
        if header.starts_with(b"solid") {
            header[0] = b'S';
        }
        out.extend_from_slice(&header);
        out.extend_from_slice(&(self.triangles.len() as u32).to_le_bytes());
        let put = |out: &mut Vec<u8>, v: DVec3| {
            for c in [v.x, v.y, v.z] {
                out.extend_from_slice(&(c as f32).to_le_bytes());
            }
        };
        for t in &self.triangles {
            let [p0, p1, p2] = t.map(|k| self.positions[k as usize]);
            put(&mut out, (p1 - p0).cross(p2 - p0).normalize_or_zero());
            put(&mut out, p0);
            put(&mut out, p1);
            put(&mut out, p2);
            out.extend_from_slice(&0u16.to_le_bytes());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, GridLayout};

    fn cylinder_patch_grid() -> PatchGrid<DVec3> {
        let layout = GridLayout::new(
            ChainLayout::with_breaks(3, vec![0.0, 0.3, 1.0], Continuity::C1).unwrap(),
            ChainLayout::uniform(2, 2, Continuity::C1).unwrap(),
        );
        let design = layout.design_from(|a, b| {
            let ang = 3.0 * a;
            DVec3::new(ang.cos(), ang.sin(), 2.0 * b)
        });
        PatchGrid::new(layout, design).unwrap()
    }

    #[test]
    fn vertices_lie_on_the_surface_and_borders_are_shared() {
        let grid = cylinder_patch_grid();
        let mesh = SurfaceMesh::from_grid(&grid, 5).unwrap();
        assert_eq!((mesh.rows, mesh.cols), (2 * 5 + 1, 2 * 5 + 1));
        assert_eq!(mesh.triangles.len(), 2 * 10 * 10);
        for (p, t) in mesh.positions.iter().zip(&mesh.params) {
            assert!(p.distance(grid.eval(t[0], t[1])) < 2e-6, "{p}");
        }
        // The u break 0.3 and the v break 0.5 are sample rows.
        assert!(mesh.params.iter().any(|t| t[0] == 0.3));
        assert!(mesh.params.iter().any(|t| t[1] == 0.5));
        for (n, t) in mesh.normals.iter().zip(&mesh.params) {
            assert!((n.length() - 1.0).abs() < 1e-12);
            let (_, pu, pv) = grid.partials(t[0], t[1]);
            assert!((*n - pu.cross(pv).normalize()).length() < 1e-5);
        }
        // Triangles wind counter-clockwise about the vertex normals.
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|k| mesh.positions[k as usize]);
            assert!((b - a).cross(c - a).dot(mesh.normals[t[0] as usize]) > 0.0);
        }
    }

    #[test]
    fn collapsed_edges_drop_their_empty_triangles() {
        let layout = GridLayout::uniform((2, 2), (1, 1), Continuity::C1).unwrap();
        // The v = 1 edge is one point (a cone's apex).
        let design = vec![
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.5, 0.0, 0.5),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.5, 0.5),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(-0.5, 0.0, 0.5),
            DVec3::new(0.0, 0.0, 1.0),
        ];
        let grid = PatchGrid::new(layout, design).unwrap();
        let mesh = SurfaceMesh::from_grid(&grid, 4).unwrap();
        assert_eq!(mesh.triangles.len(), 2 * 16 - 4);
        // Far from the origin the same mesh comes out.
        let far = PatchGrid::new(
            grid.layout().clone(),
            grid.design()
                .iter()
                .map(|p| *p + DVec3::new(1000.0, 1000.0, 0.0))
                .collect(),
        )
        .unwrap();
        let moved = SurfaceMesh::from_grid(&far, 4).unwrap();
        assert_eq!(moved.triangles, mesh.triangles);
        for (a, b) in moved.normals.iter().zip(&mesh.normals) {
            assert!((*a - *b).length() < 1e-4, "{a} vs {b}");
        }
        let apex = mesh.cols - 1;
        // Every apex vertex gets the same pooled normal.
        for i in 0..mesh.rows {
            assert!((mesh.normals[i * mesh.cols + apex] - mesh.normals[apex]).length() < 1e-12);
        }
        assert!(
            (mesh.normals[apex].length() - 1.0).abs() < 1e-12,
            "the apex gets a face normal: {} at {}",
            mesh.normals[apex],
            mesh.positions[apex]
        );
    }

    #[test]
    fn obj_and_stl_carry_the_counts() {
        let grid = cylinder_patch_grid();
        let mesh = SurfaceMesh::from_grid(&grid, 3).unwrap();
        let obj = mesh.to_obj("test");
        let count = |prefix: &str| obj.lines().filter(|l| l.starts_with(prefix)).count();
        assert_eq!(count("v "), mesh.positions.len());
        assert_eq!(count("vn "), mesh.positions.len());
        assert_eq!(count("f "), mesh.triangles.len());
        let stl = mesh.to_stl("solid-looking name");
        assert_eq!(stl.len(), 84 + 50 * mesh.triangles.len());
        assert!(!stl.starts_with(b"solid"));
        assert_eq!(
            u32::from_le_bytes([stl[80], stl[81], stl[82], stl[83]]) as usize,
            mesh.triangles.len()
        );
        assert!(SurfaceMesh::from_grid(&grid, 0).is_err());
    }
}
