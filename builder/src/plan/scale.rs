//! Scale: how many metres a unit is, from the scene's own evidence, when the
//! file does not say (OBJ and PLY never do).
//!
//! Inputs: the scene and its ray-casting structure. Output: a [`ScaleGuess`]:
//! the scale, the evidence that decided it, how sure it is, and the runner-up.
//!
//! Evidence: vertical lines on a regular grid of columns over the scene's
//! footprint are followed down through every surface they cross. Each
//! near-horizontal surface met below another gives a *gap* (where the faces
//! are oriented, only gaps of air: below a face the line leaves a solid
//! through, above one it enters a solid through): the height free
//! above a floor (a room, a storey), above a seat or a table top, under a
//! table, or through a slab. Built things share these heights whatever their
//! unit: rooms are 2.2 to 5 m high, halls more, furniture stands 0.4 to 1 m
//! high, slabs are a few decimetres. The same columns find *parapets*: the
//! top of a thin solid barrier with a room's floor on one side and a deep
//! drop on the other (gallery guards, balustrades, upper-floor sills), about
//! a metre high whatever the building. Each scale is scored by how well
//! mixtures of those metric heights explain the gaps and the parapets (in
//! log height, so the scale is a shift), each weighed as a fixed number of
//! independent observations (neighbouring columns see the same room, one
//! design repeats its parapets); the common units (m, cm, mm,
//! inch, foot, decimetre) are favoured a priori but not required, since
//! exports often rescale (the Crytek Sponza as shipped is centimetres / 20).
//! Posterior mass within a factor 1.25 of the best scale says how sure the
//! guess is; the best scale outside that window is the runner-up.
//!
//! Scenes with no gaps under a ceiling (objects, open landscapes) have no
//! such evidence: the guess from the size alone stands
//! ([`exploremaps_scenes::guess_metres_per_unit`]) and is not trusted.

use crate::raycast::{Packing, Ray, RayScene};
use exploremaps_scenes::Scene;
use glam::Vec3;

/// Columns on the footprint's long side.
const COLUMNS: usize = 80;
/// Surfaces followed down each column at most.
const MAX_LAYERS: usize = 16;
/// A surface is near-horizontal when its normal is within 40° of vertical.
const HORIZONTAL_COS: f32 = 0.766;
/// The gaps count as this many independent observations at most.
const OBSERVATIONS: f64 = 6.0;
/// Gaps needed before they say anything.
const MIN_GAPS: usize = 50;
/// A guess is sure when this share of the posterior lies within a factor
/// 1.25 of it.
const SURE: f64 = 0.8;

/// Metric heights built things share: (median m, spread in ln, weight).
const HEIGHTS: [(f64, f64, f64); 4] = [
    (0.25, 0.5, 0.1),  // slabs and treads (where faces are not oriented)
    (0.6, 0.35, 0.2),  // under tables and seats, furniture tops above floors
    (3.6, 0.4, 0.55),  // rooms and storeys, houses to palaces
    (10.0, 0.6, 0.15), // halls, naves, atria
];
/// Parapet, sill and low-wall heights (as [`HEIGHTS`]).
const PARAPETS: [(f64, f64, f64); 2] = [
    (0.95, 0.15, 0.8), // guards and sills
    (1.2, 0.6, 0.2),   // low walls, higher sills
];
/// Parapets count as this many independent observations (one design repeats).
const PARAPET_OBSERVATIONS: f64 = 3.0;
/// Parapets needed before they say anything.
const MIN_PARAPETS: usize = 10;
/// Common units (m a unit) and their names.
pub const UNITS: [(f32, &str); 6] = [(1.0, "m"), (0.1, "dm"), (0.01, "cm"), (0.001, "mm"), (0.0254, "inch"), (0.3048, "foot")];
/// Prior mass on the common units together (the rest spread evenly over ln scale).
const UNIT_PRIOR: f64 = 0.6;
/// Spread of a unit's prior, ln (a unit is a unit; exports round a little).
const UNIT_SPREAD: f64 = 0.03;
/// Scales scored: ln metres a unit from 1e-5 to 1e3, in steps of 1 %.
const LN_LO: f64 = -11.5;
const LN_HI: f64 = 6.9;
const LN_STEP: f64 = 0.01;

