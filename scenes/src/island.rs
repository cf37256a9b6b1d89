//! `island`: an open landscape, the kind of scene an atrium-shaped notion of
//! "inside" gets wrong.
//!
//! Plan (metres, +Y up, sea level y = 0): a 160 × 160 m square of sea with an
//! island about 130 m across; hills up to about 17 m; three houses on levelled
//! ground, each with a door and windows and a flat roof; a rock mass with a
//! tunnel 4 m wide through it; a river channel across the island's east with a
//! wooden bridge and railings; trees. A sun lights it. About 60k triangles.

use crate::mesh::{MeshBuilder, Opening, Wall};
use crate::scene::{Light, Material, Scene};
use crate::textures;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

const HALF: f32 = 80.0;
const RADIUS: f32 = 62.0;
/// Levelled sites: (x, z, radius) of the houses, the tunnel and the bridge ends.
const HOUSES: [(f32, f32); 3] = [(-30.0, -20.0), (-12.0, 28.0), (22.0, -34.0)];
const TUNNEL: (f32, f32) = (-38.0, 18.0);
const RIVER_X: f32 = 30.0;
const BRIDGE_Z: f32 = 10.0;
const HOUSE_W: f32 = 8.0;
const HOUSE_D: f32 = 6.0;
const WALL_H: f32 = 3.0;

pub fn island(seed: u64) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x6973_6c61);
    let mut m = MeshBuilder::new("island");
    let mat = Materials::new(&mut m, seed);
    let ground = Ground::new(&mut rng);
    m.begin_object("terrain");
    m.set_material(mat.grass);
    m.terrain(-HALF, -HALF, HALF, HALF, 128, |x, z| ground.height(x, z));
    m.begin_object("sea");
    m.set_material(mat.water);
    m.quad([Vec3::new(-HALF, 0.0, HALF), Vec3::new(HALF, 0.0, HALF), Vec3::new(HALF, 0.0, -HALF), Vec3::new(-HALF, 0.0, -HALF)]);
    for (k, &(x, z)) in HOUSES.iter().enumerate() {
        house(&mut m, &mat, &format!("house_{k}"), Vec3::new(x, ground.site_height(x, z), z), k);
    }
    tunnel(&mut m, &mat, &ground);
    bridge(&mut m, &mat, &ground);
    trees(&mut m, &mat, &ground, &mut rng);
    m.add_light(Light::Sun { direction: Vec3::new(-0.35, 0.83, 0.43), irradiance: Vec3::new(3.2, 3.0, 2.7) });
    m.finish()
}

struct Materials {
    grass: u32,
    water: u32,
    rock: u32,
    plaster: u32,
    roof: u32,
    wood: u32,
    bark: u32,
    leaves: u32,
}

impl Materials {
    fn new(m: &mut MeshBuilder, seed: u64) -> Materials {
        let grass = m.add_material(Material::diffuse("grass", [0.25, 0.42, 0.16]));
        let water = m.add_material(Material::diffuse("sea", [0.08, 0.2, 0.32]));
        let rock = m.add_material(Material::diffuse("rock", [0.45, 0.42, 0.38]));
        let plaster_tex = m.add_texture(textures::plaster([0.9, 0.86, 0.78], seed as u32));
        let plaster = m.add_material(Material { base_color_texture: Some(plaster_tex), ..Material::diffuse("house_plaster", [1.0; 3]) });
        let roof = m.add_material(Material::diffuse("roof", [0.5, 0.2, 0.15]));
        let floor_tex = m.add_texture(textures::planks(seed as u32));
        let wood = m.add_material(Material { base_color_texture: Some(floor_tex), ..Material::diffuse("wood", [1.0; 3]) });
        let bark = m.add_material(Material::diffuse("bark", [0.3, 0.2, 0.12]));
        let leaves = m.add_material(Material::diffuse("leaves", [0.15, 0.35, 0.12]));
        Materials { grass, water, rock, plaster, roof, wood, bark, leaves }
    }
}

/// The island's ground: seeded hills, levelled sites (the houses, the
/// tunnel, the bridge's ends) and the river.
struct Ground {
    /// (x, z, height, spread) of each hill.
    hills: Vec<(f32, f32, f32, f32)>,
    /// (x, z, radius) of each levelled site.
    sites: Vec<(f32, f32, f32)>,
}

