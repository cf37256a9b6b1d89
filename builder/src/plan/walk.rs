//! Walk: human scale. Where a visitor can stand and walk, for probes at eye
//! height (the paper's future work; the navigable-space issue's item 2).
//!
//! Inputs: the free-space grid (occupancy, clearance, open space, the fly
//! navigable voxels), the ray-casting scene, the eye height, metres per unit.
//! Outputs: [`Walk`] (how to stand a probe up), the navigable band, [`WalkStats`].
//!
//! 1. Floor cells: in each grid column, every free voxel of the open space with
//!    an occupied voxel below it is a candidate; a ray down from its centre finds
//!    the exact floor (within a step and two voxels; where it falls through a
//!    gap narrower than the column, rays near the column's corners do), which
//!    must face up within the slope limit and not be water (a material named water, sea, ocean,
//!    lake, river, pond or pool: nobody walks on the sea around an island, nor
//!    on the sea bed under it).
//! 2. Standing: the ray up from the floor must be free for eye height plus head
//!    room, and the eye voxel must be in the fly space (clearance ≥ r).
//! 3. Walking: floor cells of columns within a stride (0.25 m, at least the
//!    four neighbours) join when their floors differ by at most a step plus the
//!    slope limit over one voxel (more than a step only where the floor
//!    halfway is within a step of both: a seat beside the floor is no step),
//!    and a ray at hip height between them is free (a railing or a wall stops
//!    it). Stairs and ramps therefore join
//!    storeys, also where a tread's nosing hides the floor under it from the
//!    grid; a ladder or a jump does not.
//! 4. Regions kept: the connected regions of at least a sixth of the largest
//!    one's floor, and enclosed ones of at least 6 m² (nine in ten level rays
//!    from their eyes meet something: a walled courtyard of a town, a room
//!    behind a closed door, reached by jumping), except roofs (regions whose
//!    floor mostly sees the sky with another floor below it: nobody tours the
//!    roof of the building they visit). Table tops, beds and window sills are
//!    smaller and drop out, as does ground at the model's edge that no door
//!    leads to. Room-sized regions at least 1 m wide somewhere that a ledge
//!    of up to 1.3 m joins to a kept one, with nothing between, are kept too (the terraces of a hill or a block
//!    world: a path glides over the ledge). A room joins the rest through its
//!    door: the walking grid is fine enough for doors (see [`crate::plan::freespace`]).
//! 5. The band: voxels within half a step plus one voxel of eye height above a
//!    kept floor cell, and in the fly space. Neighbouring columns' bands overlap,
//!    and where floor cells joined across a stride (a nosing) the band spans
//!    the gap along the line between their eyes, so the band is connected
//!    wherever people can walk. (Without that span, a staircase's storeys
//!    were apart in the band, and no path climbed it.)
//!
//! Furniture regions (raised a step to 1.3 m beside a floor 2.5 times their
//! size, indoors or under 12 m²: beds, tables, counters) are never kept.
//!
//! A probe [`Walk::stand`]s exactly at eye height above the floor under it,
//! which must be a kept floor of its column, and in the open part of a room
//! ([`Walk::in_the_open`]); [`Walk::stand_anywhere`] leaves out the latter.
//! Defaults: eye 1.6 m, head room 0.25 m above the eye, steps up to 0.3 m,
//! slopes up to 40°.

use crate::plan::freespace::Grid;
use crate::raycast::{Packing, Ray, RayScene};
use glam::Vec3;
use petgraph::unionfind::UnionFind;
use rayon::prelude::*;
use std::collections::BTreeMap;

pub const HEAD_ROOM_M: f32 = 0.25;
pub const STEP_M: f32 = 0.3;
/// Cosine of the steepest walkable slope (40°).
pub const SLOPE_COS: f32 = 0.766;
/// A person steps over a strip this wide where no foot can stand: a stair
/// tread's nosing, a threshold, a gutter. At grid resolution such strips read
/// as missing floor (a ray up from a column under a nosing meets it at once),
/// so floor cells join across them.
pub const STRIDE_M: f32 = 0.25;
/// A region is kept when its floor is at least this share of the largest's,
/// and it is not a roof.
const REGION_SHARE: f32 = 1.0 / 6.0;
/// ... or, whatever the largest, when it is an enclosed place of at least
/// this many square metres: a room can be that small, while beds, tables,
/// kitchen islands and window sills are smaller. (The share alone left out
/// every courtyard of a town whose streets were over six times its size.)
const ROOM_M2: f32 = 6.0;
/// Enclosed: at least this share of the level rays from its eyes meet
/// something, so a walled courtyard or a room behind a closed door counts,
/// and a fringe of ground at the model's edge, open to the world, does not.
const ENCLOSED_SHARE: f32 = 0.9;
/// A region is a roof when this share of its cells sees the sky above a floor.
const ROOF_SHARE: f32 = 0.7;

/// How probes stand, in scene units.
#[derive(Clone, Debug, PartialEq)]
pub struct Walk {
    pub eye: f32,
    pub head: f32,
    /// Longest way down from a point of the band to its floor.
    pub reach: f32,
    /// The kept floor cells, (column, floor height at its centre), sorted.
    floors: Vec<(usize, f32)>,
    /// The grid the columns are of.
    grid: Grid,
    /// Half a step, scene units.
    half_step: f32,
    /// A metre, scene units.
    metre: f32,
}

