//! `exploremaps export --to matterport3d`: the bundle as one scan of the
//! Matterport3D Simulator (MatterSim), the panorama graph that
//! vision-and-language navigation work runs on. Laid out as the simulator
//! reads it by default (`./connectivity`, `./data/v1/scans`):
//!
//! - `connectivity/scans.txt`: the scan's name;
//! - `connectivity/<scan>_connectivity.json`: per probe `image_id`, `pose`
//!   (row-major 4 × 4, the skybox's frame to the world's, metres, +Z up),
//!   `included`, `visible` and `unobstructed` (a path joins them) over all
//!   probes, `height` (the camera above the floor, metres);
//! - `data/v1/scans/<scan>/matterport_skybox_images/<image_id>_skybox_small.jpg`:
//!   the six faces of the probe's smallest cube level side by side in the
//!   order the simulator slices them (+Y, +Z, +X, −Z, −X, −Y of the skybox's
//!   frame, each a GL cube-map face as the bundle's are), and where the
//!   bundle has depth `<image_id>_skybox_depth_small.png` (16-bit, distance
//!   from the camera in quarter millimetres, 0 where nothing is hit).
//!
//! The skybox is the bundle's cube turned inside out (`mirrored`); with the
//! pose, the simulator's heading is the viewer's yaw (0 looking down the
//! bundle's −Z, growing to the right), its elevation the pitch (positive
//! looks up), its images upright, and its neighbours' headings where they
//! are seen.

use super::{into_folder, io, read_faces, write, TourError, MARKER};
use exploremaps_format::depthcube::DepthCube;
use exploremaps_format::{cube_direction, cube_face_of, Graph};
use std::path::Path;

/// Bundle faces (in `CUBE_FACES` order) in the simulator's column order.
const COLUMNS: [usize; 6] = [2, 4, 0, 5, 1, 3];
/// Depth units a metre in the simulator's depth skyboxes.
const DEPTH_UNITS_A_METRE: f32 = 4000.0;
/// Rows of the bundle-to-world rotation: world x = x, world y = −z, world
/// z = y (+Z up; the simulator's heading 0 toward +Y is the bundle's −Z).
const ROTATION: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];

/// What the export wrote.
pub struct SimulatorReport {
    pub scan: String,
    pub viewpoints: usize,
    pub with_depth: usize,
}

/// A probe's viewpoint id: 32 hexadecimal digits, as the scans' are.
pub fn image_id(probe: u32) -> String {
    format!("{probe:032x}")
}

/// Writes the scan into `out` (see the module header), whole or not at all.
pub fn export(bundle: &Path, graph: &Graph, out: &Path, mut progress: impl FnMut(usize, usize)) -> Result<SimulatorReport, TourError> {
    into_folder(out, |dir| write_scan(bundle, graph, dir, &mut progress))
}

fn write_scan(bundle: &Path, graph: &Graph, out: &Path, progress: &mut impl FnMut(usize, usize)) -> Result<SimulatorReport, TourError> {
    let scan: String = graph.scene.name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    let mpu = graph.scene.metres_per_unit;
    let height = graph.scene.eye_height_m.unwrap_or(1.6);
    let n = graph.probes.len();
    let mut joined = vec![vec![false; n]; n];
    for p in &graph.paths {
        joined[p.from as usize][p.to as usize] = true;
        joined[p.to as usize][p.from as usize] = true;
    }
    let skyboxes = format!("data/v1/scans/{scan}/matterport_skybox_images");
    let mut viewpoints = Vec::with_capacity(n);
    let mut with_depth = 0;
    for (i, probe) in graph.probes.iter().enumerate() {
        progress(i, n);
        let level = probe.assets.cube_levels.first().ok_or(TourError::NotRendered(probe.id))?;
        let faces = read_faces(bundle, level)?;
        let size = faces[0].width();
        let mut strip = image::RgbImage::new(6 * size, size);
        for (column, &face) in COLUMNS.iter().enumerate() {
            for y in 0..size {
                for x in 0..size {
                    // Pixel centres land on pixel centres: an exact copy, turned.
                    let (k, s, t) = cube_face_of(mirrored(sky_direction(face, x, y, size)));
                    let (fx, fy) = (((s * size as f32) as u32).min(size - 1), ((t * size as f32) as u32).min(size - 1));
                    strip.put_pixel(column as u32 * size + x, y, *faces[k].get_pixel(fx, fy));
                }
            }
        }
        let id = image_id(probe.id);
        write(out, &format!("{skyboxes}/{id}_skybox_small.jpg"), &crate::files::jpeg(&strip, 90))?;
        let depth = match &probe.assets.depth {
            Some(file) => {
                let path = bundle.join(file);
                let bytes = std::fs::read(&path).map_err(io(&path))?;
                Some(DepthCube::decode(&bytes).map_err(|source| TourError::Depth { path: path.display().to_string(), source })?)
            }
            None => None,
        };
        if let Some(cube) = &depth {
            write(out, &format!("{skyboxes}/{id}_skybox_depth_small.png"), &depth_strip(cube, size, mpu))?;
            with_depth += 1;
        }
        let here = glam::Vec3::from(probe.position);
        let visible: Vec<bool> = graph
            .probes
            .iter()
            .enumerate()
            .map(|(j, other)| {
                let d = glam::Vec3::from(other.position) - here;
                joined[i][j] || (j != i && depth.as_ref().is_some_and(|c| distance_toward(c, d.into()).is_none_or(|hit| hit >= 0.98 * d.length())))
            })
            .collect();
        viewpoints.push(serde_json::json!({
            "image_id": id,
            "pose": pose(probe.position, mpu),
            "included": true,
            "visible": visible,
            "unobstructed": joined[i],
            "height": height,
        }));
    }
    progress(n, n);
    write(out, "connectivity/scans.txt", format!("{scan}\n").as_bytes())?;
    let json = serde_json::to_string_pretty(&viewpoints).expect("plain values");
    write(out, &format!("connectivity/{scan}_connectivity.json"), json.as_bytes())?;
    write(out, MARKER, serde_json::json!({ "matterport3d": scan }).to_string().as_bytes())?;
    Ok(SimulatorReport { scan, viewpoints: n, with_depth })
}

