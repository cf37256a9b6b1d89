//! Loader tests: tiny handmade files with exact answers, every kind of bad
//! input, round trips through the exporters, and the shared real scenes.

use super::*;
use exploremaps_scenes::{AlphaMode, BuiltIn, Light};
use rand::{Rng, SeedableRng};
use std::fs;

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    if let Some(parent) = path.parent() {
        fs::create_dir_all(parent).unwrap();
    }
    fs::write(&path, bytes).unwrap();
    path
}

fn load_default(path: &Path) -> Result<Scene, LoadError> {
    load(path, &LoadOptions::default())
}

/// The error text, which must name the file.
fn error_text(path: &Path) -> String {
    let text = load_default(path).expect_err("load should fail").to_string();
    assert!(text.contains(&path.display().to_string()), "error does not name the file: {text}");
    text
}

const QUAD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";

#[test]
fn obj_polygon_is_fan_triangulated_without_normals() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_default(&write(dir.path(), "quad.obj", QUAD_OBJ.as_bytes())).unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert!(scene.normals.is_empty());
    assert!((scene.total_area() - 1.0).abs() < 1e-6);
    assert_eq!(scene.scale_source, ScaleSource::Guessed);
    assert_eq!(scene.metres_per_unit, 1.0);
}

#[test]
fn obj_faces_with_and_without_normals_and_uvs_load_with_geometric_normals() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\nf 3 2 4\nf 1 2 5\n";
    let scene = load_default(&write(dir.path(), "mixed.obj", obj.as_bytes())).unwrap();
    assert_eq!(scene.triangles.len(), 3);
    assert!(scene.normals.is_empty(), "geometric normals are used");
    assert!(scene.validate().is_ok());
}

#[test]
fn obj_negative_indices_refer_backwards() {
    let dir = tempfile::tempdir().unwrap();
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 2\nv 1 0 2\nv 0 1 2\nf -3 -2 -1\n";
    let scene = load_default(&write(dir.path(), "neg.obj", text.as_bytes())).unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert_eq!(scene.triangle(1)[0], Vec3::new(0.0, 0.0, 2.0));
}

#[test]
fn obj_texture_path_case_and_cutout_and_emission() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbaImage::from_pixel(4, 4, image::Rgba([200, 100, 50, 255]));
    img.save(dir.path().join("Tex").join("WALL.png")).unwrap_or_else(|_| {
        fs::create_dir_all(dir.path().join("Tex")).unwrap();
        img.save(dir.path().join("Tex").join("WALL.png")).unwrap();
    });
    let mask = image::GrayImage::from_pixel(2, 2, image::Luma([0]));
    mask.save(dir.path().join("mask.png")).unwrap();
    let mtl = "newmtl wall\nKd 0.5 0.5 0.5\nmap_Kd tex\\wall.PNG\nnewmtl leaf\nKd 0 1 0\nmap_d MASK.png\nnewmtl lamp\nKd 1 1 1\nKe 4 4 2\n";
    write(dir.path(), "m.mtl", mtl.as_bytes());
    let obj = format!(
        "mtllib m.mtl\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n{}usemtl wall\nf 1/1 2/2 3/3\nusemtl leaf\nf 1/1 3/3 4/4\nusemtl lamp\nf 1 2 4\n",
        QUAD_OBJ.replace("f 1 2 3 4\n", "")
    );
    let scene = load_default(&write(dir.path(), "t.obj", obj.as_bytes())).unwrap();
    let by_name = |n: &str| scene.materials.iter().find(|m| m.name == n).unwrap();
    let wall = by_name("wall");
    let t = wall.base_color_texture.expect("texture found despite case and backslash");
    assert_eq!(scene.textures[t].image.get_pixel(0, 0).0, [200, 100, 50, 255]);
    let leaf = by_name("leaf");
    assert_eq!(leaf.alpha_mode, AlphaMode::Mask { cutoff: 0.5 });
    assert_eq!(scene.textures[leaf.base_color_texture.unwrap()].image.get_pixel(1, 1).0[3], 0);
    assert_eq!(by_name("lamp").emissive, Vec3::new(4.0, 4.0, 2.0));
    // The image convention: OBJ's v = 1 at the top becomes 0.
    assert_eq!(scene.uvs[2], glam::Vec2::new(1.0, 0.0));
}

#[test]
fn undecodable_texture_warns_and_keeps_the_colour() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "broken.png", b"\x89PNG\r\n\x1a\nthis is not a png");
    write(dir.path(), "m.mtl", b"newmtl red\nKd 1 0 0\nmap_Kd broken.png\n");
    let path = write(dir.path(), "t.obj", format!("mtllib m.mtl\nusemtl red\n{QUAD_OBJ}").as_bytes());
    let scene = load_default(&path).unwrap();
    let red = &scene.materials[scene.triangle_material[0] as usize];
    assert_eq!(red.base_color_texture, None);
    assert_eq!(red.base_color, [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(scene.stats.missing_textures, 1);
}

#[test]
fn short_mtl_colours_are_completed_instead_of_crashing_tobj() {
    // tobj 4.0.5 panics on a colour with fewer than three numbers.
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.mtl", b"newmtl grey\nKa 0.1\nKd 0.5 0.25\nnewmtl lamp\nKd 0.2\nKe 3\n");
    let path = write(
        dir.path(),
        "t.obj",
        format!("mtllib m.mtl\n{}usemtl grey\nf 1 2 3\nusemtl lamp\nf 1 3 4\n", QUAD_OBJ.replace("f 1 2 3 4\n", "")).as_bytes(),
    );
    let scene = load_default(&path).unwrap();
    let material = |t: usize| &scene.materials[scene.triangle_material[t] as usize];
    assert_eq!(material(0).base_color, [0.5, 0.25, 0.25, 1.0], "two numbers: the last repeated");
    assert_eq!(material(1).base_color, [0.2, 0.2, 0.2, 1.0], "one number: grey, as the MTL format says");
    assert_eq!(material(1).emissive, glam::Vec3::splat(3.0));
}

#[test]
fn missing_material_library_warns_and_loads_grey() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "t.obj", format!("mtllib nowhere.mtl\nusemtl x\n{QUAD_OBJ}").as_bytes());
    let scene = load_default(&path).unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert_eq!(scene.materials[scene.triangle_material[0] as usize].name, "default");
}

#[test]
fn nan_and_degenerate_triangles_are_dropped_and_counted() {
    let dir = tempfile::tempdir().unwrap();
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 2 5\n";
    let scene = load_default(&write(dir.path(), "nan.obj", text.as_bytes())).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(scene.stats.dropped_non_finite, 1);
    assert_eq!(scene.stats.dropped_degenerate, 1);
}

#[test]
fn bad_inputs_give_clear_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let missing = d.join("missing.obj");
    assert!(error_text(&missing).contains("cannot read"));
    assert!(error_text(&write(d, "scene.fbx", b"whatever")).contains(".obj"));
    assert!(error_text(&write(d, "binary.obj", &[0u8, 159, 146, 150, 0, 1, 2, 3])).contains("binary data"));
    assert!(error_text(&write(d, "binary.ply", &[0u8, 159, 146, 150, 0, 1, 2, 3])).contains("not a valid PLY"));
    assert!(error_text(&write(d, "binary.gltf", &[0u8, 159, 146, 150, 0, 1, 2, 3])).contains("not a valid glTF"));
    assert!(error_text(&write(d, "range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")).contains("out of bounds"));
    assert!(error_text(&write(d, "empty.obj", b"# nothing here\nv 0 0 0\n")).contains("no usable triangles"));
    assert!(error_text(&write(d, "flat.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")).contains("degenerate"));
    let ply_range = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
    assert!(error_text(&write(d, "range.ply", ply_range.as_bytes())).contains("vertex index 7"));
}

