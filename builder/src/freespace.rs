//! Free space: which points a probe or a path may occupy (DESIGN.md section 3.2).
//!
//! Inputs: the scene, its ray-casting structure, [`FreeSpaceParams`].
//! Outputs: [`FreeSpace`] (a voxel grid with occupancy, clearance and the chosen
//! navigable component) and [`FreeSpaceStats`].
//!
//! Steps: (1) voxelize: a voxel is occupied when a triangle overlaps it (exact
//! triangle/box separating-axis test); (2) clearance: exact Euclidean distance
//! transform (Felzenszwalb and Huttenlocher 2012, separable 1D lower envelopes)
//! from each voxel centre to the nearest occupied centre; (3) classify blocks of
//! voxels with a few ray casts from their most open voxel: *solid* (inside a
//! closed object: most hits are back faces), *inside* (a floor below and walls
//! around: the downward ray and most horizontal rays hit front faces, the
//! horizontal ones steep faces), or *open*;
//! (4) navigable voxels are free, have clearance ≥ r, and are *inside* blocks
//! (`inside`) or non-solid blocks reachable from the grid border (`outside`);
//! (5) 6-connected components; `--start` picks one, else the one the scene's
//! surfaces face into most (`inside`) or the one around the scene (`outside`).
//!
//! Parameters (defaults): at most 256 cells on the long axis (`max_cells`);
//! r = 0.5 % of the bounding-box diagonal L (`near_rel`) unless given in metres;
//! the grid is padded by 5 % of the longest extent so `outside` space surrounds
//! the scene. Memory is about 13 bytes a cell: at most 40M cells (≈ 0.5 GiB).
//! Everything is deterministic: ray casts and sums run in fixed order.

use crate::raycast::{Packing, Ray, RayScene};
use exploremaps_scenes::{Aabb, Scene};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Which free space is navigable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpaceMode {
    /// Architecture and interiors: enclosed space above a floor.
    Inside,
    /// Objects and exteriors: the space around the scene (the paper's behaviour).
    Outside,
    /// Chooses from how enclosed the scene is, and reports the choice.
    Auto,
}

impl SpaceMode {
    pub fn name(self) -> &'static str {
        match self {
            SpaceMode::Inside => "inside",
            SpaceMode::Outside => "outside",
            SpaceMode::Auto => "auto",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct FreeSpaceParams {
    pub space: SpaceMode,
    /// Cells on the longest axis of the (padded) bounding box.
    pub max_cells: usize,
    /// Near distance r as a fraction of the bounding-box diagonal.
    pub near_rel: f32,
    /// Near distance in metres; overrides `near_rel` when given.
    pub near_m: Option<f32>,
    /// Picks the navigable component containing this point.
    pub start: Option<Vec3>,
}

impl Default for FreeSpaceParams {
    fn default() -> Self {
        FreeSpaceParams { space: SpaceMode::Auto, max_cells: 256, near_rel: 0.005, near_m: None, start: None }
    }
}

/// Scenes whose free space hits front faces at least this often are interiors.
const ENCLOSURE_INSIDE: f32 = 0.6;
/// Voxels per block edge for the ray classification.
const BLOCK: usize = 4;
const MAX_TOTAL_CELLS: usize = 40_000_000;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FreeSpaceError {
    #[error("the start point {0} is outside the scene's bounds; pick a point inside them")]
    StartOutside(Vec3),
    #[error("the start point {0} is inside geometry; move it into open space")]
    StartInGeometry(Vec3),
    #[error("the start point {point} has {clearance:.3} units of clearance, less than the near distance {near:.3}; move it away from surfaces or lower the near distance")]
    StartTooNarrow { point: Vec3, clearance: f32, near: f32 },
    #[error("the start point {0} is not in {1} space (below the floor, inside an object, or outside the building); pick another or change --space")]
    StartNotNavigable(Vec3, &'static str),
    #[error("no navigable {0} space with clearance {1:.3} units was found; try --space {2} or a smaller near distance")]
    Nothing(&'static str, f32, &'static str),
    #[error("--max-cells {0} is out of range (8 to 2048)")]
    BadResolution(usize),
}

/// A regular grid of cubic voxels.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Corner of voxel (0, 0, 0).
    pub origin: Vec3,
    /// Edge length, scene units.
    pub voxel: f32,
    pub dims: [usize; 3],
}

impl Grid {
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }
    pub fn coords(&self, i: usize) -> [usize; 3] {
        let (x, rest) = (i % self.dims[0], i / self.dims[0]);
        [x, rest % self.dims[1], rest / self.dims[1]]
    }
    pub fn center(&self, c: [usize; 3]) -> Vec3 {
        self.origin + (Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) + 0.5) * self.voxel
    }
    /// The voxel holding `p`, if inside the grid.
    pub fn cell(&self, p: Vec3) -> Option<[usize; 3]> {
        let q = (p - self.origin) / self.voxel;
        let c = [q.x.floor(), q.y.floor(), q.z.floor()];
        let inside = c.iter().zip(self.dims).all(|(&v, d)| v >= 0.0 && v < d as f32);
        inside.then(|| c.map(|v| v as usize))
    }
    /// The up to 6 face neighbours of a voxel.
    fn neighbours(&self, c: [usize; 3]) -> impl Iterator<Item = [usize; 3]> + '_ {
        (0..6).filter_map(move |k| {
            let (axis, up) = (k / 2, k % 2 == 1);
            let mut n = c;
            if up {
                n[axis] += 1;
                (n[axis] < self.dims[axis]).then_some(n)
            } else {
                n[axis] = c[axis].checked_sub(1)?;
                Some(n)
            }
        })
    }
}

