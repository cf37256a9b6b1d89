//! `cathedral`: a three-aisled basilica with galleries, on a square between two
//! solid west towers.
//!
//! Plan (metres, +Y up, square y = 0; x east, z south): the church x∈[-20, 20],
//! z∈[-10, 10], its floor 0.2 up. A nave 9 m wide and 20 m high (gabled roof
//! above) between two arcades of seven arches on piers; aisles 4.2 m wide and
//! 9 m high, each under a gallery (9.4 to 12.4 m) that looks into the nave
//! through a row of openings with a parapet. Clerestory windows above the
//! galleries, tall windows in the aisles, small ones in the galleries, three in
//! the east wall and a rose window over the west portal. A stair of 50 steps
//! climbs the north aisle to the north gallery; an organ loft over the west
//! end joins both galleries. Pews, a raised chancel with an altar, a pulpit and
//! a font (no one stands on the pews). The towers are closed solids (never navigable); the square around
//! the church is open to the sky. No glass: the windows are openings.
//!
//! The kinds of space it tests together: a tall interior seen from eye height,
//! an upper floor reached only by a long stair, openings at every height into
//! open space outside, and solids beside the open square. About 3k triangles.

use crate::mesh::{MeshBuilder, Opening, Wall};
use crate::scene::{Light, Material, Scene};
use crate::textures;
use glam::{Vec2, Vec3};

const FLOOR: f32 = 0.2;
/// Church walls' extent: x ± HALF_L, outer walls at z ± HALF_W.
const HALF_L: f32 = 20.0;
const HALF_W: f32 = 10.0;
/// Arcade walls' centre lines: z ± NAVE.
const NAVE: f32 = 5.0;
/// Aisle ceiling (the galleries' floor slab from AISLE_TOP to GALLERY) and the
/// galleries' roof.
const AISLE_TOP: f32 = 9.0;
const GALLERY: f32 = 9.4;
const GALLERY_TOP: f32 = 12.4;
const NAVE_TOP: f32 = 20.0;
const OUTER_T: f32 = 0.6;
const ARCADE_T: f32 = 1.0;
const FACADE_T: f32 = 1.0;
/// The stair: 50 steps along the south aisle's outer wall, rising eastward.
const STEPS: usize = 50;
const RUN: f32 = 0.28;
const STAIR_X0: f32 = -18.5;
const STAIR_Z: (f32, f32) = (8.4, 9.6);

pub fn cathedral(seed: u64) -> Scene {
    let mut m = MeshBuilder::new("cathedral");
    let mat = Materials::new(&mut m, seed);
    m.begin_object("square");
    m.set_material(mat.paving);
    m.cuboid(Vec3::new(-40.0, -0.3, -25.0), Vec3::new(34.0, 0.0, 25.0));
    m.begin_object("church");
    m.set_material(mat.marble);
    m.cuboid(Vec3::new(-OUTER_X, 0.0, -OUTER_Z), Vec3::new(OUTER_X, FLOOR, OUTER_Z));
    m.set_material(mat.stone);
    fronts(&mut m);
    for side in [-1.0f32, 1.0] {
        long_side(&mut m, &mat, side);
    }
    roof_and_loft(&mut m, &mat);
    stair_and_chancel(&mut m, &mat);
    furnishings(&mut m, &mat);
    lamps(&mut m, &mat);
    towers(&mut m, &mat);
    m.finish()
}

/// The outer walls' outer faces, along the nave (x) and across it (z).
const OUTER_X: f32 = HALF_L + 0.5 * FACADE_T;
const OUTER_Z: f32 = HALF_W + 0.5 * OUTER_T;
/// The inner face of the front walls, and the aisles' inner edge.
const INNER_X: f32 = HALF_L - 0.5 * FACADE_T;
const AISLE_IN: f32 = NAVE + 0.5 * ARCADE_T;