#[test]
fn truncated_files_are_errors_or_shorter_scenes_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A text OBJ cut inside a number: an error naming the file.
    assert!(error_text(&write(d, "cut.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 1.\nf 1 2 3\nf 1 2")).contains("OBJ"));
    // PLY announcing more data than it has.
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n";
    assert!(error_text(&write(d, "cut.ply", ply.as_bytes())).contains("PLY"));
    // A GLB cut in half, at every eighth of its length.
    let glb = d.join("whole.glb");
    crate::scene_io::write::write_glb(&BuiltIn::Pillars.generate(0), &glb).unwrap();
    let bytes = fs::read(&glb).unwrap();
    for eighth in 1..8 {
        let cut = write(d, &format!("cut{eighth}.glb"), &bytes[..bytes.len() * eighth / 8]);
        assert!(error_text(&cut).contains("glTF"));
    }
}

#[test]
fn vertex_colours_load_from_ply_obj_and_gltf_and_colour_the_surface() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // sRGB bytes (PLY) and fractions (OBJ) decode to linear; glTF's are linear.
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 128 128 128\n3 0 1 2\n";
    let obj = "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0.50196 0.50196 0.50196\nf 1 2 3\n";
    let grey = 0.21586;
    for scene in [load_default(&write(d, "c.ply", ply.as_bytes())).unwrap(), load_default(&write(d, "c.obj", obj.as_bytes())).unwrap()] {
        assert_eq!(scene.colours.len(), 3);
        assert!((scene.colours[0] - Vec3::X).length() < 1e-6 && (scene.colours[1] - Vec3::Y).length() < 1e-6);
        assert!((scene.colours[2] - Vec3::splat(grey)).length() < 1e-4, "{:?}", scene.colours);
        // The surface's colour is the material's times the colours, interpolated.
        let materials = crate::tracer::Materials::new(&scene);
        let base = Vec3::from_slice(&scene.materials[0].base_color[..3]);
        assert!((materials.albedo(0, 0.0, 0.0) - Vec3::X * base).length() < 1e-5);
        assert!((materials.albedo(0, 0.5, 0.5) - (Vec3::Y + Vec3::splat(grey)) * 0.5 * base).length() < 1e-4);
    }
    let mut data: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect();
    data.extend([0.25f32, 0.5, 0.75, 1., 1., 1., 0., 0., 0.].iter().flat_map(|v| v.to_le_bytes()));
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 1}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]},
                      {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"}],
        "bufferViews": [{"buffer": 0, "byteLength": 72}],
        "buffers": [{"byteLength": 72, "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&data))}]
    });
    let scene = load_default(&write(d, "c.gltf", gltf.to_string().as_bytes())).unwrap();
    assert_eq!(scene.colours, [Vec3::new(0.25, 0.5, 0.75), Vec3::ONE, Vec3::ZERO]);
    // Both exporters write them: exactly to GLB, within a level of an sRGB byte to OBJ.
    crate::scene_io::write::write_glb(&scene, &d.join("back.glb")).unwrap();
    assert_eq!(load_default(&d.join("back.glb")).unwrap().colours, scene.colours);
    crate::scene_io::write::write_obj(&scene, &d.join("back.obj")).unwrap();
    let back = load_default(&d.join("back.obj")).unwrap();
    for (a, b) in back.colours.iter().zip(&scene.colours) {
        assert!((*a - *b).abs().max_element() < 0.006, "{a} against {b}");
    }
    assert_eq!(back.colours.len(), 3);
    // Without colours on every vertex there are none.
    let plain = load_default(&write(d, "q.obj", QUAD_OBJ.as_bytes())).unwrap();
    assert!(plain.colours.is_empty());
}

#[test]
fn ply_ascii_and_binary_load_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let header = |format: &str| {
        format!("ply\nformat {format} 1.0\ncomment two triangles\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n")
    };
    let ascii = format!("{}0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n", header("ascii"));
    let mut binary = header("binary_little_endian").into_bytes();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        p.iter().for_each(|v| binary.extend(v.to_le_bytes()));
    }
    binary.push(4);
    [0i32, 1, 2, 3].iter().for_each(|i| binary.extend(i.to_le_bytes()));
    let a = load_default(&write(dir.path(), "a.ply", ascii.as_bytes())).unwrap();
    let b = load_default(&write(dir.path(), "b.ply", &binary)).unwrap();
    assert_eq!(a.triangles.len(), 2);
    assert_eq!(a.positions, b.positions);
    assert_eq!(a.triangles, b.triangles);
}

#[test]
fn up_axis_z_is_rotated_to_y() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "z.obj", b"v 0 0 0\nv 1 0 0\nv 0 0 5\nf 1 2 3\n");
    let options = LoadOptions { up: parse_up_axis("z").unwrap(), metres_per_unit: Some(0.2), ..Default::default() };
    let scene = load(&path, &options).unwrap();
    let b = scene.bounds();
    assert!((b.max.y - 5.0).abs() < 1e-5 && b.max.z.abs() < 1e-5, "{b:?}");
    assert_eq!((scene.metres_per_unit, scene.scale_source), (0.2, ScaleSource::User));
    assert_eq!(parse_up_axis("-X"), Some(-Vec3::X));
    assert_eq!(parse_up_axis("w"), None);
}

#[test]
fn builtin_scene_round_trips_through_obj_and_glb() {
    let dir = tempfile::tempdir().unwrap();
    let original = BuiltIn::Gallery.generate(3);
    for name in ["gallery.obj", "gallery.glb"] {
        let path = dir.path().join(name);
        crate::scene_io::write::export(&original, &path).unwrap();
        let back = load_default(&path).unwrap();
        assert_eq!(back.triangles.len(), original.triangles.len(), "{name}");
        assert_eq!(back.textures.len(), original.textures.len(), "{name}");
        assert!((back.total_area() - original.total_area()).abs() < 1e-3 * original.total_area(), "{name}");
        let (a, b) = (original.bounds(), back.bounds());
        assert!((a.min - b.min).length() < 1e-4 && (a.max - b.max).length() < 1e-4, "{name}");
        let lamp = back.materials.iter().find(|m| m.name == "lamp").expect("lamp material");
        assert_eq!(lamp.emissive, Vec3::splat(8.0), "{name}");
        if name.ends_with(".glb") {
            // The lights come back (OBJ has none), in the loader's node order.
            assert_eq!(back.lights.len(), original.lights.len(), "{name}");
            let same = |a: &Light, b: &Light| match (a, b) {
                (Light::Point { position: pa, intensity: ia }, Light::Point { position: pb, intensity: ib }) => {
                    (*pa - *pb).length() < 1e-4 && (*ia - *ib).length() < 1e-4 * ia.length()
                }
                (Light::Sun { direction: da, irradiance: ea }, Light::Sun { direction: db, irradiance: eb }) => {
                    (da.normalize() - *db).length() < 1e-5 && (*ea - *eb).length() < 1e-4 * ea.length()
                }
                _ => false,
            };
            for a in &original.lights {
                assert!(back.lights.iter().any(|b| same(a, b)), "{name}: {a:?} did not come back");
            }
        }
        let t = back.materials.iter().find(|m| m.name == "floor_marble").unwrap().base_color_texture.unwrap();
        assert_eq!(back.textures[t].image, original.textures[0].image, "{name}");
        // Texture coordinates per triangle, compared independently of triangle order.
        let keyed = |s: &Scene| {
            let mut v: Vec<([f32; 3], glam::Vec2)> = s
                .triangles
                .iter()
                .map(|t| {
                    let c = t.iter().map(|&i| s.positions[i as usize]).sum::<Vec3>();
                    let uv = t.iter().map(|&i| s.uvs[i as usize]).sum::<glam::Vec2>();
                    (c.to_array(), uv)
                })
                .collect();
            v.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap().then(a.1.x.total_cmp(&b.1.x)));
            v
        };
        for ((ca, ua), (cb, ub)) in keyed(&original).iter().zip(&keyed(&back)) {
            assert_eq!(ca, cb, "{name}");
            assert!((*ua - *ub).length() < 1e-4, "{name}: {ua} vs {ub}");
        }
    }
}