/// Navigable space of one scene.
#[derive(Clone, Debug)]
pub struct FreeSpace {
    pub grid: Grid,
    pub occupied: Vec<bool>,
    /// Distance from each voxel centre to the nearest occupied voxel centre,
    /// scene units (0 for occupied voxels).
    pub clearance: Vec<f32>,
    /// Voxels of the chosen navigable component.
    pub navigable: Vec<bool>,
    /// Near distance r, scene units.
    pub near: f32,
    /// `Inside` or `Outside` (never `Auto`).
    pub space: SpaceMode,
    /// Scene bounds (unpadded).
    pub bounds: Aabb,
}

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FreeSpaceStats {
    pub dims: [usize; 3],
    pub voxel: f32,
    pub near: f32,
    pub occupied: usize,
    /// Free voxels that passed clearance and classification, in all components.
    pub candidates: usize,
    pub components: usize,
    pub navigable: usize,
    /// Fraction of rays from free space that hit front faces (1 = closed interior).
    pub enclosure: f32,
    pub space: &'static str,
    /// Why this space was chosen: "given" or "auto (enclosure …)".
    pub space_reason: String,
    pub rays: usize,
    pub seconds: f64,
}

impl FreeSpace {
    pub fn is_navigable(&self, p: Vec3) -> bool {
        self.grid.cell(p).is_some_and(|c| self.navigable[self.grid.index(c)])
    }

    /// Clearance at the voxel holding `p` (0 outside the grid). A lower bound on the
    /// true distance to the surface up to one voxel diagonal.
    pub fn clearance_at(&self, p: Vec3) -> f32 {
        self.grid.cell(p).map_or(0.0, |c| self.clearance[self.grid.index(c)])
    }

    /// Centres of all navigable voxels, in grid order.
    pub fn navigable_points(&self) -> Vec<Vec3> {
        (0..self.grid.len()).filter(|&i| self.navigable[i]).map(|i| self.grid.center(self.grid.coords(i))).collect()
    }

    /// The navigable voxel centre with the most clearance (ties: lowest index).
    pub fn most_open_point(&self) -> Option<Vec3> {
        (0..self.grid.len())
            .filter(|&i| self.navigable[i])
            .max_by(|&a, &b| self.clearance[a].total_cmp(&self.clearance[b]).then(b.cmp(&a)))
            .map(|i| self.grid.center(self.grid.coords(i)))
    }
}

