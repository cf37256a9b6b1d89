//! The export read back the way the simulator's loader and renderer read a
//! scan: the scan list, the connectivity file (pose row-major, transposed
//! into a column-major matrix; position its last column), the skybox strip
//! sliced into GL cube faces by column, and a view at (heading, elevation)
//! drawn as the simulator does (camera looking down −Z, turned by
//! Rx(−90° + elevation) · Rz(180° + heading), the cube turned by the pose).

use super::*;
use exploremaps_format::{direction, CubeLevel, Path as GraphPath, PathAssets, Probe, SceneInfo, CUBE_FACES};
use glam::{Mat3, Mat4, Vec3};

const FACE: u32 = 64;
const MPU: f32 = 0.5;

/// A colour that says which way it was seen in.
fn colour_of(d: Vec3) -> [u8; 3] {
    let d = d.normalize();
    [0, 1, 2].map(|i| ((d[i] * 0.5 + 0.5) * 255.0).round() as u8)
}

fn direction_of(c: [u8; 3]) -> Vec3 {
    Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32).map(|v| v / 255.0 * 2.0 - 1.0).normalize()
}

/// The distance every probe's depth gives toward `d` (scene units).
fn distance(d: Vec3) -> f32 {
    3.0 + d.normalize().y
}

/// Two probes joined by a path, faces coloured by direction, depth by [`distance`].
fn bundle(dir: &Path) -> Graph {
    let mut graph = Graph::new(SceneInfo {
        name: "two rooms".into(),
        source: "test".into(),
        triangles: 1,
        bounds_min: [-10.0; 3],
        bounds_max: [10.0; 3],
        metres_per_unit: MPU,
        scale_source: "file".into(),
        space: None,
        near_distance: None,
        eye_height_m: Some(1.5),
        credits: vec![],
    });
    for (id, position) in [[0.0, 3.0, 0.0], [6.0, 3.0, -2.0], [0.0, 3.0, 30.0]].into_iter().enumerate() {
        let faces = CUBE_FACES.map(|f| format!("probes/{id}/{FACE}_{f}.jpg"));
        for (k, name) in faces.iter().enumerate() {
            let image = image::RgbImage::from_fn(FACE, FACE, |x, y| {
                image::Rgb(colour_of(Vec3::from(cube_direction(k, (x as f32 + 0.5) / FACE as f32, (y as f32 + 0.5) / FACE as f32))))
            });
            std::fs::create_dir_all(dir.join(format!("probes/{id}"))).unwrap();
            image.save(dir.join(name)).unwrap();
        }
        let cells = 8;
        let corners = (0..6 * (cells + 1) * (cells + 1))
            .map(|i| Some(distance(Vec3::from(exploremaps_format::depthcube::corner_direction(cells, i as usize)))));
        let cube = DepthCube::new(cells, 0.01, 100.0, &corners.collect::<Vec<_>>());
        std::fs::write(dir.join(format!("probes/{id}/depth.emdc")), cube.encode()).unwrap();
        graph.probes.push(Probe {
            id: id as u32,
            position,
            cluster: None,
            preferred_directions: vec![],
            user_placed: false,
            assets: exploremaps_format::ProbeAssets {
                cube_levels: vec![CubeLevel { size: FACE, faces }],
                depth: Some(format!("probes/{id}/depth.emdc")),
                ..Default::default()
            },
        });
    }
    graph.paths.push(GraphPath {
        id: 0,
        from: 0,
        to: 1,
        polyline: vec![[0.0, 3.0, 0.0], [6.0, 3.0, -2.0]],
        length: 6.3,
        duration_s: 2.0,
        camera: vec![],
        assets: PathAssets::default(),
    });
    graph
}