impl Walk {
    /// The point exactly eye height above the walkable floor under `p`, if a
    /// person fits there (head room above the eye). The caller checks that the
    /// point is navigable.
    ///
    /// The floor must be that of a kept floor cell of `p`'s column: within half
    /// a step of its height, plus the floor's own slope over the way to the
    /// column's centre. A column's floor cell is measured at its centre, and
    /// the band above it spans the whole column, so without this a probe
    /// stood over the pew, bench or table beside that centre, an eye 1.6 m
    /// above the seat (found on a cathedral's pews: 0.5 and 1 m too high).
    pub fn stand(&self, rays: &RayScene, p: Vec3) -> Option<Vec3> {
        self.stand_anywhere(rays, p).filter(|&eye| self.in_the_open(rays, eye))
    }

    /// [`Walk::stand`] without asking for the open part of a room: for spaces
    /// with no such part (a cabin, a crawlway).
    pub fn stand_anywhere(&self, rays: &RayScene, p: Vec3) -> Option<Vec3> {
        let hit = rays.intersect(&Ray { t_max: self.reach, ..Ray::new(p, Vec3::NEG_Y) })?;
        let up = hit.normal.y.abs();
        if up < SLOPE_COS {
            return None;
        }
        let floor = p - Vec3::Y * hit.t;
        let [x, _, z] = self.grid.cell(p)?;
        let column = x + self.grid.dims[0] * z;
        let centre = self.grid.center([x, 0, z]);
        let off = Vec3::new(p.x - centre.x, 0.0, p.z - centre.z).length();
        let slack = self.half_step + off * (1.0 - up * up).sqrt() / up;
        let first = self.floors.partition_point(|&(c, _)| c < column);
        let on_kept = self.floors[first..].iter().take_while(|&&(c, _)| c == column).any(|&(_, y)| (y - floor.y).abs() <= slack);
        if !on_kept {
            return None;
        }
        let tall = self.eye + self.head;
        let clear = !rays.occluded(&Ray { t_min: 1e-3 * tall, t_max: tall, ..Ray::new(floor, Vec3::Y) });
        clear.then_some(floor + Vec3::Y * self.eye)
    }

    /// Whether a visitor would stand at `eye`, as a tour photographer puts the
    /// tripod: in the open part of a room, at least [`WALL_M`] from walls and
    /// with little of the view within a metre (furniture too),
    /// or, where the space is narrower than twice that and a little more, on
    /// its middle line; never in a door frame or the mouth of a passage (a
    /// narrow place with a wide one within [`DOOR_DEPTH_M`] along it), never
    /// at the edge of a drop. Walls are what level rays from the eye meet.
    pub fn in_the_open(&self, rays: &RayScene, eye: Vec3) -> bool {
        self.standpoint_rank(rays, eye) == Standpoint::Open
    }

    /// How a visitor would judge `eye`: in the open ([`Walk::in_the_open`]);
    /// else clear (the same test at half the distance from walls, with at
    /// most a fifth of the view near: a bay, a wide hall's side); else only
    /// a place one can stand.
    pub fn standpoint_rank(&self, rays: &RayScene, eye: Vec3) -> Standpoint {
        // Both tests share the level rays and, when asked, the near share.
        let d = level_distances(rays, eye, 3.0 * self.metre);
        let share = std::cell::OnceCell::new();
        let near = || *share.get_or_init(|| near_share(rays, eye, self.metre));
        if self.near_a_drop(rays, eye) {
            Standpoint::Cramped
        } else if self.keeps_off_walls(rays, eye, &d, &near, WALL_M, NEAR_SHARE) {
            Standpoint::Open
        } else if self.keeps_off_walls(rays, eye, &d, &near, 0.5 * WALL_M, CLEAR_NEAR_SHARE) {
            Standpoint::Clear
        } else {
            Standpoint::Cramped
        }
    }

    /// Whether the floor falls away by more than a step near `eye` (a
    /// terrace's or a gallery's edge, the top of a stair, the rim of the
    /// ground): [`DROP_M`] around, in at least two of eight directions, so
    /// that a hillside one can walk is no edge.
    fn near_a_drop(&self, rays: &RayScene, eye: Vec3) -> bool {
        let floor = eye.y - self.eye;
        let list: Vec<Ray> = (0..8)
            .map(|k| {
                let a = k as f32 * std::f32::consts::FRAC_PI_4;
                let q = eye + Vec3::new(a.cos(), 0.0, a.sin()) * DROP_M * self.metre;
                Ray::new(q, Vec3::NEG_Y)
            })
            .collect();
        let falls = rays
            .intersect_batch(&list, Packing::Single)
            .iter()
            .zip(&list)
            .filter(|(h, r)| h.is_none_or(|h| r.at(h.t).y < floor - 2.0 * self.half_step))
            .count();
        falls >= 2
    }

    /// At least `wall_m` from walls (`d`: the level rays' distances) and
    /// under `near_limit` of the view near, or, in a narrower place, a
    /// passage's middle line (see [`Walk::in_the_open`]).
    fn keeps_off_walls(&self, rays: &RayScene, eye: Vec3, d: &[f32], near: &dyn Fn() -> f32, wall_m: f32, near_limit: f32) -> bool {
        let nearest = (0..LEVEL_RAYS).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0);
        let across = |d: &[f32], k: usize| d[k] + d[(k + LEVEL_RAYS / 2) % LEVEL_RAYS];
        let width = across(d, nearest);
        let wide = 2.0 * (wall_m + MIDDLE_M) * self.metre;
        // Where there is room for it, `wall_m` from walls; else near the middle.
        let least = if width >= 2.0 * wall_m * self.metre { wall_m * self.metre } else { 0.5 * width - MIDDLE_M * self.metre };
        if d[nearest] < least {
            return false;
        }
        if width >= wide {
            return near() < near_limit;
        }
        // A narrow place: a passage, not a gap between two things (a lamp and
        // a shelf 0.4 m apart at eye height), not a niche; along it (across
        // its narrowest), both ways, no wide space.
        if width < PASSAGE_M * self.metre || near() >= NARROW_NEAR_SHARE {
            return false;
        }
        let along = (nearest + LEVEL_RAYS / 4) % LEVEL_RAYS;
        [along, (along + LEVEL_RAYS / 2) % LEVEL_RAYS].iter().all(|&k| {
            let reach = (DOOR_DEPTH_M * self.metre).min(0.9 * d[k]);
            let there = level_distances(rays, eye + level_direction(k) * reach, 3.0 * self.metre);
            across(&there, nearest) < wide
        })
    }
}

