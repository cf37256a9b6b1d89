//! Awkward scenes, as third-party files arrive: in units nobody states, with
//! furniture, objects with cabins, block worlds, atria and suites of rooms
//! joined only through doors. Each is modelled in metres and then written in
//! its own unit, with the scale left to be guessed (as an OBJ or PLY is); the
//! true scale is returned beside it, for tests and benchmarks to check the
//! guess and the map against.
//!
//! | name | unit | what it stresses |
//! |---|---|---|
//! | `cm_room` | cm | a small closed room in centimetres |
//! | `conference` | foot | a furnished room: a long table and chairs, a door |
//! | `car` | m | an object with a cabin behind glass, seats inside |
//! | `blocks` | m | a block world: 1 m terraces, block houses with doorways |
//! | `atrium` | cm / 20 | a two-storey arcade round a courtyard open to the sky, stairs up |
//! | `suite` | inch | six rooms joined only through doors, closed outside |
//! | `block_city` | m | a city of 1 m blocks, ~150 k triangles: streets, 1 m terraces, houses whose storeys are joined only by 1 m block stairs, one house sealed |

use crate::mesh::{MeshBuilder, Wall};
use crate::scene::{Light, Material, ScaleSource, Scene};
use glam::{Vec2, Vec3};

/// Every awkward scene's name.
pub const AWKWARD: [&str; 7] = ["cm_room", "conference", "car", "blocks", "atrium", "suite", "block_city"];

/// The scene and its true metres a unit; `None` for an unknown name.
pub fn awkward(name: &str) -> Option<(Scene, f32)> {
    let (scene, unit) = match name {
        "cm_room" => (cm_room(), 0.01),
        "conference" => (conference(), 0.3048),
        "car" => (car(), 1.0),
        "blocks" => (blocks(), 1.0),
        "atrium" => (atrium(), 0.2),
        "suite" => (suite(), 0.0254),
        "block_city" => (block_city(), 1.0),
        _ => return None,
    };
    Some((in_unit(scene, unit), unit))
}

/// The scene, modelled in metres, written in `unit` metres a unit, its
/// scale to be guessed.
fn in_unit(mut scene: Scene, unit: f32) -> Scene {
    for p in &mut scene.positions {
        *p /= unit;
    }
    for light in &mut scene.lights {
        if let Light::Point { position, intensity } = light {
            *position /= unit;
            // The same irradiance at the same (scaled) distance.
            *intensity /= unit * unit;
        }
    }
    scene.metres_per_unit = 1.0;
    scene.scale_source = ScaleSource::Guessed;
    scene
}

fn start(name: &str) -> (MeshBuilder, [u32; 3]) {
    let mut m = MeshBuilder::new(name);
    let wall = m.add_material(Material::diffuse("plaster", [0.75, 0.73, 0.7]));
    let floor = m.add_material(Material::diffuse("floor", [0.45, 0.35, 0.25]));
    let wood = m.add_material(Material::diffuse("wood", [0.5, 0.32, 0.18]));
    m.add_light(Light::Sun { direction: Vec3::new(0.3, 0.8, 0.4).normalize(), irradiance: Vec3::splat(3.0) });
    (m, [wall, floor, wood])
}

/// A closed box room: floor, ceiling and four walls, inside x∈[0, w],
/// z∈[0, d], y∈[0, h], 0.2 m shells; doors as (wall, centre, width) with wall
/// 0..4 = north (z = 0), south, west (x = 0), east.
fn room(m: &mut MeshBuilder, mat: [u32; 3], w: f32, h: f32, d: f32, doors: &[(usize, f32, f32)]) {
    let t = 0.2;
    let e = 0.5 * t;
    m.set_material(mat[1]);
    m.cuboid(Vec3::new(-t, -t, -t), Vec3::new(w + t, 0.0, d + t));
    m.set_material(mat[0]);
    m.cuboid(Vec3::new(-t, h, -t), Vec3::new(w + t, h + t, d + t));
    let at = |k: usize| doors.iter().filter(|o| o.0 == k).map(|o| (o.1, o.2, 2.1)).collect::<Vec<_>>();
    m.wall(Wall::along_x(-e, 0.0, w), 0.0..h, t, &at(0));
    m.wall(Wall::along_x(d + e, 0.0, w), 0.0..h, t, &at(1));
    m.wall(Wall::along_z(-e, 0.0, d), 0.0..h, t, &at(2));
    m.wall(Wall::along_z(w + e, 0.0, d), 0.0..h, t, &at(3));
}

