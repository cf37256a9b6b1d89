//! `maze`: a roofed labyrinth of narrow 2 m corridors, carved by a seeded
//! depth-first search so every cell is reachable by exactly one route. It
//! stresses path finding: neighbouring probes are often far apart by corridor.

use crate::mesh::{MeshBuilder, Wall};
use crate::scene::{Light, Material, Scene};
use crate::textures;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

const CELL: f32 = 2.0;
const HEIGHT: f32 = 3.0;
const WALL_T: f32 = 0.2;

/// A `cells`×`cells` maze (8 by default).
pub fn maze(seed: u64, cells: usize) -> Scene {
    let n = cells.max(2);
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x6d61_7a65);
    // open_east[i][j]: no wall between (i, j) and (i+1, j); open_south likewise in j.
    let mut open_east = vec![vec![false; n]; n];
    let mut open_south = vec![vec![false; n]; n];
    let mut visited = vec![vec![false; n]; n];
    let mut stack = vec![(0usize, 0usize)];
    visited[0][0] = true;
    while let Some(&(i, j)) = stack.last() {
        let mut next = Vec::new();
        if i > 0 && !visited[i - 1][j] {
            next.push((i - 1, j));
        }
        if i + 1 < n && !visited[i + 1][j] {
            next.push((i + 1, j));
        }
        if j > 0 && !visited[i][j - 1] {
            next.push((i, j - 1));
        }
        if j + 1 < n && !visited[i][j + 1] {
            next.push((i, j + 1));
        }
        if next.is_empty() {
            stack.pop();
            continue;
        }
        let (a, b) = next[rng.random_range(0..next.len())];
        match (a as isize - i as isize, b as isize - j as isize) {
            (1, 0) => open_east[i][j] = true,
            (-1, 0) => open_east[a][b] = true,
            (0, 1) => open_south[i][j] = true,
            _ => open_south[a][b] = true,
        }
        visited[a][b] = true;
        stack.push((a, b));
    }

    let mut m = MeshBuilder::new("maze");
    let tex = m.add_texture(textures::bricks(seed as u32));
    let floor_tex = m.add_texture(textures::planks(seed as u32));
    let wall = m.add_material(Material { base_color_texture: Some(tex), ..Material::diffuse("maze_bricks", [1.0; 3]) });
    let floor = m.add_material(Material { base_color_texture: Some(floor_tex), ..Material::diffuse("maze_floor", [1.0; 3]) });
    let ceiling = m.add_material(Material::diffuse("maze_ceiling", [0.85; 3]));
    let size = n as f32 * CELL;
    m.begin_object("floor");
    m.set_material(floor);
    m.cuboid(Vec3::new(-WALL_T, -0.2, -WALL_T), Vec3::new(size + WALL_T, 0.0, size + WALL_T));
    m.begin_object("ceiling");
    m.set_material(ceiling);
    m.cuboid(Vec3::new(-WALL_T, HEIGHT, -WALL_T), Vec3::new(size + WALL_T, HEIGHT + 0.2, size + WALL_T));
    m.begin_object("walls");
    m.set_material(wall);
    m.wall(Wall::along_x(0.0, 0.0, size), 0.0..HEIGHT, WALL_T, &[]);
    m.wall(Wall::along_z(0.0, 0.0, size), 0.0..HEIGHT, WALL_T, &[]);
    // Closed cell sides in a row along a line make one wall: walls meeting end
    // to end would overlap, their faces coincident.
    for i in 0..n {
        let line = (i + 1) as f32 * CELL;
        let mut runs = |closed: &dyn Fn(usize) -> bool, along_x: bool| {
            let mut j = 0;
            while j < n {
                let start = j;
                while j < n && closed(j) {
                    j += 1;
                }
                if j > start {
                    m.wall(Wall::new(along_x, line, start as f32 * CELL, j as f32 * CELL), 0.0..HEIGHT, WALL_T, &[]);
                }
                j += 1;
            }
        };
        runs(&|j| !open_east[i][j], false);
        runs(&|j| !open_south[j][i], true);
    }
    for i in (0..n).step_by(3) {
        for j in (0..n).step_by(3) {
            let position = Vec3::new((i as f32 + 0.5) * CELL, HEIGHT - 0.3, (j as f32 + 0.5) * CELL);
            m.add_light(Light::Point { position, intensity: Vec3::splat(8.0) });
        }
    }
    m.finish()
}