#[test]
fn gltf_node_transforms_are_applied() {
    // A triangle in a child node translated by (10, 0, 0) under a parent scaled by 2.
    let dir = tempfile::tempdir().unwrap();
    let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect();
    let uri = format!("data:application/octet-stream;base64,{}", base64_encode(&positions));
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"scale": [2.0, 2.0, 2.0], "children": [1]}, {"translation": [10.0, 0.0, 0.0], "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": uri}]
    });
    let scene = load_default(&write(dir.path(), "t.gltf", gltf.to_string().as_bytes())).unwrap();
    assert_eq!(scene.triangle(0), [Vec3::new(20.0, 0.0, 0.0), Vec3::new(22.0, 0.0, 0.0), Vec3::new(20.0, 2.0, 0.0)]);
    assert_eq!(scene.scale_source, ScaleSource::File);
}

#[test]
fn gltf_specular_glossiness_diffuse_and_texture_transforms_are_read() {
    // One triangle with texture coordinates (0,0), (1,0), (0,1), drawn with a
    // specular-glossiness material whose diffuse texture is offset, scaled and
    // rotated by KHR_texture_transform.
    let dir = tempfile::tempdir().unwrap();
    let mut data: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect();
    data.extend([0f32, 0., 1., 0., 0., 1.].iter().flat_map(|v| v.to_le_bytes()));
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let make = |rotation: f32, required: &[&str]| {
        serde_json::json!({
            "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "extensionsUsed": ["KHR_materials_pbrSpecularGlossiness", "KHR_texture_transform"], "extensionsRequired": required,
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}],
            "materials": [{"extensions": {"KHR_materials_pbrSpecularGlossiness": {"diffuseFactor": [0.5, 0.6, 0.7, 1.0],
                "diffuseTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.25], "scale": [2.0, 3.0], "rotation": rotation}}}}}}],
            "textures": [{"source": 0}],
            "images": [{"uri": format!("data:image/png;base64,{}", base64_encode(&png))}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]},
                          {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC2"}],
            "bufferViews": [{"buffer": 0, "byteLength": 60}],
            "buffers": [{"byteLength": 60, "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&data))}]
        })
        .to_string()
    };
    let scene = load_default(&write(dir.path(), "sg.gltf", make(0.0, &["KHR_texture_transform"]).as_bytes())).unwrap();
    assert_eq!(scene.materials[0].base_color, [0.5, 0.6, 0.7, 1.0]);
    assert_eq!(scene.materials[0].base_color_texture, Some(0));
    assert_eq!(scene.uvs, [glam::Vec2::new(0.5, 0.25), glam::Vec2::new(2.5, 0.25), glam::Vec2::new(0.5, 3.25)]);
    // A quarter turn: u' = sy·v + ox, v' = -sx·u + oy.
    let scene = load_default(&write(dir.path(), "rot.gltf", make(std::f32::consts::FRAC_PI_2, &[]).as_bytes())).unwrap();
    for (uv, want) in scene.uvs.iter().zip([glam::Vec2::new(0.5, 0.25), glam::Vec2::new(0.5, -1.75), glam::Vec2::new(3.5, 0.25)]) {
        assert!((*uv - want).length() < 1e-5, "{uv} against {want}");
    }
    // An extension nothing here reads, when required, is named in the error.
    let path = write(dir.path(), "unknown.gltf", make(0.0, &["EXT_some_future_extension"]).as_bytes());
    let text = error_text(&path);
    assert!(text.contains("EXT_some_future_extension") && text.contains("export the scene again"), "{text}");
}

#[test]
fn gltf_gpu_instances_become_copies_of_the_mesh_in_the_nodes_space() {
    // One triangle drawn by a node at z = 10 three times: as is, turned a
    // quarter about z (a rotation of normalized shorts) and moved to x = 5,
    // and doubled in size at y = 5.
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let mut data = floats(&[0., 0., 0., 1., 0., 0., 0., 1., 0.]);
    data.extend(floats(&[0., 0., 0., 5., 0., 0., 0., 5., 0.]));
    let h = (32767.0 * std::f32::consts::FRAC_1_SQRT_2).round() as i16;
    data.extend([0i16, 0, 0, 32767, 0, 0, h, h, 0, 0, 0, 32767].iter().flat_map(|x| x.to_le_bytes()));
    data.extend(floats(&[1., 1., 1., 1., 1., 1., 2., 2., 2.]));
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}],
        "extensionsUsed": ["EXT_mesh_gpu_instancing"], "extensionsRequired": ["EXT_mesh_gpu_instancing"],
        "nodes": [{"mesh": 0, "translation": [0.0, 0.0, 10.0], "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 1, "ROTATION": 2, "SCALE": 3}}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]},
                      {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"},
                      {"bufferView": 0, "byteOffset": 72, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC4"},
                      {"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 3, "type": "VEC3"}],
        "bufferViews": [{"buffer": 0, "byteLength": 132}],
        "buffers": [{"byteLength": 132, "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&data))}]
    });
    let dir = tempfile::tempdir().unwrap();
    let scene = load_default(&write(dir.path(), "instanced.gltf", gltf.to_string().as_bytes())).unwrap();
    let want =
        [[[0., 0., 10.], [1., 0., 10.], [0., 1., 10.]], [[5., 0., 10.], [5., 1., 10.], [4., 0., 10.]], [[0., 5., 10.], [2., 5., 10.], [0., 7., 10.]]];
    assert_eq!(scene.triangles.len(), 3);
    let corners: Vec<[Vec3; 3]> = scene.triangles.iter().map(|t| t.map(|v| scene.positions[v as usize])).collect();
    for w in want {
        let w = w.map(Vec3::from);
        assert!(corners.iter().any(|c| c.iter().zip(&w).all(|(p, q)| (*p - *q).length() < 1e-3)), "no triangle at {w:?} in {corners:?}");
    }
    // Attributes of different lengths are an error naming the file.
    let mut short = gltf.clone();
    short["accessors"][3]["count"] = serde_json::json!(2);
    let text = error_text(&write(dir.path(), "short.gltf", short.to_string().as_bytes()));
    assert!(text.contains("EXT_mesh_gpu_instancing") && text.contains("different instance counts"), "{text}");
}

#[test]
fn textures_in_tga_bmp_webp_and_ktx2_decode() {
    let dir = tempfile::tempdir().unwrap();
    let encoded = |format: image::ImageFormat, rgba: [u8; 4]| {
        let mut bytes = Vec::new();
        image::RgbaImage::from_pixel(2, 2, image::Rgba(rgba)).write_to(&mut std::io::Cursor::new(&mut bytes), format).unwrap();
        bytes
    };
    // OBJ: a TGA colour map and a BMP cut-out map.
    write(dir.path(), "wall.tga", &encoded(image::ImageFormat::Tga, [200, 100, 50, 255]));
    write(dir.path(), "mask.bmp", &encoded(image::ImageFormat::Bmp, [0, 0, 0, 255]));
    write(dir.path(), "m.mtl", b"newmtl wall\nKd 1 1 1\nmap_Kd wall.tga\nmap_d mask.bmp\n");
    let scene = load_default(&write(dir.path(), "t.obj", format!("mtllib m.mtl\nusemtl wall\n{QUAD_OBJ}").as_bytes())).unwrap();
    let t = scene.materials[0].base_color_texture.expect("TGA and BMP decode");
    assert_eq!(scene.textures[t].image.get_pixel(0, 0).0, [200, 100, 50, 0]);
    assert_eq!(scene.stats.missing_textures, 0);

    // glTF: one texture given only by EXT_texture_webp, one only by
    // KHR_texture_basisu (a KTX2 image of UASTC blocks, zstd-supercompressed).
    let data: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 1.].iter().flat_map(|v| v.to_le_bytes()).collect();
    let ktx2 = KTX2_UASTC;
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "extensionsUsed": ["EXT_texture_webp", "KHR_texture_basisu"], "extensionsRequired": ["EXT_texture_webp", "KHR_texture_basisu"],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}, {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 1}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}, {"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1.0], "baseColorTexture": {"index": 1}}}],
        "textures": [{"extensions": {"EXT_texture_webp": {"source": 0}}}, {"extensions": {"KHR_texture_basisu": {"source": 1}}}],
        "images": [{"uri": format!("data:image/webp;base64,{}", base64_encode(&encoded(image::ImageFormat::WebP, [10, 20, 30, 255])))},
                   {"uri": format!("data:image/ktx2;base64,{}", base64_encode(ktx2))}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]},
                      {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC2"}],
        "bufferViews": [{"buffer": 0, "byteLength": 60}],
        "buffers": [{"byteLength": 60, "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&data))}]
    });
    let scene = load_default(&write(dir.path(), "t.gltf", gltf.to_string().as_bytes())).unwrap();
    let t = scene.materials[0].base_color_texture.expect("the WebP image decodes");
    assert_eq!(scene.textures[t].image.get_pixel(1, 1).0, [10, 20, 30, 255]);
    let t = scene.materials[1].base_color_texture.expect("the KTX2 image decodes");
    assert_quadrants(&scene.textures[t].image, 0);
    assert_eq!(scene.materials[1].base_color, [0.2, 0.4, 0.6, 1.0]);
    assert_eq!(scene.stats.missing_textures, 0);

    // Damaged, the KTX2 image is a warning and its material keeps its colour.
    let mut damaged = gltf.clone();
    damaged["images"][1]["uri"] = serde_json::json!(format!("data:image/ktx2;base64,{}", base64_encode(&KTX2_UASTC[..100])));
    let scene = load_default(&write(dir.path(), "damaged.gltf", damaged.to_string().as_bytes())).unwrap();
    assert_eq!(scene.materials[1].base_color_texture, None);
    assert_eq!(scene.stats.missing_textures, 1);
}

/// KTX2 images of a 16 × 16 texture of four flat 8 × 8 quadrants, made by
/// the Basis Universal encoder (`scripts/ktx2_fixtures.py`): ETC1S blocks
/// (BasisLZ), and UASTC blocks supercompressed with zstd.
const KTX2_ETC1S: &[u8] = include_bytes!("testdata/quadrants_etc1s.ktx2");
const KTX2_UASTC: &[u8] = include_bytes!("testdata/quadrants_uastc_zstd.ktx2");
const QUADRANTS: [[u8; 3]; 4] = [[200, 40, 30], [30, 160, 60], [40, 70, 220], [240, 230, 200]];

/// Each quadrant's pixels within `tolerance` of the colour encoded.
fn assert_quadrants(image: &image::RgbaImage, tolerance: u8) {
    assert_eq!(image.dimensions(), (16, 16));
    for (x, y, p) in image.enumerate_pixels() {
        let want = QUADRANTS[(x / 8 + 2 * (y / 8)) as usize];
        assert!(p.0[..3].iter().zip(want).all(|(&a, b)| a.abs_diff(b) <= tolerance) && p.0[3] == 255, "pixel ({x}, {y}) is {:?}, not {want:?}", p.0);
    }
}

#[test]
fn ktx2_textures_transcode_from_obj_too_and_damaged_ones_are_errors_not_panics() {
    // ETC1S keeps a flat 4 × 4 block's colour to within its 5-bit endpoints
    // and intensity table; UASTC exactly here.
    for (bytes, tolerance) in [(KTX2_ETC1S, 8), (KTX2_UASTC, 0)] {
        assert_quadrants(&decode_ktx2(bytes).unwrap(), tolerance);
    }
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "quadrants.ktx2", KTX2_ETC1S);
    write(dir.path(), "m.mtl", b"newmtl wall\nKd 1 1 1\nmap_Kd quadrants.ktx2\n");
    let scene = load_default(&write(dir.path(), "t.obj", format!("mtllib m.mtl\nusemtl wall\n{QUAD_OBJ}").as_bytes())).unwrap();
    let t = scene.materials[0].base_color_texture.expect("the KTX2 map decodes");
    assert_quadrants(&scene.textures[t].image, 8);

    // A level claiming to inflate to a terabyte is refused before any
    // allocation (the transcoder would allocate what the header says).
    let mut huge = KTX2_UASTC.to_vec();
    huge[80 + 16..80 + 24].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let why = decode_ktx2(&huge).unwrap_err();
    assert!(why.contains("damaged KTX2"), "{why}");
    // Truncated, bit-flipped and overwritten files: an error or an image, never
    // a panic (KTX2_MUTATIONS=N runs more).
    let runs: usize = std::env::var("KTX2_MUTATIONS").ok().and_then(|n| n.parse().ok()).unwrap_or(3000);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    let mut errors = 0;
    for run in 0..runs {
        let mut bytes = [KTX2_ETC1S, KTX2_UASTC][run % 2].to_vec();
        match rng.random_range(0..3) {
            0 => bytes.truncate(rng.random_range(0..bytes.len())),
            1 => (0..rng.random_range(1..8)).for_each(|_| {
                let i = rng.random_range(0..bytes.len());
                bytes[i] ^= 1 << rng.random_range(0..8);
            }),
            _ => (0..rng.random_range(1..4)).for_each(|_| {
                let i = rng.random_range(0..bytes.len());
                bytes[i] = rng.random();
            }),
        }
        errors += usize::from(decode_ktx2(&bytes).is_err());
    }
    // (A third of the runs truncate, which always fails.)
    assert!(errors >= runs / 3, "{errors} of {runs} damaged files refused");
}

#[test]
fn gltf_punctual_lights_are_read_in_the_renderers_units_and_turn_with_the_up_axis() {
    // A triangle, a point light of 683 cd at (1, 2, 3) under a node moved by
    // (10, 0, 0), a sun of 1366 lux shining down (-Z turned to -Y), and a spot.
    let dir = tempfile::tempdir().unwrap();
    let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect();
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"}, "scenes": [{"nodes": [0, 1, 3]}], "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 683.0},
            {"type": "directional", "intensity": 1366.0},
            {"type": "spot", "intensity": 68.3, "spot": {"outerConeAngle": 0.5}}]}},
        "nodes": [{"mesh": 0, "translation": [10.0, 0.0, 0.0], "children": [2]},
                  {"rotation": [-0.70710677, 0.0, 0.0, 0.70710677], "extensions": {"KHR_lights_punctual": {"light": 1}}},
                  {"translation": [1.0, 2.0, 3.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
                  {"extensions": {"KHR_lights_punctual": {"light": 2}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&positions))}]
    });
    let path = write(dir.path(), "lights.gltf", gltf.to_string().as_bytes());
    let scene = load_default(&path).unwrap();
    let near = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
    let mut point = None;
    let mut sun = None;
    for l in &scene.lights {
        match *l {
            exploremaps_scenes::Light::Point { position, intensity } if intensity.x > 0.5 => point = Some((position, intensity)),
            exploremaps_scenes::Light::Sun { direction, irradiance } => sun = Some((direction, irradiance)),
            _ => {}
        }
    }
    assert_eq!(scene.lights.len(), 3, "{:?}", scene.lights);
    let (position, intensity) = point.unwrap();
    assert!(near(position, Vec3::new(11.0, 2.0, 3.0)) && near(intensity, Vec3::new(1.0, 0.5, 0.25)), "{position} {intensity}");
    let (direction, irradiance) = sun.unwrap();
    assert!(near(direction, Vec3::Y) && near(irradiance, Vec3::splat(2.0)), "{direction} {irradiance}");
    // With Z as the file's up, the sun (toward +Y in the file) turns to -Z.
    let turned = load(&path, &LoadOptions { up: Vec3::Z, ..Default::default() }).unwrap();
    let sun = turned.lights.iter().find_map(|l| match *l {
        exploremaps_scenes::Light::Sun { direction, .. } => Some(direction),
        _ => None,
    });
    assert!(near(sun.unwrap(), Vec3::NEG_Z), "{sun:?}");
}