/// What the evidence says about the scale.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ScaleGuess {
    pub metres_per_unit: f32,
    /// The common unit it is (within 3 %), if any.
    pub unit: Option<&'static str>,
    /// Posterior mass within a factor 1.25 of the guess.
    pub confidence: f32,
    pub sure: bool,
    /// The most likely scale outside that factor.
    pub runner_up: Option<f32>,
    /// Near-horizontal gaps measured, and the heights that decided (metres at
    /// the guess: the median room-sized gap).
    pub gaps: usize,
    pub room_height_m: Option<f32>,
    /// Parapets counted (none when too few to say anything), and their
    /// median height at the guess.
    pub parapets: usize,
    pub parapet_m: Option<f32>,
}

impl ScaleGuess {
    /// One line: the scale, the evidence, how sure.
    pub fn describe(&self) -> String {
        let unit = self.unit.map_or(String::new(), |u| format!(" (a {u})"));
        let room = self.room_height_m.map_or(String::new(), |h| format!(", rooms {h:.1} m high"));
        let alt = self.runner_up.map_or(String::new(), |a| format!("; else {}", scale_words(a)));
        let parapets = self.parapet_m.map_or(String::new(), |h| format!(" and {} parapets and sills, {h:.2} m high", self.parapets));
        format!(
            "{} m a unit{unit} from {} heights between floors and what is above them{room}{parapets}, {:.0} % sure{alt}",
            short(self.metres_per_unit),
            self.gaps,
            100.0 * self.confidence
        )
    }
}

/// At most four decimals, no trailing zeros (10 stays 10).
pub fn short(m: f32) -> String {
    let s = format!("{m:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

fn scale_words(m: f32) -> String {
    match unit_of(m) {
        Some(u) => format!("{} m a unit (a {u})", short(m)),
        None => format!("{} m a unit", short(m)),
    }
}

/// The common unit within 3 % of `m`.
pub fn unit_of(m: f32) -> Option<&'static str> {
    UNITS.iter().find(|(u, _)| (m / u).ln().abs() < 0.03).map(|&(_, name)| name)
}

/// The scale the scene's heights say, or `None` without enough of them.
pub fn guess(scene: &Scene, rays: &RayScene) -> Option<ScaleGuess> {
    let evidence = evidence(scene, rays);
    if evidence.gaps.len() < MIN_GAPS {
        return None;
    }
    Some(judge(&evidence))
}

/// Heights measured along vertical columns, scene units.
#[derive(Clone, Debug, Default)]
pub struct Evidence {
    /// Gaps above near-horizontal surfaces: one per surface met below another.
    pub gaps: Vec<f32>,
    /// Parapets, sills and low walls: the top of a solid barrier above the
    /// floor on one side, with a drop at least [`DROP_BEHIND`] times as deep
    /// on the other.
    pub parapets: Vec<f32>,
}

/// Per column of the grid, top down: (height, the surface's normal's y).
struct Columns {
    layers: Vec<Vec<(f32, f32)>>,
    nx: usize,
    nz: usize,
    /// Faces are oriented (outward normals): see [`oriented_share`].
    oriented: bool,
    /// Heights closer than this are the same surface.
    eps: f32,
    /// The grid's spacing.
    step: f32,
}

/// The heights the scene's columns say.
pub fn evidence(scene: &Scene, rays: &RayScene) -> Evidence {
    let columns = columns(scene, rays);
    let gaps = gaps(&columns);
    let typical = if gaps.is_empty() { f32::INFINITY } else { median(&gaps) };
    Evidence { parapets: parapets(&columns, typical), gaps }
}

/// The middle value (the upper one of an even count); `values` is not empty.
fn median(values: &[f32]) -> f32 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f32::total_cmp);
    sorted[sorted.len() / 2]
}

