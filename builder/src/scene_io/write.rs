//! Writes a [`Scene`] out as OBJ (+ MTL + PNG textures) or as a single GLB, so
//! the built-in scenes can be opened in other tools and fed back to the
//! loaders. Every file is written atomically.

use crate::files::write_atomic;
use exploremaps_scenes::{AlphaMode, Light, Scene};
use glam::{Quat, Vec3};
use serde_json::json;
use std::fmt::Write as _;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("cannot write {path}")]
    Io { path: String, source: std::io::Error },
    #[error("cannot encode texture {name}")]
    Encode { name: String, source: image::ImageError },
    #[error("{0}: unknown export format; use a .obj or .glb file name")]
    Format(String),
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ExportError + '_ {
    move |source| ExportError::Io { path: path.display().to_string(), source }
}

fn png(scene: &Scene, index: usize) -> Result<Vec<u8>, ExportError> {
    let texture = &scene.textures[index];
    let mut bytes = Vec::new();
    texture
        .image
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|source| ExportError::Encode { name: texture.name.clone(), source })?;
    Ok(bytes)
}

/// Writes by extension: `.obj` or `.glb`.
pub fn export(scene: &Scene, path: &Path) -> Result<(), ExportError> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("obj") => write_obj(scene, path),
        Some("glb") => write_glb(scene, path),
        _ => Err(ExportError::Format(path.display().to_string())),
    }
}

/// OBJ with an MTL beside it and textures in `<stem>_textures/`.
pub fn write_obj(scene: &Scene, path: &Path) -> Result<(), ExportError> {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    let dir = path.parent().unwrap_or(Path::new("."));
    let texture_dir = format!("{stem}_textures");
    for i in 0..scene.textures.len() {
        let file = dir.join(&texture_dir).join(format!("texture_{i}.png"));
        write_atomic(&file, &png(scene, i)?).map_err(io(&file))?;
    }
    let mut mtl = String::new();
    for m in &scene.materials {
        let [r, g, b, a] = m.base_color;
        let _ = writeln!(mtl, "newmtl {}\nKd {r} {g} {b}\nd {a}", m.name.replace(char::is_whitespace, "_"));
        if m.emissive != glam::Vec3::ZERO {
            let _ = writeln!(mtl, "Ke {} {} {}", m.emissive.x, m.emissive.y, m.emissive.z);
        }
        if let Some(t) = m.base_color_texture {
            let _ = writeln!(mtl, "map_Kd {texture_dir}/texture_{t}.png");
            if matches!(m.alpha_mode, AlphaMode::Mask { .. }) {
                let _ = writeln!(mtl, "map_d {texture_dir}/texture_{t}.png");
            }
        }
        mtl.push('\n');
    }
    let mtl_path = dir.join(format!("{stem}.mtl"));
    write_atomic(&mtl_path, mtl.as_bytes()).map_err(io(&mtl_path))?;

    let mut obj = String::with_capacity(scene.positions.len() * 80 + scene.triangles.len() * 40);
    let _ = writeln!(obj, "# {} exported by ExploreMaps ({} metres per unit)\nmtllib {stem}.mtl", scene.name, scene.metres_per_unit);
    // Vertex colours as the common `v x y z r g b` extension, sRGB as it is read.
    for (i, p) in scene.positions.iter().enumerate() {
        match scene.colours.get(i) {
            Some(c) => {
                let [r, g, b] = c.to_array().map(|x| crate::colour::linear_to_srgb(x) as f32 / 255.0);
                let _ = writeln!(obj, "v {} {} {} {r} {g} {b}", p.x, p.y, p.z);
            }
            None => {
                let _ = writeln!(obj, "v {} {} {}", p.x, p.y, p.z);
            }
        }
    }
    for t in &scene.uvs {
        let _ = writeln!(obj, "vt {} {}", t.x, 1.0 - t.y);
    }
    for n in &scene.normals {
        let _ = writeln!(obj, "vn {} {} {}", n.x, n.y, n.z);
    }
    let (has_uv, has_n) = (!scene.uvs.is_empty(), !scene.normals.is_empty());
    let (mut object, mut material) = (u32::MAX, u32::MAX);
    for ((tri, &o), &m) in scene.triangles.iter().zip(&scene.triangle_object).zip(&scene.triangle_material) {
        if o != object {
            object = o;
            let _ = writeln!(obj, "o {}", scene.objects[o as usize].replace(char::is_whitespace, "_"));
            material = u32::MAX;
        }
        if m != material {
            material = m;
            let _ = writeln!(obj, "usemtl {}", scene.materials[m as usize].name.replace(char::is_whitespace, "_"));
        }
        obj.push('f');
        for &i in tri {
            let i = i + 1;
            let _ = match (has_uv, has_n) {
                (true, true) => write!(obj, " {i}/{i}/{i}"),
                (true, false) => write!(obj, " {i}/{i}"),
                (false, true) => write!(obj, " {i}//{i}"),
                (false, false) => write!(obj, " {i}"),
            };
        }
        obj.push('\n');
    }
    write_atomic(path, obj.as_bytes()).map_err(io(path))
}

