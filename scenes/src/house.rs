//! `house`: a two-storey house in a walled garden, joined by a straight staircase.
//!
//! Plan (metres, +Y up, garden ground y = 0; x east, z south): a garden 24 × 20
//! m, x∈[-12, 12], z∈[-10, 10], with a low wall around it; the house x∈[-6, 6],
//! z∈[-4.5, 4.5], floors at 0.15 and 3.15 (storeys of 3 m, slabs 0.2 thick), a
//! flat roof at 6.15. Ground floor: a living room (west) and a kitchen (east)
//! with a doorway between; the front door faces south; the staircase runs
//! along the north wall, west to east, 16 steps of 0.1875 × 0.28 m (treads
//! with a 3 cm chamfered nosing), under an opening in the upper slab with a
//! railing round it. Upper floor: two bedrooms off a landing. Windows on every
//! outer wall, no glass. Ceiling lights in each room and a sun. About 1.5k
//! triangles: a scene for walking, not for detail.

use crate::mesh::{MeshBuilder, Opening, Wall};
use crate::scene::{Light, Material, Scene};
use crate::textures;
use glam::{Vec2, Vec3};

const STOREY: f32 = 3.0;
const SLAB: f32 = 0.2;
const GROUND_FLOOR: f32 = 0.15;
const WALL_T: f32 = 0.25;
const STEPS: usize = 16;
const RISE: f32 = STOREY / STEPS as f32;
const RUN: f32 = 0.28;
/// The staircase: from x = STAIR_X0 eastward, z from STAIR_Z0 to STAIR_Z0 + 1.
const STAIR_X0: f32 = -4.0;
const STAIR_Z0: f32 = -4.375;
const STAIR_W: f32 = 1.0;
/// Treads: thickness, and overhang of the nosing past the riser below.
const TREAD: f32 = 0.04;
const NOSING: f32 = 0.03;

pub fn house(seed: u64) -> Scene {
    let mut m = MeshBuilder::new("house");
    let mat = Materials::new(&mut m, seed);
    garden(&mut m, &mat);
    shell(&mut m, &mat);
    staircase(&mut m, &mat);
    furniture(&mut m, &mat);
    lamps(&mut m, &mat);
    m.finish()
}

/// The house's walls' centre lines: x from −6 to 6, z from −4.5 to 4.5.
const FOOTPRINT: (f32, f32, f32, f32) = (-6.0, 6.0, -4.5, 4.5);
const UPPER: f32 = GROUND_FLOOR + STOREY;
/// The stairwell left open in the upper slab: x from, x to, z from, z to.
const WELL: (f32, f32, f32, f32) = (STAIR_X0 + 3.0 * RUN, STAIR_X0 + STEPS as f32 * RUN, STAIR_Z0, STAIR_Z0 + STAIR_W);

struct Materials {
    grass: u32,
    stone: u32,
    plaster: u32,
    wood: u32,
    concrete: u32,
    fabric: u32,
    lamp: u32,
}

impl Materials {
    fn new(m: &mut MeshBuilder, seed: u64) -> Materials {
        let grass = m.add_material(Material::diffuse("lawn", [0.22, 0.38, 0.15]));
        let stone = m.add_material(Material::diffuse("garden_wall", [0.55, 0.52, 0.47]));
        let plaster_tex = m.add_texture(textures::plaster([0.92, 0.9, 0.85], seed as u32));
        let plaster = m.add_material(Material { base_color_texture: Some(plaster_tex), ..Material::diffuse("plaster", [1.0; 3]) });
        let planks = m.add_texture(textures::planks(seed as u32));
        let wood = m.add_material(Material { base_color_texture: Some(planks), ..Material::diffuse("floor_wood", [1.0; 3]) });
        let concrete = m.add_material(Material::diffuse("slab", [0.7, 0.7, 0.68]));
        let fabric = m.add_material(Material::diffuse("fabric", [0.3, 0.35, 0.55]));
        let lamp = m.add_material(Material { emissive: Vec3::splat(6.0), ..Material::diffuse("lamp", [1.0; 3]) });
        Materials { grass, stone, plaster, wood, concrete, fabric, lamp }
    }
}