/// Follows vertical lines on a grid over the footprint down through every
/// surface they cross.
fn columns(scene: &Scene, rays: &RayScene) -> Columns {
    let b = scene.bounds();
    let e = b.extent();
    let long = e.x.max(e.z).max(1e-9);
    let step = long / COLUMNS as f32;
    let (nx, nz) = (((e.x / step).ceil() as usize).max(1), ((e.z / step).ceil() as usize).max(1));
    let top = b.max.y + 0.01 * e.y.max(1e-6) + 1e-6;
    // Columns off the grid's lines by an irrational share, so that they do
    // not run along the edges of an axis-aligned model.
    let mut rays_down: Vec<Ray> = (0..nx * nz)
        .map(|k| {
            let (i, j) = (k % nx, k / nx);
            Ray::new(Vec3::new(b.min.x + (i as f32 + 0.382) * step, top, b.min.z + (j as f32 + 0.618) * step), Vec3::NEG_Y)
        })
        .collect();
    let eps = 1e-5 * b.diagonal().max(1e-6);
    let mut layers: Vec<Vec<(f32, f32)>> = vec![Vec::new(); rays_down.len()];
    let mut active: Vec<usize> = (0..rays_down.len()).collect();
    for _ in 0..MAX_LAYERS {
        if active.is_empty() {
            break;
        }
        let batch: Vec<Ray> = active.iter().map(|&k| rays_down[k]).collect();
        let hits = rays.intersect_batch(&batch, Packing::Single);
        let mut next = Vec::with_capacity(active.len());
        for (&k, hit) in active.iter().zip(hits) {
            if let Some(h) = hit {
                let y = rays_down[k].at(h.t).y;
                layers[k].push((y, h.normal.y));
                rays_down[k].t_min = h.t + eps;
                next.push(k);
            }
        }
        active = next;
    }
    let oriented = oriented_share(&layers) >= ORIENTED;
    Columns { layers, nx, nz, oriented, eps: 1e-4 * e.y.max(long), step }
}

fn horizontal(normal_y: f32) -> bool {
    normal_y.abs() >= HORIZONTAL_COS
}

/// The vertical gaps above near-horizontal surfaces, one per surface met
/// below another along a column.
fn gaps(columns: &Columns) -> Vec<f32> {
    let oriented = columns.oriented;
    columns
        .layers
        .iter()
        .flat_map(|column| {
            // Oriented faces tell air from solid: air lies below a face the
            // ray leaves a solid through (normal along the ray, down) and
            // above one it enters a solid through (normal up).
            column.windows(2).filter(move |w| horizontal(w[1].1) && (!oriented || (w[0].1 < 0.0 && w[1].1 > 0.0))).map(|w| w[0].0 - w[1].0)
        })
        .filter(|&g| g > columns.eps)
        .collect()
}

/// A barrier counts as a parapet when the drop behind it is at least this
/// many times its height above the floor in front.
const DROP_BEHIND: f32 = 3.0;
/// A parapet stands this share of the way up the space open above the floor
/// in front (guards and sills, not mouldings, kerbs or walls to the ceiling).
const PARAPET_SHARE: std::ops::RangeInclusive<f32> = 0.15..=0.5;

/// A barrier is at most this many columns thick.
const MAX_THICKNESS: usize = 4;

/// Parapet heights: a column whose up-facing top stands on solid down to a
/// floor, thinner than it is high, with a room's floor on one side and a
/// drop [`DROP_BEHIND`] times as deep (or no floor) on the other. Tables
/// and seats do not count (air under their tops), nor steps (the neighbour
/// up the stair is higher).
fn parapets(columns: &Columns, typical_gap: f32) -> Vec<f32> {
    let mut found = Vec::new();
    for (k, column) in columns.layers.iter().enumerate() {
        for (at, &(top, normal_y)) in column.iter().enumerate() {
            if normal_y < HORIZONTAL_COS {
                continue;
            }
            // On the same column, the next surface down is the barrier's foot.
            let Some(&(foot, _)) = column.get(at + 1) else { continue };
            for axis in [(1, 0), (0, 1)] {
                let sides = [(-axis.0, -axis.1), axis].map(|d| columns.beside(k, top, d));
                let [Some(a), Some(b)] = sides else { continue };
                let thickness = (a.steps + b.steps - 1) as f32 * columns.step;
                let (front, behind) = if a.drop <= b.drop { (a, b) } else { (b, a) };
                let height = front.drop;
                let solid = foot <= top - 0.9 * height && thickness <= height;
                // The floor in front is a room's (open at least 0.4 of the
                // typical gap), not a shelf's or a cabinet's top.
                let room = front.open >= 0.4 * typical_gap;
                if solid && room && height > columns.eps && PARAPET_SHARE.contains(&(height / front.open)) && behind.drop >= DROP_BEHIND * height {
                    found.push(height);
                }
            }
        }
    }
    found
}