/// A table: top at `height`, four legs.
fn table(m: &mut MeshBuilder, min: Vec2, max: Vec2, height: f32) {
    m.cuboid(Vec3::new(min.x, height - 0.04, min.y), Vec3::new(max.x, height, max.y));
    for (x, z) in [(min.x, min.y), (max.x - 0.06, min.y), (min.x, max.y - 0.06), (max.x - 0.06, max.y - 0.06)] {
        m.cuboid(Vec3::new(x, 0.0, z), Vec3::new(x + 0.06, height - 0.04, z + 0.06));
    }
}

/// A chair facing +z or -z: seat 0.45 m high, a back to 0.9 m.
fn chair(m: &mut MeshBuilder, at: Vec2, facing_plus_z: bool) {
    let (x0, z0) = (at.x - 0.22, at.y - 0.22);
    table(m, Vec2::new(x0, z0), Vec2::new(x0 + 0.44, z0 + 0.44), 0.45);
    let back_z = if facing_plus_z { z0 } else { z0 + 0.4 };
    m.cuboid(Vec3::new(x0, 0.45, back_z), Vec3::new(x0 + 0.44, 0.9, back_z + 0.04));
}

/// A small closed room, 3.6 × 2.6 × 3.0 m, a bed and a desk.
fn cm_room() -> Scene {
    let (mut m, mat) = start("cm_room");
    m.begin_object("room");
    room(&mut m, mat, 3.6, 2.6, 3.0, &[]);
    m.begin_object("furniture");
    m.set_material(mat[2]);
    m.cuboid(Vec3::new(0.1, 0.0, 0.1), Vec3::new(1.1, 0.5, 2.1));
    table(&mut m, Vec2::new(2.6, 0.1), Vec2::new(3.5, 0.8), 0.75);
    chair(&mut m, Vec2::new(3.05, 1.1), false);
    m.finish()
}

/// A 9 × 6 m conference room, 2.9 m high: a 5 × 1.4 m table, ten chairs, a
/// sideboard and a door into a corridor.
fn conference() -> Scene {
    let (mut m, mat) = start("conference");
    m.begin_object("room");
    room(&mut m, mat, 9.0, 2.9, 6.0, &[(2, 3.0, 1.0)]);
    // The corridor beyond the door: 2 m wide, closed.
    m.set_material(mat[1]);
    m.cuboid(Vec3::new(-2.4, -0.2, -0.2), Vec3::new(-0.2, 0.0, 6.2));
    m.set_material(mat[0]);
    m.cuboid(Vec3::new(-2.4, 2.9, -0.2), Vec3::new(-0.2, 3.1, 6.2));
    m.wall(Wall::along_z(-2.3, 0.0, 6.0), 0.0..2.9, 0.2, &[]);
    m.wall(Wall::along_x(-0.1, -2.4, -0.2), 0.0..2.9, 0.2, &[]);
    m.wall(Wall::along_x(6.1, -2.4, -0.2), 0.0..2.9, 0.2, &[]);
    m.begin_object("table");
    m.set_material(mat[2]);
    table(&mut m, Vec2::new(2.0, 2.3), Vec2::new(7.0, 3.7), 0.75);
    m.begin_object("chairs");
    for k in 0..5 {
        let x = 2.5 + k as f32 * 1.0;
        chair(&mut m, Vec2::new(x, 1.9), true);
        chair(&mut m, Vec2::new(x, 4.1), false);
    }
    m.begin_object("sideboard");
    m.cuboid(Vec3::new(8.4, 0.0, 1.5), Vec3::new(8.9, 0.9, 4.5));
    m.finish()
}

