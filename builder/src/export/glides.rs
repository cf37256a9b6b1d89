//! An exported tour's glides: for each path drawn as a glide (no video),
//! the panoramas it draws from (its ends' and those part way) as cube faces
//! and depth, for `transition.js` to reproject in WebGL 2 as the viewer does.
//!
//! ```text
//! glide/<source>/<face>.jpg   the cube faces, +X, −X, +Y, −Y, +Z, −Z (a probe's smallest level)
//! glide/<source>.depth        its depth cube's codes, little-endian 16-bit, corner by corner
//! ```
//! A source is `p<probe>` or `w<path>-<k>` (the k-th panorama part way).

use super::{copy, write, TourError};
use exploremaps_format::depthcube::DepthCube;
use exploremaps_format::{CubeLevel, GlideSource, Graph, Path as PathInfo, TransitionKind, CUBE_FACES};
use serde_json::{json, Map, Value};
use std::path::Path;

/// Whether the path is drawn as a glide.
fn glides(path: &PathInfo) -> bool {
    path.assets.video.is_none() && path.assets.transition.as_ref().is_some_and(|t| t.kind == TransitionKind::Depth)
}

fn name(path: &PathInfo, source: GlideSource) -> String {
    match source {
        GlideSource::Probe(p) => format!("p{p}"),
        GlideSource::Waypoint(k) => format!("w{}-{k}", path.id),
    }
}

/// Copies every source a glide of `graph` draws from into `dir`; the sources
/// by name (position, faces, depth and its lattice) and the bytes written.
pub(super) fn write_sources(bundle: &Path, graph: &Graph, dir: &Path) -> Result<(Map<String, Value>, u64), TourError> {
    let (mut sources, mut bytes) = (Map::new(), 0);
    for path in graph.paths.iter().filter(|p| glides(p)) {
        for (source, _) in path.glide_sources(false) {
            let name = name(path, source);
            if sources.contains_key(&name) {
                continue;
            }
            let (position, cube, depth) = match source {
                GlideSource::Probe(p) => {
                    let probe = &graph.probes[p as usize];
                    let Some((cube, depth)) = probe.assets.cube_levels.iter().min_by_key(|l| l.size).zip(probe.assets.depth.as_ref()) else {
                        return Err(TourError::NotRendered(p));
                    };
                    (probe.position, cube, depth)
                }
                GlideSource::Waypoint(k) => {
                    let w = &path.assets.transition.as_ref().expect("a glide").waypoints[k];
                    (w.position, &w.cube, &w.depth)
                }
            };
            let (mut entry, written) = write_source(bundle, dir, &name, (cube, depth))?;
            bytes += written;
            entry.insert("position".into(), json!(position));
            sources.insert(name, Value::Object(entry));
        }
    }
    Ok((sources, bytes))
}

/// One source's faces and depth, written under `name`: its entry (less its
/// position) and the bytes written.
fn write_source(bundle: &Path, dir: &Path, name: &str, (cube, depth): (&CubeLevel, &String)) -> Result<(Map<String, Value>, u64), TourError> {
    let mut bytes = 0;
    let mut faces = Vec::new();
    for (file, face) in cube.faces.iter().zip(CUBE_FACES) {
        let to = format!("glide/{name}/{face}.jpg");
        bytes += copy(&bundle.join(file), dir, &to)?;
        faces.push(to);
    }
    let from = bundle.join(depth);
    let coded = std::fs::read(&from).map_err(super::io(&from))?;
    let cube = DepthCube::decode(&coded).map_err(|source| TourError::Depth { path: from.display().to_string(), source })?;
    let to = format!("glide/{name}.depth");
    bytes += write(dir, &to, &cube.codes.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>())?;
    let entry = json!({ "faces": faces, "depth": to, "cells": cube.size, "near": cube.near, "far": cube.far });
    Ok((entry.as_object().expect("an object").clone(), bytes))
}

/// The glide of a link along `path` (travelled `reversed`): its polyline
/// and its sources in the order travelled, each with the fraction of the
/// way where it stands; None where the path is not a glide.
pub(super) fn link(path: &PathInfo, reversed: bool) -> Option<Value> {
    if !glides(path) {
        return None;
    }
    let mut polyline = path.polyline.clone();
    if reversed {
        polyline.reverse();
    }
    let sources: Vec<Value> = path.glide_sources(reversed).into_iter().map(|(source, at)| json!([name(path, source), at])).collect();
    Some(json!({ "polyline": polyline, "sources": sources }))
}