/// A standpoint's rank, best first (see [`Walk::standpoint_rank`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Standpoint {
    Open,
    Clear,
    Cramped,
}

/// Level rays a standpoint is judged by (5.6° apart: a pole 0.1 m thick a
/// metre away is met).
const LEVEL_RAYS: usize = 64;
/// A probe stands at least this far from walls where the room allows, metres.
pub const WALL_M: f32 = 1.0;
/// ... and within this of the middle line of a narrower space, metres.
const MIDDLE_M: f32 = 0.2;
/// No standpoint has the floor fall away within this, metres.
const DROP_M: f32 = 0.75;
/// A door frame or a passage's mouth: a wide space within this along a narrow one, metres.
const DOOR_DEPTH_M: f32 = 0.8;

/// In the open, at most this share of the view below the ceiling lies within a metre.
const NEAR_SHARE: f32 = 0.04;
/// The narrowest passage a probe stands in, metres, and the most of its view
/// within a metre there (a corridor 1.8 m wide has about a sixth).
const PASSAGE_M: f32 = 1.0;
const NARROW_NEAR_SHARE: f32 = 0.25;
/// A clear standpoint's most view within a metre.
const CLEAR_NEAR_SHARE: f32 = 0.2;
/// Directions the near share is judged by.
const VIEW_RAYS: usize = 128;

/// The share of the view within a metre of `eye`, over directions below 30°
/// up (a ceiling a metre above the eye is no wall).
fn near_share(rays: &RayScene, eye: Vec3, metre: f32) -> f32 {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let list: Vec<Ray> = (0..VIEW_RAYS)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f32 + 0.5) / VIEW_RAYS as f32;
            let r = (1.0 - y * y).sqrt();
            let a = golden * k as f32;
            Ray { t_max: metre, ..Ray::new(eye, Vec3::new(r * a.cos(), y, r * a.sin())) }
        })
        .filter(|r| r.dir.y < 0.5)
        .collect();
    let near = rays.occluded_batch(&list, Packing::Single).iter().filter(|&&b| b).count();
    near as f32 / list.len().max(1) as f32
}

fn level_direction(k: usize) -> Vec3 {
    let a = k as f32 * std::f32::consts::TAU / LEVEL_RAYS as f32;
    Vec3::new(a.cos(), 0.0, a.sin())
}

/// Distances to what level rays from `p` meet, at most `far`.
fn level_distances(rays: &RayScene, p: Vec3, far: f32) -> Vec<f32> {
    let list: Vec<Ray> = (0..LEVEL_RAYS).map(|k| Ray { t_max: far, ..Ray::new(p, level_direction(k)) }).collect();
    rays.intersect_batch(&list, Packing::Single).iter().map(|h| h.map_or(far, |h| h.t)).collect()
}

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct WalkStats {
    pub eye_height_m: f32,
    /// Floor cells found, and those a person can stand on.
    pub floor_cells: usize,
    pub standing_cells: usize,
    /// Connected walkable regions, those kept, and roofs left out.
    pub regions: usize,
    pub regions_kept: usize,
    pub roofs: usize,
    /// Floor area of the kept regions, m².
    pub floor_area_m2: f64,
    /// Median free height above the floors that have a ceiling, m.
    pub room_height_m: Option<f32>,
    /// Storeys: (floor height in scene units, share of the kept floor area), for
    /// heights holding at least 5 % of it (bins of 0.25 m, neighbours merged).
    /// A landscape's rolling ground may show no level at all.
    pub levels: Vec<exploremaps_format::record::Floor>,
    pub rays: usize,
}

/// A floor found in a grid column.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloorCell {
    /// Column index x + dims[0]·z.
    pub column: usize,
    pub floor_y: f32,
    /// Free height above the floor (infinite under the sky).
    pub headroom: f32,
}

/// The floor cells of a grid, column by column, lowest first within a column.
pub struct Floors {
    pub cells: Vec<FloorCell>,
    pub rays: usize,
}

/// Whether each triangle is water (its material named so): never walked on.
pub fn water_triangles(scene: &exploremaps_scenes::Scene) -> Vec<bool> {
    const WORDS: [&str; 7] = ["water", "sea", "ocean", "lake", "river", "pond", "pool"];
    let water: Vec<bool> = scene
        .materials
        .iter()
        .map(|m| {
            let name = m.name.to_lowercase();
            WORDS.iter().any(|w| name.split(|c: char| !c.is_alphanumeric()).any(|part| part == *w))
        })
        .collect();
    scene.triangle_material.iter().map(|&m| water.get(m as usize).copied().unwrap_or(false)).collect()
}

