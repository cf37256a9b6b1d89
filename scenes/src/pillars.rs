//! `pillars`: a 30×20 m hall, 6 m high, with a 6×4 grid of thick columns and
//! small objects hidden behind them. It stresses coverage behind occluders:
//! a probe sees the back of a column only from the far side.

use crate::mesh::{MeshBuilder, Wall};
use crate::scene::{Light, Material, Scene};
use crate::textures;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

pub fn pillars(seed: u64) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x7069_6c6c);
    let (w, d, h) = (30.0, 20.0, 6.0);
    let mut m = MeshBuilder::new("pillars");
    let floor_tex = m.add_texture(textures::checker_marble(seed as u32));
    let wall_tex = m.add_texture(textures::plaster([0.85, 0.85, 0.9], seed as u32));
    let floor = m.add_material(Material { base_color_texture: Some(floor_tex), ..Material::diffuse("hall_floor", [1.0; 3]) });
    let wall = m.add_material(Material { base_color_texture: Some(wall_tex), ..Material::diffuse("hall_walls", [1.0; 3]) });
    let stone = m.add_material(Material::diffuse("columns", [0.75, 0.7, 0.62]));
    let props = m.add_material(Material::diffuse("props", [0.6, 0.2, 0.15]));
    m.begin_object("hall");
    m.set_material(floor);
    m.cuboid(Vec3::new(-0.3, -0.3, -0.3), Vec3::new(w + 0.3, 0.0, d + 0.3));
    m.set_material(wall);
    m.cuboid(Vec3::new(-0.3, h, -0.3), Vec3::new(w + 0.3, h + 0.3, d + 0.3));
    m.wall(Wall::along_x(0.0, 0.0, w), 0.0..h, 0.3, &[]);
    m.wall(Wall::along_x(d, 0.0, w), 0.0..h, 0.3, &[]);
    m.wall(Wall::along_z(0.0, 0.0, d), 0.0..h, 0.3, &[]);
    m.wall(Wall::along_z(w, 0.0, d), 0.0..h, 0.3, &[]);
    m.begin_object("columns");
    m.set_material(stone);
    let mut centres = Vec::new();
    for i in 0..6 {
        for j in 0..4 {
            let c = Vec3::new(2.5 + 5.0 * i as f32, 0.0, 2.5 + 5.0 * j as f32);
            m.cylinder(c, 0.8, h, 48);
            centres.push(c);
        }
    }
    m.begin_object("props");
    m.set_material(props);
    for c in centres {
        // A small box tucked against the column on a random side.
        let angle = rng.random_range(0.0..std::f32::consts::TAU);
        let p = c + Vec3::new(angle.cos(), 0.0, angle.sin()) * 1.1;
        m.cuboid(p - Vec3::new(0.15, 0.0, 0.15), p + Vec3::new(0.15, 0.4, 0.15));
    }
    for x in [7.5, 22.5] {
        m.add_light(Light::Point { position: Vec3::new(x, h - 0.5, d * 0.5), intensity: Vec3::splat(150.0) });
    }
    m.finish()
}