impl Ground {
    /// A few seeded bumps, kept away from the levelled sites.
    fn new(rng: &mut Pcg64Mcg) -> Ground {
        let hills = (0..6)
            .map(|_| (rng.random_range(-45.0..45.0), rng.random_range(-45.0..45.0), rng.random_range(8.0..17.0), rng.random_range(10.0..16.0)))
            .collect();
        let sites = HOUSES
            .iter()
            .map(|&(x, z)| (x, z, 9.0))
            .chain([(TUNNEL.0, TUNNEL.1, 12.0), (RIVER_X - 7.0, BRIDGE_Z, 4.0), (RIVER_X + 7.0, BRIDGE_Z, 4.0)])
            .collect();
        Ground { hills, sites }
    }

    fn natural(&self, x: f32, z: f32) -> f32 {
        let r = (x * x + z * z).sqrt();
        let shore = 2.0 - 5.0 * smoothstep(RADIUS - 12.0, RADIUS + 4.0, r);
        let bumps: f32 = self.hills.iter().map(|&(hx, hz, h, s)| h * (-((x - hx).powi(2) + (z - hz).powi(2)) / (2.0 * s * s)).exp()).sum();
        let ripples = 0.4 * (0.21 * x).sin() * (0.17 * z).cos();
        shore + (bumps + ripples) * (1.0 - smoothstep(RADIUS - 20.0, RADIUS, r))
    }

    /// Ground height of a levelled site: the natural height at its centre, at least 1 m above the sea.
    fn site_height(&self, x: f32, z: f32) -> f32 {
        self.natural(x, z).max(1.0)
    }

    /// Levelled ground at each site, blended into the hills around it.
    fn level(&self, x: f32, z: f32) -> f32 {
        let mut h = self.natural(x, z);
        for &(sx, sz, radius) in &self.sites {
            let d = ((x - sx).powi(2) + (z - sz).powi(2)).sqrt();
            let w = 1.0 - smoothstep(radius, radius + 8.0, d);
            h = h * (1.0 - w) + self.site_height(sx, sz) * w;
        }
        h
    }

    /// The ground with the river: a channel 8 m wide down to 2 m below the sea, across the island.
    fn height(&self, x: f32, z: f32) -> f32 {
        let d = (x - RIVER_X).abs();
        let w = 1.0 - smoothstep(3.0, 6.0, d);
        let h = self.level(x, z);
        h * (1.0 - w) + (-2.0) * w
    }
}

/// The rock and its tunnel (along z): two side blocks and a ceiling block.
fn tunnel(m: &mut MeshBuilder, mat: &Materials, ground: &Ground) {
    let g = ground.site_height(TUNNEL.0, TUNNEL.1);
    let (tx, tz) = TUNNEL;
    m.begin_object("rock_tunnel");
    m.set_material(mat.rock);
    m.cuboid(Vec3::new(tx - 9.0, g - 1.0, tz - 7.0), Vec3::new(tx - 2.0, g + 8.0, tz + 7.0));
    m.cuboid(Vec3::new(tx + 2.0, g - 1.0, tz - 7.0), Vec3::new(tx + 9.0, g + 8.0, tz + 7.0));
    m.cuboid(Vec3::new(tx - 2.0, g + 3.4, tz - 7.0), Vec3::new(tx + 2.0, g + 8.0, tz + 7.0));
}

/// The bridge over the river: a deck at the banks' height with railings.
fn bridge(m: &mut MeshBuilder, mat: &Materials, ground: &Ground) {
    let bank = ground.site_height(RIVER_X - 7.0, BRIDGE_Z).max(ground.site_height(RIVER_X + 7.0, BRIDGE_Z));
    m.begin_object("bridge");
    m.set_material(mat.wood);
    let (x0, x1) = (RIVER_X - 9.0, RIVER_X + 9.0);
    m.cuboid(Vec3::new(x0, bank - 0.25, BRIDGE_Z - 1.5), Vec3::new(x1, bank + 0.05, BRIDGE_Z + 1.5));
    for side in [-1.0f32, 1.0] {
        let z = BRIDGE_Z + side * 1.45;
        m.cuboid(Vec3::new(x0, bank + 0.95, z - 0.05), Vec3::new(x1, bank + 1.05, z + 0.05));
        for k in 0..=6 {
            let x = x0 + (x1 - x0) * k as f32 / 6.0;
            m.cuboid(Vec3::new(x - 0.06, bank + 0.05, z - 0.06), Vec3::new(x + 0.06, bank + 0.95, z + 0.06));
        }
    }
}