/// Finds every floor in the open space (step 1), with its head room. The ray
/// down reaches a step plus two voxels: a column that straddles a step's edge
/// is occupied up to the higher tread while its centre stands over the lower.
pub fn floor_cells(grid: &Grid, occupied: &[bool], open: &[bool], rays: &RayScene, metres_per_unit: f32, water: &[bool]) -> Floors {
    let [nx, ny, nz] = grid.dims;
    let starts: Vec<[usize; 3]> = (0..nx * nz)
        .into_par_iter()
        .flat_map_iter(|col| {
            let (x, z) = (col % nx, col / nx);
            (1..ny).filter(move |&y| open[grid.index([x, y, z])] && occupied[grid.index([x, y - 1, z])]).map(move |y| [x, y, z])
        })
        .collect();
    let drop = 2.0 * grid.voxel + STEP_M / metres_per_unit;
    let down_from = |p: Vec3| Ray { t_max: drop, ..Ray::new(p, Vec3::NEG_Y) };
    let floor_at =
        |r: &Ray, h: &Option<crate::raycast::Hit>| h.filter(|h| h.normal.y.abs() >= SLOPE_COS && !water[h.triangle as usize]).map(|h| r.at(h.t));
    let down: Vec<Ray> = starts.iter().map(|&c| down_from(grid.center(c))).collect();
    let hits = rays.intersect_batch(&down, Packing::Single);
    let mut found: Vec<Option<Vec3>> = down.iter().zip(&hits).map(|(r, h)| floor_at(r, h)).collect();
    // Where the centre's ray finds no floor, the highest of four rays near
    // the column's corners (the geometry under the start voxel lies in the
    // column): a gap narrower than a voxel (a stair's last tread short of the
    // landing, a nosing) may hold the centre, and without a floor there the
    // columns either side, two voxels apart, never joined.
    let q = 0.45 * grid.voxel;
    let offsets = [Vec3::new(-q, 0.0, -q), Vec3::new(q, 0.0, -q), Vec3::new(-q, 0.0, q), Vec3::new(q, 0.0, q)];
    let missed: Vec<usize> = (0..starts.len()).filter(|&k| found[k].is_none()).collect();
    let again: Vec<Ray> = missed.iter().flat_map(|&k| offsets.map(|o| down_from(grid.center(starts[k]) + o))).collect();
    let hits_again = rays.intersect_batch(&again, Packing::Single);
    for (i, &k) in missed.iter().enumerate() {
        let four = (4 * i..4 * i + 4).filter_map(|j| floor_at(&again[j], &hits_again[j]));
        found[k] = four.max_by(|a, b| a.y.total_cmp(&b.y));
    }
    let floors: Vec<(usize, Vec3)> = starts.iter().zip(&found).filter_map(|(c, f)| f.map(|p| (c[0] + nx * c[2], p))).collect();
    let eps = 1e-3 * grid.voxel;
    let up: Vec<Ray> = floors.iter().map(|&(_, p)| Ray { t_min: eps, ..Ray::new(p, Vec3::Y) }).collect();
    let above = rays.intersect_batch(&up, Packing::Single);
    let cells = floors
        .iter()
        .zip(&above)
        // Under water (the first thing above is water) there is no head room.
        .map(|(&(column, p), h)| FloorCell {
            column,
            floor_y: p.y,
            headroom: h.map_or(f32::INFINITY, |h| if water[h.triangle as usize] { 0.0 } else { h.t }),
        })
        .collect();
    Floors { cells, rays: down.len() + again.len() + up.len() }
}

/// Whether a guessed scale makes the rooms a plausible height: the median free
/// height above floors that have a ceiling, in metres, must be 2 to 8 m. Says
/// why either way.
pub fn judge_scale(floors: &Floors, metres_per_unit: f32) -> Result<String, String> {
    let mut heights: Vec<f32> = floors.cells.iter().map(|c| c.headroom * metres_per_unit).filter(|h| h.is_finite() && *h > 0.5).collect();
    if heights.len() < 20 {
        return Err("no ceilings show how tall its rooms are".into());
    }
    heights.sort_by(f32::total_cmp);
    let median = heights[heights.len() / 2];
    if (2.0..=8.0).contains(&median) {
        Ok(format!("rooms {median:.1} m high"))
    } else {
        Err(format!(
            "its rooms would be {median:.1} m high (if they are about 3.5 m, the scale is about {:.3} m a unit)",
            3.5 / median * metres_per_unit
        ))
    }
}

/// Steps 2 to 5: the walkable regions and the eye-height band within `fly`.
pub fn walk_space(grid: &Grid, fly: &[bool], floors: &Floors, rays: &RayScene, eye: f32, metres_per_unit: f32) -> (Walk, Vec<bool>, WalkStats) {
    let gauge = Gauge::new(grid, eye, metres_per_unit);
    let standing = Standing::new(grid, fly, floors, &gauge);
    let (mut joined, bridges, hip_rays) = join_steps(grid, &standing, rays, &gauge);
    let mut regions = Regions::new(grid, floors, &standing, &mut joined, &gauge);
    let level_rays = regions.keep(grid, &standing, rays, &gauge);
    let (band, kept_cells) = eye_band(grid, fly, &standing, &regions, &bridges, &gauge);
    let mut kept_floors: Vec<(usize, f32)> =
        standing.cells.iter().zip(&regions.of).filter(|(_, &g)| regions.kept[g as usize]).map(|(c, _)| (c.column, c.floor_y)).collect();
    kept_floors.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let kept_heights: Vec<f32> = kept_floors.iter().map(|f| f.1).collect();
    let levels = levels(&kept_heights, 0.25 / metres_per_unit);
    let mut heights: Vec<f32> = floors.cells.iter().map(|c| c.headroom * metres_per_unit).filter(|h| h.is_finite()).collect();
    heights.sort_by(f32::total_cmp);
    let stats = WalkStats {
        eye_height_m: eye * metres_per_unit,
        floor_cells: floors.cells.len(),
        standing_cells: standing.cells.len(),
        regions: regions.sizes.len(),
        regions_kept: regions.kept.iter().filter(|&&k| k).count(),
        roofs: regions.roof.iter().filter(|&&r| r).count(),
        floor_area_m2: kept_cells as f64 * (grid.voxel * metres_per_unit) as f64 * (grid.voxel * metres_per_unit) as f64,
        room_height_m: heights.get(heights.len() / 2).copied(),
        levels,
        rays: floors.rays + hip_rays + level_rays,
    };
    let walk = Walk {
        eye,
        head: gauge.head,
        reach: eye + gauge.half_band + 2.0 * grid.voxel,
        floors: kept_floors,
        grid: grid.clone(),
        half_step: 0.5 * gauge.step,
        metre: 1.0 / metres_per_unit,
    };
    (walk, band, stats)
}