/// The lawn and the garden wall, its gate south.
fn garden(m: &mut MeshBuilder, mat: &Materials) {
    m.begin_object("garden");
    m.set_material(mat.grass);
    m.cuboid(Vec3::new(-12.0, -0.3, -10.0), Vec3::new(12.0, 0.0, 10.0));
    m.set_material(mat.stone);
    m.wall(Wall::along_x(-9.9, -11.9, 11.9), 0.0..1.0, 0.2, &[]);
    m.wall(Wall::along_x(9.9, -11.9, 11.9), 0.0..1.0, 0.2, &[(0.0, 1.2, 1.0)]);
    m.wall(Wall::along_z(-11.9, -9.9, 9.9), 0.0..1.0, 0.2, &[]);
    m.wall(Wall::along_z(11.9, -9.9, 9.9), 0.0..1.0, 0.2, &[]);
}

/// The house: slabs, roof, outer and inner walls.
fn shell(m: &mut MeshBuilder, mat: &Materials) {
    let (x0, x1, z0, z1) = FOOTPRINT;
    let upper = UPPER;
    m.begin_object("house");
    // Ground slab (on the lawn), the upper slab with the stairwell left open,
    // the roof. The slabs reach the walls' outer faces, so every wall stands
    // on and under a slab: no strip of a wall's end or top lies bare.
    m.set_material(mat.wood);
    let h = 0.5 * WALL_T;
    let (ox0, ox1, oz0, oz1) = (x0 - h, x1 + h, z0 - h, z1 + h);
    m.cuboid(Vec3::new(ox0, 0.0, oz0), Vec3::new(ox1, GROUND_FLOOR, oz1));
    let well = WELL;
    let (sy0, sy1) = (upper - SLAB, upper);
    m.cuboid(Vec3::new(ox0, sy0, oz0), Vec3::new(well.0, sy1, oz1));
    m.cuboid(Vec3::new(well.1, sy0, oz0), Vec3::new(ox1, sy1, oz1));
    m.cuboid(Vec3::new(well.0, sy0, well.3), Vec3::new(well.1, sy1, oz1));
    m.cuboid(Vec3::new(well.0, sy0, oz0), Vec3::new(well.1, sy1, well.2));
    m.set_material(mat.concrete);
    m.cuboid(Vec3::new(x0 - 0.3, upper + STOREY - SLAB, z0 - 0.3), Vec3::new(x1 + 0.3, upper + STOREY, z1 + 0.3));

    // Outer walls, storey by storey: windows everywhere, the front door south.
    m.set_material(mat.plaster);
    let window = |c: f32| Opening { centre: c, width: 1.2, sill: 0.9, head: 2.1 };
    for (k, floor) in [GROUND_FLOOR, upper].into_iter().enumerate() {
        let top = floor + STOREY - SLAB;
        let mut south = vec![window(-3.5), window(3.5)];
        if k == 0 {
            south.push(Opening { centre: 0.0, width: 1.0, sill: 0.0, head: 2.1 });
        } else {
            south.push(window(0.0));
        }
        m.wall_with_openings(Wall::along_x(z1, x0, x1), floor..top, WALL_T, &south);
        m.wall_with_openings(Wall::along_x(z0, x0, x1), floor..top, WALL_T, &[window(3.5)]);
        m.wall_with_openings(Wall::along_z(x0, z0, z1), floor..top, WALL_T, &[window(0.0)]);
        m.wall_with_openings(Wall::along_z(x1, z0, z1), floor..top, WALL_T, &[window(0.0)]);
    }
    // Inner walls: ground floor living room | kitchen at x = 1 (a doorway at z = 1);
    // upper floor: bedrooms at x < -1 and x > 2 off a landing, their doors facing it.
    m.wall(Wall::along_z(1.0, z0, z1), GROUND_FLOOR..upper - SLAB, 0.15, &[(1.0, 1.0, 2.1)]);
    m.wall(Wall::along_z(-1.0, -2.9, z1), upper..upper + STOREY - SLAB, 0.15, &[(0.0, 0.9, 2.1)]);
    m.wall(Wall::along_z(2.5, -2.9, z1), upper..upper + STOREY - SLAB, 0.15, &[(0.0, 0.9, 2.1)]);
}

