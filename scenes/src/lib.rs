//! Scenes for ExploreMaps: the [`Scene`] data model every stage works on, and
//! seeded procedural built-in scenes that need no files.
//!
//! | name | what it stresses |
//! |---|---|
//! | `gallery` | the default: rooms of different sizes, doors, a corridor, pillars, statues, an open courtyard |
//! | `maze` | narrow corridors: path finding |
//! | `pillars` | a hall of columns with props behind them: coverage behind occluders |
//! | `big` | a triangle budget up to tens of millions: scaling |
//! | `island` | an open landscape: terrain, houses with windows, a tunnel, a bridge |
//! | `house` | two storeys joined by a staircase, in a garden: walking between floors |
//! | `cathedral` | a tall nave, galleries up a long stair, windows at every height, solid towers |
//! | `sunroom` | a plain white room lit only through a window: global illumination |

pub mod awkward;
mod big;
mod cathedral;
mod gallery;
mod house;
mod island;
mod maze;
pub mod mesh;
mod pillars;
mod scene;
mod sunroom;
pub mod textures;

pub use scene::{guess_metres_per_unit, Aabb, AlphaMode, Light, Material, ScaleSource, Scene, SceneStats, Texture};

/// A built-in scene with its size parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuiltIn {
    Gallery,
    /// Cells per side.
    Maze(usize),
    Pillars,
    /// Target triangle count.
    Big(usize),
    Island,
    House,
    Cathedral,
    Sunroom,
    /// One of [`awkward::AWKWARD`], in its own unit.
    Awkward(&'static str),
}

pub const DEFAULT_SCENE: &str = "gallery";

/// (name, parameter meaning, one-line description) of every built-in scene.
pub const CATALOGUE: [(&str, &str, &str); 9] = [
    ("gallery", "", "museum: rooms, doors, corridor, pillars, statues, open courtyard (the default)"),
    ("maze", "cells per side, default 8", "roofed labyrinth of 2 m corridors"),
    ("pillars", "", "hall with a 6x4 grid of columns hiding small props"),
    ("big", "target triangles, default 1000000", "museum of many gallery wings on a grid, for scaling benchmarks"),
    ("island", "", "open landscape: hills, houses with doors and windows, a rock tunnel, a bridge over a river, trees"),
    ("house", "", "two-storey house with a staircase, in a walled garden"),
    ("cathedral", "", "basilica: tall nave, aisles under galleries reached by a long stair, windows at every height, solid towers"),
    ("sunroom", "", "plain white room lit only by the sun through a window (rendering test)"),
    ("awkward", "name", "third-party-like scenes in their own units, scale to guess: cm_room, conference, car, blocks, atrium, suite, block_city"),
];

impl BuiltIn {
    /// Parses `name` or `name:parameter`, e.g. `maze:12` or `big:5000000`.
    pub fn parse(spec: &str) -> Option<BuiltIn> {
        if let Some(name) = spec.strip_prefix("awkward:") {
            return awkward::AWKWARD.iter().find(|&&a| a == name).map(|&a| BuiltIn::Awkward(a));
        }
        let (name, param) = match spec.split_once(':') {
            Some((n, p)) => (n, Some(p.trim().replace('_', "").parse::<usize>().ok()?)),
            None => (spec, None),
        };
        match (name, param) {
            ("gallery", None) => Some(BuiltIn::Gallery),
            ("pillars", None) => Some(BuiltIn::Pillars),
            ("island", None) => Some(BuiltIn::Island),
            ("house", None) => Some(BuiltIn::House),
            ("cathedral", None) => Some(BuiltIn::Cathedral),
            ("sunroom", None) => Some(BuiltIn::Sunroom),
            ("maze", p) => Some(BuiltIn::Maze(p.unwrap_or(8).clamp(2, 200))),
            ("big", p) => Some(BuiltIn::Big(p.unwrap_or(1_000_000).clamp(1, 100_000_000))),
            _ => None,
        }
    }

