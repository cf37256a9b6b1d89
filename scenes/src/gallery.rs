//! `gallery`: a small museum, the embedded default scene.
//!
//! Plan (metres, +Y up, ground at y = 0, walls 4 m high; x east, z south):
//! a corridor x∈[0,40] z∈[0,4] joins room A [0,12]×[4,16], room B [12,20]×[4,12],
//! a store room E [12,20]×[12,20] (reached through B or A), hall C [20,40]×[4,20]
//! with a grid of pillars, room D [24,40]×[-12,0], and a courtyard [0,24]×[-16,0]
//! open to the sky. Statues on plinths stand in every room; point lights light
//! the rooms and a sun the courtyard. About 200k triangles, mostly statues.

use crate::mesh::MeshBuilder;
use crate::scene::{Light, Material, Scene};
use crate::textures;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

const WALL_H: f32 = 4.0;
const WALL_T: f32 = 0.3;
const DOOR_W: f32 = 1.6;
const DOOR_H: f32 = 2.5;

/// Subdivision levels of a statue: 8·4^5 = 8192 triangles each.
const STATUE_LEVELS: u32 = 5;

pub fn gallery(seed: u64) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x6761_6c6c);
    let mut m = MeshBuilder::new("gallery");
    let tex_floor = m.add_texture(textures::checker_marble(seed as u32));
    let tex_bricks = m.add_texture(textures::bricks(seed as u32));
    let tex_wood = m.add_texture(textures::planks(seed as u32));
    let tex_plaster = m.add_texture(textures::plaster([0.92, 0.88, 0.8], seed as u32));
    let textured = |name: &str, texture: usize, tint: [f32; 3]| Material {
        base_color_texture: Some(texture),
        ..Material::diffuse(name, tint)
    };
    let floor = m.add_material(textured("floor_marble", tex_floor, [1.0; 3]));
    let wall = m.add_material(textured("wall_plaster", tex_plaster, [1.0; 3]));
    let wall_red = m.add_material(textured("wall_plaster_red", tex_plaster, [0.8, 0.35, 0.3]));
    let wall_blue = m.add_material(textured("wall_plaster_blue", tex_plaster, [0.35, 0.45, 0.75]));
    let bricks = m.add_material(textured("courtyard_bricks", tex_bricks, [1.0; 3]));
    let wood = m.add_material(textured("store_planks", tex_wood, [1.0; 3]));
    let ceiling = m.add_material(Material::diffuse("ceiling", [0.8, 0.8, 0.78]));
    let stone = m.add_material(Material::diffuse("pillar_stone", [0.7, 0.68, 0.62]));
    let plinth = m.add_material(Material::diffuse("plinth", [0.2, 0.2, 0.22]));
    let marble = m.add_material(Material::diffuse("statue_marble", [0.9, 0.9, 0.88]));
    let bronze = m.add_material(Material::diffuse("statue_bronze", [0.45, 0.3, 0.15]));
    let lamp = m.add_material(Material { emissive: Vec3::splat(8.0), ..Material::diffuse("lamp", [1.0; 3]) });

    m.begin_object("ground");
    m.set_material(floor);
    m.cuboid(Vec3::new(-0.15, -0.3, -16.15), Vec3::new(40.15, 0.0, 20.15));

    m.begin_object("walls");
    m.set_material(wall);
    let door = |c: f32| (c, DOOR_W, DOOR_H);
    // Corridor walls: south (courtyard and D doors), north (A, B, C doors).
    m.wall(true, 0.0, 0.0, 40.0, 0.0, WALL_H, WALL_T, &[door(12.0), door(32.0)]);
    m.wall(true, 4.0, 0.0, 40.0, 0.0, WALL_H, WALL_T, &[door(6.0), door(16.0), door(30.0)]);
    m.wall(false, 0.0, -16.0, 16.0, 0.0, WALL_H, WALL_T, &[]);
    m.wall(false, 40.0, -12.0, 20.0, 0.0, WALL_H, WALL_T, &[]);
    m.set_material(wall_red);
    m.wall(true, 16.0, 0.0, 12.0, 0.0, WALL_H, WALL_T, &[]);
    m.wall(false, 12.0, 4.0, 20.0, 0.0, WALL_H, WALL_T, &[door(14.0)]);
    m.set_material(wood);
    m.wall(true, 12.0, 12.0, 20.0, 0.0, WALL_H, WALL_T, &[door(16.0)]);
    m.wall(true, 20.0, 12.0, 40.0, 0.0, WALL_H, WALL_T, &[]);
    m.set_material(wall_blue);
    m.wall(false, 20.0, 4.0, 20.0, 0.0, WALL_H, WALL_T, &[door(8.0)]);
    m.wall(true, -12.0, 24.0, 40.0, 0.0, WALL_H, WALL_T, &[]);
    m.set_material(bricks);
    m.wall(true, -16.0, 0.0, 24.0, 0.0, WALL_H, WALL_T, &[]);
    m.wall(false, 24.0, -16.0, 0.0, 0.0, WALL_H, WALL_T, &[door(-6.0)]);

    m.begin_object("roof");
    m.set_material(ceiling);
    let roof = |m: &mut MeshBuilder, x0: f32, z0: f32, x1: f32, z1: f32| {
        m.cuboid(Vec3::new(x0 - 0.15, WALL_H, z0 - 0.15), Vec3::new(x1 + 0.15, WALL_H + 0.3, z1 + 0.15));
    };
    roof(&mut m, 0.0, 0.0, 40.0, 4.0); // corridor
    roof(&mut m, 0.0, 4.0, 12.0, 16.0); // A
    roof(&mut m, 12.0, 4.0, 20.0, 20.0); // B and E
    roof(&mut m, 20.0, 4.0, 40.0, 20.0); // C
    roof(&mut m, 24.0, -12.0, 40.0, 0.0); // D

    m.begin_object("lamps");
    m.set_material(lamp);
    let rooms: [(&str, f32, f32, f32, f32); 6] = [
        ("A", 0.0, 4.0, 12.0, 16.0),
        ("B", 12.0, 4.0, 20.0, 12.0),
        ("E", 12.0, 12.0, 20.0, 20.0),
        ("C", 20.0, 4.0, 40.0, 20.0),
        ("D", 24.0, -12.0, 40.0, 0.0),
        ("corridor", 0.0, 0.0, 40.0, 4.0),
    ];
    for &(_, x0, z0, x1, z1) in &rooms {
        let c = Vec3::new(0.5 * (x0 + x1), WALL_H - 0.02, 0.5 * (z0 + z1));
        m.cuboid(c - Vec3::new(0.5, 0.0, 0.5), c + Vec3::new(0.5, 0.019, 0.5));
        m.add_light(Light::Point { position: c - Vec3::Y * 0.4, intensity: Vec3::new(60.0, 55.0, 45.0) });
    }
    m.add_light(Light::Sun { direction: Vec3::new(0.4, 0.8, 0.3).normalize(), irradiance: Vec3::new(3.0, 2.9, 2.6) });

    m.begin_object("pillars");
    m.set_material(stone);
    for i in 0..4 {
        for j in 0..3 {
            m.cylinder(Vec3::new(23.5 + 4.3 * i as f32, 0.0, 8.0 + 4.0 * j as f32), 0.35, WALL_H, 32);
        }
    }
    for i in 0..4 {
        m.cylinder(Vec3::new(4.0 + 5.0 * i as f32, 0.0, -4.0), 0.3, WALL_H - 0.5, 24);
    }

    let statues = [
        Vec3::new(4.0, 0.0, 10.0),
        Vec3::new(9.0, 0.0, 13.0),
        Vec3::new(16.0, 0.0, 9.0),
        Vec3::new(16.0, 0.0, 17.0),
        Vec3::new(30.0, 0.0, 12.0),
        Vec3::new(36.0, 0.0, 17.0),
        Vec3::new(32.0, 0.0, -6.0),
        Vec3::new(12.0, 0.0, -10.0),
    ];
    for (k, &base) in statues.iter().enumerate() {
        m.begin_object(&format!("statue_{k}"));
        m.set_material(plinth);
        m.cuboid(base + Vec3::new(-0.4, 0.0, -0.4), base + Vec3::new(0.4, 1.0, 0.4));
        m.set_material(if k % 3 == 2 { bronze } else { marble });
        statue(&mut m, &mut rng, base + Vec3::Y * 1.9);
    }
    m.finish()
}

/// A seeded lumpy figure: an ellipsoid with a few random bulges.
pub(crate) fn statue(m: &mut MeshBuilder, rng: &mut Pcg64Mcg, centre: Vec3) {
    let lobes: Vec<(Vec3, f32)> = (0..5)
        .map(|_| {
            let d = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            (d.normalize_or(Vec3::Y), rng.random_range(0.1..0.45))
        })
        .collect();
    m.blob(centre, Vec3::new(0.35, 0.9, 0.35), STATUE_LEVELS, |d| {
        1.0 + lobes.iter().map(|&(c, a)| a * d.dot(c).max(0.0).powi(6)).sum::<f32>()
    });
}