#[test]
fn the_simulator_reads_the_scan_back_facing_the_viewers_yaw_with_depth_in_quarter_millimetres() {
    let dir = tempfile::tempdir().unwrap();
    let graph = bundle(&dir.path().join("b"));
    let out = dir.path().join("m3d");
    let report = export(&dir.path().join("b"), &graph, &out, |_, _| {}).unwrap();
    assert_eq!((report.viewpoints, report.with_depth), (3, 3));
    // The scan list and the connectivity file.
    let scans = std::fs::read_to_string(out.join("connectivity/scans.txt")).unwrap();
    let scan: Vec<&str> = scans.split_whitespace().collect();
    assert_eq!(scan, ["two_rooms"]);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("connectivity/two_rooms_connectivity.json")).unwrap()).unwrap();
    let viewpoints = json.as_array().unwrap();
    assert_eq!(viewpoints.len(), 3);
    let flags = |v: &serde_json::Value, key: &str| v[key].as_array().unwrap().iter().map(|b| b.as_bool().unwrap()).collect::<Vec<_>>();
    assert_eq!(flags(&viewpoints[0], "unobstructed"), [false, true, false]);
    assert_eq!(flags(&viewpoints[1], "unobstructed"), [true, false, false]);
    // Probe 2 lies 30 units away, past the 4 units the depth sees: not visible.
    assert_eq!(flags(&viewpoints[0], "visible"), [false, true, false]);
    for (probe, v) in graph.probes.iter().zip(viewpoints) {
        assert!(v["included"].as_bool().unwrap() && v["height"].as_f64() == Some(1.5));
        let id = v["image_id"].as_str().unwrap();
        assert!(id.len() == 32 && id.chars().all(|c| c.is_ascii_hexdigit()), "{id}");
        // glm reads the 16 numbers column-major; the loader transposes them.
        let pose: Vec<f32> = v["pose"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect();
        let m = Mat4::from_cols_array(&pose.clone().try_into().unwrap()).transpose();
        let position = m.w_axis.truncate();
        let rotation = Mat3::from_mat4(m);
        assert!((rotation.determinant() - 1.0).abs() < 1e-5, "a rotation");
        let p = Vec3::from(probe.position) * MPU;
        let expected = Vec3::new(p.x, -p.z, p.y);
        assert!(position.distance(expected) < 1e-4 && position.z == probe.position[1] * MPU, "metres, +Z up: {position}");
        // The skybox strip sliced as the loader does: +X column 2, −X 4, +Y 0, −Y 5, +Z 1, −Z 3.
        let skyboxes = out.join("data/v1/scans/two_rooms/matterport_skybox_images");
        let strip = image::open(skyboxes.join(format!("{id}_skybox_small.jpg"))).unwrap().to_rgb8();
        let depth = image::open(skyboxes.join(format!("{id}_skybox_depth_small.png"))).unwrap().to_luma16();
        let w = strip.width() / 6;
        assert_eq!((w, strip.height(), depth.width(), depth.height()), (FACE, FACE, 6 * FACE, FACE));
        let column = [2, 4, 0, 5, 1, 3];
        for (heading, elevation) in [(0.0f32, 0.0f32), (0.7, 0.0), (-2.0, 0.4), (3.0, -0.6), (1.2, 1.3)] {
            // The simulator's view: camera space to world is (Rx · Rz)⁻¹, world to the cube's frame rotation⁻¹.
            let view = Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2 + elevation) * Mat4::from_rotation_z(std::f32::consts::PI + heading);
            let world = view.inverse().transform_vector3(Vec3::NEG_Z);
            let sky = rotation.inverse() * world;
            let (face, s, t) = cube_face_of(sky.into());
            let (x, y) = (column[face] * w + ((s * w as f32) as u32).min(w - 1), ((t * w as f32) as u32).min(w - 1));
            let seen = direction_of(strip.get_pixel(x, y).0);
            let wanted = Vec3::from(direction(heading, elevation));
            assert!(seen.angle_between(wanted) < 0.06, "heading {heading}, elevation {elevation}: the simulator sees {seen}, the viewer {wanted}");
            // The simulator returns its frame bottom row first: the top of the
            // image it gives is the bottom of its framebuffer, below the centre.
            let top = rotation.inverse() * view.inverse().transform_vector3(Vec3::new(0.0, -0.3, -1.0));
            let (face, s, t) = cube_face_of(top.into());
            let (tx, ty) = (column[face] * w + ((s * w as f32) as u32).min(w - 1), ((t * w as f32) as u32).min(w - 1));
            let above = direction_of(strip.get_pixel(tx, ty).0);
            assert!(
                above.y > seen.y + 0.1 || elevation > 1.2,
                "heading {heading}, elevation {elevation}: the image's top shows {above}, above {seen}"
            );
            // Its right is the viewer's right (yaw grows to the right).
            let right = rotation.inverse() * view.inverse().transform_vector3(Vec3::new(0.3, 0.0, -1.0));
            let (face, s, t) = cube_face_of(right.into());
            let (rx, ry) = (column[face] * w + ((s * w as f32) as u32).min(w - 1), ((t * w as f32) as u32).min(w - 1));
            let rightward = direction_of(strip.get_pixel(rx, ry).0);
            let turn = rightward.x * seen.z - rightward.z * seen.x;
            assert!(turn < 0.0 || elevation > 1.2, "heading {heading}: the image's right shows {rightward}, right of {seen}");
            let metres = depth.get_pixel(x, y).0[0] as f32 / 4000.0;
            let true_metres = distance(wanted) * MPU;
            assert!((metres - true_metres).abs() < 0.02 * true_metres, "heading {heading}: depth {metres} m against {true_metres} m");
        }
    }
    // Its navigation's heading toward a neighbour, from the positions ((sin h, cos h) along the
    // floor), is the viewer's yaw toward it, where the images show it.
    let position = |v: &serde_json::Value| Vec3::new(v["pose"][3].as_f64().unwrap() as f32, v["pose"][7].as_f64().unwrap() as f32, 0.0);
    let toward = position(&viewpoints[1]) - position(&viewpoints[0]);
    let heading = toward.x.atan2(toward.y);
    let d = Vec3::from(graph.probes[1].position) - Vec3::from(graph.probes[0].position);
    let (yaw, _) = exploremaps_format::yaw_pitch(d.into());
    assert!((heading - yaw).abs() < 1e-4, "navigation's heading {heading} against the viewer's yaw {yaw}");
    // Again into the same folder: it is this command's, so it is replaced.
    export(&dir.path().join("b"), &graph, &out, |_, _| {}).unwrap();
}

#[test]
fn a_folder_the_export_did_not_write_is_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let graph = bundle(&dir.path().join("b"));
    let out = dir.path().join("mine");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "keep").unwrap();
    assert!(matches!(export(&dir.path().join("b"), &graph, &out, |_, _| {}), Err(TourError::Occupied(_))));
    assert_eq!(std::fs::read_to_string(out.join("notes.txt")).unwrap(), "keep");
}