/// Computes the navigable free space of a scene.
pub fn free_space(scene: &Scene, rays: &RayScene, params: &FreeSpaceParams) -> Result<(FreeSpace, FreeSpaceStats), FreeSpaceError> {
    let started = Instant::now();
    if !(8..=2048).contains(&params.max_cells) {
        return Err(FreeSpaceError::BadResolution(params.max_cells));
    }
    let bounds = scene.bounds();
    let near = match params.near_m {
        Some(m) => m / scene.metres_per_unit,
        None => params.near_rel * bounds.diagonal(),
    };
    let grid = make_grid(&bounds, params.max_cells);
    let occupied = voxelize(scene, &grid);
    let clearance: Vec<f32> = distance_transform(&grid, &occupied).into_iter().map(|d2| d2.sqrt() * grid.voxel).collect();

    let (classes, enclosure, ray_count) = classify_blocks(&grid, &occupied, &clearance, rays);
    let (space, space_reason) = match params.space {
        SpaceMode::Auto if enclosure >= ENCLOSURE_INSIDE => (SpaceMode::Inside, format!("auto: enclosure {enclosure:.2} ≥ {ENCLOSURE_INSIDE}")),
        SpaceMode::Auto => (SpaceMode::Outside, format!("auto: enclosure {enclosure:.2} < {ENCLOSURE_INSIDE}")),
        given => (given, "given".to_string()),
    };
    let block_dims = grid.dims.map(|d| d.div_ceil(BLOCK));
    let class_of = |c: [usize; 3]| classes[c[0] / BLOCK + block_dims[0] * (c[1] / BLOCK + block_dims[1] * (c[2] / BLOCK))];
    let candidate: Vec<bool> = (0..grid.len())
        .into_par_iter()
        .map(|i| {
            let class = class_of(grid.coords(i));
            !occupied[i] && clearance[i] >= near && if space == SpaceMode::Inside { class == Class::Inside } else { class != Class::Solid }
        })
        .collect();
    let (labels, sizes) = components(&grid, &candidate);

    let chosen = match params.start {
        Some(p) => {
            let c = grid.cell(p).ok_or(FreeSpaceError::StartOutside(p))?;
            let i = grid.index(c);
            let hits = rays.intersect_batch(&probe_directions().map(|d| Ray::new(p, d)), Packing::Single);
            if occupied[i] || classify(&hits) == Class::Solid {
                return Err(FreeSpaceError::StartInGeometry(p));
            }
            if clearance[i] < near {
                return Err(FreeSpaceError::StartTooNarrow { point: p, clearance: clearance[i], near });
            }
            if labels[i] == NONE {
                return Err(FreeSpaceError::StartNotNavigable(p, space.name()));
            }
            labels[i]
        }
        None if space == SpaceMode::Outside => {
            // The padding guarantees free space at the grid's corner, around the scene.
            let corner = labels[0];
            if corner == NONE {
                return Err(FreeSpaceError::Nothing("outside", near, "inside"));
            }
            corner
        }
        None => most_faced_component(scene, &grid, &labels, sizes.len(), near)
            .ok_or(FreeSpaceError::Nothing("inside", near, "outside"))?,
    };
    let navigable: Vec<bool> = labels.iter().map(|&l| l == chosen).collect();
    let stats = FreeSpaceStats {
        dims: grid.dims,
        voxel: grid.voxel,
        near,
        occupied: occupied.iter().filter(|&&o| o).count(),
        candidates: candidate.iter().filter(|&&c| c).count(),
        components: sizes.len(),
        navigable: sizes[chosen as usize],
        enclosure,
        space: space.name(),
        space_reason,
        rays: ray_count,
        seconds: started.elapsed().as_secs_f64(),
    };
    Ok((FreeSpace { grid, occupied, clearance, navigable, near, space, bounds }, stats))
}

fn make_grid(bounds: &Aabb, max_cells: usize) -> Grid {
    let extent = bounds.extent();
    let pad = 0.05 * extent.max_element();
    let padded = extent + Vec3::splat(2.0 * pad);
    let mut voxel = padded.max_element() / max_cells as f32;
    // Keep the total within the memory bound (flat scenes are far from cubic).
    let cells = |v: f32| (padded / v).ceil();
    while { let c = cells(voxel); c.x * c.y * c.z } > MAX_TOTAL_CELLS as f32 {
        voxel *= 1.1;
    }
    // Two extra voxels of margin so the border is always free.
    let dims = (cells(voxel) + 4.0).to_array().map(|v| v as usize);
    Grid { origin: bounds.min - Vec3::splat(pad + 2.0 * voxel), voxel, dims }
}