    pub fn generate(self, seed: u64) -> Scene {
        match self {
            BuiltIn::Gallery => gallery::gallery(seed),
            BuiltIn::Maze(cells) => maze::maze(seed, cells),
            BuiltIn::Pillars => pillars::pillars(seed),
            BuiltIn::Big(triangles) => big::big(seed, triangles),
            BuiltIn::Island => island::island(seed),
            BuiltIn::House => house::house(seed),
            BuiltIn::Cathedral => cathedral::cathedral(seed),
            BuiltIn::Sunroom => sunroom::sunroom(),
            BuiltIn::Awkward(name) => awkward::awkward(name).map(|(scene, _)| scene).expect("parsed from the list"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_is_valid_and_seeded() {
        for spec in ["gallery", "maze", "pillars", "big:50000", "island", "house", "cathedral", "sunroom", "awkward:atrium"] {
            let scene = BuiltIn::parse(spec).unwrap().generate(1);
            scene.validate().unwrap_or_else(|e| panic!("{spec}: {e}"));
            assert_eq!(scene.stats, SceneStats::default(), "{spec} made bad triangles");
            let again = BuiltIn::parse(spec).unwrap().generate(1);
            assert_eq!(scene.positions, again.positions, "{spec} is not deterministic");
            assert!(!scene.lights.is_empty(), "{spec} has no lights");
        }
    }

    #[test]
    fn gallery_is_in_the_requested_size_range() {
        let scene = BuiltIn::Gallery.generate(0);
        let n = scene.triangles.len();
        assert!((50_000..=300_000).contains(&n), "gallery has {n} triangles");
        assert!(scene.textures.len() >= 3);
        assert!(scene.objects.iter().filter(|o| o.starts_with("statue")).count() >= 6);
    }

    #[test]
    fn big_meets_its_triangle_budget() {
        let scene = BuiltIn::parse("big:200000").unwrap().generate(3);
        assert!(scene.triangles.len() >= 200_000);
        assert!(scene.triangles.len() < 300_000);
    }

    #[test]
    fn closed_boxes_have_outward_normals() {
        let mut m = mesh::MeshBuilder::new("box");
        m.cuboid(glam::Vec3::ZERO, glam::Vec3::ONE);
        let scene = m.finish();
        assert_eq!(scene.triangles.len(), 12);
        let centre = glam::Vec3::splat(0.5);
        for t in 0..12 {
            let [a, b, c] = scene.triangle(t);
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0 - centre) > 0.0, "triangle {t} faces inward");
        }
        assert!((scene.total_area() - 6.0).abs() < 1e-5);
        // Prisms along z and x alike.
        let mut m = mesh::MeshBuilder::new("prisms");
        let profile = [glam::Vec2::new(0.0, 0.0), glam::Vec2::new(2.0, 0.0), glam::Vec2::new(1.0, 1.5)];
        m.prism_z(&profile, 0.0, 3.0);
        m.prism_x(&profile, 5.0, 7.0);
        let scene = m.finish();
        assert_eq!(scene.triangles.len(), 16);
        let centres = [glam::Vec3::new(1.0, 0.5, 1.5), glam::Vec3::new(6.0, 1.0, 0.5)];
        for t in 0..16 {
            let [a, b, c] = scene.triangle(t);
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0 - centres[t / 8]) > 0.0, "prism triangle {t} faces inward");
        }
    }

    /// Area of the triangles that share their plane and facing with another
    /// one and overlap it where no face lies against them (a face against
    /// one, like a wall's top under the roof, is hidden), sampled at seven
    /// interior points each, by object.
    fn coincident_area(scene: &Scene) -> Vec<(String, f32)> {
        use glam::Vec3;
        type Plane = [i64; 4];
        let plane = |n: Vec3, d: f32| -> Plane { [n.x, n.y, n.z, d].map(|x| (x * 1000.0).round() as i64) };
        // Triangles by plane and by the 1 m cells their bounds touch.
        let cell = |p: Vec3| p.floor().as_ivec3().to_array();
        let mut grid: std::collections::HashMap<(Plane, [i32; 3]), Vec<usize>> = Default::default();
        for t in 0..scene.triangles.len() {
            let [a, b, c] = scene.triangle(t);
            let n = (b - a).cross(c - a).normalize_or_zero();
            let (lo, hi) = (cell(a.min(b).min(c)), cell(a.max(b).max(c)));
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        grid.entry((plane(n, n.dot(a)), [x, y, z])).or_default().push(t);
                    }
                }
            }
        }
        let covered = |key: Plane, x: Vec3, n: Vec3, not: usize| {
            grid.get(&(key, cell(x))).is_some_and(|list| {
                list.iter().any(|&o| {
                    let p = scene.triangle(o);
                    o != not && (0..3).all(|k| (p[(k + 1) % 3] - p[k]).cross(x - p[k]).dot(n) > 1e-7)
                })
            })
        };
        let mut by_object: std::collections::BTreeMap<String, f32> = Default::default();
        for t in 0..scene.triangles.len() {
            let [a, b, c] = scene.triangle(t);
            let n = (b - a).cross(c - a);
            let unit = n.normalize_or_zero();
            let (key, against) = (plane(unit, unit.dot(a)), plane(-unit, -unit.dot(a)));
            let samples = [(0.33, 0.33), (0.6, 0.2), (0.2, 0.6), (0.2, 0.2), (0.1, 0.8), (0.8, 0.1), (0.1, 0.1)];
            let hit = samples
                .iter()
                .map(|&(u, v)| a + u * (b - a) + v * (c - a))
                .filter(|&x| covered(key, x, n, t) && !covered(against, x, -n, usize::MAX))
                .count();
            if hit > 0 && unit != Vec3::ZERO {
                let object = scene.objects[scene.triangle_object[t] as usize].clone();
                *by_object.entry(object).or_default() += scene.triangle_area(t) * hit as f32 / samples.len() as f32;
            }
        }
        by_object.into_iter().collect()
    }

    #[test]
    fn builtin_scenes_have_no_coincident_faces() {
        // A box face lying in another's plane, facing the same way, draws in
        // whichever order a renderer meets them (Cycles shades such strips
        // black, a rasterized proxy flickers).
        let mut two = mesh::MeshBuilder::new("two boxes");
        two.cuboid(glam::Vec3::ZERO, glam::Vec3::ONE);
        two.cuboid(glam::Vec3::new(0.5, 0.0, 0.0), glam::Vec3::new(1.5, 1.0, 1.0));
        let found: f32 = coincident_area(&two.finish()).iter().map(|o| o.1).sum();
        assert!(found > 1.0, "the check missed two overlapping boxes: {found} m²");
        for spec in ["gallery", "maze", "pillars", "big:50000", "island", "house", "cathedral", "sunroom"] {
            let scene = BuiltIn::parse(spec).unwrap().generate(1);
            let found = coincident_area(&scene);
            assert!(found.is_empty(), "{spec}: coincident faces (object, m²): {found:?}");
        }
    }

    #[test]
    fn slabs_cover_a_union_of_rectangles_once() {
        let mut m = mesh::MeshBuilder::new("slabs");
        m.slabs(&[[0.0, 0.0, 2.0, 2.0], [1.0, 1.0, 3.0, 3.0], [5.0, 0.0, 6.0, 1.0]], 0.0, 0.5);
        let scene = m.finish();
        let top: f32 = (0..scene.triangles.len()).filter(|&t| scene.triangle(t).iter().all(|p| p.y == 0.5)).map(|t| scene.triangle_area(t)).sum();
        assert!((top - 8.0).abs() < 1e-4, "tops cover {top} m², the union is 8");
        assert!(coincident_area(&scene).is_empty());
    }

    #[test]
    fn parse_rejects_unknown_names_and_bad_parameters() {
        assert_eq!(BuiltIn::parse("maze:12"), Some(BuiltIn::Maze(12)));
        assert_eq!(BuiltIn::parse("big:5_000_000"), Some(BuiltIn::Big(5_000_000)));
        assert_eq!(BuiltIn::parse("castle"), None);
        assert_eq!(BuiltIn::parse("maze:x"), None);
        assert_eq!(BuiltIn::parse("gallery:3"), None);
    }
}