struct Materials {
    paving: u32,
    stone: u32,
    marble: u32,
    wood: u32,
    lead: u32,
    cloth: u32,
    lamp: u32,
}

impl Materials {
    fn new(m: &mut MeshBuilder, seed: u64) -> Materials {
        let paving = m.add_material(Material::diffuse("square", [0.5, 0.48, 0.44]));
        let stone_tex = m.add_texture(textures::plaster([0.86, 0.82, 0.74], seed as u32));
        let stone = m.add_material(Material { base_color_texture: Some(stone_tex), ..Material::diffuse("stone", [1.0; 3]) });
        let marble_tex = m.add_texture(textures::checker_marble(seed as u32));
        let marble = m.add_material(Material { base_color_texture: Some(marble_tex), ..Material::diffuse("marble_floor", [1.0; 3]) });
        let planks = m.add_texture(textures::planks(seed as u32));
        let wood = m.add_material(Material { base_color_texture: Some(planks), ..Material::diffuse("oak", [1.0; 3]) });
        let lead = m.add_material(Material::diffuse("roof_lead", [0.32, 0.34, 0.36]));
        let cloth = m.add_material(Material::diffuse("altar_cloth", [0.75, 0.12, 0.1]));
        let lamp = m.add_material(Material { emissive: Vec3::splat(8.0), ..Material::diffuse("lamp", [1.0; 3]) });
        Materials { paving, stone, marble, wood, lead, cloth, lamp }
    }
}

fn door(centre: f32, width: f32, head: f32) -> Opening {
    Opening { centre, width, sill: 0.0, head }
}

/// West front: the portal below, the rose window above; east wall: three
/// tall windows behind the altar.
fn fronts(m: &mut MeshBuilder) {
    m.wall_with_openings(Wall::along_z(-HALF_L, -HALF_W, HALF_W), FLOOR..10.0, FACADE_T, &[door(0.0, 3.0, 5.5)]);
    m.wall_with_openings(
        Wall::along_z(-HALF_L, -HALF_W, HALF_W),
        10.0..NAVE_TOP,
        FACADE_T,
        &[Opening { centre: 0.0, width: 3.5, sill: 1.5, head: 5.5 }],
    );
    let tall = |centre: f32| Opening { centre, width: 1.2, sill: 4.0, head: 12.0 };
    m.wall_with_openings(Wall::along_z(HALF_L, -HALF_W, HALF_W), FLOOR..NAVE_TOP, FACADE_T, &[tall(-3.0), tall(0.0), tall(3.0)]);
}