/// Marks every voxel a triangle overlaps. Per triangle, only the voxels near its
/// plane are tested: for each column along the plane's dominant axis, the
/// plane's span over the column bounds the candidates.
fn voxelize(scene: &Scene, grid: &Grid) -> Vec<bool> {
    let marks: Vec<AtomicBool> = (0..grid.len()).map(|_| AtomicBool::new(false)).collect();
    let half = Vec3::splat(0.5 * grid.voxel);
    (0..scene.triangles.len()).into_par_iter().for_each(|t| {
        let tri = scene.triangle(t);
        let lo = tri[0].min(tri[1]).min(tri[2]);
        let hi = tri[0].max(tri[1]).max(tri[2]);
        let to_cell = |p: Vec3| ((p - grid.origin) / grid.voxel).floor();
        let (c0, c1) = (to_cell(lo).max(Vec3::ZERO), to_cell(hi));
        let max_c = Vec3::new(grid.dims[0] as f32 - 1.0, grid.dims[1] as f32 - 1.0, grid.dims[2] as f32 - 1.0);
        let c1 = c1.min(max_c);
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let axis = if n.x.abs() >= n.y.abs() && n.x.abs() >= n.z.abs() { 0 } else if n.y.abs() >= n.z.abs() { 1 } else { 2 };
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for a in c0[u] as usize..=c1[u] as usize {
            for b in c0[v] as usize..=c1[v] as usize {
                // Plane height along `axis` over the column's footprint corners.
                let (mut k_lo, mut k_hi) = (c0[axis], c1[axis]);
                if n[axis] != 0.0 {
                    let mut span = (f32::INFINITY, f32::NEG_INFINITY);
                    for (du, dv) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                        let pu = grid.origin[u] + (a as f32 + du) * grid.voxel;
                        let pv = grid.origin[v] + (b as f32 + dv) * grid.voxel;
                        let h = tri[0][axis] - (n[u] * (pu - tri[0][u]) + n[v] * (pv - tri[0][v])) / n[axis];
                        span = (span.0.min(h), span.1.max(h));
                    }
                    k_lo = k_lo.max(((span.0 - grid.origin[axis]) / grid.voxel).floor() - 1.0);
                    k_hi = k_hi.min(((span.1 - grid.origin[axis]) / grid.voxel).floor() + 1.0);
                }
                let mut k = k_lo;
                while k <= k_hi {
                    let mut c = [0usize; 3];
                    c[axis] = k as usize;
                    c[u] = a;
                    c[v] = b;
                    let centre = grid.center(c);
                    if triangle_box_overlap(centre, half, &tri) {
                        marks[grid.index(c)].store(true, Ordering::Relaxed);
                    }
                    k += 1.0;
                }
            }
        }
    });
    marks.into_iter().map(AtomicBool::into_inner).collect()
}

/// Separating-axis test of a triangle against an axis-aligned box (Akenine-Möller
/// 2001): box axes, the triangle's normal, and the nine edge × axis products.
pub(crate) fn triangle_box_overlap(centre: Vec3, half: Vec3, tri: &[Vec3; 3]) -> bool {
    let v = tri.map(|p| p - centre);
    let separated = |axis: Vec3| {
        let p = v.map(|q| q.dot(axis));
        let r = half.dot(axis.abs());
        p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r
    };
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let normal = edges[0].cross(edges[1]);
    if [Vec3::X, Vec3::Y, Vec3::Z].into_iter().any(separated) || separated(normal) {
        return false;
    }
    for e in edges {
        for a in [Vec3::X, Vec3::Y, Vec3::Z] {
            let axis = e.cross(a);
            if axis.length_squared() > 1e-20 && separated(axis) {
                return false;
            }
        }
    }
    true
}