/// A car on the ground: a 4.6 × 1.8 m body 0.3-0.9 m high, a cabin to 1.4 m
/// closed by thin glass, four seats inside, wheels.
fn car() -> Scene {
    let mut m = MeshBuilder::new("car");
    let paint = m.add_material(Material::diffuse("paint", [0.6, 0.05, 0.05]));
    let glass = m.add_material(Material::diffuse("glass", [0.2, 0.25, 0.3]));
    let seat = m.add_material(Material::diffuse("leather", [0.15, 0.12, 0.1]));
    let tyre = m.add_material(Material::diffuse("rubber", [0.05, 0.05, 0.05]));
    m.add_light(Light::Sun { direction: Vec3::new(0.3, 0.8, 0.4).normalize(), irradiance: Vec3::splat(3.0) });
    m.begin_object("body");
    m.set_material(paint);
    // Floor pan, bonnet and boot: the cabin sits between them on the pan.
    m.cuboid(Vec3::new(0.0, 0.3, 0.0), Vec3::new(4.6, 0.4, 1.8));
    m.cuboid(Vec3::new(0.0, 0.4, 0.0), Vec3::new(1.2, 0.9, 1.8));
    m.cuboid(Vec3::new(3.6, 0.4, 0.0), Vec3::new(4.6, 0.9, 1.8));
    // Doors below the windows, and the roof.
    m.cuboid(Vec3::new(1.2, 0.4, 0.0), Vec3::new(3.6, 0.9, 0.04));
    m.cuboid(Vec3::new(1.2, 0.4, 1.76), Vec3::new(3.6, 0.9, 1.8));
    m.cuboid(Vec3::new(1.3, 1.38, 0.1), Vec3::new(3.4, 1.42, 1.7));
    m.begin_object("glass");
    m.set_material(glass);
    let quad = |m: &mut MeshBuilder, c: [Vec3; 4]| {
        m.quad(c);
        m.quad([c[3], c[2], c[1], c[0]]);
    };
    // Windscreen, rear screen, side windows.
    quad(&mut m, [Vec3::new(1.2, 0.9, 0.04), Vec3::new(1.2, 0.9, 1.76), Vec3::new(1.3, 1.38, 1.7), Vec3::new(1.3, 1.38, 0.1)]);
    quad(&mut m, [Vec3::new(3.6, 0.9, 1.76), Vec3::new(3.6, 0.9, 0.04), Vec3::new(3.4, 1.38, 0.1), Vec3::new(3.4, 1.38, 1.7)]);
    quad(&mut m, [Vec3::new(1.2, 0.9, 0.04), Vec3::new(1.3, 1.38, 0.1), Vec3::new(3.4, 1.38, 0.1), Vec3::new(3.6, 0.9, 0.04)]);
    quad(&mut m, [Vec3::new(3.6, 0.9, 1.76), Vec3::new(3.4, 1.38, 1.7), Vec3::new(1.3, 1.38, 1.7), Vec3::new(1.2, 0.9, 1.76)]);
    m.begin_object("seats");
    m.set_material(seat);
    for (x, z) in [(1.6, 0.3), (1.6, 1.0), (2.7, 0.3), (2.7, 1.0)] {
        m.cuboid(Vec3::new(x, 0.4, z), Vec3::new(x + 0.5, 0.6, z + 0.5));
        m.cuboid(Vec3::new(x + 0.45, 0.6, z), Vec3::new(x + 0.55, 1.1, z + 0.5));
    }
    m.begin_object("wheels");
    m.set_material(tyre);
    for (x, z) in [(0.6, -0.02), (0.6, 1.57), (3.6, -0.02), (3.6, 1.57)] {
        m.cuboid(Vec3::new(x, 0.0, z), Vec3::new(x + 0.6, 0.6, z + 0.25));
    }
    m.finish()
}

