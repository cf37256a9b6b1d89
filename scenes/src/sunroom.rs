//! `sunroom`: a closed, plain white room lit only through one window, the
//! hardest case for cached global illumination: sunlight falls on the floor
//! and everything else (the ceiling above all) is lit by what the floor and
//! walls bounce. No textures, so nothing hides a renderer's artefacts.
//!
//! Plan (metres, +Y up, z south): inside x∈[0, 6], z∈[0, 5], floor y = 0,
//! ceiling y = 3, walls and slabs 0.2 thick; a 1.6 × 1.4 m window (sill 0.9 m)
//! in the south wall, no glass; a sun 40° up from the south-south-east, and
//! the sky, outside. A low white block stands in the room to cast a shadow.

use crate::mesh::{MeshBuilder, Opening, Wall};
use crate::scene::{Light, Material, Scene};
use glam::Vec3;

pub fn sunroom() -> Scene {
    let mut m = MeshBuilder::new("sunroom");
    let (w, h, d, t) = (6.0, 3.0, 5.0, 0.2);
    let e = 0.5 * t;
    let white = m.add_material(Material::diffuse("white_paint", [0.8, 0.8, 0.8]));
    let floor = m.add_material(Material::diffuse("pale_floor", [0.6, 0.55, 0.48]));
    m.begin_object("room");
    m.set_material(floor);
    m.cuboid(Vec3::new(-e, -t, -e), Vec3::new(w + e, 0.0, d + e));
    m.set_material(white);
    m.cuboid(Vec3::new(-e, h, -e), Vec3::new(w + e, h + t, d + e));
    m.wall(Wall::along_x(0.0, 0.0, w), 0.0..h, t, &[]);
    m.wall_with_openings(Wall::along_x(d, 0.0, w), 0.0..h, t, &[Opening { centre: 0.5 * w, width: 1.6, sill: 0.9, head: 2.3 }]);
    m.wall(Wall::along_z(0.0, 0.0, d), 0.0..h, t, &[]);
    m.wall(Wall::along_z(w, 0.0, d), 0.0..h, t, &[]);
    m.begin_object("block");
    m.cuboid(Vec3::new(2.2, 0.0, 1.4), Vec3::new(3.0, 0.8, 2.2));
    // From the south-south-east, 40° up: through the window onto the floor.
    let (elevation, azimuth) = (40f32.to_radians(), 20f32.to_radians());
    let direction = Vec3::new(azimuth.sin() * elevation.cos(), elevation.sin(), azimuth.cos() * elevation.cos());
    m.add_light(Light::Sun { direction, irradiance: Vec3::new(3.4, 3.2, 2.9) });
    m.finish()
}