/// Squared distance, in voxels, from each voxel centre to the nearest occupied
/// voxel centre: exact, by three passes of the 1D lower-envelope transform.
pub(crate) fn distance_transform(grid: &Grid, occupied: &[bool]) -> Vec<f32> {
    const FAR: f32 = 1e20;
    let mut d: Vec<f32> = occupied.iter().map(|&o| if o { 0.0 } else { FAR }).collect();
    let [nx, ny, nz] = grid.dims;
    for axis in 0..3 {
        let (n, stride) = match axis {
            0 => (nx, 1),
            1 => (ny, nx),
            _ => (nz, nx * ny),
        };
        // Every line along `axis` starts at a voxel whose coordinate on it is 0.
        let starts: Vec<usize> = (0..grid.len()).filter(|&i| grid.coords(i)[axis] == 0).collect();
        let lines: Vec<Vec<f32>> = starts
            .par_iter()
            .map(|&s| {
                let f: Vec<f32> = (0..n).map(|k| d[s + k * stride]).collect();
                lower_envelope(&f)
            })
            .collect();
        for (&s, line) in starts.iter().zip(lines) {
            for (k, value) in line.into_iter().enumerate() {
                d[s + k * stride] = value;
            }
        }
    }
    d
}

/// 1D squared distance transform: out[q] = min_p (q − p)² + f[p].
fn lower_envelope(f: &[f32]) -> Vec<f32> {
    let n = f.len();
    let mut out = vec![0.0; n];
    let mut v = vec![0usize; n];
    let mut z = vec![0.0f32; n + 1];
    let mut k = 0;
    z[0] = f32::NEG_INFINITY;
    z[1] = f32::INFINITY;
    let intersect = |q: usize, p: usize| ((f[q] + (q * q) as f32) - (f[p] + (p * p) as f32)) / (2.0 * q as f32 - 2.0 * p as f32);
    for q in 1..n {
        let mut s = intersect(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = intersect(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f32::INFINITY;
    }
    k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f32 {
            k += 1;
        }
        let dq = q as f32 - v[k] as f32;
        *o = dq * dq + f[v[k]];
    }
    out
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Class {
    /// No free voxel, or never classified.
    Unknown,
    /// Inside a closed object: rays from it mostly see back faces.
    Solid,
    /// A floor below and walls around.
    Inside,
    Open,
}

/// Ray directions of the classification: 8 horizontal, then up, then down.
fn probe_directions() -> [Vec3; 10] {
    let mut d = [Vec3::ZERO; 10];
    for (k, item) in d.iter_mut().enumerate().take(8) {
        let a = std::f32::consts::TAU * (k as f32 + 0.5) / 8.0;
        *item = Vec3::new(a.cos(), 0.0, a.sin());
    }
    d[8] = Vec3::Y;
    d[9] = Vec3::NEG_Y;
    d
}

/// Whether ray `i` of [`probe_directions`] hit a surface's front.
fn front_hit(hits: &[Option<crate::raycast::Hit>], i: usize) -> bool {
    hits[i].is_some_and(|hit| hit.normal.dot(probe_directions()[i]) < 0.0)
}

/// Classifies a point from the hits of the [`probe_directions`] rays cast from it.
/// Walls must be steep: above the eaves of a courtyard, horizontal rays meet
/// roof slopes, and that space is above the roof, not inside.
fn classify(hits: &[Option<crate::raycast::Hit>]) -> Class {
    let fronts = (0..hits.len()).filter(|&i| front_hit(hits, i)).count();
    let backs = hits.iter().filter(|h| h.is_some()).count() - fronts;
    let walls = (0..8).filter(|&i| front_hit(hits, i) && hits[i].is_some_and(|h| h.normal.y.abs() < 0.7)).count();
    if backs > fronts {
        Class::Solid
    } else if front_hit(hits, 9) && walls >= 6 {
        Class::Inside
    } else {
        Class::Open
    }
}

/// Classifies each block of BLOCK³ voxels from its most open free voxel, and
/// measures enclosure over blocks in the middle 60 % of the scene.
fn classify_blocks(grid: &Grid, occupied: &[bool], clearance: &[f32], rays: &RayScene) -> (Vec<Class>, f32, usize) {
    let bd = grid.dims.map(|d| d.div_ceil(BLOCK));
    let blocks = bd[0] * bd[1] * bd[2];
    // The sample point of each block: its free voxel with the most clearance.
    let samples: Vec<Option<[usize; 3]>> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let bc = [b % bd[0], (b / bd[0]) % bd[1], b / (bd[0] * bd[1])];
            let mut best: Option<([usize; 3], f32)> = None;
            for z in bc[2] * BLOCK..((bc[2] + 1) * BLOCK).min(grid.dims[2]) {
                for y in bc[1] * BLOCK..((bc[1] + 1) * BLOCK).min(grid.dims[1]) {
                    for x in bc[0] * BLOCK..((bc[0] + 1) * BLOCK).min(grid.dims[0]) {
                        let i = grid.index([x, y, z]);
                        if !occupied[i] && best.is_none_or(|(_, c)| clearance[i] > c) {
                            best = Some(([x, y, z], clearance[i]));
                        }
                    }
                }
            }
            best.map(|(c, _)| c)
        })
        .collect();
    let dirs = probe_directions();
    let origins: Vec<(usize, Vec3)> = samples.iter().enumerate().filter_map(|(b, s)| s.map(|c| (b, grid.center(c)))).collect();
    let ray_list: Vec<Ray> = origins.iter().flat_map(|&(_, o)| dirs.iter().map(move |&d| Ray::new(o, d))).collect();
    let hits = rays.intersect_batch(&ray_list, Packing::Single);
    let mut classes = vec![Class::Unknown; blocks];
    let middle_lo = grid.origin + Vec3::from(grid.dims.map(|d| d as f32)) * grid.voxel * 0.2;
    let middle_hi = grid.origin + Vec3::from(grid.dims.map(|d| d as f32)) * grid.voxel * 0.8;
    let (mut front_in_middle, mut rays_in_middle) = (0usize, 0usize);
    for (k, &(b, origin)) in origins.iter().enumerate() {
        let h = &hits[k * dirs.len()..(k + 1) * dirs.len()];
        classes[b] = classify(h);
        if classes[b] != Class::Solid && origin.cmpge(middle_lo).all() && origin.cmple(middle_hi).all() {
            front_in_middle += (0..dirs.len()).filter(|&i| front_hit(h, i)).count();
            rays_in_middle += dirs.len();
        }
    }
    let enclosure = if rays_in_middle > 0 { front_in_middle as f32 / rays_in_middle as f32 } else { 0.0 };
    (classes, enclosure, ray_list.len())
}