/// A person's measures in scene units.
struct Gauge {
    eye: f32,
    head: f32,
    /// The most a stride may rise: a step, and a slope's rise across a voxel.
    rise: f32,
    /// Half the eye-height band's thickness.
    half_band: f32,
    step: f32,
    metres_per_unit: f32,
}

impl Gauge {
    fn new(grid: &Grid, eye: f32, metres_per_unit: f32) -> Gauge {
        let rise = STEP_M / metres_per_unit + grid.voxel * (1.0 - SLOPE_COS * SLOPE_COS).sqrt() / SLOPE_COS;
        Gauge { eye, head: HEAD_ROOM_M / metres_per_unit, rise, half_band: 0.5 * rise + grid.voxel, step: STEP_M / metres_per_unit, metres_per_unit }
    }
}

/// Step 2: the floor cells a person can stand on (head room, eyes in the
/// space), and them by column for neighbour look-ups.
struct Standing {
    cells: Vec<FloorCell>,
    by_column: Vec<Vec<u32>>,
}

impl Standing {
    fn new(grid: &Grid, fly: &[bool], floors: &Floors, gauge: &Gauge) -> Standing {
        let (eye, head) = (gauge.eye, gauge.head);
        let eye_voxel = |c: &FloorCell| grid.cell(over_column(grid, c.column, c.floor_y + eye));
        let cells: Vec<FloorCell> =
            floors.cells.iter().copied().filter(|c| c.headroom >= eye + head && eye_voxel(c).is_some_and(|v| fly[grid.index(v)])).collect();
        let mut by_column: Vec<Vec<u32>> = vec![Vec::new(); grid.dims[0] * grid.dims[2]];
        for (k, c) in cells.iter().enumerate() {
            by_column[c.column].push(k as u32);
        }
        Standing { cells, by_column }
    }
}

/// The point `h` above a standing cell's floor.
fn above(grid: &Grid, c: &FloorCell, h: f32) -> Vec3 {
    over_column(grid, c.column, c.floor_y + h)
}

/// Step 3: steps to the next columns along x and z, then, between cells that
/// are still apart, to the other columns within a stride ahead (half the
/// disc, so each pair once); each checked by a hip-height ray. The rise is
/// the same across a stride as between neighbours: a step is a step, and
/// slopes are followed column by column. Returns the cells joined, the
/// joins across a stride (the band spans them), and the rays cast.
fn join_steps(grid: &Grid, standing: &Standing, rays: &RayScene, gauge: &Gauge) -> (UnionFind<u32>, Vec<(u32, u32)>, usize) {
    let (by_column, standing) = (&standing.by_column, &standing.cells);
    let (rise, step, eye, metres_per_unit) = (gauge.rise, gauge.step, gauge.eye, gauge.metres_per_unit);
    let centre = |c: &FloorCell, h: f32| above(grid, c, h);
    let (near, far): (Vec<_>, Vec<_>) = stride_offsets(grid.voxel * metres_per_unit).into_iter().partition(|&(dx, dz)| dx * dx + dz * dz == 1);
    let mut parent: UnionFind<u32> = UnionFind::new(standing.len());
    let mut hip_rays = 0;
    let mut bridges: Vec<(u32, u32)> = Vec::new();
    for (pass, offsets) in [near, far].iter().enumerate() {
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for (a, c) in standing.iter().enumerate() {
            let (x, z) = (c.column % grid.dims[0], c.column / grid.dims[0]);
            for &(dx, dz) in offsets {
                let (Some(nx), Some(nz)) = (x.checked_add_signed(dx), z.checked_add_signed(dz)) else { continue };
                if nx >= grid.dims[0] || nz >= grid.dims[2] {
                    continue;
                }
                for &b in &by_column[nx + grid.dims[0] * nz] {
                    let apart = pass == 0 || !parent.equiv(a as u32, b);
                    if apart && (standing[b as usize].floor_y - c.floor_y).abs() <= rise {
                        pairs.push((a as u32, b));
                    }
                }
            }
        }
        let hips: Vec<Ray> =
            pairs.iter().map(|&(a, b)| Ray::segment(centre(&standing[a as usize], 0.5 * eye), centre(&standing[b as usize], 0.5 * eye))).collect();
        hip_rays += hips.len();
        let blocked = rays.occluded_batch(&hips, Packing::Single);
        // A rise of more than a step is two steps (a stair's treads are
        // narrower than a voxel) or a slope only where the floor halfway lies
        // within a step of both ends; a seat or a bench beside the floor does
        // not (before this, the rise of a step and a slope let a visitor
        // onto a cathedral's pews, and probes stood on them).
        let ends = |k: usize| (&standing[pairs[k].0 as usize], &standing[pairs[k].1 as usize]);
        let tall: Vec<usize> = (0..pairs.len()).filter(|&k| !blocked[k] && (ends(k).0.floor_y - ends(k).1.floor_y).abs() > step).collect();
        // Each cast down from half a step above the higher floor, to half a step below the lower.
        let halfway: Vec<Ray> = tall
            .iter()
            .map(|&k| {
                let (a, b) = ends(k);
                let top = a.floor_y.max(b.floor_y) + 0.5 * step;
                let mid = centre(a, 0.0).lerp(centre(b, 0.0), 0.5).with_y(top);
                Ray { t_max: (a.floor_y - b.floor_y).abs() + step, ..Ray::new(mid, Vec3::NEG_Y) }
            })
            .collect();
        hip_rays += halfway.len();
        let mut shut_tall = vec![false; pairs.len()];
        for ((&k, ray), hit) in tall.iter().zip(&halfway).zip(rays.intersect_batch(&halfway, Packing::Single)) {
            let (a, b) = ends(k);
            // The floor met, if it faces up within the slope limit.
            let y = hit.filter(|h| h.normal.y.abs() >= SLOPE_COS).map(|h| ray.at(h.t).y);
            shut_tall[k] = !y.is_some_and(|y| (y - a.floor_y).abs() <= step && (y - b.floor_y).abs() <= step);
        }
        for ((&(a, b), &shut), &steep) in pairs.iter().zip(&blocked).zip(&shut_tall) {
            if !shut && !steep {
                if pass == 1 {
                    bridges.push((a, b));
                }
                parent.union(a, b);
            }
        }
    }
    (parent, bridges, hip_rays)
}