#[test]
fn gltf_quantized_attributes_load_like_floats() {
    // KHR_mesh_quantization as gltfpack writes it: positions as normalized
    // shorts under a node's scale, normals as normalized bytes, texture
    // coordinates as unsigned bytes (not normalized) at a stride of 4.
    let dir = tempfile::tempdir().unwrap();
    let mut data: Vec<u8> = [0i16, 0, 0, 0, 32767, 0, 0, 0, 0, 32767, 0, 0].iter().flat_map(|v| v.to_le_bytes()).collect();
    data.extend([0i8, 0, 127, 0, 0, 0, 127, 0, 0, 0, 127, 0].map(|v| v as u8));
    data.extend([0u8, 0, 0, 0, 4, 0, 0, 0, 0, 2, 0, 0]);
    let gltf = |required: &str| {
        serde_json::json!({
            "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "extensionsUsed": [required], "extensionsRequired": [required],
            "nodes": [{"mesh": 0, "scale": [2.0, 2.0, 2.0]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}]}],
            "accessors": [
                {"bufferView": 0, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [32767, 32767, 0]},
                {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 3, "type": "VEC3"},
                {"bufferView": 2, "componentType": 5121, "count": 3, "type": "VEC2"}],
            "bufferViews": [{"buffer": 0, "byteLength": 24, "byteStride": 8}, {"buffer": 0, "byteOffset": 24, "byteLength": 12, "byteStride": 4},
                            {"buffer": 0, "byteOffset": 36, "byteLength": 12, "byteStride": 4}],
            "buffers": [{"byteLength": 48, "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&data))}]
        })
        .to_string()
    };
    let scene = load_default(&write(dir.path(), "q.gltf", gltf("KHR_mesh_quantization").as_bytes())).unwrap();
    assert_eq!(scene.triangle(0), [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)]);
    assert!(scene.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6), "{:?}", scene.normals);
    assert_eq!(scene.uvs, [glam::Vec2::ZERO, glam::Vec2::new(4.0, 0.0), glam::Vec2::new(0.0, 2.0)]);
    // A view too short for its count is an error naming the accessor, not a panic.
    let short = gltf("KHR_mesh_quantization").replace("\"count\":3,\"type\":\"VEC2\"", "\"count\":300,\"type\":\"VEC2\"");
    assert!(short.contains("\"count\":300"));
    assert!(error_text(&write(dir.path(), "short.gltf", short.as_bytes())).contains("accessor 2 (TEXCOORD_0)"));
}