/// One long side (`side` −1 north, +1 south): the outer wall, the arcade
/// wall, the aisle's ceiling and the gallery's roof.
fn long_side(m: &mut MeshBuilder, mat: &Materials, side: f32) {
    let (ow, inner_x, aisle_in) = (OUTER_Z, INNER_X, AISLE_IN);
    let bays: Vec<f32> = (0..8).map(|k| -17.5 + 5.0 * k as f32).collect();
    let arches: Vec<f32> = (0..7).map(|k| -15.0 + 5.0 * k as f32).collect();
    // Outer wall: the aisle's tall windows (a door in the north one),
    // the gallery's small ones above the slab between them.
    let mut low: Vec<Opening> = bays.iter().map(|&x| Opening { centre: x, width: 1.6, sill: 2.5, head: 7.0 }).collect();
    if side < 0.0 {
        low[5] = door(bays[5], 2.0, 3.5);
    }
    m.wall_with_openings(Wall::along_x(side * HALF_W, -inner_x, inner_x), FLOOR..AISLE_TOP, OUTER_T, &low);
    let small: Vec<Opening> = bays.iter().map(|&x| Opening { centre: x, width: 1.0, sill: 1.0, head: 2.4 }).collect();
    m.wall_with_openings(Wall::along_x(side * HALF_W, -inner_x, inner_x), GALLERY..GALLERY_TOP, OUTER_T, &small);
    // Arcade wall in three bands: arches, gallery openings (a doorway at
    // the west end onto the organ loft), clerestory windows.
    let arch: Vec<Opening> = arches.iter().map(|&x| door(x, 3.4, 6.8)).collect();
    m.wall_with_openings(Wall::along_x(side * NAVE, -inner_x, inner_x), FLOOR..GALLERY, ARCADE_T, &arch);
    let mut tribune: Vec<Opening> = arches.iter().map(|&x| Opening { centre: x, width: 3.0, sill: 1.0, head: 2.6 }).collect();
    tribune.insert(0, door(-18.2, 1.2, 2.4));
    m.wall_with_openings(Wall::along_x(side * NAVE, -inner_x, inner_x), GALLERY..GALLERY_TOP + 0.4, ARCADE_T, &tribune);
    let clerestory: Vec<Opening> = arches.iter().map(|&x| Opening { centre: x, width: 2.0, sill: 1.6, head: 5.6 }).collect();
    m.wall_with_openings(Wall::along_x(side * NAVE, -inner_x, inner_x), GALLERY_TOP + 0.4..NAVE_TOP, ARCADE_T, &clerestory);
    // Aisle ceiling (the gallery's floor) and the gallery's roof, through
    // the outer wall; the south one open over the stair's top.
    let (z_in, z_out) = (side * aisle_in, side * ow);
    let (za, zb) = (z_in.min(z_out), z_in.max(z_out));
    let rect = |x0: f32, x1: f32, z0: f32, z1: f32| [x0, z0, x1, z1];
    if side > 0.0 {
        let well = (-12.0, -4.4, STAIR_Z.0, STAIR_Z.1 + 0.1);
        m.slabs(
            &[rect(-inner_x, well.0, za, zb), rect(well.1, inner_x, za, zb), rect(well.0, well.1, za, well.2), rect(well.0, well.1, well.3, zb)],
            AISLE_TOP,
            GALLERY,
        );
        // Railing round the well's open sides.
        m.cuboid(Vec3::new(well.0, GALLERY, well.2 - 0.06), Vec3::new(well.1, GALLERY + 1.0, well.2));
        m.cuboid(Vec3::new(well.0 - 0.06, GALLERY, well.2), Vec3::new(well.0, GALLERY + 1.0, well.3));
    } else {
        m.cuboid(Vec3::new(-inner_x, AISLE_TOP, za), Vec3::new(inner_x, GALLERY, zb));
    }
    m.set_material(mat.lead);
    m.cuboid(Vec3::new(-inner_x, GALLERY_TOP, za), Vec3::new(inner_x, GALLERY_TOP + 0.4, zb));
    m.set_material(mat.stone);
}

/// The nave's ceiling and gabled roof; the organ loft across the west end.
fn roof_and_loft(m: &mut MeshBuilder, mat: &Materials) {
    // Nave ceiling over the arcades and the front walls, the gabled roof on it.
    m.cuboid(Vec3::new(-OUTER_X, NAVE_TOP, -AISLE_IN), Vec3::new(OUTER_X, NAVE_TOP + 0.4, AISLE_IN));
    m.set_material(mat.lead);
    let top = NAVE_TOP + 0.4;
    m.prism_x(&[Vec2::new(top, -AISLE_IN - 0.3), Vec2::new(top + 5.0, 0.0), Vec2::new(top, AISLE_IN + 0.3)], -OUTER_X, OUTER_X);

    // The organ loft across the west end, joining the galleries, with a parapet.
    m.set_material(mat.wood);
    let loft = -INNER_X + 3.5;
    m.cuboid(Vec3::new(-INNER_X, AISLE_TOP, -NAVE + 0.5 * ARCADE_T), Vec3::new(loft, GALLERY, NAVE - 0.5 * ARCADE_T));
    m.cuboid(Vec3::new(loft - 0.1, GALLERY, -NAVE + 0.5 * ARCADE_T), Vec3::new(loft, GALLERY + 1.0, NAVE - 0.5 * ARCADE_T));
}

