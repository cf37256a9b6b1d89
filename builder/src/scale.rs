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
//! high, slabs are a few decimetres. Each scale is scored by how well a
//! mixture of those metric heights explains the gaps (in log height, so the
//! scale is a shift), weighed as a fixed number of independent observations
//! (neighbouring columns see the same room); the common units (m, cm, mm,
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
}

impl ScaleGuess {
    /// One line: the scale, the evidence, how sure.
    pub fn describe(&self) -> String {
        let unit = self.unit.map_or(String::new(), |u| format!(" (a {u})"));
        let room = self.room_height_m.map_or(String::new(), |h| format!(", rooms {h:.1} m high"));
        let alt = self.runner_up.map_or(String::new(), |a| format!("; else {}", scale_words(a)));
        format!(
            "{} m a unit{unit} from {} heights between floors and what is above them{room}, {:.0} % sure{alt}",
            short(self.metres_per_unit),
            self.gaps,
            100.0 * self.confidence
        )
    }
}

/// At most four decimals, no trailing zeros (10 stays 10).
fn short(m: f32) -> String {
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
    let gaps = gaps(scene, rays);
    if gaps.len() < MIN_GAPS {
        return None;
    }
    Some(judge(&gaps))
}

/// The vertical gaps above near-horizontal surfaces, scene units, one per
/// surface met below another along a column.
pub fn gaps(scene: &Scene, rays: &RayScene) -> Vec<f32> {
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
    // Per column: (height, the surface's normal's y) of each surface crossed, top down.
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
    let min_gap = 1e-4 * e.y.max(long);
    let oriented = oriented_share(&layers) >= ORIENTED;
    let horizontal = |n: f32| n.abs() >= HORIZONTAL_COS;
    layers
        .iter()
        .flat_map(|column| {
            // Oriented faces tell air from solid: air lies below a face the
            // ray leaves a solid through (normal along the ray, down) and
            // above one it enters a solid through (normal up).
            column.windows(2).filter(move |w| horizontal(w[1].1) && (!oriented || (w[0].1 < 0.0 && w[1].1 > 0.0))).map(|w| w[0].0 - w[1].0).filter(move |&g| g > min_gap)
        })
        .collect()
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
pub fn posterior(gaps: &[f32]) -> Vec<(f64, f64)> {
    let ln_gaps: Vec<f64> = gaps.iter().map(|&g| (g as f64).ln()).collect();
    let n = ((LN_HI - LN_LO) / LN_STEP) as usize + 1;
    let weight = OBSERVATIONS / ln_gaps.len().max(1) as f64;
    (0..n)
        .map(|k| {
            let ln_s = LN_LO + k as f64 * LN_STEP;
            let fit: f64 = ln_gaps.iter().map(|&g| mixture(g + ln_s).ln()).sum::<f64>() * weight;
            (ln_s, fit + prior(ln_s).ln())
        })
        .collect()
}

/// Scores every scale against the gaps and the unit prior.
pub fn judge(gaps: &[f32]) -> ScaleGuess {
    let (scales, log_post): (Vec<f64>, Vec<f64>) = posterior(gaps).into_iter().unzip();
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
    }
}

/// The common unit itself when within 3 % of one.
fn snap(m: f32) -> f32 {
    UNITS.iter().map(|u| u.0).find(|u| (m / u).ln().abs() < 0.03).unwrap_or(m)
}

/// Density of a metric ln height under [`HEIGHTS`], with a floor so that one
/// odd gap cannot veto a scale.
fn mixture(ln_h: f64) -> f64 {
    let d: f64 = HEIGHTS.iter().map(|&(m, s, w)| w * normal(ln_h, m.ln(), s)).sum();
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
    fn rooms_in_common_units_are_measured_within_a_quarter() {
        // A furnished room in feet, a closed room in centimetres, a suite in
        // inches, blocks in metres. (The atrium in Crytek's centimetres / 20
        // is not found yet: room heights alone read it as feet.)
        for name in ["conference", "cm_room", "suite", "blocks"] {
            let (scene, truth) = awkward(name).unwrap();
            let g = guessed(&scene).unwrap_or_else(|| panic!("{name}: no evidence"));
            let ratio = (g.metres_per_unit / truth).max(truth / g.metres_per_unit);
            assert!(ratio <= 1.25, "{name}: guessed {} m a unit, truly {truth}: {}", g.metres_per_unit, g.describe());
            assert!(g.unit.is_some(), "{name}: {}", g.describe());
        }
        // The furnished room is sure: its table and chairs agree with its height.
        let (scene, _) = awkward("conference").unwrap();
        assert!(guessed(&scene).unwrap().sure);
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
        let g = judge(&gaps);
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
