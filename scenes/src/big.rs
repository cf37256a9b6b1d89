//! `big`: a museum of many `gallery` wings on a grid, sized by a triangle
//! budget (up to tens of millions), for scaling benchmarks of ray casting,
//! exploration and rendering. Like a real large museum, it is mostly rooms
//! with detailed statues, not a solid mass of detail.

use crate::gallery::{wing, GalleryMaterials, SUN, WING_SIZE};
use crate::mesh::MeshBuilder;
use crate::scene::Scene;
use glam::Vec3;
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

/// At least `target_triangles` triangles (default 1,000,000).
pub fn big(seed: u64, target_triangles: usize) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x6269_6767);
    let mut m = MeshBuilder::new("big");
    let materials = GalleryMaterials::add(&mut m, seed);
    // One wing first to learn its size, then a square grid of as many as needed.
    wing(&mut m, &materials, &mut rng, Vec3::ZERO, "w0_");
    let per_wing = m.triangle_count();
    let count = target_triangles.div_ceil(per_wing).max(1);
    let side = (count as f32).sqrt().ceil() as usize;
    for k in 1..count {
        let origin = Vec3::new((k % side) as f32 * WING_SIZE.0, 0.0, (k / side) as f32 * WING_SIZE.1);
        wing(&mut m, &materials, &mut rng, origin, &format!("w{k}_"));
    }
    m.add_light(SUN);
    m.finish()
}
