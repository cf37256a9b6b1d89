//! Free space: which points a probe or a path may occupy, at human scale
//! where the scene has floors.
//!
//! Inputs: the scene, its ray-casting structure, [`FreeSpaceParams`].
//! Outputs: [`FreeSpace`] (a voxel grid with occupancy, clearance, the open
//! space inside the scene's box and the navigable voxels) and [`FreeSpaceStats`].
//!
//! Steps: (1) voxelize: a voxel is occupied when a triangle overlaps it (exact
//! triangle/box separating-axis test); (2) clearance: exact Euclidean distance
//! transform (Felzenszwalb and Huttenlocher 2012) from each voxel centre to the
//! nearest occupied centre; (3) *solids*: the free voxels inside the scene's
//! bounding box fall into 6-connected pockets; rays cast from each pocket's most
//! open voxel in each block of 4³ voxels decide whether that part is enclosed by
//! back faces (the inside of a wall, a slab, a closed object, the ground seen
//! from below) or not; pockets with no voxel two voxels away from every surface
//! (slivers inside walls and slabs) count as solid too. The *open space*
//! is every free voxel in the box outside such solids: the surface it sees is
//! the ceiling of any placement ([`crate::plan::coverage`] reports it); (4) which kind
//! of scene: `outside` (an object: most of its surface faces out of its box,
//! toward the sides or below) or `inside` (everything else: interiors,
//! semi-open architecture, landscapes); (5) navigable voxels, by height mode:
//!
//! * *fly*: `inside`: open space with clearance ≥ r, in every 6-connected part
//!   the scene's surface faces (each triangle votes for the part in front of
//!   it) with a tenth of the most-faced part's votes, never under water:
//!   pockets (an attic, the void between a roof and its panels) stay out;
//!   `outside`: free space with clearance ≥ r around the scene, in the padding
//!   and in the open space connected to it;
//! * *walk* ([`crate::plan::walk`]): voxels within a band around eye height above the
//!   walkable floors of the visitor's parts of the fly space: the most-faced
//!   part, parts with a tenth of its votes, and parts reaching the box's
//!   boundary (a courtyard, the ground around a building), never an attic or a
//!   sealed void (slope, steps and head room as people
//!   move; roofs and small surfaces such as table tops left out). Probes stand at
//!   exactly eye height above a floor ([`FreeSpace::stand`]).
//!
//! What it guarantees: a navigable point is in no voxel a triangle touches, has
//! clearance ≥ r (the voxel-quantized distance transform), is never in a pocket
//! enclosed by back faces (so never under the ground or inside a closed solid),
//! and in `inside` mode lies inside the scene's bounding box (never above the
//! highest roof or beyond the terrain's edge; a flat scene lower than a person
//! stands gets a storey of sky above its ground, see `room_box`). `auto` never looks at how a
//! particular scene is shaped beyond these measures: which way the surface faces
//! (out of the box or into it), and whether floors and a trustworthy scale exist.
//!
//! Parameters (defaults): at most 256 cells on the long axis (`max_cells`),
//! and voxels of at most 0.4 m when walking (`walk_voxel_m`: a door 0.8 m wide
//! stays open; a large scene is planned again on the finer grid once walking
//! is chosen);
//! r = 0.5 % of the bounding-box diagonal L (`near_rel`) unless given in metres,
//! and at most 0.3 m when walking or when the scale is stated or plausibly
//! guessed (a probe must pass any door a person passes); the
//! grid is padded by 5 % of the longest extent. Memory is about 14 bytes a cell:
//! at most 40M cells (≈ 0.6 GiB). Deterministic: ray casts and sums run in fixed
//! order.