/// What lies beside a barrier, past its thickness.
struct Side {
    /// Columns from the barrier's column to the first open one.
    steps: usize,
    /// The barrier's top above the floor there (infinite: no floor).
    drop: f32,
    /// The height open above that floor.
    open: f32,
}

impl Columns {
    /// Beside the barrier whose top is at `level` in column `k`, in grid
    /// direction `d`: the first column open at `level`, where its floor runs
    /// on to the next column (a place to stand, not a moulding's ledge).
    /// Off the grid or past every surface, the drop is infinite.
    fn beside(&self, k: usize, level: f32, d: (isize, isize)) -> Option<Side> {
        let (i, j) = ((k % self.nx) as isize, (k / self.nx) as isize);
        let at = |s: isize| -> Option<usize> {
            let (x, z) = (i + s * d.0, j + s * d.1);
            ((0..self.nx as isize).contains(&x) && (0..self.nz as isize).contains(&z)).then(|| x as usize + z as usize * self.nx)
        };
        for steps in 1..=MAX_THICKNESS {
            let Some(n) = at(steps as isize) else { return Some(Side { steps, drop: f32::INFINITY, open: f32::INFINITY }) };
            // The same barrier's top: go on across it.
            if self.layers[n].iter().any(|l| (l.0 - level).abs() <= self.eps && l.1 >= HORIZONTAL_COS) {
                continue;
            }
            let (floor, open) = self.floor_below(n, level)?;
            if floor.is_finite() {
                let beyond = at(steps as isize + 1).and_then(|b| self.floor_below(b, level));
                if !beyond.is_some_and(|(f, _)| (f - floor).abs() <= 0.1 * (level - floor)) {
                    return None;
                }
            }
            return Some(Side { steps, drop: level - floor, open });
        }
        None
    }

    /// The first floor below `level` in column `n`, open from that floor to
    /// above `level`: (its height, the height open above it). `None` when
    /// column `n` is not open at `level`; no floor at all is an infinitely
    /// deep drop.
    fn floor_below(&self, n: usize, level: f32) -> Option<(f32, f32)> {
        let column = &self.layers[n];
        let Some(k) = column.iter().position(|l| l.0 < level - self.eps) else { return Some((f32::NEG_INFINITY, f32::INFINITY)) };
        let ceiling = if k == 0 { f32::INFINITY } else { column[k - 1].0 };
        let floor = column[k];
        let faces_up = if self.oriented { floor.1 >= HORIZONTAL_COS } else { horizontal(floor.1) };
        (ceiling > level + self.eps && faces_up).then_some((floor.0, ceiling - floor.0))
    }
}

/// Faces count as oriented (outward normals) when at least this share of the
/// columns that cross anything alternate entering solids (normal up) and
/// leaving them.
const ORIENTED: f32 = 0.6;

fn oriented_share(layers: &[Vec<(f32, f32)>]) -> f32 {
    let crossed = layers.iter().filter(|c| !c.is_empty()).count();
    // (A model of interiors alone, its surfaces facing in, starts leaving.)
    let alternating = layers.iter().filter(|c| !c.is_empty() && c.windows(2).all(|w| (w[0].1 > 0.0) != (w[1].1 > 0.0))).count();
    alternating as f32 / crossed.max(1) as f32
}

/// The log posterior (unnormalised) of every scale scored: (ln metres a
/// unit, log posterior), in steps of [`LN_STEP`].
pub fn posterior(evidence: &Evidence) -> Vec<(f64, f64)> {
    let ln = |v: &[f32]| -> Vec<f64> { v.iter().map(|&g| (g as f64).ln()).collect() };
    let (ln_gaps, ln_parapets) = (ln(&evidence.gaps), ln(&evidence.parapets));
    let n = ((LN_HI - LN_LO) / LN_STEP) as usize + 1;
    let gap_weight = OBSERVATIONS / ln_gaps.len().max(1) as f64;
    let parapet_weight = if ln_parapets.len() >= MIN_PARAPETS { PARAPET_OBSERVATIONS / ln_parapets.len() as f64 } else { 0.0 };
    (0..n)
        .map(|k| {
            let ln_s = LN_LO + k as f64 * LN_STEP;
            let rooms: f64 = ln_gaps.iter().map(|&g| mixture(&HEIGHTS, g + ln_s).ln()).sum::<f64>() * gap_weight;
            let parapets: f64 = ln_parapets.iter().map(|&g| mixture(&PARAPETS, g + ln_s).ln()).sum::<f64>() * parapet_weight;
            (ln_s, rooms + parapets + prior(ln_s).ln())
        })
        .collect()
}

