//! PLY (ASCII and binary, either endianness) through `ply-rs-bw`: `vertex`
//! elements with x, y, z (and optional nx, ny, nz, u, v / s, t and red, green,
//! blue), `face`
//! elements with a `vertex_indices` (or `vertex_index`) list, fan-triangulated.

use super::obj::empty_scene;
use super::{check_triangle_count, LoadError};
use crate::colour::{srgb_decode, srgb_to_linear};
use exploremaps_scenes::{Material, Scene};
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use std::path::Path;

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

fn index_list(p: &Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUChar(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListShort(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUShort(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListInt(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUInt(v) => v.iter().map(|&i| i as i64).collect(),
        _ => return None,
    })
}

/// A vertex's colour, linear, from the properties `names` (red, green, blue):
/// bytes as sRGB-encoded 0-255 as scanners write them, floats as 0-1 sRGB.
fn colour(v: &DefaultElement, names: &[&str; 3]) -> Option<Vec3> {
    let channel = |name: &str| match *v.get(name)? {
        Property::UChar(b) => Some(srgb_to_linear(b)),
        Property::UShort(s) => Some(srgb_decode(s as f32 / 65535.0)),
        Property::Float(f) => Some(srgb_decode(f.clamp(0.0, 1.0))),
        Property::Double(f) => Some(srgb_decode((f as f32).clamp(0.0, 1.0))),
        _ => None,
    };
    Some(Vec3::new(channel(names[0])?, channel(names[1])?, channel(names[2])?))
}

pub(super) fn load(path: &Path, bytes: &[u8], max_triangles: u64) -> Result<Scene, LoadError> {
    let parser = Parser::<DefaultElement>::new();
    let bad = |e: ply_rs_bw::parser::ParseError| LoadError::malformed(path, format!("not a valid PLY file ({e}); it may be truncated or corrupt"));
    let mut reader = ply_rs_bw::parser::Reader::new(std::io::BufReader::new(std::io::Cursor::new(bytes)));
    let header = parser.read_header(&mut reader).map_err(bad)?;
    // The header's counts, checked before the payload is read: every element
    // takes at least a byte, and every face makes at least one triangle.
    for element in header.elements.values() {
        if element.count > bytes.len() {
            return Err(LoadError::malformed(
                path,
                format!(
                    "its header declares {} '{}' elements in a file of {} bytes; the file is truncated or its header is wrong",
                    element.count,
                    element.name,
                    bytes.len()
                ),
            ));
        }
    }
    check_triangle_count(path, header.elements.get("face").map_or(0, |f| f.count as u64), max_triangles)?;
    let payload = parser.read_payload(&mut reader, &header).map_err(bad)?;
    let vertices = payload.get("vertex").ok_or_else(|| LoadError::malformed(path, "no 'vertex' element in the header"))?;
    let faces = payload.get("face").map(Vec::as_slice).unwrap_or(&[]);
    let get = |e: &DefaultElement, key: &str| e.get(key).and_then(scalar);

    let mut scene = empty_scene(vec![Material::diffuse("default", [0.75, 0.75, 0.75])], Vec::new());
    scene.objects.push(path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default());
    let mut has_normals = true;
    let mut uvs = Vec::new();
    let mut colours = Vec::new();
    // The colour properties' names, from the header: `red` or `diffuse_red`, ….
    let declared = |name: &str| header.elements.get("vertex").is_some_and(|e| e.properties.contains_key(name));
    let names = if declared("red") {
        Some(["red", "green", "blue"])
    } else {
        declared("diffuse_red").then_some(["diffuse_red", "diffuse_green", "diffuse_blue"])
    };
    for (i, v) in vertices.iter().enumerate() {
        let (Some(x), Some(y), Some(z)) = (get(v, "x"), get(v, "y"), get(v, "z")) else {
            return Err(LoadError::malformed(path, format!("vertex {i} lacks numeric x, y, z properties")));
        };
        scene.positions.push(Vec3::new(x as f32, y as f32, z as f32));
        match (get(v, "nx"), get(v, "ny"), get(v, "nz")) {
            (Some(a), Some(b), Some(c)) if has_normals => scene.normals.push(Vec3::new(a as f32, b as f32, c as f32)),
            _ => has_normals = false,
        }
        let uv = (get(v, "u").or(get(v, "s")), get(v, "v").or(get(v, "t")));
        if let (Some(a), Some(b)) = uv {
            uvs.push(Vec2::new(a as f32, 1.0 - b as f32));
        }
        if let Some(c) = names.as_ref().and_then(|n| colour(v, n)) {
            colours.push(c);
        }
    }
    if colours.len() == scene.positions.len() {
        scene.colours = colours;
    }
    if !has_normals {
        scene.normals.clear();
    }
    if uvs.len() == scene.positions.len() {
        scene.uvs = uvs;
    }
    let n = scene.positions.len() as i64;
    for (f, face) in faces.iter().enumerate() {
        let Some(list) = face.get("vertex_indices").or(face.get("vertex_index")).and_then(index_list) else {
            return Err(LoadError::malformed(path, format!("face {f} has no vertex_indices list")));
        };
        if let Some(bad) = list.iter().find(|&&i| i < 0 || i >= n) {
            return Err(LoadError::malformed(path, format!("face {f} uses vertex index {bad}, but there are {n} vertices")));
        }
        for k in 1..list.len().saturating_sub(1) {
            scene.triangles.push([list[0] as u32, list[k] as u32, list[k + 1] as u32]);
            scene.triangle_material.push(0);
            scene.triangle_object.push(0);
        }
    }
    Ok(scene)
}
