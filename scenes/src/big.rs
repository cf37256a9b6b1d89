//! `big`: a hall filled with a grid of detailed statues, sized by a triangle
//! budget (up to tens of millions), for scaling benchmarks of ray casting,
//! exploration and rendering.

use crate::gallery::statue;
use crate::mesh::MeshBuilder;
use crate::scene::{Light, Material, Scene};
use glam::Vec3;
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

/// Triangles of one statue (subdivision level 5 of an octahedron).
const STATUE_TRIANGLES: usize = 8 * 4usize.pow(5);
const SPACING: f32 = 3.0;

/// At least `target_triangles` triangles (default 1,000,000).
pub fn big(seed: u64, target_triangles: usize) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x6269_6767);
    let count = target_triangles.div_ceil(STATUE_TRIANGLES).max(1);
    let side = (count as f32).sqrt().ceil() as usize;
    let extent = side as f32 * SPACING;
    let mut m = MeshBuilder::new("big");
    let floor = m.add_material(Material::diffuse("floor", [0.5, 0.5, 0.5]));
    let marble = m.add_material(Material::diffuse("statue_marble", [0.9, 0.9, 0.88]));
    m.begin_object("hall");
    m.set_material(floor);
    let h = 8.0;
    m.cuboid(Vec3::new(-0.3, -0.3, -0.3), Vec3::new(extent + 0.3, 0.0, extent + 0.3));
    m.cuboid(Vec3::new(-0.3, h, -0.3), Vec3::new(extent + 0.3, h + 0.3, extent + 0.3));
    for (along_x, line) in [(true, 0.0), (true, extent), (false, 0.0), (false, extent)] {
        m.wall(along_x, line, 0.0, extent, 0.0, h, 0.3, &[]);
    }
    m.set_material(marble);
    for k in 0..count {
        let (i, j) = (k % side, k / side);
        m.begin_object(&format!("statue_{k}"));
        statue(&mut m, &mut rng, Vec3::new((i as f32 + 0.5) * SPACING, 1.0, (j as f32 + 0.5) * SPACING));
    }
    m.add_light(Light::Point { position: Vec3::new(extent * 0.5, h - 0.5, extent * 0.5), intensity: Vec3::splat(extent * extent) });
    m.finish()
}