/// Scores every scale against the evidence and the unit prior.
pub fn judge(evidence: &Evidence) -> ScaleGuess {
    let gaps = &evidence.gaps;
    let (scales, log_post): (Vec<f64>, Vec<f64>) = posterior(evidence).into_iter().unzip();
    let n = scales.len();
    let best = (0..n).max_by(|&a, &b| log_post[a].total_cmp(&log_post[b])).unwrap_or(0);
    let peak = log_post[best];
    let mass: Vec<f64> = log_post.iter().map(|&l| (l - peak).exp()).collect();
    let total: f64 = mass.iter().sum();
    let window = (1.25f64.ln() / LN_STEP).round() as usize;
    let near = |k: usize| k.abs_diff(best) <= window;
    let within: f64 = (0..n).filter(|&k| near(k)).map(|k| mass[k]).sum();
    let runner_up = (0..n).filter(|&k| !near(k)).max_by(|&a, &b| log_post[a].total_cmp(&log_post[b]));
    let metres_per_unit = snap(scales[best].exp() as f32);
    let confidence = (within / total) as f32;
    let counted = evidence.parapets.len() >= MIN_PARAPETS;
    let rooms: Vec<f32> = {
        let mut r: Vec<f32> = gaps.iter().map(|&g| g * metres_per_unit).filter(|&h| (1.8..30.0).contains(&h)).collect();
        r.sort_by(f32::total_cmp);
        r
    };
    ScaleGuess {
        metres_per_unit,
        unit: unit_of(metres_per_unit),
        confidence,
        sure: confidence as f64 >= SURE,
        runner_up: runner_up.map(|k| snap(scales[k].exp() as f32)),
        gaps: gaps.len(),
        room_height_m: rooms.get(rooms.len() / 2).copied(),
        parapets: if counted { evidence.parapets.len() } else { 0 },
        parapet_m: counted.then(|| median(&evidence.parapets) * metres_per_unit),
    }
}

/// The common unit itself when within 3 % of one.
fn snap(m: f32) -> f32 {
    UNITS.iter().map(|u| u.0).find(|u| (m / u).ln().abs() < 0.03).unwrap_or(m)
}

/// Density of a metric ln height under [`HEIGHTS`], with a floor so that one
/// odd gap cannot veto a scale.
fn mixture(heights: &[(f64, f64, f64)], ln_h: f64) -> f64 {
    let d: f64 = heights.iter().map(|&(m, s, w)| w * normal(ln_h, m.ln(), s)).sum();
    d + 1e-3
}

/// Prior density over ln scale: the common units, and the rest spread evenly.
fn prior(ln_s: f64) -> f64 {
    let units: f64 = UNITS.iter().map(|&(u, _)| normal(ln_s, (u as f64).ln(), UNIT_SPREAD)).sum::<f64>() / UNITS.len() as f64;
    UNIT_PRIOR * units + (1.0 - UNIT_PRIOR) / (LN_HI - LN_LO)
}

