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
//! | `sunroom` | a plain white room lit only through a window: global illumination |

mod big;
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
    Sunroom,
}

pub const DEFAULT_SCENE: &str = "gallery";

/// (name, parameter meaning, one-line description) of every built-in scene.
pub const CATALOGUE: [(&str, &str, &str); 7] = [
    ("gallery", "", "museum: rooms, doors, corridor, pillars, statues, open courtyard (the default)"),
    ("maze", "cells per side, default 8", "roofed labyrinth of 2 m corridors"),
    ("pillars", "", "hall with a 6x4 grid of columns hiding small props"),
    ("big", "target triangles, default 1000000", "museum of many gallery wings on a grid, for scaling benchmarks"),
    ("island", "", "open landscape: hills, houses with doors and windows, a rock tunnel, a bridge over a river, trees"),
    ("house", "", "two-storey house with a staircase, in a walled garden"),
    ("sunroom", "", "plain white room lit only by the sun through a window (rendering test)"),
];

impl BuiltIn {
    /// Parses `name` or `name:parameter`, e.g. `maze:12` or `big:5000000`.
    pub fn parse(spec: &str) -> Option<BuiltIn> {
        let (name, param) = match spec.split_once(':') {
            Some((n, p)) => (n, Some(p.trim().replace('_', "").parse::<usize>().ok()?)),
            None => (spec, None),
        };
        match (name, param) {
            ("gallery", None) => Some(BuiltIn::Gallery),
            ("pillars", None) => Some(BuiltIn::Pillars),
            ("island", None) => Some(BuiltIn::Island),
            ("house", None) => Some(BuiltIn::House),
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
            BuiltIn::Sunroom => sunroom::sunroom(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_is_valid_and_seeded() {
        for spec in ["gallery", "maze", "pillars", "big:50000", "island", "house", "sunroom"] {
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