/// A single binary glTF with embedded PNG textures, one primitive per material.
pub fn write_glb(scene: &Scene, path: &Path) -> Result<(), ExportError> {
    let mut glb = Glb::default();
    let attributes = vertex_attributes(&mut glb, scene);
    let primitives = primitives(&mut glb, scene, &attributes);
    let mut images = Vec::new();
    for i in 0..scene.textures.len() {
        let view = glb.view(&png(scene, i)?, None);
        images.push(json!({ "bufferView": view, "mimeType": "image/png", "name": scene.textures[i].name }));
    }
    let materials: Vec<_> = scene.materials.iter().map(gltf_material).collect();
    let textures: Vec<_> = (0..scene.textures.len()).map(|i| json!({ "source": i })).collect();
    let (nodes, lights) = light_nodes(scene);
    let mut document = json!({
        "asset": { "version": "2.0", "generator": "ExploreMaps" },
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": [{ "primitives": primitives }],
        "materials": materials,
        "textures": textures,
        "images": images,
    });
    if !lights.is_empty() {
        document["extensionsUsed"] = json!(["KHR_materials_emissive_strength", "KHR_lights_punctual"]);
        document["extensions"] = json!({ "KHR_lights_punctual": { "lights": lights } });
    }
    write_atomic(path, &glb.finish(document)).map_err(io(path))
}

fn floats(v: &mut dyn Iterator<Item = f32>) -> Vec<u8> {
    v.flat_map(f32::to_le_bytes).collect()
}

/// The scene's vertex attributes, each in a view of its own: a primitive's
/// `attributes`.
fn vertex_attributes(glb: &mut Glb, scene: &Scene) -> serde_json::Value {
    let bounds = scene.bounds();
    let view = glb.view(&floats(&mut scene.positions.iter().flat_map(|p| p.to_array())), Some(ARRAY_BUFFER));
    let positions = glb.accessor(json!({ "bufferView": view, "componentType": FLOAT, "count": scene.positions.len(), "type": "VEC3",
        "min": bounds.min.to_array(), "max": bounds.max.to_array() }));
    let mut attributes = json!({ "POSITION": positions });
    if !scene.normals.is_empty() {
        let view = glb.view(&floats(&mut scene.normals.iter().flat_map(|n| n.to_array())), Some(ARRAY_BUFFER));
        attributes["NORMAL"] =
            json!(glb.accessor(json!({ "bufferView": view, "componentType": FLOAT, "count": scene.normals.len(), "type": "VEC3" })));
    }
    if !scene.uvs.is_empty() {
        let view = glb.view(&floats(&mut scene.uvs.iter().flat_map(|t| t.to_array())), Some(ARRAY_BUFFER));
        attributes["TEXCOORD_0"] =
            json!(glb.accessor(json!({ "bufferView": view, "componentType": FLOAT, "count": scene.uvs.len(), "type": "VEC2" })));
    }
    if !scene.colours.is_empty() {
        // glTF's vertex colours are linear, as the scene keeps them.
        let view = glb.view(&floats(&mut scene.colours.iter().flat_map(|c| c.to_array())), Some(ARRAY_BUFFER));
        attributes["COLOR_0"] =
            json!(glb.accessor(json!({ "bufferView": view, "componentType": FLOAT, "count": scene.colours.len(), "type": "VEC3" })));
    }
    attributes
}