fn normal(x: f64, mean: f64, spread: f64) -> f64 {
    let z = (x - mean) / spread;
    (-0.5 * z * z).exp() / (spread * (2.0 * std::f64::consts::PI).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use exploremaps_scenes::awkward::awkward;

    fn guessed(scene: &Scene) -> Option<ScaleGuess> {
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        guess(scene, &rays)
    }

    #[test]
    fn rooms_are_measured_within_a_quarter() {
        // A furnished room in feet, a closed room in centimetres, a suite in
        // inches, blocks in metres, an atrium in centimetres / 20.
        for name in ["conference", "cm_room", "suite", "blocks", "atrium"] {
            let (scene, truth) = awkward(name).unwrap();
            let g = guessed(&scene).unwrap_or_else(|| panic!("{name}: no evidence"));
            let ratio = (g.metres_per_unit / truth).max(truth / g.metres_per_unit);
            assert!(ratio <= 1.25, "{name}: guessed {} m a unit, truly {truth}: {}", g.metres_per_unit, g.describe());
            assert_eq!(g.unit.is_some(), name != "atrium", "{name}: {}", g.describe());
        }
        // The furnished room is sure: its table and chairs agree with its height.
        let (scene, _) = awkward("conference").unwrap();
        assert!(guessed(&scene).unwrap().sure);
    }

    #[test]
    fn the_atriums_parapets_decide_its_scale() {
        // Its storeys alone read as feet (a 6 m arcade); its 1 m parapets
        // say 0.2 m a unit.
        let (scene, truth) = awkward("atrium").unwrap();
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        let evidence = evidence(&scene, &rays);
        assert!(evidence.parapets.len() >= MIN_PARAPETS);
        let ratio = |g: &ScaleGuess| (g.metres_per_unit / truth).max(truth / g.metres_per_unit);
        let with = judge(&evidence);
        assert!(with.sure && ratio(&with) <= 1.25, "{}", with.describe());
        assert!(with.describe().contains("parapets"), "{}", with.describe());
        let without = judge(&Evidence { parapets: Vec::new(), ..evidence });
        assert!(ratio(&without) > 1.25, "{}", without.describe());
    }

    /// A gallery 4 m up over half of a 10 m hall, with `edge` at its rim.
    fn gallery_with(edge: impl Fn(&mut exploremaps_scenes::mesh::MeshBuilder)) -> Evidence {
        let mut m = exploremaps_scenes::mesh::MeshBuilder::new("gallery edge");
        m.slabs(&[[0.0, 0.0, 10.0, 10.0]], -0.3, 0.0);
        m.slabs(&[[0.0, 0.0, 10.0, 3.3]], 3.7, 4.0);
        m.slabs(&[[0.0, 0.0, 10.0, 10.0]], 8.0, 8.3);
        edge(&mut m);
        let scene = m.finish();
        let rays = RayScene::new(&scene.positions, &scene.triangles, 0).unwrap();
        evidence(&scene, &rays)
    }

    #[test]
    fn a_parapet_is_measured_and_a_table_at_the_rim_is_not() {
        let parapet = gallery_with(|m| m.cuboid(Vec3::new(0.0, 4.0, 3.0), Vec3::new(10.0, 5.0, 3.3)));
        assert!(parapet.parapets.len() >= MIN_PARAPETS, "{:?}", parapet.parapets);
        assert!(parapet.parapets.iter().all(|&h| (h - 1.0).abs() < 0.02), "{:?}", parapet.parapets);
        // A table top on legs: air under it, so no barrier.
        let table = gallery_with(|m| {
            m.cuboid(Vec3::new(2.0, 4.7, 2.5), Vec3::new(8.0, 4.75, 3.3));
            for x in [2.0, 7.9] {
                m.cuboid(Vec3::new(x, 4.0, 2.5), Vec3::new(x + 0.1, 4.7, 2.6));
            }
        });
        assert!(table.parapets.is_empty(), "{:?}", table.parapets);
    }

    #[test]
    fn a_common_unit_is_named_and_the_runner_up_given() {
        let (scene, _) = awkward("cm_room").unwrap();
        let g = guessed(&scene).unwrap();
        assert_eq!(g.unit, Some("cm"), "{}", g.describe());
        assert!(g.describe().contains("cm"));
        let alt = g.runner_up.expect("a runner-up");
        assert!((alt / g.metres_per_unit).ln().abs() > 1.25f32.ln());
    }

    #[test]
    fn scales_are_written_without_trailing_zeros() {
        assert_eq!(short(10.0), "10");
        assert_eq!(short(0.3048), "0.3048");
        assert_eq!(short(0.01), "0.01");
        assert_eq!(short(1.0), "1");
    }

    #[test]
    fn scattered_heights_are_not_sure() {
        // Gaps spread evenly over three decades say nothing about the unit.
        let gaps: Vec<f32> = (0..600).map(|k| 10f32.powf(k as f32 / 200.0)).collect();
        let g = judge(&Evidence { gaps, parapets: Vec::new() });
        assert!(!g.sure, "{}", g.describe());
    }

    #[test]
    fn a_scene_without_floors_under_ceilings_has_no_evidence() {
        // A single box: two horizontal faces, one gap a column.
        let mut m = exploremaps_scenes::mesh::MeshBuilder::new("box");
        m.cuboid(Vec3::ZERO, Vec3::ONE);
        let scene = m.finish();
        assert!(guessed(&scene).is_none_or(|g| !g.sure));
    }
}