/// Twelve trees on open ground, away from the sites and the river.
fn trees(m: &mut MeshBuilder, mat: &Materials, ground: &Ground, rng: &mut Pcg64Mcg) {
    let mut planted = 0;
    while planted < 12 {
        let (x, z) = (rng.random_range(-50.0..50.0f32), rng.random_range(-50.0..50.0f32));
        let clear = ground.sites.iter().all(|&(sx, sz, r)| (x - sx).powi(2) + (z - sz).powi(2) > (r + 6.0).powi(2)) && (x - RIVER_X).abs() > 8.0;
        if !clear || (x * x + z * z).sqrt() > RADIUS - 14.0 {
            continue;
        }
        let base = Vec3::new(x, ground.height(x, z) - 0.3, z);
        m.begin_object(&format!("tree_{planted}"));
        m.set_material(mat.bark);
        m.cylinder(base, 0.3, 4.5, 10);
        m.set_material(mat.leaves);
        let crown = rng.random_range(2.0..3.0);
        m.blob(base + Vec3::Y * (4.5 + 0.6 * crown), Vec3::new(crown, crown * 0.8, crown), 3, |d| 1.0 + 0.12 * (5.0 * d.x).sin() * (4.0 * d.z).cos());
        planted += 1;
    }
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A one-room house with its floor 0.15 above `ground`: a door in the south
/// wall, windows in the others (and one beside the door), a flat roof slab, a
/// table inside. Its foundation reaches 0.6 below the ground so slopes never
/// show under it.
fn house(m: &mut MeshBuilder, mat: &Materials, name: &str, centre: Vec3, k: usize) {
    let (plaster, wood, roof) = (mat.plaster, mat.wood, mat.roof);
    let (w, d, t) = (HOUSE_W, HOUSE_D, 0.25);
    let (x0, z0) = (centre.x - 0.5 * w, centre.z - 0.5 * d);
    let floor = centre.y + 0.15;
    m.begin_object(name);
    m.set_material(wood);
    m.cuboid(Vec3::new(x0 - t, centre.y - 0.6, z0 - t), Vec3::new(x0 + w + t, floor, z0 + d + t));
    m.set_material(plaster);
    let window = |c: f32| Opening { centre: c, width: 1.2, sill: 0.9, head: 2.1 };
    let door = Opening { centre: x0 + 0.3 * w, width: 1.0, sill: 0.0, head: 2.1 };
    m.wall_with_openings(Wall::along_x(z0 + d, x0, x0 + w), floor..floor + WALL_H, t, &[door, window(x0 + 0.7 * w)]);
    m.wall_with_openings(Wall::along_x(z0, x0, x0 + w), floor..floor + WALL_H, t, &[window(x0 + 0.3 * w), window(x0 + 0.7 * w)]);
    m.wall_with_openings(Wall::along_z(x0, z0, z0 + d), floor..floor + WALL_H, t, &[window(z0 + 0.5 * d)]);
    m.wall_with_openings(Wall::along_z(x0 + w, z0, z0 + d), floor..floor + WALL_H, t, &[window(z0 + 0.5 * d)]);
    m.set_material(roof);
    m.cuboid(Vec3::new(x0 - 0.5, floor + WALL_H, z0 - 0.5), Vec3::new(x0 + w + 0.5, floor + WALL_H + 0.3, z0 + d + 0.5));
    m.set_material(wood);
    let table = Vec3::new(x0 + 0.35 * w + 0.1 * k as f32, floor, z0 + 0.45 * d);
    m.cuboid(table + Vec3::new(-0.8, 0.72, -0.5), table + Vec3::new(0.8, 0.78, 0.5));
    for (dx, dz) in [(-0.7, -0.4), (0.7, -0.4), (-0.7, 0.4), (0.7, 0.4)] {
        m.cuboid(table + Vec3::new(dx - 0.04, 0.0, dz - 0.04), table + Vec3::new(dx + 0.04, 0.72, dz + 0.04));
    }
}