/// One primitive per material that has triangles, sharing the attributes.
fn primitives(glb: &mut Glb, scene: &Scene, attributes: &serde_json::Value) -> Vec<serde_json::Value> {
    let mut primitives = Vec::new();
    for m in 0..scene.materials.len() as u32 {
        let indices: Vec<u8> = scene
            .triangles
            .iter()
            .zip(&scene.triangle_material)
            .filter(|(_, &tm)| tm == m)
            .flat_map(|(t, _)| t.iter().flat_map(|i| i.to_le_bytes()))
            .collect();
        if indices.is_empty() {
            continue;
        }
        let view = glb.view(&indices, Some(ELEMENT_ARRAY_BUFFER));
        let accessor = glb.accessor(json!({ "bufferView": view, "componentType": UNSIGNED_INT, "count": indices.len() / 4, "type": "SCALAR" }));
        primitives.push(json!({ "attributes": attributes, "indices": accessor, "material": m }));
    }
    primitives
}

/// A material as glTF: base colour, emission (its strength above 1 as
/// `KHR_materials_emissive_strength`), alpha mode.
fn gltf_material(m: &exploremaps_scenes::Material) -> serde_json::Value {
    let mut pbr = json!({ "baseColorFactor": m.base_color, "metallicFactor": 0.0, "roughnessFactor": 1.0 });
    if let Some(t) = m.base_color_texture {
        pbr["baseColorTexture"] = json!({ "index": t });
    }
    let peak = m.emissive.max_element();
    let mut out = json!({ "name": m.name, "pbrMetallicRoughness": pbr });
    if peak > 0.0 {
        let factor = if peak > 1.0 { m.emissive / peak } else { m.emissive };
        out["emissiveFactor"] = json!(factor.to_array());
        if peak > 1.0 {
            out["extensions"] = json!({ "KHR_materials_emissive_strength": { "emissiveStrength": peak } });
        }
    }
    match m.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask { cutoff } => {
            out["alphaMode"] = json!("MASK");
            out["alphaCutoff"] = json!(cutoff);
        }
        AlphaMode::Blend => out["alphaMode"] = json!("BLEND"),
    }
    out
}

/// The nodes (the mesh's first) and the lights as `KHR_lights_punctual`,
/// each on a node of its own, in candela and lux at the loader's 683 lumens
/// a watt (so they load back as they are).
fn light_nodes(scene: &Scene) -> (Vec<serde_json::Value>, Vec<serde_json::Value>) {
    let mut nodes = vec![json!({ "mesh": 0, "name": scene.name })];
    let mut lights = Vec::new();
    for light in &scene.lights {
        let (mut node, kind, power) = match *light {
            Light::Point { position, intensity } => (json!({ "translation": position.to_array() }), "point", intensity),
            // The light shines along its node's -Z: turn +Z to the sun.
            Light::Sun { direction, irradiance } => {
                (json!({ "rotation": Quat::from_rotation_arc(Vec3::Z, direction.normalize()).to_array() }), "directional", irradiance)
            }
        };
        let peak = power.max_element().max(f32::MIN_POSITIVE);
        lights.push(json!({ "type": kind, "color": (power / peak).to_array(), "intensity": peak * crate::scene_io::LUMENS_PER_WATT }));
        node["extensions"] = json!({ "KHR_lights_punctual": { "light": lights.len() - 1 } });
        nodes.push(node);
    }
    (nodes, lights)
}