/// The pose of a probe at `position` (scene units): [`ROTATION`], and the
/// position turned the same way, in metres; row-major.
fn pose(position: [f32; 3], mpu: f32) -> Vec<f32> {
    let p = position.map(|c| c * mpu);
    let mut out = Vec::with_capacity(16);
    for row in ROTATION {
        out.extend(row);
        out.push(row[0] * p[0] + row[1] * p[1] + row[2] * p[2]);
    }
    out.extend([0.0, 0.0, 0.0, 1.0]);
    out
}

/// The distance (scene units) the cube sees toward `d`, bilinear between
/// its lattice corners (nearest where one of them sees nothing).
pub(crate) fn distance_toward(cube: &DepthCube, d: [f32; 3]) -> Option<f32> {
    let (face, s, t) = cube_face_of(d);
    let (n, side) = (cube.size as f32, cube.side());
    let (x, y) = (s * n, t * n);
    let (x0, y0) = ((x.floor() as usize).min(side - 2), (y.floor() as usize).min(side - 2));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let at = |cx: usize, cy: usize| cube.distance(cube.codes[face * side * side + cy * side + cx]);
    let corners = [at(x0, y0), at(x0 + 1, y0), at(x0, y0 + 1), at(x0 + 1, y0 + 1)];
    match corners {
        [Some(a), Some(b), Some(c), Some(e)] => Some((a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + e * fx) * fy),
        _ => at(x.round() as usize, y.round() as usize),
    }
}

/// The direction through the centre of pixel (x, y) of face `face` (`size`²).
fn sky_direction(face: usize, x: u32, y: u32, size: u32) -> [f32; 3] {
    cube_direction(face, (x as f32 + 0.5) / size as f32, (y as f32 + 0.5) / size as f32)
}

/// The bundle's direction shown through skybox direction `d`: the opposite
/// one. The simulator's camera at heading h and elevation e looks toward
/// (−sin h·cos e, −cos h·cos e, −sin e) of its world, the reverse of the
/// heading its navigation uses, and it reads its frame back bottom row first
/// (so shows it upside down); with the skybox the bundle's cube turned inside
/// out, one rigid pose serves both (the tests replay its arithmetic).
fn mirrored([x, y, z]: [f32; 3]) -> [f32; 3] {
    [-x, -y, -z]
}

/// The depth skybox: six `size`² faces in [`COLUMNS`] order, 16-bit PNG.
fn depth_strip(cube: &DepthCube, size: u32, mpu: f32) -> Vec<u8> {
    let mut strip = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(6 * size, size);
    for (column, &face) in COLUMNS.iter().enumerate() {
        for y in 0..size {
            for x in 0..size {
                let d = mirrored(sky_direction(face, x, y, size));
                let units = distance_toward(cube, d).map_or(0.0, |m| (m * mpu * DEPTH_UNITS_A_METRE).round().clamp(1.0, 65535.0));
                strip.put_pixel(column as u32 * size + x, y, image::Luma([units as u16]));
            }
        }
    }
    let mut png = Vec::new();
    image::DynamicImage::ImageLuma16(strip).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).expect("PNG into memory");
    png
}

#[cfg(test)]
mod tests;
