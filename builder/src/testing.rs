//! Scenes with exact answers for the stage tests.

use exploremaps_scenes::mesh::{MeshBuilder, Wall};
use exploremaps_scenes::Scene;
use glam::Vec3;

/// Closed rooms in a row along x, each `w` wide, `h` high and `d` deep, sharing
/// 0.2-thick walls, with a door (1.2 × 2.2, at z = d/2) in the walls listed in
/// `doors` (0 = the west outer wall, 1 = between rooms 0 and 1, …). Floor and
/// roof slabs end flush with the walls' outer faces.
pub fn rooms(count: usize, w: f32, h: f32, d: f32, doors: &[usize]) -> Scene {
    rooms_with(count, w, h, d, doors, |_| {})
}

/// [`rooms`] with more geometry added by `furnish`.
pub fn rooms_with(count: usize, w: f32, h: f32, d: f32, doors: &[usize], furnish: impl FnOnce(&mut MeshBuilder)) -> Scene {
    let mut m = MeshBuilder::new("rooms");
    let (t, x1) = (0.2, count as f32 * w);
    let e = 0.5 * t;
    m.cuboid(Vec3::new(-e, -t, -e), Vec3::new(x1 + e, 0.0, d + e));
    m.cuboid(Vec3::new(-e, h, -e), Vec3::new(x1 + e, h + t, d + e));
    m.wall(Wall::along_x(0.0, 0.0, x1), 0.0..h, t, &[]);
    m.wall(Wall::along_x(d, 0.0, x1), 0.0..h, t, &[]);
    for k in 0..=count {
        let door: &[(f32, f32, f32)] = if doors.contains(&k) { &[(0.5 * d, 1.2, 2.2)] } else { &[] };
        m.wall(Wall::along_z(k as f32 * w, 0.0, d), 0.0..h, t, door);
    }
    furnish(&mut m);
    m.finish()
}

/// A closed 10 × 3 × 6 room (x, y, z) with a round pillar of `radius` at (5, 3).
pub fn pillar_room(radius: f32) -> Scene {
    let mut m = MeshBuilder::new("pillar");
    let (w, h, d, t) = (10.0, 3.0, 6.0, 0.2);
    let e = 0.5 * t;
    m.cuboid(Vec3::new(-e, -t, -e), Vec3::new(w + e, 0.0, d + e));
    m.cuboid(Vec3::new(-e, h, -e), Vec3::new(w + e, h + t, d + e));
    for (along_x, line, len) in [(true, 0.0, w), (true, d, w), (false, 0.0, d), (false, w, d)] {
        m.wall(Wall::new(along_x, line, 0.0, len), 0.0..h, t, &[]);
    }
    m.cylinder(Vec3::new(5.0, 0.0, 3.0), radius, h, 32);
    m.finish()
}

/// A third-party test scene in `../shared/scenes` (next to the checkout), by
/// its path there; `None`, saying SKIPPED, where it is absent.
pub fn shared_scene(relative: &str) -> Option<std::path::PathBuf> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes").join(relative);
    if path.exists() {
        Some(path)
    } else {
        eprintln!("SKIPPED: {} is absent (the shared test scenes are not next to this checkout)", path.display());
        None
    }
}