/// Three terraces of 1 m blocks, each 1 m above the last (no stair), with a
/// block house on each, a doorway 1 m wide and 2 m high.
fn blocks() -> Scene {
    let (mut m, mat) = start("blocks");
    m.begin_object("ground");
    m.set_material(mat[1]);
    let size = 24;
    let level = |x: i32, _z: i32| -> i32 { (x / 8).min(2) };
    for x in 0..size {
        for z in 0..size {
            let top = level(x, z) as f32 + 1.0;
            m.cuboid(Vec3::new(x as f32, 0.0, z as f32), Vec3::new(x as f32 + 1.0, top, z as f32 + 1.0));
        }
    }
    m.begin_object("houses");
    m.set_material(mat[0]);
    // Houses 5 × 5 blocks outside, 3 high, a doorway in the south wall.
    for (hx, hz) in [(1, 2), (9, 3), (1, 15), (17, 16)] {
        let base = level(hx + 2, hz + 2) as f32 + 1.0;
        for i in 0..5 {
            for j in 0..5 {
                let edge = i == 0 || i == 4 || j == 0 || j == 4;
                for k in 0..4 {
                    let door = j == 4 && i == 2 && k < 2;
                    let roof = k == 3;
                    if (edge && !door) || roof {
                        let p = Vec3::new((hx + i) as f32, base + k as f32, (hz + j) as f32);
                        m.cuboid(p, p + Vec3::ONE);
                    }
                }
            }
        }
    }
    m.finish()
}

/// A courtyard 12 × 20 m open to the sky, ringed by a 4 m wide arcade of two
/// storeys (4.2 m each), a stair in one corner up to the gallery.
fn atrium() -> Scene {
    let (mut m, mat) = start("atrium");
    let (w, d, aisle, storey, t) = (12.0f32, 20.0f32, 4.0f32, 4.2f32, 0.3f32);
    let (x0, z0, x1, z1) = (-aisle, -aisle, w + aisle, d + aisle);
    m.begin_object("floor");
    m.set_material(mat[1]);
    m.cuboid(Vec3::new(x0 - t, -t, z0 - t), Vec3::new(x1 + t, 0.0, z1 + t));
    m.begin_object("gallery");
    // The gallery floor: a ring over the arcade, with the stair's well.
    m.slabs(&[[x0, z0, x1, 0.0], [x0, d, x1, z1], [x0, 0.0, 0.0, d - 5.0], [w, 0.0, x1, d]], storey - t, storey);
    // The roof over the gallery ring.
    m.set_material(mat[0]);
    m.slabs(&[[x0, z0, x1, 0.0], [x0, d, x1, z1], [x0, 0.0, 0.0, d], [w, 0.0, x1, d]], 2.0 * storey - t, 2.0 * storey);
    m.begin_object("walls");
    m.wall(Wall::along_x(z0 - 0.5 * t, x0, x1), 0.0..2.0 * storey, t, &[]);
    m.wall(Wall::along_x(z1 + 0.5 * t, x0, x1), 0.0..2.0 * storey, t, &[]);
    m.wall(Wall::along_z(x0 - 0.5 * t, z0, z1), 0.0..2.0 * storey, t, &[]);
    m.wall(Wall::along_z(x1 + 0.5 * t, z0, z1), 0.0..2.0 * storey, t, &[]);
    m.begin_object("columns");
    // Columns round the courtyard on both storeys, every 4 m; a parapet above.
    let mut posts = Vec::new();
    for k in 0..=3 {
        posts.push((k as f32 * 4.0, 0.0));
        posts.push((k as f32 * 4.0, d));
    }
    for k in 1..5 {
        posts.push((0.0, k as f32 * 4.0));
        posts.push((w, k as f32 * 4.0));
    }
    for &(x, z) in &posts {
        m.cylinder(Vec3::new(x, 0.0, z), 0.3, 2.0 * storey, 16);
    }
    m.cuboid(Vec3::new(-0.15, storey, -0.15), Vec3::new(w + 0.15, storey + 1.0, 0.15));
    m.cuboid(Vec3::new(-0.15, storey, d - 0.15), Vec3::new(w + 0.15, storey + 1.0, d + 0.15));
    m.cuboid(Vec3::new(w - 0.15, storey, -0.15), Vec3::new(w + 0.15, storey + 1.0, d + 0.15));
    m.cuboid(Vec3::new(-0.15, storey, -0.15), Vec3::new(0.15, storey + 1.0, d - 5.0));
    m.begin_object("stair");
    // In the west aisle's north end, climbing +z: 24 risers of 0.175 m, 0.3 m treads.
    m.set_material(mat[2]);
    let risers = 24;
    let rise = storey / risers as f32;
    for k in 0..risers {
        let z = d - 5.0 - 7.2 + k as f32 * 0.3;
        m.cuboid(Vec3::new(x0 + 0.5, 0.0, z), Vec3::new(-0.5, (k + 1) as f32 * rise, z + 0.3));
    }
    m.finish()
}