const NONE: u32 = u32::MAX;

/// 6-connected components of the marked voxels, labelled in grid order.
fn components(grid: &Grid, marked: &[bool]) -> (Vec<u32>, Vec<usize>) {
    let mut labels = vec![NONE; grid.len()];
    let mut sizes = Vec::new();
    let mut queue = VecDeque::new();
    for seed in 0..grid.len() {
        if !marked[seed] || labels[seed] != NONE {
            continue;
        }
        let label = sizes.len() as u32;
        labels[seed] = label;
        queue.push_back(seed);
        let mut size = 0;
        while let Some(i) = queue.pop_front() {
            size += 1;
            for n in grid.neighbours(grid.coords(i)) {
                let j = grid.index(n);
                if marked[j] && labels[j] == NONE {
                    labels[j] = label;
                    queue.push_back(j);
                }
            }
        }
        sizes.push(size);
    }
    (labels, sizes)
}

/// The component that the scene's surfaces face into most: each triangle votes
/// for the first component found stepping out along its normal (r plus one
/// voxel, doubling up to eight times that). Votes count triangles, not area:
/// the detail of a scene (columns, arches, statues) faces its main space, while
/// a few huge panels (a backdrop, the outside of the outer walls) face the space
/// around it.
fn most_faced_component(scene: &Scene, grid: &Grid, labels: &[u32], count: usize, near: f32) -> Option<u32> {
    let votes: Vec<u32> = (0..scene.triangles.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = scene.triangle(t);
            let n = (b - a).cross(c - a).normalize_or_zero();
            let centroid = (a + b + c) / 3.0;
            [1.0, 2.0, 4.0, 8.0]
                .iter()
                .filter_map(|k| grid.cell(centroid + n * (near + grid.voxel) * k))
                .map(|cell| labels[grid.index(cell)])
                .find(|&l| l != NONE)
                .unwrap_or(NONE)
        })
        .collect();
    let mut tally = vec![0usize; count];
    for v in votes.into_iter().filter(|&v| v != NONE) {
        tally[v as usize] += 1;
    }
    (0..count).filter(|&i| tally[i] > 0).max_by(|&x, &y| tally[x].cmp(&tally[y]).then(y.cmp(&x))).map(|i| i as u32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::rooms;
    use exploremaps_scenes::mesh::MeshBuilder;
    use exploremaps_scenes::BuiltIn;

    fn run(scene: &Scene, params: &FreeSpaceParams) -> Result<(FreeSpace, FreeSpaceStats), FreeSpaceError> {
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        free_space(scene, &rays, params)
    }


    #[test]
    fn triangle_box_overlap_exact_cases() {
        let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let h = Vec3::splat(0.1);
        assert!(triangle_box_overlap(Vec3::new(0.2, 0.2, 0.0), h, &tri));
        assert!(triangle_box_overlap(Vec3::new(0.2, 0.2, 0.09), h, &tri), "within half a voxel of the plane");
        assert!(!triangle_box_overlap(Vec3::new(0.2, 0.2, 0.11), h, &tri));
        assert!(!triangle_box_overlap(Vec3::new(0.7, 0.7, 0.0), h, &tri), "beyond the hypotenuse");
        assert!(triangle_box_overlap(Vec3::new(0.55, 0.55, 0.0), h, &tri), "the box reaches the hypotenuse");
    }

    #[test]
    fn distance_transform_matches_brute_force() {
        let grid = Grid { origin: Vec3::ZERO, voxel: 1.0, dims: [9, 7, 5] };
        let occupied: Vec<bool> = (0..grid.len()).map(|i| (i * 7919) % 23 == 0).collect();
        let d = distance_transform(&grid, &occupied);
        for (i, &di) in d.iter().enumerate() {
            let c = grid.coords(i);
            let brute = (0..grid.len())
                .filter(|&j| occupied[j])
                .map(|j| {
                    let o = grid.coords(j);
                    (0..3).map(|k| (c[k] as f32 - o[k] as f32).powi(2)).sum::<f32>()
                })
                .fold(f32::INFINITY, f32::min);
            assert_eq!(di, brute, "voxel {c:?}");
        }
    }

    #[test]
    fn closed_box_is_one_inside_component() {
        let (space, stats) = run(&rooms(1, 6.0, 3.0, 4.0, &[]), &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.space, "inside", "{stats:?}");
        assert!(stats.enclosure > 0.9);
        assert_eq!(stats.components, 1, "{stats:?}");
        assert!(space.is_navigable(Vec3::new(3.0, 1.5, 2.0)));
        assert!(!space.is_navigable(Vec3::new(3.0, -1.0, 2.0)), "below the floor");
        assert!(!space.is_navigable(Vec3::new(3.0, 4.0, 2.0)), "above the roof");
        assert!(!space.is_navigable(Vec3::new(-1.0, 1.5, 2.0)), "outside the walls");
        // Half the height is the most clearance there is (up to a voxel).
        let open = space.most_open_point().unwrap();
        assert!((space.clearance_at(open) - 1.5).abs() < 2.0 * space.grid.voxel, "{open}");
    }

    #[test]
    fn rooms_joined_by_a_door_are_one_component_and_sealed_rooms_two() {
        for (doors, expected) in [(vec![1], 2), (vec![], 3), (vec![1, 2], 1)] {
            let scene = rooms(3, 5.0, 3.0, 4.0, &doors);
            let (_, stats) = run(&scene, &FreeSpaceParams { space: SpaceMode::Inside, ..Default::default() }).unwrap();
            assert_eq!(stats.components, expected, "doors {doors:?}: {stats:?}");
        }
    }

    #[test]
    fn start_point_picks_the_component_and_bad_starts_are_errors() {
        let scene = rooms(2, 5.0, 3.0, 4.0, &[]);
        let inside = FreeSpaceParams { space: SpaceMode::Inside, ..Default::default() };
        let (space, _) = run(&scene, &FreeSpaceParams { start: Some(Vec3::new(7.5, 1.5, 2.0)), ..inside.clone() }).unwrap();
        assert!(space.is_navigable(Vec3::new(7.5, 1.5, 2.0)) && !space.is_navigable(Vec3::new(2.5, 1.5, 2.0)));
        let err = |p: Vec3| run(&scene, &FreeSpaceParams { start: Some(p), ..inside.clone() }).unwrap_err();
        assert!(matches!(err(Vec3::new(5.0, 1.5, 2.0)), FreeSpaceError::StartInGeometry(_)));
        assert!(matches!(err(Vec3::new(0.14, 1.5, 2.0)), FreeSpaceError::StartTooNarrow { .. }));
        assert!(matches!(err(Vec3::new(50.0, 1.5, 2.0)), FreeSpaceError::StartOutside(_)));
        assert!(matches!(err(Vec3::new(2.5, -0.5, 2.0)), FreeSpaceError::StartNotNavigable(..)));
        // A closed box with the start outside it and no opening: a clear error, not a hang.
        assert!(matches!(err(Vec3::new(-0.4, 1.5, 2.0)), FreeSpaceError::StartNotNavigable(..)));
    }

    #[test]
    fn a_closed_box_has_no_outside_start_inside_it_and_outside_surrounds_it() {
        let scene = rooms(1, 6.0, 3.0, 4.0, &[]);
        let outside = FreeSpaceParams { space: SpaceMode::Outside, ..Default::default() };
        let (space, stats) = run(&scene, &outside).unwrap();
        assert!(stats.navigable > 0);
        assert!(space.is_navigable(Vec3::new(-0.4, 1.5, 2.0)) && !space.is_navigable(Vec3::new(3.0, 1.5, 2.0)));
        // Starting inside a closed box in outside mode finds the (sealed) interior, not a hang.
        let (inner, _) = run(&scene, &FreeSpaceParams { start: Some(Vec3::new(3.0, 1.5, 2.0)), ..outside }).unwrap();
        assert!(!inner.is_navigable(Vec3::new(-0.4, 1.5, 2.0)));
    }

    #[test]
    fn auto_chooses_inside_for_the_gallery_and_outside_for_an_object() {
        let (space, stats) = run(&BuiltIn::Gallery.generate(1), &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.space, "inside", "{stats:?}");
        assert!(space.is_navigable(Vec3::new(30.0, 1.6, 8.5)), "the pillared hall");
        assert!(space.is_navigable(Vec3::new(6.0, 1.6, -8.0)), "the open courtyard");
        assert!(!space.is_navigable(Vec3::new(20.0, 6.0, 10.0)), "above the roof");
        let mut m = MeshBuilder::new("blob");
        m.blob(Vec3::ZERO, Vec3::ONE, 3, |_| 1.0);
        let (_, stats) = run(&m.finish(), &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.space, "outside", "{stats:?}");
    }

    #[test]
    fn deterministic_at_any_thread_count() {
        let scene = BuiltIn::Pillars.generate(3);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let a = one.install(|| run(&scene, &FreeSpaceParams::default()).unwrap());
        let b = run(&scene, &FreeSpaceParams::default()).unwrap();
        assert_eq!(a.0.navigable, b.0.navigable);
        assert_eq!(a.0.clearance, b.0.clearance);
    }
}