fn base64_encode(bytes: &[u8]) -> String {
    base64::encode(bytes)
}

/// A wavy grid of `n`² quads as a glTF with its positions, texture
/// coordinates and indices; Draco-compressed (by `draco-core`'s encoder, a
/// test-only feature) when `draco`, plain otherwise. `damage` edits the
/// compressed stream before it is written.
fn grid_gltf(n: u32, draco: bool, damage: impl Fn(&mut Vec<u8>)) -> String {
    use draco_core::{
        draco_types::DataType,
        encoder_buffer::EncoderBuffer,
        encoder_options::EncoderOptions,
        geometry_attribute::{GeometryAttributeType, PointAttribute},
        mesh_encoder::MeshEncoder,
    };
    let side = n + 1;
    let points: Vec<([f32; 3], [f32; 2])> = (0..side * side)
        .map(|i| {
            let (x, z) = ((i % side) as f32, (i / side) as f32);
            ([x, (0.7 * x).sin() * (0.4 * z).cos(), z], [x / n as f32, z / n as f32])
        })
        .collect();
    let indices: Vec<u32> = (0..n * n)
        .flat_map(|q| {
            let (x, z) = (q % n, q / n);
            let a = z * side + x;
            [a, a + side, a + 1, a + 1, a + side, a + side + 1]
        })
        .collect();
    let (lo, hi) = points.iter().fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), (p, _)| {
        (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k])))
    });
    let count = points.len();
    let mut accessors = serde_json::json!([
        {"componentType": 5126, "count": count, "type": "VEC3", "min": lo, "max": hi},
        {"componentType": 5126, "count": count, "type": "VEC2"},
        {"componentType": 5125, "count": indices.len(), "type": "SCALAR"}
    ]);
    let mut primitive = serde_json::json!({"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2});
    let mut top = serde_json::json!({});
    let (bytes, views): (Vec<u8>, serde_json::Value) = if draco {
        let mut mesh = draco_core::mesh::Mesh::new();
        mesh.set_num_points(count);
        for (kind, components) in [(GeometryAttributeType::Position, 3usize), (GeometryAttributeType::TexCoord, 2)] {
            let mut attribute = PointAttribute::new();
            attribute.init(kind, components as u8, DataType::Float32, false, count);
            for (i, (p, uv)) in points.iter().enumerate() {
                let values = if components == 3 { &p[..] } else { &uv[..] };
                for (k, v) in values.iter().enumerate() {
                    attribute.buffer_mut().update(&v.to_le_bytes(), Some((i * components + k) * 4));
                }
            }
            mesh.add_attribute(attribute);
        }
        mesh.set_num_faces(indices.len() / 3);
        mesh.set_faces_from_flat_indices(&indices);
        let mut encoder = MeshEncoder::new();
        encoder.set_mesh(mesh);
        let mut out = EncoderBuffer::new();
        encoder.encode(&EncoderOptions::new(), &mut out).unwrap();
        let mut stream = out.data().to_vec();
        damage(&mut stream);
        primitive["extensions"] =
            serde_json::json!({"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0, "TEXCOORD_0": 1}}});
        top = serde_json::json!({"extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"]});
        let len = stream.len();
        (stream, serde_json::json!([{"buffer": 0, "byteLength": len}]))
    } else {
        let mut bytes: Vec<u8> = points.iter().flat_map(|(p, _)| p.iter().flat_map(|v| v.to_le_bytes())).collect();
        let uv_at = bytes.len();
        bytes.extend(points.iter().flat_map(|(_, uv)| uv.iter().flat_map(|v| v.to_le_bytes())));
        let index_at = bytes.len();
        bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
        for k in 0..3 {
            accessors[k]["bufferView"] = serde_json::json!(k);
        }
        let len = bytes.len();
        (
            bytes,
            serde_json::json!([
                {"buffer": 0, "byteOffset": 0, "byteLength": uv_at},
                {"buffer": 0, "byteOffset": uv_at, "byteLength": index_at - uv_at},
                {"buffer": 0, "byteOffset": index_at, "byteLength": len - index_at}
            ]),
        )
    };
    let mut gltf = serde_json::json!({
        "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [primitive]}], "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": bytes.len(), "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&bytes))}]
    });
    if let (Some(g), Some(t)) = (gltf.as_object_mut(), top.as_object()) {
        g.extend(t.clone());
    }
    gltf.to_string()
}