/// Step 4: standing cells joined into regions; roofs, what is outdoors, and
/// which regions are kept.
struct Regions {
    /// Per standing cell.
    of: Vec<u32>,
    /// Per region, in standing cells.
    sizes: Vec<usize>,
    roof: Vec<bool>,
    outdoors: Vec<bool>,
    kept: Vec<bool>,
}

impl Regions {
    fn new(grid: &Grid, floors: &Floors, standing: &Standing, joined: &mut UnionFind<u32>, gauge: &Gauge) -> Regions {
        let standing = &standing.cells;
        let roots: Vec<u32> = (0..standing.len() as u32).map(|k| joined.find_mut(k)).collect();
        let mut region_of = vec![u32::MAX; standing.len()];
        let mut sizes: Vec<usize> = Vec::new();
        let mut roofish: Vec<usize> = Vec::new();
        let mut sky: Vec<usize> = Vec::new();
        let lowest: Vec<f32> = by_column_lowest(floors, grid.dims[0] * grid.dims[2]);
        for k in 0..standing.len() {
            let r = roots[k] as usize;
            if region_of[r] == u32::MAX {
                region_of[r] = sizes.len() as u32;
                sizes.push(0);
                roofish.push(0);
                sky.push(0);
            }
            let g = region_of[r] as usize;
            region_of[k] = g as u32;
            sizes[g] += 1;
            let c = &standing[k];
            sky[g] += c.headroom.is_infinite() as usize;
            if c.headroom.is_infinite() && lowest[c.column] < c.floor_y - gauge.rise {
                roofish[g] += 1;
            }
        }
        let roof: Vec<bool> = (0..sizes.len()).map(|g| roofish[g] as f32 >= ROOF_SHARE * sizes[g] as f32).collect();
        let outdoors: Vec<bool> = (0..sizes.len()).map(|g| 2 * sky[g] > sizes[g]).collect();
        Regions { of: region_of, kept: vec![false; sizes.len()], sizes, roof, outdoors }
    }

    /// Keeps the large regions that are no roof and no furniture, smaller
    /// room-sized ones when enclosed (16 level rays from the eyes of up to 16
    /// of their cells, spread through the region), and terraces a ledge away
    /// from a kept region. Returns the rays cast.
    fn keep(&mut self, grid: &Grid, standing: &Standing, rays: &RayScene, gauge: &Gauge) -> usize {
        let (sizes, roof, region_of) = (&self.sizes, &self.roof, &self.of);
        let (eye, metres_per_unit) = (gauge.eye, gauge.metres_per_unit);
        let largest = (0..sizes.len()).filter(|&g| !roof[g]).map(|g| sizes[g]).max().unwrap_or(0);
        let cell_m2 = (grid.voxel * metres_per_unit).powi(2);
        let ledges = ledges(grid, standing, region_of, gauge, rays);
        let furniture = furniture(&ledges, sizes, &self.outdoors, cell_m2);
        let mut kept: Vec<bool> = (0..sizes.len()).map(|g| !roof[g] && !furniture[g] && sizes[g] as f32 >= REGION_SHARE * largest as f32).collect();
        let rooms: Vec<usize> = (0..sizes.len()).filter(|&g| !roof[g] && !furniture[g] && !kept[g] && sizes[g] as f32 * cell_m2 >= ROOM_M2).collect();
        let mut cells_of: Vec<Vec<usize>> = vec![Vec::new(); sizes.len()];
        for (k, &g) in region_of.iter().enumerate() {
            if rooms.binary_search(&(g as usize)).is_ok() {
                cells_of[g as usize].push(k);
            }
        }
        let mut level_rays = Vec::new();
        for &g in &rooms {
            let cells = &cells_of[g];
            for i in 0..16.min(cells.len()) {
                let eye_at = above(grid, &standing.cells[cells[i * cells.len() / 16.min(cells.len())]], eye);
                for d in 0..16 {
                    let a = d as f32 * std::f32::consts::TAU / 16.0;
                    level_rays.push(Ray::new(eye_at, Vec3::new(a.cos(), 0.0, a.sin())));
                }
            }
        }
        let met = rays.occluded_batch(&level_rays, Packing::Single);
        let mut at = 0;
        for &g in &rooms {
            let n = 16 * 16.min(sizes[g]);
            kept[g] = met[at..at + n].iter().filter(|&&m| m).count() as f32 >= ENCLOSED_SHARE * n as f32;
            at += n;
        }
        let candidates: Vec<bool> = (0..sizes.len()).map(|g| !kept[g] && !roof[g] && !furniture[g] && sizes[g] as f32 * cell_m2 >= ROOM_M2).collect();
        let radius = (TERRACE_WIDTH_M / (2.0 * grid.voxel * metres_per_unit)).ceil() as isize;
        let wide = wide_regions(grid, standing, region_of, &candidates, radius);
        keep_terraces(&mut kept, &ledges, |g| candidates[g] && wide[g]);
        self.kept = kept;
        level_rays.len()
    }
}

