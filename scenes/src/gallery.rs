//! `gallery`: a small museum, the embedded default scene.
//!
//! Plan (metres, +Y up, ground at y = 0, walls 4 m high; x east, z south):
//! a corridor x∈[0,40] z∈[0,4] joins room A [0,12]×[4,16], room B [12,20]×[4,12],
//! a store room E [12,20]×[12,20] (reached through B or A), hall C [20,40]×[4,20]
//! with a grid of pillars, room D [24,40]×[-12,0], and a courtyard [0,24]×[-16,0]
//! open to the sky. Statues on plinths stand in every room; point lights light
//! the rooms and a sun the courtyard. About 70k triangles, mostly statues.

use crate::mesh::{MeshBuilder, Wall};
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
    let materials = GalleryMaterials::add(&mut m, seed);
    wing(&mut m, &materials, &mut rng, Vec3::ZERO, "", Neighbours::default());
    m.add_light(SUN);
    m.finish()
}

/// Late-morning sun over the courtyard.
pub(crate) const SUN: Light = Light::Sun { direction: Vec3::new(0.4243, 0.8485, 0.3182), irradiance: Vec3::new(3.0, 2.9, 2.6) };

/// Footprint of one wing on the ground, x by z, with a margin.
pub(crate) const WING_SIZE: (f32, f32) = (42.0, 38.0);

/// The wing's materials; the default (every index 0) serves to count a
/// wing's triangles without making its textures.
#[derive(Default)]
pub(crate) struct GalleryMaterials {
    pub(crate) floor: u32,
    wall: u32,
    wall_red: u32,
    wall_blue: u32,
    bricks: u32,
    wood: u32,
    ceiling: u32,
    stone: u32,
    plinth: u32,
    marble: u32,
    bronze: u32,
    lamp: u32,
}

impl GalleryMaterials {
    pub(crate) fn add(m: &mut MeshBuilder, seed: u64) -> GalleryMaterials {
        let tex_floor = m.add_texture(textures::checker_marble(seed as u32));
        let tex_bricks = m.add_texture(textures::bricks(seed as u32));
        let tex_wood = m.add_texture(textures::planks(seed as u32));
        let tex_plaster = m.add_texture(textures::plaster([0.92, 0.88, 0.8], seed as u32));
        let textured = |name: &str, texture: usize, tint: [f32; 3]| Material { base_color_texture: Some(texture), ..Material::diffuse(name, tint) };
        GalleryMaterials {
            floor: m.add_material(textured("floor_marble", tex_floor, [1.0; 3])),
            wall: m.add_material(textured("wall_plaster", tex_plaster, [1.0; 3])),
            wall_red: m.add_material(textured("wall_plaster_red", tex_plaster, [0.8, 0.35, 0.3])),
            wall_blue: m.add_material(textured("wall_plaster_blue", tex_plaster, [0.35, 0.45, 0.75])),
            bricks: m.add_material(textured("courtyard_bricks", tex_bricks, [1.0; 3])),
            wood: m.add_material(textured("store_planks", tex_wood, [1.0; 3])),
            ceiling: m.add_material(Material::diffuse("ceiling", [0.8, 0.8, 0.78])),
            stone: m.add_material(Material::diffuse("pillar_stone", [0.7, 0.68, 0.62])),
            plinth: m.add_material(Material::diffuse("plinth", [0.2, 0.2, 0.22])),
            marble: m.add_material(Material::diffuse("statue_marble", [0.9, 0.9, 0.88])),
            bronze: m.add_material(Material::diffuse("statue_bronze", [0.45, 0.3, 0.15])),
            lamp: m.add_material(Material { emissive: Vec3::splat(8.0), ..Material::diffuse("lamp", [1.0; 3]) }),
        }
    }
}

/// Which outer walls of a wing have a door to a neighbouring wing: on the
/// x sides into the corridor (z = 2), on the z sides into the courtyard
/// (low z) and the store room E (high z), both at x = 16, so that the doors
/// of wings side by side on a grid face each other.
#[derive(Clone, Copy, Default)]
pub(crate) struct Neighbours {
    pub low_x: bool,
    pub high_x: bool,
    pub low_z: bool,
    pub high_z: bool,
}

/// Where the doors between neighbouring wings are, in wing coordinates: the
/// line (z) of those on the x sides, and the line (x) of those on the z sides.
pub(crate) const JOIN_Z: f32 = 2.0;
pub(crate) const JOIN_X: f32 = 16.0;