/// A one-buffer `.gltf` with a data URI as a GLB holding those bytes in its binary chunk.
fn as_glb(text: &str) -> Vec<u8> {
    let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
    let uri = json["buffers"][0].as_object_mut().unwrap().remove("uri").unwrap();
    let bytes = base64::decode(uri.as_str().unwrap().split_once(";base64,").unwrap().1).unwrap();
    super::gltf_decode::glb(json.to_string().as_bytes(), &bytes)
}

#[test]
fn draco_compressed_gltf_loads_like_the_plain_file() {
    let dir = tempfile::tempdir().unwrap();
    let plain = load_default(&write(dir.path(), "plain.gltf", grid_gltf(12, false, |_| ()).as_bytes())).unwrap();
    assert_eq!(plain.triangles.len(), 288);
    for name in ["draco.gltf", "draco.glb"] {
        let text = grid_gltf(12, true, |_| ());
        // The same file as a GLB: its buffer's bytes in the binary chunk.
        let bytes = if name.ends_with(".glb") { as_glb(&text) } else { text.into_bytes() };
        let draco = load_default(&write(dir.path(), name, &bytes)).unwrap();
        assert_eq!(draco.triangles.len(), plain.triangles.len(), "{name}");
        assert!((draco.total_area() - plain.total_area()).abs() < 1e-3 * plain.total_area(), "{name}");
        // Draco may reorder points and faces: each decoded vertex matches the
        // plain one nearest it, within the default 11-bit quantization, with
        // the same texture coordinates.
        for (p, uv) in draco.positions.iter().zip(&draco.uvs) {
            let (k, d) = plain.positions.iter().enumerate().map(|(k, q)| (k, (*p - *q).length())).min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
            assert!(d < 0.01, "{name}: {p} is {d} from the nearest plain vertex");
            assert!((*uv - plain.uvs[k]).length() < 2e-3, "{name}: uv {uv} against {}", plain.uvs[k]);
        }
    }
}

#[test]
fn damaged_draco_data_is_an_error_naming_the_file_never_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let damages: [fn(&mut Vec<u8>); 5] = [
        |s| s.truncate(s.len() / 2),
        |s| s.truncate(9),
        |s| s.iter_mut().skip(12).step_by(7).for_each(|b| *b ^= 0x5a),
        |s| s[..5].copy_from_slice(b"DRACX"),
        |s| s.clear(),
    ];
    for (i, damage) in damages.iter().enumerate() {
        let path = write(dir.path(), &format!("d{i}.gltf"), grid_gltf(6, true, damage).as_bytes());
        let result = std::panic::catch_unwind(|| load_default(&path)).unwrap_or_else(|_| panic!("case {i} panicked"));
        // Damage the decoder cannot see (a flipped bit in a value) may load; what does not decode must say so.
        if let Err(e) = result {
            let text = e.to_string();
            assert!(text.contains(&path.display().to_string()) && text.contains("KHR_draco_mesh_compression"), "case {i}: {text}");
        }
    }
    // A stream cut in half never decodes.
    let path = write(dir.path(), "half.gltf", grid_gltf(6, true, |s| s.truncate(s.len() / 2)).as_bytes());
    assert!(error_text(&path).contains("does not decode"));
}

/// The plain grid glTF with its three views compressed by meshoptimizer
/// (`EXT_meshopt_compression`) as `gltfpack` lays them out: the compressed
/// data in buffer 0, a fallback buffer 1 holding nothing. Positions go
/// through the exponential filter when `exp_filter`. `edit` changes view k's
/// extension object before writing.
fn meshopt_gltf(n: u32, exp_filter: bool, edit: impl Fn(usize, &mut serde_json::Value)) -> String {
    let mut json: serde_json::Value = serde_json::from_str(&grid_gltf(n, false, |_| ())).unwrap();
    let uri = json["buffers"][0]["uri"].as_str().unwrap().to_string();
    let bytes = base64::decode(uri.split_once(";base64,").unwrap().1).unwrap();
    let count = json["accessors"][0]["count"].as_u64().unwrap() as usize;
    let mut packed = Vec::new();
    for (k, (mode, stride)) in [("ATTRIBUTES", 12), ("ATTRIBUTES", 8), ("TRIANGLES", 4)].into_iter().enumerate() {
        let view = json["bufferViews"][k].clone();
        let (at, len) = (view["byteOffset"].as_u64().unwrap() as usize, view["byteLength"].as_u64().unwrap() as usize);
        let raw = &bytes[at..at + len];
        let (encoded, elements, filter) = if mode == "TRIANGLES" {
            let indices: Vec<u32> = raw.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect();
            (meshopt::encode_index_buffer(&indices, count).unwrap(), indices.len(), "NONE")
        } else if k == 0 && exp_filter {
            let floats: Vec<f32> = raw.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
            let mut filtered = vec![[0u8; 12]; count];
            // SAFETY: `filtered` holds `count` elements of 12 bytes, `floats` 3 a vertex.
            unsafe {
                meshopt::ffi::meshopt_encodeFilterExp(
                    filtered.as_mut_ptr().cast(),
                    count,
                    12,
                    15,
                    floats.as_ptr(),
                    meshopt::ffi::meshopt_EncodeExpMode_meshopt_EncodeExpSeparate,
                )
            };
            (meshopt::encode_vertex_buffer(&filtered).unwrap(), count, "EXPONENTIAL")
        } else if stride == 12 {
            let v: Vec<[u8; 12]> = raw.chunks_exact(12).map(|c| c.try_into().unwrap()).collect();
            (meshopt::encode_vertex_buffer(&v).unwrap(), count, "NONE")
        } else {
            let v: Vec<[u8; 8]> = raw.chunks_exact(8).map(|c| c.try_into().unwrap()).collect();
            (meshopt::encode_vertex_buffer(&v).unwrap(), count, "NONE")
        };
        packed.resize(packed.len().next_multiple_of(4), 0);
        let mut ext = serde_json::json!({"buffer": 0, "byteOffset": packed.len(), "byteLength": encoded.len(), "byteStride": stride, "count": elements, "mode": mode, "filter": filter});
        packed.extend_from_slice(&encoded);
        edit(k, &mut ext);
        let view = &mut json["bufferViews"][k];
        view["buffer"] = serde_json::json!(1);
        if mode == "ATTRIBUTES" {
            view["byteStride"] = serde_json::json!(stride);
        }
        view["extensions"] = serde_json::json!({"EXT_meshopt_compression": ext});
    }
    json["buffers"] = serde_json::json!([
        {"byteLength": packed.len(), "uri": format!("data:application/octet-stream;base64,{}", base64_encode(&packed))},
        {"byteLength": bytes.len(), "extensions": {"EXT_meshopt_compression": {"fallback": true}}}
    ]);
    json["extensionsUsed"] = serde_json::json!(["EXT_meshopt_compression"]);
    json["extensionsRequired"] = serde_json::json!(["EXT_meshopt_compression"]);
    json.to_string()
}