/// Step 5: the eye-height band over the kept regions' cells, and along each
/// kept join across a stride; with the count of kept cells.
fn eye_band(grid: &Grid, fly: &[bool], standing: &Standing, regions: &Regions, bridges: &[(u32, u32)], gauge: &Gauge) -> (Vec<bool>, usize) {
    let (eye, half_band) = (gauge.eye, gauge.half_band);
    let (kept, region_of) = (&regions.kept, &regions.of);
    let centre = |c: &FloorCell, h: f32| above(grid, c, h);
    let mut band = vec![false; grid.len()];
    let mut kept_cells = 0usize;
    for (k, c) in standing.cells.iter().enumerate() {
        if !kept[region_of[k] as usize] {
            continue;
        }
        kept_cells += 1;
        let (lo, hi) = (centre(c, eye - half_band), centre(c, eye + half_band));
        let (Some(a), Some(b)) = (grid.cell(lo).or(grid.cell(centre(c, eye))), grid.cell(hi).or(grid.cell(centre(c, eye)))) else { continue };
        for y in a[1]..=b[1] {
            let i = grid.index([a[0], y, a[2]]);
            band[i] |= fly[i];
        }
    }
    // Each voxel on the line between two bridged eyes, and those within half
    // the band above and below it.
    let reach = (half_band / grid.voxel).ceil() as usize;
    for &(a, b) in bridges.iter().filter(|&&(a, _)| kept[region_of[a as usize] as usize]) {
        let (a, b) = (&standing.cells[a as usize], &standing.cells[b as usize]);
        grid.walk_segment(centre(a, eye), centre(b, eye), |i| {
            let [x, y, z] = grid.coords(i);
            for y in y.saturating_sub(reach)..=(y + reach).min(grid.dims[1] - 1) {
                let j = grid.index([x, y, z]);
                band[j] |= fly[j];
            }
            true
        });
    }
    (band, kept_cells)
}

/// The point at height `y` over the centre of grid column `column`.
fn over_column(grid: &Grid, column: usize, y: f32) -> Vec3 {
    let (x, z) = (column % grid.dims[0], column / grid.dims[0]);
    Vec3::new(grid.origin.x + (x as f32 + 0.5) * grid.voxel, y, grid.origin.z + (z as f32 + 0.5) * grid.voxel)
}

/// Where one region's floor lies a step to [`FURNITURE_M`] above another's
/// along their edge (within two columns).
struct Ledge {
    /// A level ray from the higher region's eye over the lower floor is free
    /// for at least half the columns tried (no wall between).
    open: bool,
}

/// The ledges between regions, keyed (higher region, lower region).
fn ledges(grid: &Grid, standing: &Standing, region_of: &[u32], gauge: &Gauge, rays: &RayScene) -> BTreeMap<(u32, u32), Ledge> {
    let (by_column, standing) = (&standing.by_column, &standing.cells);
    let (step, metre, eye) = (gauge.step, 1.0 / gauge.metres_per_unit, gauge.eye);
    /// Column pairs tried a ledge for openness.
    const TRIED: usize = 8;
    let mut samples: BTreeMap<(u32, u32), Vec<(usize, usize)>> = BTreeMap::new();
    for (a, c) in standing.iter().enumerate() {
        let (x, z) = ((c.column % grid.dims[0]) as isize, (c.column / grid.dims[0]) as isize);
        for (dx, dz) in [(1, 0), (-1, 0), (0, 1), (0, -1), (2, 0), (-2, 0), (0, 2), (0, -2)] {
            let (nx, nz) = (x + dx, z + dz);
            if nx < 0 || nz < 0 || nx >= grid.dims[0] as isize || nz >= grid.dims[2] as isize {
                continue;
            }
            for &b in &by_column[nx as usize + grid.dims[0] * nz as usize] {
                let (ra, rb) = (region_of[a], region_of[b as usize]);
                let rise = c.floor_y - standing[b as usize].floor_y;
                if ra != rb && rise > step && rise <= FURNITURE_M * metre {
                    let tried = samples.entry((ra, rb)).or_default();
                    if tried.len() < TRIED {
                        tried.push((a, b as usize));
                    }
                }
            }
        }
    }
    let level: Vec<Ray> = samples
        .values()
        .flatten()
        .map(|&(a, b)| {
            let y = standing[a].floor_y + eye;
            Ray::segment(over_column(grid, standing[a].column, y), over_column(grid, standing[b].column, y))
        })
        .collect();
    let blocked = rays.occluded_batch(&level, Packing::Single);
    let mut at = 0;
    samples
        .into_iter()
        .map(|(key, tried)| {
            let free = blocked[at..at + tried.len()].iter().filter(|&&b| !b).count();
            at += tried.len();
            (key, Ledge { open: 2 * free >= tried.len() })
        })
        .collect()
}