/// The staircase up to the landing, with its railings.
fn staircase(m: &mut MeshBuilder, mat: &Materials) {
    let (upper, well) = (UPPER, WELL);
    // The staircase: solid steps from the ground floor up to the landing, each
    // tread overhanging its riser by a nosing with a chamfered edge, as real
    // treads do (the floor under a nosing is hidden from above).
    m.begin_object("staircase");
    m.set_material(mat.wood);
    for k in 0..STEPS {
        let x = STAIR_X0 + k as f32 * RUN;
        let top = GROUND_FLOOR + (k + 1) as f32 * RISE;
        m.cuboid(Vec3::new(x, GROUND_FLOOR, STAIR_Z0), Vec3::new(x + RUN, top - TREAD, STAIR_Z0 + STAIR_W));
        let (front, chamfer) = (x - NOSING, 0.5 * TREAD);
        let tread = [
            Vec2::new(front, top - TREAD),
            Vec2::new(x + RUN, top - TREAD),
            Vec2::new(x + RUN, top),
            Vec2::new(front + chamfer, top),
            Vec2::new(front, top - chamfer),
        ];
        m.prism_z(&tread, STAIR_Z0, STAIR_Z0 + STAIR_W);
    }
    // Railings: along the stairwell's open side upstairs, and beside the stairs.
    m.set_material(mat.stone);
    m.cuboid(Vec3::new(well.0, upper, well.3), Vec3::new(well.1, upper + 0.95, well.3 + 0.06));
    m.cuboid(Vec3::new(well.0 - 0.06, upper, well.2), Vec3::new(well.0, upper + 0.95, well.3 + 0.06));
}

/// Furniture: a sofa, beds, the kitchen's table and counter.
fn furniture(m: &mut MeshBuilder, mat: &Materials) {
    let upper = UPPER;
    m.begin_object("furniture");
    m.set_material(mat.fabric);
    m.cuboid(Vec3::new(-5.2, GROUND_FLOOR, 2.0), Vec3::new(-3.0, GROUND_FLOOR + 0.8, 3.0)); // sofa
    m.cuboid(Vec3::new(-5.0, upper, 1.0), Vec3::new(-3.0, upper + 0.55, 3.2)); // bed, west room
    m.cuboid(Vec3::new(3.5, upper, 1.0), Vec3::new(5.5, upper + 0.55, 3.2)); // bed, east room
    m.set_material(mat.wood);
    m.cuboid(Vec3::new(3.0, GROUND_FLOOR + 0.72, 1.0), Vec3::new(4.6, GROUND_FLOOR + 0.78, 2.2)); // kitchen table top
    for (dx, dz) in [(3.05, 1.05), (4.5, 1.05), (3.05, 2.1), (4.5, 2.1)] {
        m.cuboid(Vec3::new(dx, GROUND_FLOOR, dz), Vec3::new(dx + 0.05, GROUND_FLOOR + 0.72, dz + 0.05));
    }
    m.cuboid(Vec3::new(5.2, GROUND_FLOOR, -2.5), Vec3::new(5.8, GROUND_FLOOR + 0.9, 2.5));
    // kitchen counter
}

/// Ceiling lights, one a room, and the sun.
fn lamps(m: &mut MeshBuilder, mat: &Materials) {
    let upper = UPPER;
    m.begin_object("lamps");
    m.set_material(mat.lamp);
    for (x, floor, z) in [(-2.5, GROUND_FLOOR, 1.0), (3.5, GROUND_FLOOR, 0.0), (-3.5, upper, 1.5), (4.2, upper, 1.5), (0.7, upper, -1.5)] {
        let y = floor + STOREY - SLAB;
        m.cuboid(Vec3::new(x - 0.25, y - 0.05, z - 0.25), Vec3::new(x + 0.25, y, z + 0.25));
        m.add_light(Light::Point { position: Vec3::new(x, y - 0.3, z), intensity: Vec3::splat(25.0) });
    }
    m.add_light(Light::Sun { direction: Vec3::new(0.3, 0.8, 0.52), irradiance: Vec3::new(3.0, 2.9, 2.6) });
}