/// A vertex-coloured mesh (a proxy level) as a glTF binary: positions, linear vertex colours
/// (`COLOR_0`, from the baked sRGB ones), triangles, one unlit material
/// (`KHR_materials_unlit`: the colours already hold the lighting).
pub fn unlit_mesh_glb(name: &str, positions: &[glam::Vec3], triangles: &[[u32; 3]], colours: &[[u8; 3]]) -> Vec<u8> {
    let mut glb = Glb::default();
    let (lo, hi) = positions.iter().fold((glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let (lo, hi) = if positions.is_empty() { (glam::Vec3::ZERO, glam::Vec3::ZERO) } else { (lo, hi) };
    let view = glb.view(&floats(&mut positions.iter().flat_map(|p| p.to_array())), Some(ARRAY_BUFFER));
    let position = glb.accessor(
        json!({ "bufferView": view, "componentType": FLOAT, "count": positions.len(), "type": "VEC3", "min": lo.to_array(), "max": hi.to_array() }),
    );
    let mut attributes = json!({ "POSITION": position });
    if colours.len() == positions.len() {
        let linear = floats(&mut colours.iter().flat_map(|c| c.map(crate::colour::srgb_to_linear)));
        let view = glb.view(&linear, Some(ARRAY_BUFFER));
        attributes["COLOR_0"] = json!(glb.accessor(json!({ "bufferView": view, "componentType": FLOAT, "count": colours.len(), "type": "VEC3" })));
    }
    let indices: Vec<u8> = triangles.iter().flat_map(|t| t.iter().flat_map(|i| i.to_le_bytes())).collect();
    let view = glb.view(&indices, Some(ELEMENT_ARRAY_BUFFER));
    let accessor = glb.accessor(json!({ "bufferView": view, "componentType": UNSIGNED_INT, "count": triangles.len() * 3, "type": "SCALAR" }));
    let document = json!({
        "asset": { "version": "2.0", "generator": "ExploreMaps" },
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "name": name }],
        "meshes": [{ "primitives": [{ "attributes": attributes, "indices": accessor, "material": 0 }] }],
        "materials": [{ "name": "baked", "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 },
            "extensions": { "KHR_materials_unlit": {} } }],
    });
    glb.finish(document)
}

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// A glTF binary being put together: buffer views and accessors over one
/// binary chunk. (The `gltf` crate reads GLB; writing one is a few lines.)
#[derive(Default)]
struct Glb {
    bin: Vec<u8>,
    views: Vec<serde_json::Value>,
    accessors: Vec<serde_json::Value>,
}

impl Glb {
    /// Appends `bytes` as a buffer view, 4-byte aligned; returns its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut view = json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(view);
        self.views.len() - 1
    }

    fn accessor(&mut self, accessor: serde_json::Value) -> usize {
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// The file: `document` with the accessors, views and buffer added.
    fn finish(mut self, mut document: serde_json::Value) -> Vec<u8> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        document["accessors"] = json!(self.accessors);
        document["bufferViews"] = json!(self.views);
        document["buffers"] = json!([{ "byteLength": self.bin.len() }]);
        let mut text = serde_json::to_vec(&document).expect("JSON of plain values");
        while !text.len().is_multiple_of(4) {
            text.push(b' ');
        }
        let total = 12 + 8 + text.len() + 8 + self.bin.len();
        let mut glb = Vec::with_capacity(total);
        glb.extend_from_slice(b"glTF");
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&(total as u32).to_le_bytes());
        glb.extend_from_slice(&(text.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"JSON");
        glb.extend_from_slice(&text);
        glb.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"BIN\0");
        glb.extend_from_slice(&self.bin);
        glb
    }
}