/// Six rooms, 5 × 4 m and 2.7 m high, in two rows of three, joined only
/// through doors (a chain, and one across); closed outside.
fn suite() -> Scene {
    let (mut m, mat) = start("suite");
    let (w, d, h, t) = (5.0, 4.0, 2.7, 0.2);
    m.begin_object("shell");
    m.set_material(mat[1]);
    m.cuboid(Vec3::new(-t, -t, -t), Vec3::new(3.0 * w + t, 0.0, 2.0 * d + t));
    m.set_material(mat[0]);
    m.cuboid(Vec3::new(-t, h, -t), Vec3::new(3.0 * w + t, h + t, 2.0 * d + t));
    m.wall(Wall::along_x(-0.5 * t, 0.0, 3.0 * w), 0.0..h, t, &[]);
    m.wall(Wall::along_x(2.0 * d + 0.5 * t, 0.0, 3.0 * w), 0.0..h, t, &[]);
    m.wall(Wall::along_z(-0.5 * t, 0.0, 2.0 * d), 0.0..h, t, &[]);
    m.wall(Wall::along_z(3.0 * w + 0.5 * t, 0.0, 2.0 * d), 0.0..h, t, &[]);
    m.begin_object("partitions");
    // Between the rows: a door from the first room of each row only.
    m.wall(Wall::along_x(d, 0.0, 3.0 * w), 0.0..h, 0.15, &[(0.5 * w, 0.9, 2.1)]);
    // Across each row: doors off the rooms' middle lines.
    for k in 1..3 {
        let x = k as f32 * w;
        m.wall(Wall::along_z(x, 0.0, d), 0.0..h, 0.15, &[(0.8 + k as f32 * 0.6, 0.9, 2.1)]);
        m.wall(Wall::along_z(x, d, 2.0 * d), 0.0..h, 0.15, &[(d + 3.0 - k as f32 * 0.5, 0.9, 2.1)]);
    }
    m.begin_object("furniture");
    m.set_material(mat[2]);
    table(&mut m, Vec2::new(1.5, 1.2), Vec2::new(3.5, 2.4), 0.75);
    m.cuboid(Vec3::new(11.0, 0.0, 4.3), Vec3::new(13.0, 0.5, 6.3));
    m.cuboid(Vec3::new(5.3, 0.0, 0.2), Vec3::new(9.7, 0.9, 0.8));
    m.finish()
}