/// Slow: the shared third-party scenes (`cargo test -- --ignored`).
#[cfg(test)]
mod shared_scene_tests {
    use super::*;
    use crate::load::{load, LoadOptions};
    use std::path::Path;

    fn shared(relative: &str) -> Option<Scene> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes").join(relative);
        if !path.exists() {
            eprintln!("SKIPPED: {} is absent", path.display());
            return None;
        }
        Some(load(&path, &LoadOptions::default()).unwrap())
    }

    #[test]
    #[ignore]
    fn sponzas_are_inside_and_the_bunny_outside() {
        for (file, space, inside_point, outside_point) in [
            ("sponza_crytek/sponza_crytek.obj", "inside", Vec3::new(0.0, 8.0, 0.0), Vec3::new(0.0, 75.0, 0.0)),
            ("sponza_dabrovic/sponza.obj", "inside", Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 16.5, 0.0)),
            ("stanford_bunny/bun_zipper.ply", "outside", Vec3::new(0.065, 0.1, 0.0), Vec3::new(-0.02, 0.1, 0.0)),
        ] {
            let Some(scene) = shared(file) else { continue };
            let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
            let (fs, stats) = free_space(&scene, &rays, &FreeSpaceParams::default()).unwrap();
            eprintln!("{file}: {stats:?}");
            assert_eq!(stats.space, space, "{file}");
            assert!(fs.is_navigable(inside_point), "{file}: {inside_point} should be navigable");
            assert!(!fs.is_navigable(outside_point), "{file}: {outside_point} should not be");
        }
    }
}