/// One museum wing (the plan in the module header) with its origin at `o`;
/// object names get `prefix`.
pub(crate) fn wing(m: &mut MeshBuilder, mat: &GalleryMaterials, rng: &mut Pcg64Mcg, o: Vec3, prefix: &str, next: Neighbours) {
    let v = |x: f32, y: f32, z: f32| o + Vec3::new(x, y, z);
    m.begin_object(&format!("{prefix}ground"));
    m.set_material(mat.floor);
    m.cuboid(v(-0.15, -0.3, -16.15), v(40.15, 0.0, 20.15));

    m.begin_object(&format!("{prefix}walls"));
    let door = |c: f32| (c, DOOR_W, DOOR_H);
    let join = |on: bool, c: f32| if on { vec![door(c)] } else { Vec::new() };
    // (material, along x, line, from, to, doors) in wing coordinates.
    type Planned = (u32, bool, f32, f32, f32, Vec<(f32, f32, f32)>);
    let walls: [Planned; 12] = [
        // Corridor walls: south (courtyard and D doors), north (A, B, C doors); outer walls.
        (mat.wall, true, 0.0, 0.0, 40.0, vec![door(12.0), door(32.0)]),
        (mat.wall, true, 4.0, 0.0, 40.0, vec![door(6.0), door(16.0), door(30.0)]),
        (mat.wall, false, 0.0, -16.0, 16.0, join(next.low_x, JOIN_Z)),
        (mat.wall, false, 40.0, -12.0, 20.0, join(next.high_x, JOIN_Z)),
        (mat.wall_red, true, 16.0, 0.0, 12.0, Vec::new()),
        (mat.wall_red, false, 12.0, 4.0, 20.0, vec![door(14.0)]),
        (mat.wood, true, 12.0, 12.0, 20.0, vec![door(16.0)]),
        (mat.wood, true, 20.0, 12.0, 40.0, join(next.high_z, JOIN_X)),
        (mat.wall_blue, false, 20.0, 4.0, 20.0, vec![door(8.0)]),
        (mat.wall_blue, true, -12.0, 24.0, 40.0, Vec::new()),
        (mat.bricks, true, -16.0, 0.0, 24.0, join(next.low_z, JOIN_X)),
        (mat.bricks, false, 24.0, -16.0, 0.0, vec![door(-6.0)]),
    ];
    for (material, along_x, line, from, to, doors) in walls {
        m.set_material(material);
        let (shift_line, shift_run) = if along_x { (o.z, o.x) } else { (o.x, o.z) };
        let doors: Vec<_> = doors.iter().map(|&(c, w, h)| (c + shift_run, w, h)).collect();
        m.wall(Wall::new(along_x, line + shift_line, from + shift_run, to + shift_run), o.y..o.y + WALL_H, WALL_T, &doors);
    }

    m.begin_object(&format!("{prefix}roof"));
    m.set_material(mat.ceiling);
    let rooms: [(f32, f32, f32, f32); 6] = [
        (0.0, 0.0, 40.0, 4.0),    // corridor
        (0.0, 4.0, 12.0, 16.0),   // A
        (12.0, 4.0, 20.0, 12.0),  // B
        (12.0, 12.0, 20.0, 20.0), // E
        (20.0, 4.0, 40.0, 20.0),  // C
        (24.0, -12.0, 40.0, 0.0), // D
    ];
    // Each room's roof reaches over its walls' outer halves.
    let h = 0.5 * WALL_T;
    let roofs: Vec<[f32; 4]> = rooms.iter().map(|&(x0, z0, x1, z1)| [o.x + x0 - h, o.z + z0 - h, o.x + x1 + h, o.z + z1 + h]).collect();
    m.slabs(&roofs, o.y + WALL_H, o.y + WALL_H + 0.3);

    m.begin_object(&format!("{prefix}lamps"));
    m.set_material(mat.lamp);
    for &(x0, z0, x1, z1) in &rooms {
        let c = v(0.5 * (x0 + x1), WALL_H - 0.02, 0.5 * (z0 + z1));
        m.cuboid(c - Vec3::new(0.5, 0.0, 0.5), c + Vec3::new(0.5, 0.019, 0.5));
        m.add_light(Light::Point { position: c - Vec3::Y * 0.4, intensity: Vec3::new(60.0, 55.0, 45.0) });
    }

    m.begin_object(&format!("{prefix}pillars"));
    m.set_material(mat.stone);
    for i in 0..4 {
        for j in 0..3 {
            m.cylinder(v(23.5 + 4.3 * i as f32, 0.0, 8.0 + 4.0 * j as f32), 0.35, WALL_H, 32);
        }
    }
    for i in 0..4 {
        m.cylinder(v(4.0 + 5.0 * i as f32, 0.0, -4.0), 0.3, WALL_H - 0.5, 24);
    }

    let statues = [(4.0, 10.0), (9.0, 13.0), (16.0, 9.0), (16.0, 17.0), (30.0, 12.0), (36.0, 17.0), (32.0, -6.0), (12.0, -10.0)];
    for (k, &(x, z)) in statues.iter().enumerate() {
        let base = v(x, 0.0, z);
        m.begin_object(&format!("{prefix}statue_{k}"));
        m.set_material(mat.plinth);
        m.cuboid(base + Vec3::new(-0.4, 0.0, -0.4), base + Vec3::new(0.4, 1.0, 0.4));
        m.set_material(if k % 3 == 2 { mat.bronze } else { mat.marble });
        statue(m, rng, base + Vec3::Y * 1.9);
    }
}

/// A seeded lumpy figure: an ellipsoid with a few random bulges.
pub(crate) fn statue(m: &mut MeshBuilder, rng: &mut Pcg64Mcg, centre: Vec3) {
    let lobes: Vec<(Vec3, f32)> = (0..5)
        .map(|_| {
            let d = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            (d.normalize_or(Vec3::Y), rng.random_range(0.1..0.45))
        })
        .collect();
    m.blob(centre, Vec3::new(0.35, 0.9, 0.35), STATUE_LEVELS, |d| 1.0 + lobes.iter().map(|&(c, a)| a * d.dot(c).max(0.0).powi(6)).sum::<f32>());
}