/// A city of 1 m blocks on a 64 × 64 block ground, in lots of 16 × 16 with
/// streets between: a hill of 1 m terraces (one level a lot), houses of two
/// and three storeys, their storeys joined only by stairs of 1 m blocks (too
/// steep to walk), one house sealed, trees. Every block is a whole cube, as
/// a naive exporter writes them.
fn block_city() -> Scene {
    let (mut m, mat) = start("block_city");
    let lot_level = |lx: i32, lz: i32| -> i32 {
        if lz <= 1 && lx >= 2 {
            lx - 1 + lz
        } else {
            0
        }
    };
    m.begin_object("ground");
    m.set_material(mat[1]);
    for x in 0..64 {
        for z in 0..64 {
            let top = lot_level(x / 16, z / 16) as f32 + 1.0;
            m.cuboid(Vec3::new(x as f32, 0.0, z as f32), Vec3::new(x as f32 + 1.0, top, z as f32 + 1.0));
        }
    }
    for lx in 0..4 {
        for lz in 0..4 {
            let k = lx + 4 * lz;
            let (x0, z0, base) = (lx * 16 + 5, lz * 16 + 5, lot_level(lx, lz) + 1);
            if k % 5 == 4 {
                m.begin_object("trees");
                m.set_material(mat[2]);
                for (tx, tz) in [(x0 + 2, z0 + 2), (x0 + 7, z0 + 3), (x0 + 4, z0 + 8)] {
                    let (tx, tz, b) = (tx as f32, tz as f32, base as f32);
                    m.cuboid(Vec3::new(tx, b, tz), Vec3::new(tx + 1.0, b + 4.0, tz + 1.0));
                    m.cuboid(Vec3::new(tx - 1.0, b + 4.0, tz - 1.0), Vec3::new(tx + 2.0, b + 6.0, tz + 2.0));
                }
                continue;
            }
            m.begin_object("houses");
            m.set_material(mat[0]);
            block_house(&mut m, (x0, z0, base), (8 + k % 3, 8 + (2 * k) % 3), 2 + k % 2, k == 6);
        }
    }
    m.finish()
}

/// A house of 1 m blocks at (x0, z0) on ground level `base`, `size` blocks
/// outside, storeys 4 blocks high (3 of air, a slab), a door in the south
/// wall and windows unless `sealed`, 1 m block stairs up through each slab.
fn block_house(m: &mut MeshBuilder, (x0, z0, base): (i32, i32, i32), (w, d): (i32, i32), storeys: i32, sealed: bool) {
    let block = |m: &mut MeshBuilder, x: i32, y: i32, z: i32| {
        let p = Vec3::new(x as f32, y as f32, z as f32);
        m.cuboid(p, p + Vec3::ONE);
    };
    for s in 0..storeys {
        let floor = base + 4 * s;
        for x in x0..x0 + w {
            for z in z0..z0 + d {
                let wall = x == x0 || x == x0 + w - 1 || z == z0 || z == z0 + d - 1;
                let door = !sealed && s == 0 && z == z0 + d - 1 && x == x0 + w / 2;
                let corner = (x == x0 || x == x0 + w - 1) && (z == z0 || z == z0 + d - 1);
                let window = !sealed && !corner && (x + z) % 3 == 0;
                for k in 0..3 {
                    let open = (door && k < 2) || (window && k == 1);
                    if wall && !open {
                        block(m, x, floor + k, z);
                    }
                }
                // The slab above, with the stairwell over the stair.
                let well = s + 1 < storeys && (x0 + 2..x0 + 5).contains(&x) && (z0 + 1..z0 + 3).contains(&z);
                if !well {
                    block(m, x, floor + 3, z);
                }
            }
        }
        if s + 1 < storeys {
            // Three steps of 1 m under the well, the last 1 m below the slab's top.
            for i in 0..3 {
                for y in 0..=i {
                    block(m, x0 + 2 + i, floor + y, z0 + 1);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_awkward_scene_is_valid_and_in_its_unit() {
        for name in AWKWARD {
            let (scene, unit) = awkward(name).unwrap();
            scene.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(scene.scale_source, ScaleSource::Guessed);
            let tall_m = scene.bounds().extent().y * unit;
            assert!((1.0..20.0).contains(&tall_m), "{name} is {tall_m} m tall");
        }
        assert!(awkward("nothing").is_none());
    }
}