/// The stair up to the south gallery; the chancel at the east end.
fn stair_and_chancel(m: &mut MeshBuilder, mat: &Materials) {
    // The stair: solid steps of 0.184 × 0.28 m up to the south gallery.
    m.begin_object("stair");
    m.set_material(mat.stone);
    let rise = (GALLERY - FLOOR) / STEPS as f32;
    for k in 0..STEPS {
        let x = STAIR_X0 + k as f32 * RUN;
        m.cuboid(Vec3::new(x, FLOOR, STAIR_Z.0), Vec3::new(x + RUN, FLOOR + (k + 1) as f32 * rise, STAIR_Z.1));
    }

    // The chancel, two steps up at the east end.
    m.set_material(mat.marble);
    let chancel = (13.0, 13.3);
    m.cuboid(Vec3::new(chancel.0, FLOOR, -4.3), Vec3::new(chancel.1, FLOOR + 0.2, 4.3));
    m.cuboid(Vec3::new(chancel.1, FLOOR, -4.3), Vec3::new(INNER_X - 0.05, FLOOR + 0.4, 4.3));
}

/// The altar, pews, a pulpit, a font.
fn furnishings(m: &mut MeshBuilder, mat: &Materials) {
    m.begin_object("furnishings");
    m.set_material(mat.cloth);
    m.cuboid(Vec3::new(16.5, FLOOR + 0.4, -1.2), Vec3::new(17.5, FLOOR + 1.4, 1.2));
    m.set_material(mat.wood);
    for row in 0..22 {
        let x = -14.0 + row as f32;
        for (z0, z1) in [(-4.0, -0.9), (0.9, 4.0)] {
            m.cuboid(Vec3::new(x, FLOOR + 0.42, z0), Vec3::new(x + 0.42, FLOOR + 0.47, z1));
            m.cuboid(Vec3::new(x + 0.42, FLOOR, z0), Vec3::new(x + 0.48, FLOOR + 0.95, z1));
        }
    }
    m.cylinder(Vec3::new(11.5, FLOOR, -3.6), 0.6, 1.4, 12);
    m.set_material(mat.marble);
    m.cylinder(Vec3::new(-16.0, FLOOR, 2.5), 0.5, 1.0, 12);
}

/// Hanging lamps down the nave and in the aisles; the sun from the south-west.
fn lamps(m: &mut MeshBuilder, mat: &Materials) {
    m.begin_object("lamps");
    m.set_material(mat.lamp);
    for (x, y, z) in [(-10.0, 12.0, 0.0), (0.0, 12.0, 0.0), (10.0, 12.0, 0.0), (-5.0, 7.5, 7.6), (5.0, 7.5, 7.6), (-5.0, 7.5, -7.6), (5.0, 7.5, -7.6)]
    {
        m.cuboid(Vec3::new(x - 0.3, y, z - 0.3), Vec3::new(x + 0.3, y + 0.2, z + 0.3));
        m.add_light(Light::Point { position: Vec3::new(x, y - 0.3, z), intensity: Vec3::splat(if y > 10.0 { 400.0 } else { 120.0 }) });
    }
    m.add_light(Light::Sun { direction: Vec3::new(-0.4, 0.75, 0.53), irradiance: Vec3::new(3.0, 2.9, 2.6) });
}

/// The west towers: closed solids flanking the front.
fn towers(m: &mut MeshBuilder, mat: &Materials) {
    m.begin_object("towers");
    m.set_material(mat.stone);
    for side in [-1.0f32, 1.0] {
        let (z0, z1) = (side * (AISLE_IN + 0.5), side * (OUTER_Z + 0.5));
        m.cuboid(Vec3::new(-OUTER_X - 5.0, 0.0, z0.min(z1)), Vec3::new(-OUTER_X, 32.0, z0.max(z1)));
    }
}
