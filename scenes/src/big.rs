//! `big`: a museum of many `gallery` wings on a grid, sized by a triangle
//! budget (up to tens of millions), for scaling benchmarks of ray casting,
//! exploration and rendering. Like a real large museum, it is mostly rooms
//! with detailed statues, not a solid mass of detail.

use crate::gallery::{wing, GalleryMaterials, Neighbours, JOIN_X, JOIN_Z, SUN, WING_SIZE};
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
    // How many wings the budget needs, counted on a wing built and dropped
    // (the same geometry as any other but for its doors), then a square grid
    // of them, each joined to its neighbours by a door and a paved walk.
    let per_wing = {
        let mut probe = MeshBuilder::new("wing");
        wing(&mut probe, &GalleryMaterials::default(), &mut rng.clone(), Vec3::ZERO, "", Neighbours::default());
        probe.triangle_count()
    };
    let count = target_triangles.div_ceil(per_wing).max(1);
    let side = (count as f32).sqrt().ceil() as usize;
    let origin = |k: usize| Vec3::new((k % side) as f32 * WING_SIZE.0, 0.0, (k / side) as f32 * WING_SIZE.1);
    for k in 0..count {
        let next = Neighbours { low_x: k % side > 0, high_x: k % side + 1 < side && k + 1 < count, low_z: k >= side, high_z: k + side < count };
        wing(&mut m, &materials, &mut rng, origin(k), &format!("w{k}_"), next);
        m.begin_object(&format!("w{k}_walks"));
        m.set_material(materials.floor);
        let o = origin(k);
        if next.high_x {
            m.cuboid(o + Vec3::new(40.15, -0.3, JOIN_Z - 1.5), o + Vec3::new(WING_SIZE.0 - 0.15, 0.0, JOIN_Z + 1.5));
        }
        if next.high_z {
            m.cuboid(o + Vec3::new(JOIN_X - 1.5, -0.3, 20.15), o + Vec3::new(JOIN_X + 1.5, 0.0, WING_SIZE.1 - 16.15));
        }
    }
    m.add_light(SUN);
    m.finish()
}