#[test]
fn meshopt_compressed_gltf_loads_like_the_plain_file() {
    let dir = tempfile::tempdir().unwrap();
    let plain = load_default(&write(dir.path(), "plain.gltf", grid_gltf(12, false, |_| ()).as_bytes())).unwrap();
    for exp_filter in [false, true] {
        for name in ["meshopt.gltf", "meshopt.glb", "external.gltf", "file-uri.gltf"] {
            let text = meshopt_gltf(12, exp_filter, |_, _| ());
            let bytes = if name.ends_with(".glb") {
                as_glb(&text)
            } else if name.ends_with(".gltf") && name != "meshopt.gltf" {
                // The compressed data in a file beside the scene (read once:
                // the transcoded file's buffers are handed on), named
                // relative to it or by an absolute `file:` URI.
                let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
                let uri = json["buffers"][0]["uri"].as_str().unwrap().to_string();
                let bin = write(dir.path(), "external.bin", &base64::decode(uri.split_once(";base64,").unwrap().1).unwrap());
                json["buffers"][0]["uri"] =
                    serde_json::json!(if name == "external.gltf" { "external.bin".to_string() } else { format!("file://{}", bin.display()) });
                json.to_string().into_bytes()
            } else {
                text.into_bytes()
            };
            let scene = load_default(&write(dir.path(), name, &bytes)).unwrap();
            // The codecs are lossless: the same triangles, vertices and
            // texture coordinates; the exponential filter keeps 15 bits of
            // mantissa (positions up to 12 here: within 12 / 2^14).
            assert_eq!(scene.triangles, plain.triangles, "{name}");
            assert_eq!(scene.uvs, plain.uvs, "{name}");
            let tolerance = if exp_filter { 12.0 / 16384.0 } else { 0.0 };
            for (p, q) in scene.positions.iter().zip(&plain.positions) {
                assert!((*p - *q).abs().max_element() <= tolerance, "{name}, filter {exp_filter}: {p} against {q}");
            }
        }
    }
    // The file beside it shorter than its buffer declares: an error naming both.
    let mut json: serde_json::Value = serde_json::from_str(&String::from_utf8(fs::read(dir.path().join("external.gltf")).unwrap()).unwrap()).unwrap();
    json["buffers"][0]["byteLength"] = serde_json::json!(json["buffers"][0]["byteLength"].as_u64().unwrap() + 100);
    let text = error_text(&write(dir.path(), "short.gltf", json.to_string().as_bytes()));
    assert!(text.contains("external.bin") && text.contains("declares"), "{text}");
    // A buffer under another scheme is refused, naming it.
    json["buffers"][0]["uri"] = serde_json::json!("https://example.com/external.bin");
    let text = error_text(&write(dir.path(), "remote.gltf", json.to_string().as_bytes()));
    assert!(text.contains("https://example.com/external.bin") && text.contains("data URI"), "{text}");
}

#[test]
fn damaged_meshopt_data_is_an_error_naming_the_file_never_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    type Edit = fn(usize, &mut serde_json::Value);
    let edits: [(&str, Edit); 7] = [
        ("does not decode", |k, e| {
            if k == 2 {
                e["byteLength"] = serde_json::json!(e["byteLength"].as_u64().unwrap() / 2)
            }
        }),
        ("does not decode", |k, e| {
            if k == 0 {
                e["byteLength"] = serde_json::json!(5)
            }
        }),
        ("stride of 6 bytes", |k, e| {
            if k == 0 {
                e["byteStride"] = serde_json::json!(6)
            }
        }),
        ("mode \"STRIPS\"", |k, e| {
            if k == 2 {
                e["mode"] = serde_json::json!("STRIPS")
            }
        }),
        ("filter \"QUATERNION\"", |k, e| {
            if k == 0 {
                e["filter"] = serde_json::json!("QUATERNION")
            }
        }),
        ("lies outside its buffer", |k, e| {
            if k == 1 {
                e["byteOffset"] = serde_json::json!(1u64 << 40)
            }
        }),
        ("over 4 GiB", |k, e| {
            if k == 0 {
                e["count"] = serde_json::json!(1u64 << 40)
            }
        }),
    ];
    for (i, (expected, edit)) in edits.iter().enumerate() {
        let path = write(dir.path(), &format!("m{i}.gltf"), meshopt_gltf(6, false, edit).as_bytes());
        let text = std::panic::catch_unwind(|| error_text(&path)).unwrap_or_else(|_| panic!("case {i} panicked"));
        assert!(text.contains(expected) && text.contains("EXT_meshopt_compression"), "case {i}: {text}");
    }
}

/// The shared third-party scenes, when `../shared/scenes` is there.
use crate::testing::shared_scene as shared;

#[test]
fn shared_scenes_load_with_their_documented_sizes() {
    let cases = [
        ("cornell_box/CornellBox-Original.obj", 36, 0),
        ("stanford_bunny/bun_zipper.ply", 69_451, 0),
        ("sponza_dabrovic/sponza.obj", 66_450, 1),
        ("sponza_crytek/sponza_crytek.obj", 236_809, 1),
    ];
    for (relative, triangles, min_textures) in cases {
        let Some(path) = shared(relative) else { continue };
        let scene = load_default(&path).unwrap();
        let dropped = scene.stats.dropped_degenerate + scene.stats.dropped_non_finite;
        assert_eq!(scene.triangles.len() + dropped, triangles, "{relative}");
        assert!(dropped * 100 < triangles.max(100), "{relative}: dropped {dropped}");
        assert!(scene.textures.len() >= min_textures, "{relative}");
        assert_eq!(scene.stats.missing_textures, 0, "{relative}");
    }
}