use crate::plan::samples::surface_samples;
use crate::plan::walk::{self, Walk, WalkStats};
use crate::raycast::{Hit, Packing, Ray, RayScene};
use exploremaps_scenes::{Aabb, ScaleSource, Scene};
use glam::Vec3;
use petgraph::unionfind::UnionFind;
use rand::Rng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Which free space is navigable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpaceMode {
    /// Scenes one is in (interiors, architecture, landscapes): the open space
    /// inside the scene's bounding box.
    Inside,
    /// Objects: the space around the scene (the paper's behaviour).
    Outside,
    /// Chooses from which way the scene's surface faces, and reports the choice.
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

/// At which heights probes and paths may be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeightMode {
    /// Walk for architecture and landscapes with floors and a trustworthy
    /// scale, fly otherwise; the choice is reported.
    Auto,
    /// At eye height above walkable floors (human scale).
    Walk,
    /// Anywhere in the navigable space (objects, coverage research).
    Fly,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FreeSpaceParams {
    pub space: SpaceMode,
    pub height: HeightMode,
    /// Eye height above the floor when walking, metres.
    pub eye_height_m: f32,
    /// Cells on the longest axis of the (padded) bounding box.
    pub max_cells: usize,
    /// Largest voxel when walking, metres: the grid is refined to it (within
    /// the cell budget) so that every door a person passes is open on it.
    pub walk_voxel_m: f32,
    /// Voxel edge in scene units; overrides `max_cells` (within the budget).
    pub voxel: Option<f32>,
    /// Near distance r as a fraction of the bounding-box diagonal.
    pub near_rel: f32,
    /// Near distance in metres; overrides `near_rel` when given.
    pub near_m: Option<f32>,
    /// Picks the navigable part containing this point.
    pub start: Option<Vec3>,
    pub seed: u64,
}

impl Default for FreeSpaceParams {
    fn default() -> Self {
        FreeSpaceParams {
            space: SpaceMode::Auto,
            height: HeightMode::Auto,
            eye_height_m: 1.6,
            max_cells: 256,
            walk_voxel_m: WALK_VOXEL_M,
            voxel: None,
            near_rel: 0.005,
            near_m: None,
            start: None,
            seed: 1,
        }
    }
}

/// `auto` takes a scene for an object when more than this share of the rays
/// leaving its surface leave its box sideways or downward.
pub(crate) const FACING_OUT_OBJECT: f32 = 0.5;
/// An object with an interior (a car, a machine) by [`kind_evidence`]: more
/// of its surface faces out than a place's without thick walls, less of
/// its box is closed space than a building's rooms, and from above it
/// shows its top, not a ground. Buildings measured (docs/2026-12-06-map.md)
/// have closed space over 60 % of the box or a ground over 15 % of it.
const CABIN_FACING_OUT: f32 = 0.2;
const CABIN_ENCLOSED: f32 = 0.45;
const CABIN_GROUND: f32 = 0.15;
/// When walking, a part of the open space is a visitor's when the scene faces it
/// with at least this share of the votes of the most-faced part (or it reaches
/// the box's boundary).
const FACED_SHARE: f32 = 0.1;
/// Largest near distance when walking, or when the scale is trusted: about a
/// person's half width.
const PERSON_NEAR_M: f32 = 0.3;

/// The open sky a flat scene gets above its lowest point, metres (see `room_box`).
const STOREY_M: f32 = 3.0;
/// Largest walking voxel: a door 0.8 m wide and 2.0 m high always leaves a
/// free column (two voxels fit the width) whose eye voxel (1.6 m) is below
/// the lintel, and its clearance (one voxel) passes the near distance 0.3 m.
const WALK_VOXEL_M: f32 = 0.4;
/// Voxels per block edge for the solid test's ray origins.
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
    #[error("the start point {0} is not in {1} space (below the floor, inside an object, outside the building, or not at eye height above a floor when walking); pick another, or change --space or --walk/--fly")]
    StartNotNavigable(Vec3, &'static str),
    #[error("no navigable {0} space with clearance {1:.3} units was found; {2}")]
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
    /// Visits the voxels the segment `a`-`b` passes through, in order, voxel
    /// by voxel (Amanatides and Woo, "A fast voxel traversal algorithm for
    /// ray tracing", 1987), while `visit` returns true. False when an end is
    /// outside the grid or `visit` stopped the walk.
    pub fn walk_segment(&self, a: Vec3, b: Vec3, mut visit: impl FnMut(usize) -> bool) -> bool {
        let (Some(mut c), Some(end)) = (self.cell(a), self.cell(b)) else { return false };
        let (qa, d) = ((a - self.origin) / self.voxel, (b - a) / self.voxel);
        // Per axis: the step, the segment parameter of the next voxel face, and between faces.
        let step = d.to_array().map(|x| if x > 0.0 { 1isize } else { -1 });
        let mut next: [f32; 3] = std::array::from_fn(|k| match d[k] {
            0.0 => f32::INFINITY,
            x => ((c[k] as f32 + if x > 0.0 { 1.0 } else { 0.0 }) - qa[k]) / x,
        });
        let between = d.to_array().map(|x| if x == 0.0 { f32::INFINITY } else { 1.0 / x.abs() });
        // One voxel a face crossed (rounding may not reach `end` exactly).
        let crossings: usize = (0..3).map(|k| c[k].abs_diff(end[k])).sum();
        for _ in 0..=crossings {
            if !visit(self.index(c)) {
                return false;
            }
            let k = (0..3).min_by(|&x, &y| next[x].total_cmp(&next[y])).unwrap_or(0);
            if c == end || next[k] > 1.0 {
                break;
            }
            match c[k].checked_add_signed(step[k]).filter(|&v| v < self.dims[k]) {
                Some(v) => c[k] = v,
                None => break,
            }
            next[k] += between[k];
        }
        true
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
    /// Free voxels inside the scene's bounding box and outside closed solids:
    /// the surface they see is the most any placement could see.
    pub open: Vec<bool>,
    /// Voxels where probes and paths may be.
    pub navigable: Vec<bool>,
    /// When walking: the fly space of the visitor's parts, where a path may
    /// leave walking height to join what walking cannot (a ledge, a
    /// terrace); empty when flying (paths keep to `navigable`).
    pub glide: Vec<bool>,
    /// Near distance r, scene units.
    pub near: f32,
    /// `Inside` or `Outside` (never `Auto`).
    pub space: SpaceMode,
    /// Eye height and floors when walking; `None` when flying.
    pub walk: Option<Walk>,
    /// Scene bounds (unpadded).
    pub bounds: Aabb,
    /// Distance from each voxel centre to the nearest navigable voxel centre,
    /// scene units; made when first asked for.
    navigable_distance: std::sync::OnceLock<Vec<f32>>,
}

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FreeSpaceStats {
    pub dims: [usize; 3],
    pub voxel: f32,
    pub near: f32,
    pub occupied: usize,
    /// Free voxels in the box outside closed solids.
    pub open: usize,
    /// Free voxels inside closed solids (walls, slabs, under the ground).
    pub solid: usize,
    /// Parts of the open space with clearance ≥ r, and how many were kept.
    pub components: usize,
    pub components_kept: usize,
    /// Room-sized parts left out, largest first.
    pub left_out: Vec<LeftOut>,
    pub navigable: usize,
    /// Fraction of rays from open space that hit front faces (1 = closed interior).
    pub enclosure: f32,
    /// Fraction of rays leaving the surface that leave the box sideways or downward.
    pub facing_out: f32,
    pub space: &'static str,
    /// Why this space was chosen: "given" or "auto (…)".
    pub space_reason: String,
    /// "walk" or "fly".
    pub height: &'static str,
    pub height_reason: String,
    pub walk: Option<WalkStats>,
    pub rays: usize,
    #[serde(skip)]
    pub seconds: f64,
}

impl FreeSpace {
    pub fn is_navigable(&self, p: Vec3) -> bool {
        self.grid.cell(p).is_some_and(|c| self.navigable[self.grid.index(c)])
    }

    /// Whether every voxel the segment `a`-`b` passes through is navigable.
    /// (Points sampled along it every half voxel missed a wall's corner that
    /// the segment clipped by less than that: paths in a large maze grazed
    /// corners at clearance 0.)
    pub fn segment_navigable(&self, a: Vec3, b: Vec3) -> bool {
        self.grid.walk_segment(a, b, |i| self.navigable[i])
    }

    /// Whether every voxel the segment `a`-`b` passes through is in the space
    /// paths may glide through ([`FreeSpace::glide`], or the navigable space
    /// when flying).
    pub fn segment_glides(&self, a: Vec3, b: Vec3) -> bool {
        self.grid.walk_segment(a, b, |i| self.glides(i))
    }

    /// Whether paths may cross voxel `i` (gliding where walking cannot).
    pub fn glides(&self, i: usize) -> bool {
        if self.glide.is_empty() {
            self.navigable[i]
        } else {
            self.glide[i]
        }
    }

    /// The least clearance of the voxels the segment `a`-`b` passes through
    /// (0 when it leaves the grid).
    pub fn segment_clearance(&self, a: Vec3, b: Vec3) -> f32 {
        let mut least = f32::INFINITY;
        let inside = self.grid.walk_segment(a, b, |i| {
            least = least.min(self.clearance[i]);
            true
        });
        if inside {
            least
        } else {
            0.0
        }
    }

    /// Whether `p` lies in the open space (free, in the box, outside solids).
    pub fn is_open(&self, p: Vec3) -> bool {
        self.grid.cell(p).is_some_and(|c| self.open[self.grid.index(c)])
    }

    /// Clearance at the voxel holding `p` (0 outside the grid). A lower bound on the
    /// true distance to the surface up to one voxel diagonal.
    pub fn clearance_at(&self, p: Vec3) -> f32 {
        self.grid.cell(p).map_or(0.0, |c| self.clearance[self.grid.index(c)])
    }

    /// How far along a straight line from `p` no point can be navigable: the
    /// distance from `p`'s voxel centre to the nearest navigable voxel centre
    /// less a voxel diagonal (both points may lie anywhere in their voxels).
    /// `None` outside the grid. Lets a march skip empty space without missing
    /// a navigable voxel.
    pub fn navigable_free_run(&self, p: Vec3) -> Option<f32> {
        let c = self.grid.cell(p)?;
        let distances = self
            .navigable_distance
            .get_or_init(|| distance_transform(&self.grid, &self.navigable).into_par_iter().map(|d2| d2.sqrt() * self.grid.voxel).collect());
        Some(distances[self.grid.index(c)] - 3f32.sqrt() * self.grid.voxel)
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

    /// Where a probe near `p` stands: `p` itself when flying (if navigable); when
    /// walking, exactly eye height above the floor under `p`, if a person can
    /// stand there. `None` when there is no such place.
    pub fn stand(&self, rays: &RayScene, p: Vec3) -> Option<Vec3> {
        let standing = match &self.walk {
            None => p,
            Some(w) => w.stand(rays, p)?,
        };
        self.is_navigable(standing).then_some(standing)
    }

    /// Whether a visitor would stand at `p` ([`Walk::in_the_open`]; anywhere when flying).
    pub fn in_the_open(&self, rays: &RayScene, p: Vec3) -> bool {
        self.walk.as_ref().is_none_or(|w| w.in_the_open(rays, p))
    }

    /// How a visitor would judge `p` ([`Walk::standpoint_rank`]; open when flying).
    pub fn standpoint_rank(&self, rays: &RayScene, p: Vec3) -> walk::Standpoint {
        self.walk.as_ref().map_or(walk::Standpoint::Open, |w| w.standpoint_rank(rays, p))
    }

    /// [`FreeSpace::stand`], walking, without asking for the open part of a
    /// room ([`Walk::stand_anywhere`]).
    pub fn stand_anywhere(&self, rays: &RayScene, p: Vec3) -> Option<Vec3> {
        let standing = match &self.walk {
            None => p,
            Some(w) => w.stand_anywhere(rays, p)?,
        };
        self.is_navigable(standing).then_some(standing)
    }
}

/// Computes the navigable free space of a scene: the kind of scene and its
/// box, the box's voxels, walk or fly (on a finer grid when walking needs
/// one), the parts kept, and the eye-height band when walking.
pub fn free_space(scene: &Scene, rays: &RayScene, params: &FreeSpaceParams) -> Result<(FreeSpace, FreeSpaceStats), FreeSpaceError> {
    let started = Instant::now();
    let mut survey = Survey::new(scene, rays, params)?;
    let (fs, mut stats) = match survey.finer_grid(scene, params) {
        // Surveyed again on the finer grid, with the first survey's choices.
        Some(finer) => {
            let (fs, mut stats) = Survey::new(scene, rays, &finer)?.build(scene, rays, &finer)?;
            let voxel = finer.voxel.expect("a finer grid's voxel");
            let door_m = 2.0 * voxel * scene.metres_per_unit;
            stats.height_reason = if survey.walking {
                format!("{}; on a {:.2} m grid, so doors {door_m:.1} m wide are open", survey.height_reason, voxel * scene.metres_per_unit)
            } else {
                format!("{}; no floor was left on {:.2} m voxels", stats.height_reason, survey.vol.grid.voxel * scene.metres_per_unit)
            };
            stats.space_reason = survey.space_reason;
            stats.rays += survey.ray_count;
            (fs, stats)
        }
        None => survey.build(scene, rays, params)?,
    };
    stats.seconds = started.elapsed().as_secs_f64();
    Ok((fs, stats))
}

/// What the free space is decided from, before the parts are kept: the
/// kind of scene, its box and voxels, the space chosen, the floors, and walk
/// or fly.
struct Survey {
    bounds: Aabb,
    kind: SceneKind,
    room: Aabb,
    vol: Volumes,
    space: SpaceMode,
    space_reason: String,
    water: Vec<bool>,
    floors: Option<walk::Floors>,
    /// Whether the scale is one to trust.
    trusted: bool,
    walking: bool,
    height_reason: String,
    near: f32,
    ray_count: usize,
}

impl Survey {
    fn new(scene: &Scene, rays: &RayScene, params: &FreeSpaceParams) -> Result<Survey, FreeSpaceError> {
        if !(8..=2048).contains(&params.max_cells) {
            return Err(FreeSpaceError::BadResolution(params.max_cells));
        }
        let bounds = scene.bounds();
        let mut near = match params.near_m {
            Some(m) => m / scene.metres_per_unit,
            None => params.near_rel * bounds.diagonal(),
        };
        let kind = SceneKind::judge(scene, rays, &bounds, params);
        let (room, sky) = if kind.inside { room_box(&bounds, params.eye_height_m, scene.metres_per_unit) } else { (bounds, false) };
        let vol = Volumes::new(scene, rays, &room, params);
        let ray_count = vol.solids.rays + FACING_SAMPLES + if kind.evidence.is_some() { KIND_RAYS } else { 0 };
        let (space, space_reason) = kind.space(params.space, vol.solids.enclosure, sky.then_some((&bounds, &room)));
        // Walk or fly: walking needs a scene to be in, floors, and a scale to trust:
        // stated, or guessed with rooms of a plausible height.
        let water = walk::water_triangles(scene);
        let floors = (space == SpaceMode::Inside || params.height == HeightMode::Walk)
            .then(|| walk::floor_cells(&vol.grid, &vol.occupied, &vol.open, rays, scene.metres_per_unit, &water));
        let judged = scale_judgement(scene, floors.as_ref());
        let has_floors = floors.as_ref().is_some_and(|f| !f.cells.is_empty());
        let (walking, height_reason) = walk_or_fly(params.height, space, has_floors, &judged);
        // With a scale to trust, or walking, r is at most a person's half width:
        // a probe passes any door a visitor passes, however large the scene.
        if params.near_m.is_none() && (judged.is_ok() || walking) {
            near = near.min(PERSON_NEAR_M / scene.metres_per_unit);
        }
        let trusted = judged.is_ok();
        Ok(Survey { bounds, kind, room, vol, space, space_reason, water, floors, trusted, walking, height_reason, near, ray_count })
    }

    /// The parameters to survey again with on a finer grid, when one is
    /// needed and the budget allows it. A large scene's grid is coarser than
    /// a door: walk on a finer one. It can also close every corridor of a
    /// large interior (a 200 m maze of 2 m corridors on 0.86 m voxels keeps
    /// no floor): with a scale to trust, look for floors again on the
    /// walking grid. (The grid cannot be decided before the first survey:
    /// walking, and the floors, are found on it.)
    fn finer_grid(&mut self, scene: &Scene, params: &FreeSpaceParams) -> Option<FreeSpaceParams> {
        let walk_voxel = params.walk_voxel_m / scene.metres_per_unit;
        let has_floors = self.floors.as_ref().is_some_and(|f| !f.cells.is_empty());
        let look_again = !has_floors && self.trusted && self.space == SpaceMode::Inside && params.height == HeightMode::Auto;
        if !((self.walking || look_again) && self.vol.grid.voxel > 1.001 * walk_voxel) {
            return None;
        }
        let finer = make_grid(&self.room, params.max_cells, Some(walk_voxel)).voxel;
        if params.voxel.is_none() && finer < 0.999 * self.vol.grid.voxel {
            let height = if self.walking { HeightMode::Walk } else { params.height };
            return Some(FreeSpaceParams { space: self.space, height, voxel: Some(finer), ..params.clone() });
        }
        if self.walking && finer > 1.001 * walk_voxel {
            let door_m = 2.0 * finer * scene.metres_per_unit;
            self.height_reason =
                format!("{}; the grid is as fine as its cell budget allows: doors narrower than {door_m:.1} m may be closed", self.height_reason);
        }
        None
    }

    /// The free space on this survey's grid: the parts kept, and the
    /// eye-height band when walking. (`seconds` is left to the caller.)
    fn build(self, scene: &Scene, rays: &RayScene, params: &FreeSpaceParams) -> Result<(FreeSpace, FreeSpaceStats), FreeSpaceError> {
        let Survey { bounds, kind, vol, space, space_reason, water, floors, walking, height_reason, near, mut ray_count, .. } = self;
        let eye = params.eye_height_m / scene.metres_per_unit;
        let choice = Choice { space, walking, near };
        let parts = keep_parts(scene, rays, &vol, &water, &choice, params.start)?;
        let (solid, enclosure) = ((0..vol.grid.len()).filter(|&i| vol.free_in_box[i] && !vol.open[i]).count(), vol.solids.enclosure);
        let mut fs = vol.into_space(&parts, &choice, bounds);
        let walk_stats = match walking {
            true => Some(fs.walk_on(floors.as_ref().expect("computed when walking"), rays, eye, scene.metres_per_unit, params.start)?),
            false => None,
        };
        ray_count += walk_stats.as_ref().map_or(0, |w| w.rays);
        let stats = FreeSpaceStats {
            dims: fs.grid.dims,
            voxel: fs.grid.voxel,
            near,
            occupied: fs.occupied.iter().filter(|&&o| o).count(),
            open: fs.open.iter().filter(|&&o| o).count(),
            solid,
            components: parts.kept.len(),
            components_kept: parts.kept.iter().filter(|&&k| k).count(),
            left_out: parts.left_out,
            navigable: fs.navigable.iter().filter(|&&n| n).count(),
            enclosure,
            facing_out: kind.facing_out,
            space: space.name(),
            space_reason,
            height: if walking { "walk" } else { "fly" },
            height_reason,
            walk: walk_stats,
            rays: ray_count,
            seconds: 0.0,
        };
        Ok((fs, stats))
    }
}

impl FreeSpace {
    /// Walking: the eye-height band over the kept floors becomes the
    /// navigable space, and the kept parts are where paths glide.
    fn walk_on(
        &mut self,
        floors: &walk::Floors,
        rays: &RayScene,
        eye: f32,
        metres_per_unit: f32,
        start: Option<Vec3>,
    ) -> Result<WalkStats, FreeSpaceError> {
        let (walk, band, stats) = walk::walk_space(&self.grid, &self.navigable, floors, rays, eye, metres_per_unit);
        if band.iter().all(|&b| !b) {
            return Err(FreeSpaceError::Nothing("walkable", self.near, "no floor a person can reach and stand on at eye height; try --fly"));
        }
        if let Some(p) = start {
            if !band[self.grid.index(self.grid.cell(p).expect("checked by keep_parts"))] {
                return Err(FreeSpaceError::StartNotNavigable(p, "walkable"));
            }
        }
        self.glide = std::mem::replace(&mut self.navigable, band);
        self.walk = Some(walk);
        Ok(stats)
    }
}

/// What kind of scene it is, from which way its surface faces (and, for
/// `auto`, how much of its box is closed and whether it shows a ground).
struct SceneKind {
    facing_out: f32,
    /// (enclosed, ground), measured for `auto` only.
    evidence: Option<(f32, f32)>,
    /// An object with an interior (a car's cabin).
    cabin: bool,
    /// A scene to be in.
    inside: bool,
}

impl SceneKind {
    fn judge(scene: &Scene, rays: &RayScene, bounds: &Aabb, params: &FreeSpaceParams) -> SceneKind {
        // Which way the surface faces decides `auto`'s space; a scene to be in
        // that is too flat to stand in gets a storey of sky (see `room_box`).
        let facing_out = facing_out(scene, rays, bounds, params.seed);
        let evidence = (params.space == SpaceMode::Auto).then(|| kind_evidence(rays, bounds, params.seed));
        let cabin = evidence.is_some_and(|(enclosed, ground)| facing_out > CABIN_FACING_OUT && enclosed < CABIN_ENCLOSED && ground < CABIN_GROUND);
        let inside = match params.space {
            SpaceMode::Auto => facing_out <= FACING_OUT_OBJECT && !cabin,
            given => given == SpaceMode::Inside,
        };
        SceneKind { facing_out, evidence, cabin, inside }
    }

    /// The space planned in, and why; `raised` holds the scene's box and the
    /// one raised for a flat scene.
    fn space(&self, asked: SpaceMode, enclosure: f32, raised: Option<(&Aabb, &Aabb)>) -> (SpaceMode, String) {
        let (facing_out, cabin, inside) = (self.facing_out, self.cabin, self.inside);
        let (space, mut space_reason) = match asked {
            SpaceMode::Auto if cabin => {
                let (enclosed, ground) = self.evidence.expect("auto");
                let why = format!(
                    "auto: an object with an interior: {:.0} % of its surface faces out of its box, only {:.0} % of the box is closed space and {:.0} % of its footprint shows a ground from above; --space inside plans its interior",
                    100.0 * facing_out,
                    100.0 * enclosed,
                    100.0 * ground
                );
                (SpaceMode::Outside, why)
            }
            SpaceMode::Auto if !inside => {
                (SpaceMode::Outside, format!("auto: an object, {:.0} % of its surface faces out of its box", 100.0 * facing_out))
            }
            SpaceMode::Auto => (
                SpaceMode::Inside,
                format!("auto: a scene to be in, {:.0} % of its surface faces out of its box, enclosure {:.2}", 100.0 * facing_out, enclosure),
            ),
            given => (given, "given".to_string()),
        };
        if let Some((bounds, room)) = raised {
            space_reason += &format!(
                "; lower than a person stands ({:.2} units high), so it has open sky up to {:.2} units above its lowest point",
                bounds.extent().y,
                room.extent().y
            );
        }
        (space, space_reason)
    }
}

/// The box's voxels: occupancy, clearance, and the open space (free voxels
/// in the box outside the pockets enclosed by back faces).
struct Volumes {
    grid: Grid,
    occupied: Vec<bool>,
    clearance: Vec<f32>,
    in_box: Vec<bool>,
    free_in_box: Vec<bool>,
    solids: Solids,
    open: Vec<bool>,
}

impl Volumes {
    fn new(scene: &Scene, rays: &RayScene, room: &Aabb, params: &FreeSpaceParams) -> Volumes {
        let grid = make_grid(room, params.max_cells, params.voxel);
        let occupied = voxelize(scene, &grid);
        let clearance: Vec<f32> = distance_transform(&grid, &occupied).into_iter().map(|d2| d2.sqrt() * grid.voxel).collect();
        let in_box: Vec<bool> = (0..grid.len())
            .into_par_iter()
            .map(|i| {
                let p = grid.center(grid.coords(i));
                p.cmpge(room.min).all() && p.cmple(room.max).all()
            })
            .collect();
        let free_in_box: Vec<bool> = (0..grid.len()).map(|i| in_box[i] && !occupied[i]).collect();
        let solids = classify_solids(&grid, &free_in_box, &clearance, room, rays);
        let open: Vec<bool> = (0..grid.len()).map(|i| free_in_box[i] && !solids.solid[i]).collect();
        Volumes { grid, occupied, clearance, in_box, free_in_box, solids, open }
    }

    /// The free space of the kept parts (flying: paths glide where probes
    /// fly; walking narrows it to the eye-height band, see `walk_on`).
    fn into_space(self, parts: &Parts, choice: &Choice, bounds: Aabb) -> FreeSpace {
        let navigable: Vec<bool> = parts.labels.iter().map(|&l| l != NONE && parts.kept[l as usize]).collect();
        let Volumes { grid, occupied, clearance, open, .. } = self;
        let (near, space) = (choice.near, choice.space);
        FreeSpace {
            grid,
            occupied,
            clearance,
            open,
            navigable,
            glide: Vec::new(),
            near,
            space,
            walk: None,
            bounds,
            navigable_distance: Default::default(),
        }
    }
}

/// Whether the scale is one to walk by: stated, or guessed with rooms of a
/// plausible height (`Ok` says why, `Err` why not).
fn scale_judgement(scene: &Scene, floors: Option<&walk::Floors>) -> Result<String, String> {
    match scene.scale_source {
        ScaleSource::File | ScaleSource::User | ScaleSource::Measured => {
            Ok(format!("the scale is {} ({} m a unit)", scale_word(scene.scale_source), crate::plan::scale::short(scene.metres_per_unit)))
        }
        ScaleSource::Guessed => match floors {
            Some(f) => walk::judge_scale(f, scene.metres_per_unit).map(|why| format!("the guessed scale is plausible ({why})")),
            None => Err("the scale is only guessed".to_string()),
        },
    }
}

/// Walk or fly, and why, for the height mode asked.
fn walk_or_fly(asked: HeightMode, space: SpaceMode, has_floors: bool, judged: &Result<String, String>) -> (bool, String) {
    match asked {
        HeightMode::Fly => (false, "given".to_string()),
        HeightMode::Walk => (true, "given".to_string()),
        HeightMode::Auto if space == SpaceMode::Outside => (false, "auto: objects are seen in free flight".to_string()),
        HeightMode::Auto if !has_floors => (false, "auto: no floor a person can stand on".to_string()),
        HeightMode::Auto => match judged {
            Ok(why) => (true, format!("auto: floors, and {why}")),
            Err(why) => (false, format!("auto: {why}; pass --metres-per-unit to walk")),
        },
    }
}

/// What the navigable space is made of: the space planned in, whether it
/// is walked, and r.
struct Choice {
    space: SpaceMode,
    walking: bool,
    near: f32,
}

/// The open space's parts where a probe fits, which are kept, and the large
/// ones left out with why.
struct Parts {
    labels: Vec<u32>,
    /// Per part.
    kept: Vec<bool>,
    left_out: Vec<LeftOut>,
}

/// Splits the space a probe fits in into parts and keeps where a visitor
/// is: the start point's part, or the most-faced part, parts with a tenth
/// of its votes, and (walking) the parts open to the world.
fn keep_parts(scene: &Scene, rays: &RayScene, vol: &Volumes, water: &[bool], choice: &Choice, start: Option<Vec3>) -> Result<Parts, FreeSpaceError> {
    let candidate: Vec<bool> = (0..vol.grid.len())
        .into_par_iter()
        .map(|i| {
            let allowed = match choice.space {
                SpaceMode::Outside => !vol.occupied[i] && (!vol.in_box[i] || vol.open[i]),
                _ => vol.open[i],
            };
            allowed && vol.clearance[i] >= choice.near
        })
        .collect();
    let (labels, sizes) = components(&vol.grid, &candidate);
    let mut kept = vec![false; sizes.len()];
    // Why each part left out was, for the report.
    let mut apart: Vec<&'static str> = vec!["apart from the start point's part"; sizes.len()];
    match start {
        Some(p) => {
            let c = vol.grid.cell(p).ok_or(FreeSpaceError::StartOutside(p))?;
            let i = vol.grid.index(c);
            if vol.occupied[i] || (vol.free_in_box[i] && !vol.open[i]) {
                return Err(FreeSpaceError::StartInGeometry(p));
            }
            if vol.clearance[i] < choice.near {
                return Err(FreeSpaceError::StartTooNarrow { point: p, clearance: vol.clearance[i], near: choice.near });
            }
            if labels[i] == NONE {
                return Err(FreeSpaceError::StartNotNavigable(p, choice.space.name()));
            }
            kept[labels[i] as usize] = true;
        }
        // The padding guarantees free space at the grid's corner, around the scene.
        None if choice.space == SpaceMode::Outside => match labels[0] {
            NONE => return Err(FreeSpaceError::Nothing("outside", choice.near, "try --space inside or a smaller near distance")),
            corner => {
                kept[corner as usize] = true;
                apart.fill("inside the object, apart from the space around it");
            }
        },
        None => {
            let votes = faced_votes(scene, &vol.grid, &labels, sizes.len(), choice.near);
            let most = votes.iter().copied().max().unwrap_or(0);
            if most == 0 {
                return Err(FreeSpaceError::Nothing("inside", choice.near, "try --space outside or a smaller near distance"));
            }
            // Where a visitor is, walking or flying: the most-faced part, parts
            // with a tenth of its votes, and parts open to the world. Pockets
            // (an attic, the void between a roof and its panels) stay out: no
            // probe may stand where the rest of the map cannot reach.
            let exterior = touches_boundary(&vol.grid, &labels, sizes.len(), &vol.in_box);
            // (A walker also keeps the open parts, as courtyards; in flight
            // the open air above the roofs is one with them.)
            for (k, &v) in votes.iter().enumerate() {
                kept[k] = v > 0 && (v as f32 >= FACED_SHARE * most as f32 || (choice.walking && exterior[k]));
            }
            // Nobody visits the sea under its surface (its bed faces it).
            let drowned = under_water(water, rays, &vol.grid, &labels, &vol.clearance, sizes.len());
            let wraps = wrapping(&vol.grid, &labels, &kept);
            for (k, &d) in drowned.iter().enumerate() {
                kept[k] &= !d;
                apart[k] = if d {
                    "under water"
                } else if votes[k] == 0 {
                    "no surface faces it (a void inside geometry)"
                } else if exterior[k] {
                    "open to the box's edge but apart from the rest (the outside of a building)"
                } else if wraps[k] {
                    "around the rest, closed by outer panels (the outside of a building inside a backdrop)"
                } else {
                    "sealed off: no opening to the rest wide enough to pass"
                };
            }
        }
    }
    let left_out = left_out_parts(&vol.grid, &labels, &vol.in_box, &kept, &apart, scene.metres_per_unit);
    Ok(Parts { labels, kept, left_out })
}

/// A part of the open space left out of the navigable space.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LeftOut {
    /// Its voxels' mean position, scene units.
    pub centre: [f32; 3],
    pub volume_m3: f32,
    pub why: &'static str,
}

/// Parts a person could stand in (at least [`LEFT_OUT_M3`], not counting
/// the voxels along the box's edge, where a shell one voxel thick outside a
/// backdrop would count) that are not kept, largest first, with why.
fn left_out_parts(grid: &Grid, labels: &[u32], in_box: &[bool], kept: &[bool], why: &[&'static str], metres_per_unit: f32) -> Vec<LeftOut> {
    let voxel_m3 = (grid.voxel * metres_per_unit).powi(3);
    let mut sums = vec![(glam::DVec3::ZERO, 0usize); kept.len()];
    for (i, &l) in labels.iter().enumerate() {
        if l != NONE && !kept[l as usize] && grid.neighbours(grid.coords(i)).all(|n| in_box[grid.index(n)]) {
            let (sum, count) = &mut sums[l as usize];
            *sum += grid.center(grid.coords(i)).as_dvec3();
            *count += 1;
        }
    }
    let mut out: Vec<LeftOut> = sums
        .iter()
        .zip(why)
        .filter(|((_, count), _)| *count as f32 * voxel_m3 >= LEFT_OUT_M3)
        .map(|(&(sum, count), &why)| LeftOut { centre: (sum / count as f64).as_vec3().into(), volume_m3: count as f32 * voxel_m3, why })
        .collect();
    out.sort_by(|a, b| b.volume_m3.total_cmp(&a.volume_m3));
    out
}

/// Parts smaller than this are not reported, m³ (a closet is bigger).
const LEFT_OUT_M3: f32 = 4.0;

fn scale_word(source: ScaleSource) -> &'static str {
    match source {
        ScaleSource::File => "stated by the file",
        ScaleSource::User => "given",
        ScaleSource::Guessed => "guessed",
        ScaleSource::Measured => "measured from its heights",
    }
}

/// Per part of the open space: whether its most open voxel lies under a
/// water surface (the first thing above it is water).
fn under_water(water: &[bool], rays: &RayScene, grid: &Grid, labels: &[u32], clearance: &[f32], parts: usize) -> Vec<bool> {
    if !water.contains(&true) {
        return vec![false; parts];
    }
    let mut open_most: Vec<Option<usize>> = vec![None; parts];
    for (i, &l) in labels.iter().enumerate().filter(|(_, &l)| l != NONE) {
        let best = &mut open_most[l as usize];
        if best.is_none_or(|b| clearance[i] > clearance[b]) {
            *best = Some(i);
        }
    }
    open_most
        .iter()
        .map(|i| i.is_some_and(|i| rays.intersect(&Ray::new(grid.center(grid.coords(i)), Vec3::Y)).is_some_and(|h| water[h.triangle as usize])))
        .collect()
}

/// Surface samples of the facing test.
const FACING_SAMPLES: usize = 4096;

/// Share of cosine-distributed rays leaving the surface's front that leave the
/// bounding box sideways or downward without hitting anything: high for an
/// object seen from around it, low for interiors (rays hit walls) and for
/// landscapes (rays that escape go up, to the sky).
pub fn facing_out(scene: &Scene, rays: &RayScene, bounds: &Aabb, seed: u64) -> f32 {
    let samples = surface_samples(scene, FACING_SAMPLES, crate::seeds::Stream::Facing.seed(seed));
    let mut rng = crate::seeds::Stream::Outward.rng(seed);
    let eps = 1e-4 * bounds.diagonal().max(1e-6);
    let list: Vec<Ray> = samples
        .points
        .iter()
        .zip(&samples.normals)
        .map(|(&p, &n)| Ray::new(p + n * eps, crate::seeds::cosine_direction(n, glam::Vec2::new(rng.random(), rng.random()))))
        .collect();
    if list.is_empty() {
        return 0.0;
    }
    let hits = rays.intersect_batch(&list, Packing::Single);
    let out = list.iter().zip(&hits).filter(|(r, h)| h.is_none() && r.dir.y < 0.5).count();
    out as f32 / list.len() as f32
}

/// Points of the box of [`kind_evidence`], how many of their 14 rays must
/// hit for a point to be closed all round (a room's windows let a few out),
/// and the side of its grid of rays down.
const KIND_POINTS: usize = 2048;
const KIND_HITS: usize = 11;
const KIND_GROUND_SIDE: usize = 48;
/// Rays [`kind_evidence`] casts: 14 from each point (6 axes, 8 diagonals) and the grid down.
const KIND_RAYS: usize = KIND_POINTS * 14 + KIND_GROUND_SIDE * KIND_GROUND_SIDE;

/// What tells an object with an interior (a car, a machine) from a place,
/// whatever the scale: (enclosed, ground).
/// - enclosed: the share of the box's volume in free space closed all round
///   (at least 11 of 14 rays from a point hit, mostly front faces): most of
///   a building's box is its rooms; a car's cabin is a quarter of its box.
/// - ground: the share of rays cast straight down over the box's footprint
///   whose first hit faces up in its lower half: a place open to the
///   sky (a plaza, a courtyard, a landscape, rooms without ceilings) shows
///   its ground; an object shows its top.
pub fn kind_evidence(rays: &RayScene, bounds: &Aabb, seed: u64) -> (f32, f32) {
    let mut rng = crate::seeds::Stream::Kind.rng(seed);
    let (lo, ext) = (bounds.min, bounds.extent().max(Vec3::splat(1e-6)));
    let mut dirs: Vec<Vec3> = vec![Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
    for k in 0..8 {
        dirs.push(
            Vec3::new(if k & 1 == 0 { 1.0 } else { -1.0 }, if k & 2 == 0 { 1.0 } else { -1.0 }, if k & 4 == 0 { 1.0 } else { -1.0 }).normalize(),
        );
    }
    let points: Vec<Vec3> = (0..KIND_POINTS).map(|_| lo + ext * Vec3::new(rng.random(), rng.random(), rng.random())).collect();
    let list: Vec<Ray> = points.iter().flat_map(|&p| dirs.iter().map(move |&d| Ray::new(p, d))).collect();
    let hits = rays.intersect_batch(&list, Packing::Packets8);
    let enclosed = hits
        .chunks(dirs.len())
        .zip(list.chunks(dirs.len()))
        .filter(|(h, r)| {
            let hit = h.iter().filter(|h| h.is_some()).count();
            let front = h.iter().zip(*r).filter(|(h, r)| h.is_some_and(|h| h.normal.dot(r.dir) < 0.0)).count();
            hit >= KIND_HITS && 2 * front > hit
        })
        .count();
    let side = KIND_GROUND_SIDE;
    let top = bounds.max.y + 0.01 * ext.y;
    let down: Vec<Ray> = (0..side * side)
        .map(|k| {
            let (u, v) = (((k % side) as f32 + 0.5) / side as f32, ((k / side) as f32 + 0.5) / side as f32);
            Ray::new(Vec3::new(lo.x + u * ext.x, top, lo.z + v * ext.z), Vec3::NEG_Y)
        })
        .collect();
    let low = lo.y + 0.5 * ext.y;
    let ground = rays
        .intersect_batch(&down, Packing::Packets8)
        .iter()
        .zip(&down)
        .filter(|(h, r)| h.is_some_and(|h| h.normal.y > 0.0 && r.origin.y - h.t < low))
        .count();
    (enclosed as f32 / KIND_POINTS as f32, ground as f32 / down.len() as f32)
}

/// The box a scene to be in is navigated in, and whether it was raised: the
/// scene's own, except for a flat scene (a plaza, a field, a ground plane
/// alone), lower than a person stands (eye height and head room) and more
/// than four times as wide as it is high. Its own box leaves no room above
/// its ground, so it gets open sky up to a storey (`STOREY_M`, at least
/// that standing height) above its lowest point. Rooms are never that low,
/// so no room's roof is opened; a scale that is only guessed may misjudge a
/// miniature, which the width condition keeps out.
fn room_box(bounds: &Aabb, eye_m: f32, metres_per_unit: f32) -> (Aabb, bool) {
    let (extent, standing_m) = (bounds.extent(), eye_m + walk::HEAD_ROOM_M);
    let flat = extent.y * metres_per_unit < standing_m && extent.x.max(extent.z) > 4.0 * extent.y;
    if !flat {
        return (*bounds, false);
    }
    let mut room = *bounds;
    room.max.y = bounds.min.y + STOREY_M.max(standing_m) / metres_per_unit;
    (room, true)
}

/// The grid over the padded box: `max_cells` on its long side, or voxels of
/// the given size; coarser if the total would pass the cell budget.
fn make_grid(bounds: &Aabb, max_cells: usize, voxel: Option<f32>) -> Grid {
    let extent = bounds.extent();
    let pad = 0.05 * extent.max_element();
    let padded = extent + Vec3::splat(2.0 * pad);
    let mut voxel = voxel.unwrap_or(padded.max_element() / max_cells as f32);
    // Keep the total within the memory bound (flat scenes are far from cubic).
    let cells = |v: f32| (padded / v).ceil();
    while {
        let c = cells(voxel);
        c.x * c.y * c.z
    } > MAX_TOTAL_CELLS as f32
    {
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
    // A thousandth of a voxel larger: a surface lying exactly on a voxel boundary
    // (a floor at 0.15 m on a 0.103 m grid) must not slip between both voxels' tests.
    let half = Vec3::splat(0.5005 * grid.voxel);
    (0..scene.triangles.len()).into_par_iter().for_each(|t| {
        let tri = scene.triangle(t);
        let lo = tri[0].min(tri[1]).min(tri[2]);
        let hi = tri[0].max(tri[1]).max(tri[2]);
        let to_cell = |p: Vec3| ((p - grid.origin) / grid.voxel).floor();
        let (c0, c1) = (to_cell(lo).max(Vec3::ZERO), to_cell(hi));
        let max_c = Vec3::new(grid.dims[0] as f32 - 1.0, grid.dims[1] as f32 - 1.0, grid.dims[2] as f32 - 1.0);
        let c1 = c1.min(max_c);
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let axis = if n.x.abs() >= n.y.abs() && n.x.abs() >= n.z.abs() {
            0
        } else if n.y.abs() >= n.z.abs() {
            1
        } else {
            2
        };
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
    let mut d: Vec<f32> = occupied.par_iter().map(|&o| if o { 0.0 } else { FAR }).collect();
    let [nx, ny, nz] = grid.dims;
    // Lines along x and y lie within a z slab: transform them in place, a slab a task.
    d.par_chunks_mut(nx * ny).for_each(|slab| {
        for row in slab.chunks_mut(nx) {
            let out = lower_envelope(row);
            row.copy_from_slice(&out);
        }
        for x in 0..nx {
            let line: Vec<f32> = (0..ny).map(|y| slab[x + nx * y]).collect();
            for (y, v) in lower_envelope(&line).into_iter().enumerate() {
                slab[x + nx * y] = v;
            }
        }
    });
    // Lines along z, a y row of them a task: gathered and written back by rows
    // of x, which are contiguous.
    let planes: Vec<Vec<f32>> = (0..ny)
        .into_par_iter()
        .map(|y| {
            let mut block = vec![0.0; nx * nz];
            for x in 0..nx {
                let line: Vec<f32> = (0..nz).map(|z| d[x + nx * (y + ny * z)]).collect();
                for (z, v) in lower_envelope(&line).into_iter().enumerate() {
                    block[x + nx * z] = v;
                }
            }
            block
        })
        .collect();
    for (y, block) in planes.into_iter().enumerate() {
        for z in 0..nz {
            let at = nx * (y + ny * z);
            d[at..at + nx].copy_from_slice(&block[nx * z..nx * (z + 1)]);
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

/// Ray directions of the solid test: 8 horizontal, then up, then down.
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

/// Which free voxels of the box lie inside closed solids.
struct Solids {
    /// Per voxel: free, in the box, and enclosed by back faces.
    solid: Vec<bool>,
    /// Fraction of rays from open space in the middle 60 % of the box that hit front faces.
    enclosure: f32,
    rays: usize,
}

/// Splits the free voxels of the box into 6-connected pockets, and each block of
/// BLOCK³ voxels by pocket; casts the [`probe_directions`] rays from the most
/// open voxel of each (block, pocket) pair. The pair is solid when its first
/// hits are mostly back faces or most of its rays have a positive winding
/// number (a ray that crosses nothing counts as outside). Both
/// sides of a thin wall thus get their own rays, and a closed object whose
/// inside leaks out through a small hole (the Stanford bunny's base) is still
/// solid inside and open outside.
fn classify_solids(grid: &Grid, free: &[bool], clearance: &[f32], bounds: &Aabb, rays: &RayScene) -> Solids {
    let (labels, _) = components(grid, free);
    let bd = grid.dims.map(|d| d.div_ceil(BLOCK));
    let block_of = |c: [usize; 3]| c[0] / BLOCK + bd[0] * (c[1] / BLOCK + bd[1] * (c[2] / BLOCK));
    // Per block: (pocket, most open voxel) pairs, in pocket order.
    let origins: Vec<Vec<(u32, usize)>> = (0..bd[0] * bd[1] * bd[2])
        .into_par_iter()
        .map(|b| {
            let bc = [b % bd[0], (b / bd[0]) % bd[1], b / (bd[0] * bd[1])];
            let mut best: Vec<(u32, usize)> = Vec::new();
            for z in bc[2] * BLOCK..((bc[2] + 1) * BLOCK).min(grid.dims[2]) {
                for y in bc[1] * BLOCK..((bc[1] + 1) * BLOCK).min(grid.dims[1]) {
                    for x in bc[0] * BLOCK..((bc[0] + 1) * BLOCK).min(grid.dims[0]) {
                        let i = grid.index([x, y, z]);
                        if !free[i] {
                            continue;
                        }
                        match best.iter_mut().find(|(l, _)| *l == labels[i]) {
                            Some(slot) if clearance[i] > clearance[slot.1] => slot.1 = i,
                            Some(_) => {}
                            None => best.push((labels[i], i)),
                        }
                    }
                }
            }
            best.sort_unstable();
            best
        })
        .collect();
    let flat: Vec<usize> = origins.iter().flat_map(|o| o.iter().map(|&(_, i)| i)).collect();
    let dirs = probe_directions();
    let list: Vec<Ray> = flat.iter().flat_map(|&i| dirs.iter().map(move |&d| Ray::new(grid.center(grid.coords(i)), d))).collect();
    let (hits, winding, cast) = crossings(rays, &list, grid.voxel);
    let front = |h: &Option<Hit>, d: Vec3| h.is_some_and(|h| h.normal.dot(d) < 0.0);
    // Inside when the first hits are mostly back faces, or when most rays
    // leave more surfaces than they enter (the winding number: it holds inside
    // overlapping closed solids, a slab meeting the walls, where the first hit
    // alone is fooled; the first hit holds where coplanar faces, a wall's top
    // flush with a slab's underside, hide a crossing). A ray that crosses
    // nothing votes outside: a wall built of boxes side by side has a pair of
    // coincident faces at each joint, one of which a ray may miss, adding one
    // to its winding number, and in the open air beside a building, where
    // most rays escape, the few that crossed its walls outvoted them (a
    // cathedral's square was solid in 4 m blocks). A closed object open
    // through a small hole (the Stanford bunny's base) still has most of its
    // rays inside.
    let pair_solid: Vec<bool> = (0..flat.len())
        .map(|k| {
            let (h, w) = (&hits[k * dirs.len()..(k + 1) * dirs.len()], &winding[k * dirs.len()..(k + 1) * dirs.len()]);
            let fronts = h.iter().zip(&dirs).filter(|(h, &d)| front(h, d)).count();
            let backs = h.iter().filter(|h| h.is_some()).count() - fronts;
            let inside = w.iter().filter(|w| w.is_some_and(|w| w > 0)).count();
            backs > fronts || 2 * inside > dirs.len()
        })
        .collect();
    // Slivers: pockets with no voxel two voxels away from every surface. They are
    // the insides of walls, slabs and steps (where coplanar faces can fool both
    // ray tests), never a place for a probe: solid.
    let mut widest = vec![0.0f32; labels.iter().filter(|&&l| l != NONE).map(|&l| l as usize + 1).max().unwrap_or(0)];
    for i in 0..grid.len() {
        if labels[i] != NONE {
            widest[labels[i] as usize] = widest[labels[i] as usize].max(clearance[i]);
        }
    }
    // Each voxel takes the verdict of its (block, pocket) pair.
    let starts: Vec<usize> = origins
        .iter()
        .scan(0, |n, o| {
            let s = *n;
            *n += o.len();
            Some(s)
        })
        .collect();
    let solid: Vec<bool> = (0..grid.len())
        .into_par_iter()
        .map(|i| {
            if !free[i] {
                return false;
            }
            let b = block_of(grid.coords(i));
            let k = origins[b].binary_search_by_key(&labels[i], |&(l, _)| l).expect("every free voxel's pocket has an origin in its block");
            pair_solid[starts[b] + k] || widest[labels[i] as usize] < 2.0 * grid.voxel
        })
        .collect();
    // Enclosure over the middle of the box, for the log and the report.
    let (lo, hi) = (bounds.min + bounds.extent() * 0.2, bounds.max - bounds.extent() * 0.2);
    let (mut front_mid, mut rays_mid) = (0usize, 0usize);
    for (k, &i) in flat.iter().enumerate() {
        let p = grid.center(grid.coords(i));
        if !pair_solid[k] && p.cmpge(lo).all() && p.cmple(hi).all() {
            front_mid += hits[k * dirs.len()..(k + 1) * dirs.len()].iter().zip(&dirs).filter(|(h, &d)| front(h, d)).count();
            rays_mid += dirs.len();
        }
    }
    let enclosure = if rays_mid > 0 { front_mid as f32 / rays_mid as f32 } else { 0.0 };
    Solids { solid, enclosure, rays: cast }
}

/// Most surfaces a ray of the solid test crosses before its winding number is taken as is.
const MAX_CROSSINGS: usize = 16;

/// For each ray: its first hit, and its winding number (surfaces left through
/// their back minus surfaces entered through their front, up to
/// MAX_CROSSINGS), `None` when it crosses nothing. Returns the rays cast too.
fn crossings(rays: &RayScene, list: &[Ray], voxel: f32) -> (Vec<Option<Hit>>, Vec<Option<i32>>, usize) {
    let mut first = vec![None; list.len()];
    let mut winding: Vec<Option<i32>> = vec![None; list.len()];
    let mut active: Vec<(usize, Ray)> = list.iter().copied().enumerate().collect();
    let mut cast = 0;
    for round in 0..MAX_CROSSINGS {
        if active.is_empty() {
            break;
        }
        let hits = rays.intersect_batch(&active.iter().map(|a| a.1).collect::<Vec<_>>(), Packing::Single);
        cast += active.len();
        let mut next = Vec::with_capacity(active.len());
        for ((k, ray), hit) in active.into_iter().zip(hits) {
            let Some(h) = hit else { continue };
            if round == 0 {
                first[k] = Some(h);
            }
            *winding[k].get_or_insert(0) += if h.normal.dot(ray.dir) > 0.0 { 1 } else { -1 };
            next.push((k, Ray { t_min: h.t + 1e-3 * voxel, ..ray }));
        }
        active = next;
    }
    (first, winding, cast)
}

const NONE: u32 = u32::MAX;

/// 6-connected components of the marked voxels, labelled in grid order (by
/// each component's lowest voxel index). Runs of marked voxels along x are
/// joined (union-find) with the overlapping runs of the rows below and behind:
/// a fine grid's open air is a few runs a row, far fewer unions than voxels.
fn components(grid: &Grid, marked: &[bool]) -> (Vec<u32>, Vec<usize>) {
    components_by(grid, marked, false)
}

/// 26-connected components (voxels touching by a face, an edge or a corner),
/// labelled as [`components`]: the parts a path through voxel centres can join.
pub(crate) fn components_26(grid: &Grid, marked: &[bool]) -> (Vec<u32>, Vec<usize>) {
    components_by(grid, marked, true)
}

fn components_by(grid: &Grid, marked: &[bool], diagonal: bool) -> (Vec<u32>, Vec<usize>) {
    let [nx, ny, nz] = grid.dims;
    let row_runs: Vec<Vec<(u32, u32)>> = (0..ny * nz)
        .into_par_iter()
        .map(|r| {
            let row = &marked[r * nx..(r + 1) * nx];
            let mut runs = Vec::new();
            let mut x = 0;
            while x < nx {
                if row[x] {
                    let start = x;
                    while x < nx && row[x] {
                        x += 1;
                    }
                    runs.push((start as u32, x as u32));
                } else {
                    x += 1;
                }
            }
            runs
        })
        .collect();
    let first: Vec<usize> = row_runs
        .iter()
        .scan(0, |n, r| {
            let s = *n;
            *n += r.len();
            Some(s)
        })
        .collect();
    let count = first.last().map_or(0, |&f| f + row_runs.last().map_or(0, Vec::len));
    let mut parent: UnionFind<u32> = UnionFind::new(count);
    // Rows met before this one in grid order: below, behind, and with
    // diagonals the two behind it one up and one down. Diagonally, runs that
    // only touch end to end meet too.
    let reach = diagonal as u32;
    for r in 0..ny * nz {
        let (y, z) = (r % ny, r / ny);
        let behind = [(y > 0).then(|| r - 1), (z > 0).then(|| r - ny)];
        let corners = [(diagonal && y > 0 && z > 0).then(|| r - ny - 1), (diagonal && y + 1 < ny && z > 0).then(|| r - ny + 1)];
        for q in behind.into_iter().chain(corners).flatten() {
            let (mine, theirs) = (&row_runs[r], &row_runs[q]);
            let (mut i, mut j) = (0, 0);
            while i < mine.len() && j < theirs.len() {
                let (a, b) = (mine[i], theirs[j]);
                if a.0 < b.1 + reach && b.0 < a.1 + reach {
                    parent.union((first[r] + i) as u32, (first[q] + j) as u32);
                }
                if a.1 <= b.1 {
                    i += 1;
                } else {
                    j += 1;
                }
            }
        }
    }
    let mut run_label = vec![NONE; count];
    let mut sizes = Vec::new();
    for k in 0..count {
        let root = parent.find_mut(k as u32) as usize;
        if run_label[root] == NONE {
            run_label[root] = sizes.len() as u32;
            sizes.push(0);
        }
        run_label[k] = run_label[root];
    }
    let mut labels = vec![NONE; grid.len()];
    for (r, runs) in row_runs.iter().enumerate() {
        for (j, &(s, e)) in runs.iter().enumerate() {
            let label = run_label[first[r] + j];
            labels[r * nx + s as usize..r * nx + e as usize].fill(label);
            sizes[label as usize] += (e - s) as usize;
        }
    }
    (labels, sizes)
}

/// Per component: whether it reaches the box's boundary (open to the world
/// outside the box, like a courtyard or the ground around a building).
fn touches_boundary(grid: &Grid, labels: &[u32], count: usize, in_box: &[bool]) -> Vec<bool> {
    let mut touches = vec![false; count];
    for i in 0..grid.len() {
        if labels[i] != NONE && !touches[labels[i] as usize] && grid.neighbours(grid.coords(i)).any(|n| !in_box[grid.index(n)]) {
            touches[labels[i] as usize] = true;
        }
    }
    touches
}

/// Per component: whether its bounds hold the kept parts' bounds with room
/// to spare on every side (the space around a building, where a backdrop
/// closes it in).
fn wrapping(grid: &Grid, labels: &[u32], kept: &[bool]) -> Vec<bool> {
    let mut bounds = vec![([usize::MAX; 3], [0usize; 3]); kept.len()];
    let (mut lo_kept, mut hi_kept) = ([usize::MAX; 3], [0usize; 3]);
    for (i, &l) in labels.iter().enumerate().filter(|(_, &l)| l != NONE) {
        let c = grid.coords(i);
        let (lo, hi) = &mut bounds[l as usize];
        for a in 0..3 {
            (lo[a], hi[a]) = (lo[a].min(c[a]), hi[a].max(c[a]));
            if kept[l as usize] {
                (lo_kept[a], hi_kept[a]) = (lo_kept[a].min(c[a]), hi_kept[a].max(c[a]));
            }
        }
    }
    // Sideways only: a building's outside need not reach under its floor.
    bounds.iter().map(|(lo, hi)| [0, 2].iter().all(|&a| lo[a] < lo_kept[a] && hi[a] > hi_kept[a])).collect()
}

/// Per component: how many triangles face it. Each triangle votes for the first
/// component found stepping out along its normal (r plus one voxel, doubling up
/// to eight times that). Votes count triangles, not area: the detail of a scene
/// (columns, arches, statues, furniture) faces the space it is seen from, while
/// a few huge panels (a backdrop, the walls of a sealed void) count little.
fn faced_votes(scene: &Scene, grid: &Grid, labels: &[u32], count: usize, near: f32) -> Vec<usize> {
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
    tally
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{rooms, rooms_with};
    use exploremaps_scenes::mesh::{MeshBuilder, Wall};
    use exploremaps_scenes::BuiltIn;

    fn run(scene: &Scene, params: &FreeSpaceParams) -> Result<(FreeSpace, FreeSpaceStats), FreeSpaceError> {
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        free_space(scene, &rays, params)
    }

    fn fly(space: SpaceMode) -> FreeSpaceParams {
        FreeSpaceParams { space, height: HeightMode::Fly, ..Default::default() }
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
    fn a_segment_walks_through_every_voxel_it_touches_in_order() {
        use rand::{Rng, SeedableRng};
        let grid = Grid { origin: Vec3::new(-1.0, 0.5, 2.0), voxel: 0.4, dims: [9, 7, 8] };
        let size = Vec3::new(9.0, 7.0, 8.0) * 0.4;
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let mut point = || grid.origin + Vec3::new(rng.random(), rng.random(), rng.random()) * size * 0.999;
        for _ in 0..300 {
            let (a, b) = (point(), point());
            let mut walked = Vec::new();
            assert!(grid.walk_segment(a, b, |i| {
                walked.push(i);
                true
            }));
            assert_eq!((walked.first(), walked.last()), (grid.cell(a).map(|c| grid.index(c)).as_ref(), grid.cell(b).map(|c| grid.index(c)).as_ref()));
            // Each step to a face neighbour.
            for w in walked.windows(2) {
                let (x, y) = (grid.coords(w[0]), grid.coords(w[1]));
                assert_eq!((0..3).map(|k| x[k].abs_diff(y[k])).sum::<usize>(), 1, "{a} -> {b}");
            }
            // Every voxel that points 1/200 of a voxel apart land in is walked.
            let n = ((b - a).length() / grid.voxel * 200.0).ceil() as usize;
            for k in 0..=n {
                let c = grid.cell(a + (b - a) * (k as f32 / n as f32)).unwrap();
                assert!(walked.contains(&grid.index(c)), "{a} -> {b} misses {c:?}");
            }
        }
        // Stopped by `visit`, or an end off the grid: false.
        assert!(!grid.walk_segment(grid.origin + 0.1, grid.origin + 1.0, |_| false));
        assert!(!grid.walk_segment(grid.origin - 0.1, grid.origin + 1.0, |_| true));
    }

    #[test]
    fn components_match_a_flood_fill_and_are_labelled_in_grid_order() {
        // Random grids of various densities (sparse: many small parts; dense:
        // runs that meet in U shapes, which union-find must merge late), by
        // faces and by faces, edges and corners.
        let grid = Grid { origin: Vec3::ZERO, voxel: 1.0, dims: [13, 9, 7] };
        for diagonal in [false, true] {
            let densities: &[usize] = if diagonal { &[1, 2, 3] } else { &[3, 5, 8, 12] };
            for &density in densities {
                let marked: Vec<bool> = (0..grid.len()).map(|i| ((i * 2_654_435_761usize) >> 7) % 16 < density).collect();
                let (labels, sizes) = if diagonal { components_26(&grid, &marked) } else { components(&grid, &marked) };
                // Reference: a flood fill from each unlabelled voxel in grid order.
                let mut reference = vec![NONE; grid.len()];
                let mut ref_sizes = Vec::new();
                for seed in 0..grid.len() {
                    if !marked[seed] || reference[seed] != NONE {
                        continue;
                    }
                    let label = ref_sizes.len() as u32;
                    let mut stack = vec![seed];
                    reference[seed] = label;
                    let mut size = 0;
                    while let Some(i) = stack.pop() {
                        size += 1;
                        let c = grid.coords(i).map(|v| v as i64);
                        for d in 0..27i64 {
                            let o = [d % 3 - 1, (d / 3) % 3 - 1, d / 9 - 1];
                            let steps = o.iter().filter(|&&v| v != 0).count();
                            if steps == 0 || (!diagonal && steps > 1) {
                                continue;
                            }
                            let n = [c[0] + o[0], c[1] + o[1], c[2] + o[2]];
                            if n.iter().zip(grid.dims).any(|(&v, d)| v < 0 || v >= d as i64) {
                                continue;
                            }
                            let j = grid.index(n.map(|v| v as usize));
                            if marked[j] && reference[j] == NONE {
                                reference[j] = label;
                                stack.push(j);
                            }
                        }
                    }
                    ref_sizes.push(size);
                }
                assert!(ref_sizes.len() > 1, "density {density}: the grid must have several parts to test");
                assert_eq!(labels, reference, "density {density}, diagonal {diagonal}");
                assert_eq!(sizes, ref_sizes, "density {density}, diagonal {diagonal}");
            }
        }
    }

    #[test]
    fn closed_box_is_one_inside_component_and_its_thick_walls_are_solid() {
        let (space, stats) = run(&rooms(1, 6.0, 3.0, 4.0, &[]), &FreeSpaceParams { height: HeightMode::Fly, ..Default::default() }).unwrap();
        assert_eq!(stats.space, "inside", "{stats:?}");
        assert!(stats.enclosure > 0.9);
        assert_eq!(stats.components_kept, 1, "{stats:?}");
        assert!(space.is_navigable(Vec3::new(3.0, 1.5, 2.0)));
        assert!(!space.is_navigable(Vec3::new(3.0, -1.0, 2.0)), "below the floor");
        assert!(!space.is_navigable(Vec3::new(3.0, 4.0, 2.0)), "above the roof");
        assert!(!space.is_navigable(Vec3::new(-1.0, 1.5, 2.0)), "outside the walls");
        // The 0.2-thick walls and slabs are closed boxes: free voxels inside them are solid.
        assert!(stats.solid > 0, "{stats:?}");
        assert!(!space.is_open(Vec3::new(3.0, -0.1, 2.0)), "inside the floor slab");
        assert!(space.is_open(Vec3::new(3.0, 0.1, 2.0)), "just above the floor");
        // Half the height is the most clearance there is (up to a voxel).
        let open = space.most_open_point().unwrap();
        assert!((space.clearance_at(open) - 1.5).abs() < 2.0 * space.grid.voxel, "{open}");
    }

    #[test]
    fn rooms_joined_by_a_door_are_one_space_and_sealed_rooms_are_kept_apart() {
        let centre = |k: usize| Vec3::new(2.5 + 5.0 * k as f32, 1.5, 2.0);
        for doors in [vec![1], vec![], vec![1, 2]] {
            let scene = rooms(3, 5.0, 3.0, 4.0, &doors);
            let params = FreeSpaceParams { start: Some(centre(0)), ..fly(SpaceMode::Inside) };
            let (space, stats) = run(&scene, &params).unwrap();
            for k in 1..3 {
                let joined = (1..=k).all(|d| doors.contains(&d));
                assert_eq!(space.is_navigable(centre(k)), joined, "doors {doors:?}, room {k}: {stats:?}");
            }
        }
    }

    #[test]
    fn the_air_around_a_building_inside_a_backdrop_is_named_so() {
        // A closed room with posts, inside a closed box of thin panels 5 m off (the Crytek Sponza's backdrop).
        let scene = rooms_with(1, 6.0, 3.0, 4.0, &[], |m| {
            for x in [1.5, 3.0, 4.5] {
                m.cylinder(Vec3::new(x, 0.5, 2.0), 0.2, 2.0, 64);
            }
            let (lo, hi, t) = (Vec3::new(-5.0, -0.2, -5.0), Vec3::new(11.0, 6.0, 9.0), 0.1);
            m.cuboid(lo - Vec3::Y * t, Vec3::new(hi.x, lo.y, hi.z));
            m.cuboid(Vec3::new(lo.x, hi.y, lo.z), hi + Vec3::Y * t);
            m.cuboid(lo, Vec3::new(lo.x + t, hi.y, hi.z));
            m.cuboid(Vec3::new(hi.x - t, lo.y, lo.z), hi);
            m.cuboid(lo, Vec3::new(hi.x, hi.y, lo.z + t));
            m.cuboid(Vec3::new(lo.x, lo.y, hi.z - t), hi);
        });
        let (space, stats) = run(&scene, &fly(SpaceMode::Inside)).unwrap();
        assert!(space.is_navigable(Vec3::new(2.2, 1.5, 1.0)), "{stats:?}");
        let largest = stats.left_out.first().unwrap_or_else(|| panic!("the air around the room is left out: {stats:?}"));
        assert!(largest.why.starts_with("around the rest"), "{largest:?}");
        assert!(largest.volume_m3 > 500.0, "{largest:?}");
    }

    #[test]
    fn start_point_picks_the_component_and_bad_starts_are_errors() {
        let scene = rooms(2, 5.0, 3.0, 4.0, &[]);
        let inside = fly(SpaceMode::Inside);
        let (space, _) = run(&scene, &FreeSpaceParams { start: Some(Vec3::new(7.5, 1.5, 2.0)), ..inside.clone() }).unwrap();
        assert!(space.is_navigable(Vec3::new(7.5, 1.5, 2.0)) && !space.is_navigable(Vec3::new(2.5, 1.5, 2.0)));
        let err = |p: Vec3| run(&scene, &FreeSpaceParams { start: Some(p), ..inside.clone() }).unwrap_err();
        assert!(matches!(err(Vec3::new(5.0, 1.5, 2.0)), FreeSpaceError::StartInGeometry(_)));
        assert!(matches!(err(Vec3::new(0.14, 1.5, 2.0)), FreeSpaceError::StartTooNarrow { .. }));
        assert!(matches!(err(Vec3::new(50.0, 1.5, 2.0)), FreeSpaceError::StartOutside(_)));
        assert!(matches!(err(Vec3::new(2.5, -0.5, 2.0)), FreeSpaceError::StartNotNavigable(..)));
        // Outside the closed box in inside mode: not navigable, a clear error, not a hang.
        assert!(matches!(err(Vec3::new(-0.4, 1.5, 2.0)), FreeSpaceError::StartNotNavigable(..) | FreeSpaceError::StartOutside(_)));
        // Walking: a start above a floor but not at eye height is refused.
        let walk = FreeSpaceParams { height: HeightMode::Walk, start: Some(Vec3::new(2.5, 0.4, 2.0)), ..inside.clone() };
        assert!(matches!(run(&scene, &walk).unwrap_err(), FreeSpaceError::StartNotNavigable(..)));
    }

    #[test]
    fn a_closed_box_has_no_outside_start_inside_it_and_outside_surrounds_it() {
        let scene = rooms(1, 6.0, 3.0, 4.0, &[]);
        let outside = fly(SpaceMode::Outside);
        let (space, stats) = run(&scene, &outside).unwrap();
        assert!(stats.navigable > 0);
        assert!(space.is_navigable(Vec3::new(-0.4, 1.5, 2.0)) && !space.is_navigable(Vec3::new(3.0, 1.5, 2.0)));
        // Starting inside a closed box in outside mode finds the (sealed) interior, not a hang.
        let (inner, _) = run(&scene, &FreeSpaceParams { start: Some(Vec3::new(3.0, 1.5, 2.0)), ..outside }).unwrap();
        assert!(!inner.is_navigable(Vec3::new(-0.4, 1.5, 2.0)));
    }

    #[test]
    fn floors_a_coarse_grid_closes_are_looked_for_again_on_the_walking_grid() {
        // A 50 m maze of 2 m corridors on 64 cells: its 0.87 m voxels leave no
        // floor, as 256 cells do in a 200 m maze. It used to be "no navigable space".
        let scene = BuiltIn::Maze(25).generate(1);
        let (space, stats) = run(&scene, &FreeSpaceParams { max_cells: 64, ..Default::default() }).unwrap();
        assert_eq!(stats.height, "walk", "{stats:?}");
        assert!(stats.height_reason.contains("no floor was left on 0.8"), "{stats:?}");
        assert!((space.grid.voxel - 0.4).abs() < 1e-3, "{}", space.grid.voxel);
        assert!(space.is_navigable(Vec3::new(1.0, 1.6, 1.0)), "the first cell, at eye height");
        // Flying is not retried: it needs no floor.
        let (space, stats) = run(&scene, &FreeSpaceParams { max_cells: 64, height: HeightMode::Fly, ..Default::default() })
            .map_or((None, None), |(f, s)| (Some(f.grid.voxel), Some(s)));
        assert!(space.is_none_or(|v| v > 0.8), "{stats:?}");
    }

    #[test]
    fn auto_chooses_inside_and_walking_for_the_gallery_and_outside_flight_for_an_object() {
        let (space, stats) = run(&BuiltIn::Gallery.generate(1), &FreeSpaceParams { height: HeightMode::Fly, ..Default::default() }).unwrap();
        assert_eq!(stats.space, "inside", "{stats:?}");
        assert!(space.is_navigable(Vec3::new(30.0, 1.6, 8.5)), "the pillared hall");
        assert!(space.is_navigable(Vec3::new(6.0, 1.6, -8.0)), "the open courtyard");
        assert!(space.is_navigable(Vec3::new(6.0, 3.6, -8.0)), "high in the courtyard: flying");
        assert!(!space.is_navigable(Vec3::new(20.0, 6.0, 10.0)), "above the roof, outside the box");
        let (space, stats) = run(&BuiltIn::Gallery.generate(1), &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.height, "walk", "{stats:?}");
        assert!(space.is_navigable(Vec3::new(30.0, 1.6, 8.5)) && !space.is_navigable(Vec3::new(30.0, 3.3, 8.5)), "walking: eye height only");
        assert!(!space.is_navigable(Vec3::new(6.0, 0.4, -8.0)));
        let mut m = MeshBuilder::new("blob");
        m.blob(Vec3::ZERO, Vec3::ONE, 3, |_| 1.0);
        let (_, stats) = run(&m.finish(), &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.space, "outside", "{stats:?}");
        assert_eq!(stats.height, "fly", "{stats:?}");
    }

    #[test]
    fn a_staircase_joins_the_storeys_in_the_walking_space() {
        // The house's stairs: floors at 0.15 and 3.15 m, treads with nosings.
        // Eye height in the living room and on the landing are one part of the
        // band that paths run through (26-connected, as they step).
        let scene = BuiltIn::House.generate(1);
        let (walk, stats) = run(&scene, &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.height, "walk", "{stats:?}");
        let (ground, upper) = (Vec3::new(-3.0, 0.15 + 1.6, 0.0), Vec3::new(-3.0, 3.15 + 1.6, -2.0));
        assert!(walk.is_navigable(ground) && walk.is_navigable(upper), "{ground} {upper}");
        let (labels, _) = components_26(&walk.grid, &walk.navigable);
        let label = |p: Vec3| labels[walk.grid.index(walk.grid.cell(p).unwrap())];
        assert_eq!(label(ground), label(upper), "the stairs join the storeys");
    }

    #[test]
    fn an_island_is_a_scene_to_be_in_walked_on_its_ground_in_its_houses_and_tunnel() {
        let scene = BuiltIn::Island.generate(1);
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let (walk, stats) = free_space(&scene, &rays, &FreeSpaceParams::default()).unwrap();
        assert_eq!((stats.space, stats.height), ("inside", "walk"), "{stats:?}");
        let (fly, _) = free_space(&scene, &rays, &FreeSpaceParams { height: HeightMode::Fly, ..Default::default() }).unwrap();
        // The first surface straight down from high above.
        let top = |x: f32, z: f32| rays.intersect(&Ray::new(Vec3::new(x, 60.0, z), Vec3::NEG_Y)).map(|h| 60.0 - h.t).unwrap();
        let hill = Vec3::new(0.0, top(0.0, 0.0), 0.0);
        assert!(walk.is_navigable(hill + Vec3::Y * 1.6), "eye height on open ground {hill}");
        assert!(!walk.is_navigable(hill + Vec3::Y * 6.0) && fly.is_navigable(hill + Vec3::Y * 6.0), "the air above: flying only");
        assert!(!fly.is_open(hill - Vec3::Y * 1.0), "under the ground");
        // Inside the tunnel: its rock's top is 8 m above its floor.
        let tunnel = Vec3::new(-38.0, top(-38.0, 18.0) - 8.0, 18.0);
        assert!(walk.is_navigable(tunnel + Vec3::Y * 1.6), "in the tunnel {tunnel}");
        // Inside the first house, beside its table: its roof's top is 3.3 m above its floor.
        let house = Vec3::new(-28.0, top(-28.0, -19.0) - 3.3, -19.0);
        assert!(walk.is_navigable(house + Vec3::Y * 1.6), "in the house {house}");
        assert!(!walk.is_navigable(house + Vec3::Y * 4.9), "on its roof");
        // A visitor walks in through the 1 m door: the walking grid is refined
        // for doors (the default grid's 0.69 m voxels close them), and the house
        // and the hill are one part of the walking space.
        assert!(walk.grid.voxel <= 0.4 + 1e-4 && fly.grid.voxel > 0.6, "walk {} fly {}", walk.grid.voxel, fly.grid.voxel);
        assert!(stats.height_reason.contains("doors"), "{stats:?}");
        let (labels, _) = components(&walk.grid, &walk.navigable);
        let label = |p: Vec3| labels[walk.grid.index(walk.grid.cell(p).unwrap())];
        assert_eq!(label(house + Vec3::Y * 1.6), label(hill + Vec3::Y * 1.6), "the house joins the ground through its door");
        assert_eq!(label(tunnel + Vec3::Y * 1.6), label(hill + Vec3::Y * 1.6), "and so does the tunnel");
        let w = stats.walk.unwrap();
        assert!(w.roofs >= 1, "the houses' flat roofs are left out: {w:?}");
    }

    #[test]
    fn a_walled_courtyard_is_walked_but_a_table_top_and_a_fringe_of_ground_are_not() {
        // A 60 m square of streets (3,600 m²) with a walled courtyard of 5 × 4 m
        // (no door: it is reached by jumping) and a 2 × 2 m table, 0.8 m high.
        // Kept: the courtyard (enclosed, over 6 m²). Left out: the table (too
        // small) and a strip of ground walled off at the edge (open to the world).
        let mut m = MeshBuilder::new("town");
        m.terrain(-30.0, -30.0, 30.0, 30.0, 8, |_, _| 0.0);
        m.wall(Wall::along_x(0.0, 0.0, 5.2), 0.0..5.0, 0.2, &[]);
        m.wall(Wall::along_x(4.2, 0.0, 5.2), 0.0..5.0, 0.2, &[]);
        m.wall(Wall::along_z(0.0, 0.0, 4.2), 0.0..5.0, 0.2, &[]);
        m.wall(Wall::along_z(5.2, 0.0, 4.2), 0.0..5.0, 0.2, &[]);
        m.cuboid(Vec3::new(-15.0, 0.0, -15.0), Vec3::new(-13.0, 0.8, -13.0));
        // A wall cutting off a 4 m strip at the town's edge: open to the world, no door.
        m.wall(Wall::along_x(26.0, -30.0, 30.0), 0.0..5.0, 0.2, &[]);
        let mut town = m.finish();
        (town.scale_source, town.metres_per_unit) = (ScaleSource::File, 1.0);
        let (walk, stats) = run(&town, &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.height, "walk", "{stats:?}");
        assert!(walk.is_navigable(Vec3::new(-10.0, 1.6, 10.0)), "the streets");
        assert!(walk.is_navigable(Vec3::new(2.6, 1.6, 2.1)), "the courtyard: {stats:?}");
        assert!(!walk.is_navigable(Vec3::new(-14.0, 2.4, -14.0)), "eye height on the table");
        assert!(!walk.is_navigable(Vec3::new(0.0, 1.6, 28.0)), "the strip beyond the wall at the edge");
    }

    #[test]
    fn the_open_air_beside_walls_built_of_boxes_is_not_solid() {
        // The cathedral's walls are boxes side by side (a joint at every
        // window and arch, each a pair of coincident faces); only its towers,
        // roof and the insides of its thick walls and slabs are solid, never
        // the square around it at any height.
        let scene = BuiltIn::Cathedral.generate(1);
        let (space, _) = run(&scene, &fly(SpaceMode::Inside)).unwrap();
        let b = scene.bounds();
        let g = &space.grid;
        let beside = |p: Vec3| p.x > 21.0 || p.z.abs() > 11.0 || (p.x < -21.0 && p.x > -25.0 && p.z.abs() < 5.5);
        let solid_outside = (0..g.len())
            .filter(|&i| {
                let p = g.center(g.coords(i));
                p.cmpge(b.min).all() && p.cmple(b.max).all() && p.y > 0.3 && beside(p) && !space.occupied[i] && !space.open[i]
            })
            .count();
        assert_eq!(solid_outside, 0, "voxels of the square taken for solid");
        assert!(!space.is_open(Vec3::new(-23.0, 10.0, 8.0)), "inside a tower");
        assert!(space.is_open(Vec3::new(0.0, 10.0, 0.0)) && space.is_open(Vec3::new(0.0, 10.5, 7.5)), "the nave and a gallery");
    }

    #[test]
    fn pews_are_not_stood_on_and_a_gap_at_a_stairs_top_is_stepped_over() {
        // A square with rows of pews (seats 0.47 m up, backs 0.95 m) and five
        // stairs of ten 0.2 m steps, each up to its own 3 × 3 m platform with
        // a 0.1 m gap before it, the gaps shifted by 0.08 m from stair to stair
        // so that some gap holds a column's centre whatever the grid. A seat is
        // more than a step above the floor beside it; a platform is reached
        // only up its stair. A mast makes the box tall enough to stand on the
        // platforms.
        let mut m = MeshBuilder::new("square");
        m.terrain(-20.0, -20.0, 20.0, 20.0, 8, |_, _| 0.0);
        m.cuboid(Vec3::new(18.0, 0.0, 18.0), Vec3::new(18.5, 8.0, 18.5));
        for row in 0..4 {
            let x = -10.0 + row as f32;
            m.cuboid(Vec3::new(x, 0.42, -14.0), Vec3::new(x + 0.42, 0.47, -11.0));
            m.cuboid(Vec3::new(x + 0.42, 0.0, -14.0), Vec3::new(x + 0.48, 0.95, -11.0));
        }
        for k in 0..5 {
            let (x0, z0) = (-10.0 + 0.08 * k as f32, -6.0 + 4.0 * k as f32);
            for s in 0..10 {
                let x = x0 + 0.3 * s as f32;
                m.cuboid(Vec3::new(x, 0.0, z0), Vec3::new(x + 0.3, 0.2 * (s + 1) as f32, z0 + 1.5));
            }
            m.cuboid(Vec3::new(x0 + 3.1, 0.0, z0 - 0.75), Vec3::new(x0 + 6.1, 2.0, z0 + 2.25));
        }
        let mut square = m.finish();
        (square.scale_source, square.metres_per_unit) = (ScaleSource::File, 1.0);
        let rays = RayScene::new(&square.positions, &square.triangles, 0).unwrap();
        let (walk, stats) = free_space(&square, &rays, &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.height, "walk", "{stats:?}");
        for k in 0..5 {
            let top = Vec3::new(-5.4 + 0.08 * k as f32, 3.6, -5.25 + 4.0 * k as f32);
            assert!(walk.is_navigable(top), "platform {k} is not reached: {stats:?}");
        }
        // Wherever over the pews a probe is put, it stands on the floor or not at all.
        let mut stood = 0;
        for i in 0..40 {
            for j in 0..6 {
                let p = Vec3::new(-10.0 + 0.1 * i as f32, 1.9, -13.5 + 0.5 * j as f32);
                if let Some(s) = walk.stand(&rays, p) {
                    assert!((s.y - 1.6).abs() < 1e-3, "a probe near {p} stands at {s}, on a pew");
                    stood += 1;
                }
            }
        }
        assert!(stood > 20, "only {stood} of 240 points between the pews stand");
    }

    /// A square yard `2·half` m across, walled 0.2 m thick and `high` m high.
    fn walled_yard(name: &str, half: f32, high: f32) -> MeshBuilder {
        let mut m = MeshBuilder::new(name);
        m.cuboid(Vec3::new(-half, -0.2, -half), Vec3::new(half, 0.0, half));
        let inner = half - 0.2;
        for (x0, z0, x1, z1) in [(-half, -half, half, -inner), (-half, inner, half, half), (-half, -half, -inner, half), (inner, -half, half, half)] {
            m.cuboid(Vec3::new(x0, 0.0, z0), Vec3::new(x1, high, z1));
        }
        m
    }

    #[test]
    fn a_slot_between_two_walls_is_no_standpoint_and_a_corridor_middle_is() {
        // A walled yard with a corridor 2.1 m wide and a slot 0.45 m wide,
        // both 6 m long. The slot's middle line is no passage a visitor
        // stands in (it counted as one before the 1 m passage rule).
        let mut m = walled_yard("slot", 6.0, 3.0);
        for (z0, z1) in [(0.85, 0.95), (3.05, 3.15), (-3.1, -3.0), (-2.55, -2.45)] {
            m.cuboid(Vec3::new(-5.0, 0.0, z0), Vec3::new(1.0, 3.0, z1));
        }
        let mut yard = m.finish();
        (yard.scale_source, yard.metres_per_unit) = (ScaleSource::File, 1.0);
        let rays = RayScene::new(&yard.positions, &yard.triangles, 0).unwrap();
        let (space, stats) = free_space(&yard, &rays, &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.height, "walk", "{stats:?}");
        let (corridor, slot) = (Vec3::new(-2.0, 1.6, 2.0), Vec3::new(-2.0, 1.6, -2.775));
        assert_eq!(space.standpoint_rank(&rays, corridor), walk::Standpoint::Open);
        assert!(space.in_the_open(&rays, corridor));
        assert_eq!(space.standpoint_rank(&rays, slot), walk::Standpoint::Cramped);
        // Half a metre from the yard's wall, with little of the view near: clear, not open.
        assert_eq!(space.standpoint_rank(&rays, Vec3::new(3.5, 1.6, -5.1)), walk::Standpoint::Clear);
    }

    #[test]
    fn the_edge_of_a_terrace_is_no_standpoint_and_its_middle_is() {
        // A walled yard with a terrace 6 m square and 1 m high in its middle.
        let mut m = walled_yard("terrace", 8.0, 3.5);
        m.cuboid(Vec3::new(-3.0, 0.0, -3.0), Vec3::new(3.0, 1.0, 3.0));
        let mut yard = m.finish();
        (yard.scale_source, yard.metres_per_unit) = (ScaleSource::File, 1.0);
        let rays = RayScene::new(&yard.positions, &yard.triangles, 0).unwrap();
        let (space, stats) = free_space(&yard, &rays, &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.height, "walk", "{stats:?}");
        let rank = |x: f32, y: f32| space.standpoint_rank(&rays, Vec3::new(x, y, 0.5));
        assert_eq!(rank(0.0, 2.6), walk::Standpoint::Open, "the terrace's middle");
        assert_eq!(rank(2.6, 2.6), walk::Standpoint::Cramped, "0.4 m from the terrace's edge");
        // Below the terrace the floor rises, and nothing falls: open.
        assert_eq!(rank(5.0, 1.6), walk::Standpoint::Open, "the yard beside the terrace");
    }

    #[test]
    fn terraces_a_metre_up_in_the_open_are_walked_and_a_bench_is_not() {
        // A yard 40 m across within 1 m walls (open: level rays leave it); a
        // terrace 8 × 6 m and 1 m high, a second 4 × 4 m a metre higher on
        // it, each far under a sixth of the yard and reached only over a 1 m
        // ledge (before, both were left out: too small, and furniture beside
        // the yard). A solid bench 2 × 0.8 m beside them, a tower 8 m high
        // in a corner.
        let mut m = walled_yard("terraces", 20.0, 1.0);
        m.cuboid(Vec3::new(-19.8, 0.0, -19.8), Vec3::new(-17.8, 8.0, -17.8));
        m.cuboid(Vec3::new(0.0, 0.0, 0.0), Vec3::new(8.0, 1.0, 6.0));
        m.cuboid(Vec3::new(4.0, 1.0, 1.0), Vec3::new(8.0, 2.0, 5.0));
        m.cuboid(Vec3::new(-8.0, 0.0, -8.0), Vec3::new(-6.0, 0.5, -7.2));
        let mut yard = m.finish();
        (yard.scale_source, yard.metres_per_unit) = (ScaleSource::File, 1.0);
        let rays = RayScene::new(&yard.positions, &yard.triangles, 0).unwrap();
        // (A yard this open reads as an object in auto mode: it is given.)
        let params = FreeSpaceParams { space: SpaceMode::Inside, height: HeightMode::Walk, ..Default::default() };
        let (space, stats) = free_space(&yard, &rays, &params).unwrap();
        assert_eq!(stats.height, "walk", "{stats:?}");
        let eye_over = |x: f32, floor: f32, z: f32| space.stand_anywhere(&rays, Vec3::new(x, floor + 1.6, z)).map(|p| p.y - 1.6);
        assert!(eye_over(-10.0, 0.0, 10.0).is_some_and(|f| f.abs() < 0.1), "the yard");
        assert!(eye_over(2.0, 1.0, 3.0).is_some_and(|f| (f - 1.0).abs() < 0.1), "the first terrace");
        assert!(eye_over(6.0, 2.0, 3.0).is_some_and(|f| (f - 2.0).abs() < 0.1), "the second terrace");
        assert!(eye_over(-7.0, 0.5, -7.6).is_none_or(|f| (f - 0.5).abs() > 0.1), "the bench");
        // The yard's wall is as high as a terrace, and as large: too narrow.
        assert!(eye_over(0.0, 1.0, 19.9).is_none_or(|f| (f - 1.0).abs() > 0.1), "the wall's top");
    }

    #[test]
    fn a_flat_plaza_or_a_bare_ground_plane_has_sky_to_stand_in() {
        // A 40 m plaza whose tallest things are 1.2 m hedges: its own box ends
        // below eye height. Walked on at eye height, never above the sky given.
        let mut m = MeshBuilder::new("plaza");
        m.terrain(-20.0, -20.0, 20.0, 20.0, 8, |_, _| 0.0);
        for k in 0..4 {
            let x = -15.0 + 8.0 * k as f32;
            m.cuboid(Vec3::new(x, 0.0, -5.0), Vec3::new(x + 4.0, 1.2, -4.2));
            m.cuboid(Vec3::new(x, 0.0, 6.0), Vec3::new(x + 2.0, 0.5, 6.5));
        }
        let mut plaza = m.finish();
        (plaza.scale_source, plaza.metres_per_unit) = (ScaleSource::File, 1.0);
        let (walk, stats) = run(&plaza, &FreeSpaceParams::default()).unwrap();
        assert_eq!((stats.space, stats.height), ("inside", "walk"), "{stats:?}");
        assert!(stats.space_reason.contains("sky"), "{stats:?}");
        assert!(walk.is_navigable(Vec3::new(0.0, 1.6, 0.0)) && walk.is_navigable(Vec3::new(-14.0, 1.6, 15.0)), "eye height on the plaza");
        let (fly, _) = run(&plaza, &fly(SpaceMode::Inside)).unwrap();
        assert!(fly.is_navigable(Vec3::new(0.0, 2.2, 0.0)) && !fly.is_navigable(Vec3::new(0.0, 3.5, 0.0)), "the sky given ends a storey up");
        assert!(!fly.is_open(Vec3::new(0.0, -0.5, 0.0)), "never under the ground");
        // A ground plane alone (no height at all) is flown over, not refused.
        let mut m = MeshBuilder::new("field");
        m.terrain(-40.0, -25.0, 40.0, 25.0, 4, |_, _| 0.0);
        let (field, stats) = run(&m.finish(), &FreeSpaceParams::default()).unwrap();
        assert_eq!(stats.space, "inside", "{stats:?}");
        assert!(field.is_navigable(Vec3::new(0.0, 1.6, 0.0)), "{stats:?}");
        // Rooms are never that low: the gallery's box is its own.
        let gallery = BuiltIn::Gallery.generate(1);
        assert!(!room_box(&gallery.bounds(), 1.6, gallery.metres_per_unit).1);
    }

    #[test]
    fn walking_needs_a_scale_it_can_trust() {
        // The same box with its scale only guessed: rooms 3 m high are plausible,
        // rooms 30 units high under a guess of metres are not.
        for (height, walks) in [(3.0, true), (30.0, false)] {
            let mut scene = rooms(1, 2.0 * height, height, 1.5 * height, &[]);
            scene.scale_source = ScaleSource::Guessed;
            let (_, stats) = run(&scene, &FreeSpaceParams::default()).unwrap();
            assert_eq!(stats.height == "walk", walks, "{height}: {stats:?}");
        }
    }

    #[test]
    fn deterministic_at_any_thread_count() {
        let scene = BuiltIn::Pillars.generate(3);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let a = one.install(|| run(&scene, &FreeSpaceParams::default()).unwrap());
        let b = run(&scene, &FreeSpaceParams::default()).unwrap();
        assert_eq!(a.0.navigable, b.0.navigable);
        assert_eq!(a.0.open, b.0.open);
        assert_eq!(a.0.clearance, b.0.clearance);
    }
}

/// Slow: the shared third-party scenes (`cargo test -- --ignored`).
#[cfg(test)]
mod shared_scene_tests {
    use super::*;
    use crate::scene_io::{load, LoadOptions};

    fn shared(relative: &str) -> Option<Scene> {
        crate::testing::shared_scene(relative).map(|path| load(&path, &LoadOptions::default()).unwrap())
    }

    #[test]
    #[ignore]
    fn every_shared_scene_gets_a_sensible_space() {
        // (file, space, height, a point that must be navigable, one that must not,
        // floor levels one walking region must join).
        for (file, space, height, inside_point, outside_point, joined) in [
            ("sponza_crytek/sponza_crytek.obj", "inside", "fly", Vec3::new(0.0, 8.0, 0.0), Vec3::new(0.0, -3.0, 0.0), None),
            ("sponza_dabrovic/sponza.obj", "inside", "walk", Vec3::new(0.0, 1.6, 0.0), Vec3::new(0.0, 6.0, 0.0), None),
            ("stanford_bunny/bun_zipper.ply", "outside", "fly", Vec3::new(0.065, 0.1, 0.0), Vec3::new(-0.02, 0.1, 0.0), None),
            // The curved stair's treads have rounded nosings: it still joins the storeys.
            ("wooden_staircase/wooden_staircase.obj", "inside", "walk", Vec3::new(0.0, 1.6, -2.0), Vec3::new(0.0, 5.5, 3.0), Some(2)),
            ("grey_white_room/grey_white_room.obj", "inside", "walk", Vec3::new(1.6, 1.6, -0.8), Vec3::new(1.6, 0.5, -0.8), None),
            ("dream_apartment/dream_apartment.glb", "inside", "walk", Vec3::new(7.8, 1.6, -6.4), Vec3::new(7.8, 2.5, -6.4), None),
            ("cornell_box/CornellBox-Original.obj", "inside", "fly", Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, -0.5, 0.0), None),
        ] {
            let Some(scene) = shared(file) else { continue };
            let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
            let (fs, stats) = free_space(&scene, &rays, &FreeSpaceParams::default()).unwrap();
            eprintln!("{file}: {stats:?}");
            assert_eq!((stats.space, stats.height), (space, height), "{file}");
            assert!(fs.is_navigable(inside_point), "{file}: {inside_point} should be navigable");
            assert!(!fs.is_navigable(outside_point), "{file}: {outside_point} should not be");
            if let Some(levels) = joined {
                let walk = stats.walk.as_ref().expect("walked");
                assert_eq!((walk.regions_kept, walk.levels.len()), (1, levels), "{file}: one region over {levels} levels: {walk:?}");
            }
        }
    }
}