/// Regions that are furniture: beside a region at least 2.5 times their
/// size, whose floor lies a step to [`FURNITURE_M`] below theirs along their
/// edge (a bed, a table, a sofa, a counter; a stage too, which nobody tours
/// from), and indoors or smaller than [`FURNITURE_MAX_M2`]. Terraces in the
/// open, and terraces of like size and storeys, which stairs join into one
/// region, are not.
fn furniture(ledges: &BTreeMap<(u32, u32), Ledge>, sizes: &[usize], outdoors: &[bool], cell_m2: f32) -> Vec<bool> {
    let mut out = vec![false; sizes.len()];
    for &(ra, rb) in ledges.keys() {
        let (ra, rb) = (ra as usize, rb as usize);
        let small = sizes[ra] as f32 * cell_m2 < FURNITURE_MAX_M2;
        if (sizes[ra] as f32) * FURNITURE_SHARE < sizes[rb] as f32 && (small || !outdoors[ra]) {
            out[ra] = true;
        }
    }
    out
}

/// A terrace is at least this wide somewhere, metres (a wall's top is not).
const TERRACE_WIDTH_M: f32 = 1.0;

/// Of the `candidates`, the regions with a cell whose square of `radius`
/// cells around it is all theirs: somewhere a person's footprint fits with
/// room to turn.
fn wide_regions(grid: &Grid, standing: &Standing, region_of: &[u32], candidates: &[bool], radius: isize) -> Vec<bool> {
    let (by_column, standing) = (&standing.by_column, &standing.cells);
    let mut wide = vec![false; candidates.len()];
    let theirs = |x: isize, z: isize, g: u32| {
        (0..grid.dims[0] as isize).contains(&x)
            && (0..grid.dims[2] as isize).contains(&z)
            && by_column[x as usize + grid.dims[0] * z as usize].iter().any(|&b| region_of[b as usize] == g)
    };
    for (k, c) in standing.iter().enumerate() {
        let g = region_of[k];
        if !candidates[g as usize] || wide[g as usize] {
            continue;
        }
        let (x, z) = ((c.column % grid.dims[0]) as isize, (c.column / grid.dims[0]) as isize);
        wide[g as usize] = (-radius..=radius).all(|dz| (-radius..=radius).all(|dx| theirs(x + dx, z + dz, g)));
    }
    wide
}

/// Regions an open ledge joins to a kept region are kept too, in chains,
/// where `eligible` (room-sized, wide, not roofs or furniture): the terraces
/// of a hill or a block world, a metre up or down from the street, which a
/// path reaches by gliding over the ledge.
fn keep_terraces(kept: &mut [bool], ledges: &BTreeMap<(u32, u32), Ledge>, eligible: impl Fn(usize) -> bool) {
    loop {
        let mut grown = false;
        for (&(hi, lo), _) in ledges.iter().filter(|(_, l)| l.open) {
            for (from, to) in [(lo as usize, hi as usize), (hi as usize, lo as usize)] {
                if kept[from] && !kept[to] && eligible(to) {
                    kept[to] = true;
                    grown = true;
                }
            }
        }
        if !grown {
            return;
        }
    }
}

/// Furniture tops stand at most this high above the floor, metres (a counter,
/// a bed's head); ledges a path glides over are as high.
const FURNITURE_M: f32 = 1.3;
/// Furniture in the open is smaller than this, m² (a picnic table, a bench).
const FURNITURE_MAX_M2: f32 = 12.0;
/// A raised region is furniture when the floor beside it is this many times larger.
const FURNITURE_SHARE: f32 = 2.5;

/// Column offsets (dx, dz) ahead of a column within a stride, at least the
/// next columns along x and z: the half disc with dz > 0, or dz = 0 and dx > 0,
/// so that each pair of columns is tried once.
fn stride_offsets(voxel_m: f32) -> Vec<(isize, isize)> {
    let k = (STRIDE_M / voxel_m).floor().max(1.0);
    let n = k as isize;
    let mut out = Vec::new();
    for dz in 0..=n {
        for dx in -n..=n {
            if (dz > 0 || dx > 0) && ((dx * dx + dz * dz) as f32).sqrt() <= k {
                out.push((dx, dz));
            }
        }
    }
    out
}

/// Floor heights holding at least 5 % of the cells, in bins of `bin` units,
/// neighbouring bins merged: (mean height, share of the cells).
fn levels(heights: &[f32], bin: f32) -> Vec<exploremaps_format::record::Floor> {
    if heights.is_empty() {
        return Vec::new();
    }
    let lowest = heights.iter().copied().fold(f32::INFINITY, f32::min);
    let mut bins: std::collections::BTreeMap<i64, (f64, usize)> = std::collections::BTreeMap::new();
    for &h in heights {
        let e = bins.entry(((h - lowest) / bin) as i64).or_default();
        e.0 += h as f64;
        e.1 += 1;
    }
    let n = heights.len() as f32;
    let mut out: Vec<(i64, f64, usize)> = Vec::new();
    for (k, (sum, count)) in bins.into_iter().filter(|(_, (_, c))| *c as f32 >= 0.05 * n) {
        match out.last_mut() {
            Some(last) if last.0 + 1 == k => *last = (k, last.1 + sum, last.2 + count),
            _ => out.push((k, sum, count)),
        }
    }
    out.into_iter().map(|(_, sum, count)| ((sum / count as f64) as f32, count as f32 / n).into()).collect()
}

/// Per column, the lowest floor height (infinite where there is none).
fn by_column_lowest(floors: &Floors, columns: usize) -> Vec<f32> {
    let mut lowest = vec![f32::INFINITY; columns];
    for c in &floors.cells {
        lowest[c.column] = lowest[c.column].min(c.floor_y);
    }
    lowest
}