#[test]
fn hostile_gltf_accessors_are_errors_not_panics() {
    // Accessors that claim more data than their buffers hold, or index past the vertices.
    let dir = tempfile::tempdir().unwrap();
    let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect();
    let uri = format!("data:application/octet-stream;base64,{}", base64_encode(&positions));
    let make = |count: u32, view_length: u32, buffer_length: u32| {
        serde_json::json!({
            "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]}],
            "bufferViews": [{"buffer": 0, "byteLength": view_length}],
            "buffers": [{"byteLength": buffer_length, "uri": uri}]
        })
        .to_string()
    };
    for (i, (count, view, buffer)) in [(300, 36, 36), (3, 3600, 36), (3, 36, 3600), (1_000_000_000, 36, 36)].into_iter().enumerate() {
        let path = write(dir.path(), &format!("h{i}.gltf"), make(count, view, buffer).as_bytes());
        let result = std::panic::catch_unwind(|| load_default(&path));
        let result = result.unwrap_or_else(|_| panic!("case {i} panicked"));
        assert!(result.is_err(), "case {i} loaded");
    }
    // A stride under the element's size (found by fuzzing: gltf's reader
    // asserts on it in debug builds and reads overlapping elements otherwise).
    let mut overlapping: serde_json::Value = serde_json::from_str(&make(2, 36, 36)).unwrap();
    overlapping["bufferViews"][0]["byteStride"] = serde_json::json!(8);
    let path = write(dir.path(), "stride.gltf", overlapping.to_string().as_bytes());
    let text = std::panic::catch_unwind(|| error_text(&path)).expect("no panic");
    assert!(text.contains("8 bytes apart"), "{text}");
    // Images with no source, or a buffer view and no MIME type (found by
    // fuzzing: gltf's validation lets both through and `Image::source`
    // unwraps them).
    for (i, image) in [serde_json::json!({"name": "no uri"}), serde_json::json!({"bufferView": 0})].into_iter().enumerate() {
        let mut json: serde_json::Value = serde_json::from_str(&make(3, 36, 36)).unwrap();
        json["images"] = serde_json::json!([image]);
        let path = write(dir.path(), &format!("image{i}.gltf"), json.to_string().as_bytes());
        let text = std::panic::catch_unwind(|| error_text(&path)).expect("no panic");
        assert!(text.contains("image 0 has"), "{text}");
    }
}

#[test]
fn gltf_uris_naming_devices_or_undecodable_names_are_errors_not_hangs() {
    // gltf reads a named file whole (/dev/zero never ends) and panics on a
    // URI whose %-escapes are not UTF-8.
    let dir = tempfile::tempdir().unwrap();
    let data = format!("data:application/octet-stream;base64,{}", base64_encode(&[0u8; 36]));
    let gltf = |buffer_uri: &str, image_uri: Option<&str>| {
        let mut json = serde_json::json!({
            "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [0.0,0.0,0.0]}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "buffers": [{"byteLength": 36, "uri": buffer_uri}]
        });
        if let Some(uri) = image_uri {
            json["images"] = serde_json::json!([{"uri": uri}]);
        }
        json.to_string()
    };
    let cases = [
        (gltf("../../../../../../../../../dev/zero", None), "not a regular file"),
        (gltf("file:///dev/zero", None), "not a regular file"),
        (gltf(&data, Some("../../../../../../../../../dev/zero")), "not a regular file"),
        (gltf("%FF%FE.bin", None), "UTF-8"),
    ];
    for (i, (text, expected)) in cases.iter().enumerate() {
        let path = write(dir.path(), &format!("u{i}.gltf"), text.as_bytes());
        let message = error_text(&path);
        assert!(message.contains(expected), "case {i}: {message}");
    }
}

#[test]
fn textures_over_the_side_limit_are_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.obj");
    for (side, decodes) in [(MAX_TEXTURE_SIDE, true), (MAX_TEXTURE_SIDE + 1, false)] {
        let file = dir.path().join(format!("{side}.png"));
        image::GrayImage::new(side, 1).save(&file).unwrap();
        assert_eq!(decode_texture(&scene, &file).is_some(), decodes, "a texture {side} pixels wide");
    }
}

#[test]
fn gltf_accessors_of_the_wrong_type_or_empty_are_errors_not_panics() {
    // gltf 1.4 reads float indices into `unreachable!()` (found by fuzzing).
    let dir = tempfile::tempdir().unwrap();
    let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect();
    let uri = format!("data:application/octet-stream;base64,{}", base64_encode(&positions));
    let json = serde_json::json!({
        "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 0}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": uri}]
    });
    let path = write(dir.path(), "float_indices.gltf", json.to_string().as_bytes());
    assert!(error_text(&path).contains("(indices) holds Vec3 F32"), "{}", error_text(&path));
    // A count of 0 overflowed gltf's reader.
    let mut json = json;
    json["meshes"][0]["primitives"][0].as_object_mut().unwrap().remove("indices");
    json["accessors"][0]["count"] = 0.into();
    let path = write(dir.path(), "no_positions.gltf", json.to_string().as_bytes());
    assert!(error_text(&path).contains("count of 0"), "{}", error_text(&path));
}

#[test]
fn files_over_the_triangle_limit_or_claiming_absurd_counts_fail_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    let limit = |n| LoadOptions { max_triangles: n, ..Default::default() };
    let quad = write(dir.path(), "quad.obj", QUAD_OBJ.as_bytes());
    assert!(load(&quad, &limit(2)).is_ok());
    let message = load(&quad, &limit(1)).unwrap_err().to_string();
    assert!(message.contains("holds 2 triangles") && message.contains("--max-triangles 2"), "{message}");
    // A PLY header may claim anything; its counts are checked before the payload.
    let header = |vertices: u64, faces: u64| {
        format!("ply\nformat binary_little_endian 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\nelement face {faces}\nproperty list uchar int vertex_indices\nend_header\n")
    };
    let huge = write(dir.path(), "huge.ply", header(1 << 31, 1).as_bytes());
    assert!(error_text(&huge).contains("declares 2147483648 'vertex' elements"), "{}", error_text(&huge));
    let mut many = header(3, 40).into_bytes();
    many.resize(many.len() + 36 + 40 * 13, 0);
    let many = write(dir.path(), "many.ply", &many);
    assert!(load(&many, &limit(39)).unwrap_err().to_string().contains("holds 40 triangles"));
    // glTF: a node graph naming one child ten times at each of 30 levels
    // instances its triangle 10^30 times; counted without walking it.
    let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect();
    let uri = format!("data:application/octet-stream;base64,{}", base64_encode(&positions));
    let mut nodes: Vec<serde_json::Value> = (0..30).map(|i| serde_json::json!({"children": vec![i + 1; 10]})).collect();
    nodes.push(serde_json::json!({"mesh": 0}));
    let json = serde_json::json!({
        "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0,0.0,0.0], "max": [1.0,1.0,0.0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": uri}]
    });
    let nested = write(dir.path(), "nested.gltf", json.to_string().as_bytes());
    let started = std::time::Instant::now();
    assert!(error_text(&nested).contains("node instances"), "{}", error_text(&nested));
    assert!(started.elapsed().as_secs() < 5);
    let mut json = json;
    json["nodes"] = serde_json::json!([{"children": vec![1; 100]}, {"mesh": 0}]);
    let hundred = write(dir.path(), "hundred.gltf", json.to_string().as_bytes());
    assert_eq!(load(&hundred, &limit(100)).unwrap().triangles.len(), 100);
    assert!(load(&hundred, &limit(99)).unwrap_err().to_string().contains("holds 100 triangles"));
}

#[test]
fn obj_face_indices_far_out_of_range_are_errors_not_panics() {
    // tobj 4.0.5 multiplies a normal index unchecked (found by fuzzing).
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "far.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-21 2//1 3//1\n");
    let result = std::panic::catch_unwind(|| load_default(&path)).expect("no panic escapes the loader");
    // (Debug builds catch tobj's overflow, release builds its bounds check.)
    let error = result.unwrap_err().to_string();
    assert!(error.contains("out of range") || error.contains("out of bounds"), "{error}");
}
