//! The proxy job: the light 3D stand-in of the scene (see `crate::proxy`),
//! simplified, coloured by the renderer's lighting, coded and written with
//! its point-to-go tables and depth cubes, listed last in `proxy/proxy.json`.

use crate::bundle::{write, BundleError};
use std::path::Path;

const PROXY_GLB: &str = "proxy/proxy.glb";
/// The most triangles of a proxy chunk: about 2 ms of decoding in a browser.
const CHUNK_TRIANGLES: usize = 7_000;
/// Triangles a packet of vertex splits brings back: applying one takes a
/// few milliseconds in a phone's browser (splits cost more a triangle to
/// decode than a level sent whole).
const PACKET_TRIANGLES: usize = 750;
/// Texels a face of a probe's point-to-go depth cube.
const DEPTH_MAP_SIZE: u32 = 32;
/// The proxy's entry for graph.json, written after its files: shards and
/// resumed runs find it there whoever made it.
pub(super) const PROXY_LIST: &str = "proxy/proxy.json";

/// The proxy's entry, if it and every file it lists are in the bundle.
pub(super) fn listed(dir: &Path) -> Option<exploremaps_format::Proxy> {
    let text = std::fs::read_to_string(dir.join(PROXY_LIST)).ok()?;
    let proxy: exploremaps_format::Proxy = serde_json::from_str(&text).ok()?;
    let complete = files(&proxy).iter().all(|f| dir.join(f).exists());
    complete.then_some(proxy)
}

pub(super) fn files(proxy: &exploremaps_format::Proxy) -> Vec<String> {
    let chunks = proxy.levels.iter().flat_map(|l| &l.chunks).flat_map(|c| std::iter::once(&c.file).chain(&c.seen));
    let listed = proxy.levels.iter().flat_map(|l| std::iter::once(&l.file).chain(&l.seen)).chain(&proxy.glb).chain(&proxy.depth_maps).chain(chunks);
    // Packets share files: each file once.
    listed.cloned().chain(proxy.stream.iter().flat_map(|s| s.files().into_iter().map(|(file, _)| file))).collect()
}

/// The proxy's levels simplified from the scene, coloured by the renderer's
/// lighting, coded into `proxy/<level>.emmc` with its point-to-go table in
/// `proxy/<level>.seen`, the finest also as a GLB, then listed in
/// `proxy/proxy.json`.
pub(super) fn render(
    dir: &Path,
    scene: &exploremaps_scenes::Scene,
    graph: &exploremaps_format::Graph,
    renderer: &crate::tracer::Renderer,
    params: &crate::proxy::ProxyParams,
) -> Result<(), BundleError> {
    use exploremaps_format::{meshcode, seen, Proxy, ProxyChunk, ProxyLevel, ProxyStream};
    let started = std::time::Instant::now();
    // The storeys the dollhouse can cut at (graph.json is validated when read, so an error here is a bug).
    let floors = graph.stats.floors().map_err(exploremaps_format::FormatError::Invalid)?.iter().map(|f| f.height).collect();
    let mut proxy = Proxy { levels: Vec::new(), glb: None, floors, depth_maps: Vec::new(), stream: None };
    let probes: Vec<glam::Vec3> = graph.probes.iter().map(|p| glam::Vec3::from(p.position)).collect();
    // Point-to-go from panoramas: a 32² depth cube a probe (a few KB), from
    // the near distance to twice the scene's size.
    let diagonal = scene.bounds().diagonal();
    let near = graph.scene.near_distance.unwrap_or(1e-3 * diagonal).max(1e-4 * diagonal);
    let mut depth_bytes = 0;
    for (id, &eye) in probes.iter().enumerate() {
        let empty = exploremaps_format::depthmap::DepthMap { size: DEPTH_MAP_SIZE, near, far: 2.0 * diagonal, depth: Vec::new(), best: Vec::new() };
        let map = crate::proxy::seen::depth_map(renderer.tracer.rays, eye, &probes, empty, 1e-4 * diagonal).encode();
        let file = format!("proxy/depth/{id}.emdm");
        write(dir, &file, &map)?;
        depth_bytes += map.len();
        proxy.depth_maps.push(file);
    }
    // The finer level's colours and table, for the stream that rebuilds it.
    let mut finer: Option<(Vec<[u8; 3]>, Vec<u32>)> = None;
    for (i, level) in crate::proxy::levels(scene, params).into_iter().enumerate() {
        let colours = crate::proxy::bake::bake(renderer, &level.mesh, level.error, params.bake_samples, i as u64);
        let best = crate::proxy::seen::best_probes(renderer.tracer.rays, &level.mesh, &probes, level.error);
        // A large level in spatial chunks (a viewer decodes one between two frames).
        let parts = crate::proxy::chunks(&level.mesh, CHUNK_TRIANGLES);
        let mut chunks = Vec::new();
        // A level in one part: its bytes and decoded order, for its stream.
        let mut whole = None;
        for (c, triangles) in parts.iter().enumerate() {
            let name = if parts.len() == 1 { format!("proxy/{i}") } else { format!("proxy/{i}-{c}") };
            let (mesh, was) = level.mesh.subset(triangles);
            let mut data = mesh.to_coded();
            data.colours = was.iter().map(|&v| colours[v as usize]).collect();
            let file = format!("{name}.emmc");
            let coded =
                meshcode::encode(&data, params.bits).map_err(|e| BundleError::Proxy { path: dir.join(&file).display().to_string(), source: e })?;
            write(dir, &file, &coded.bytes)?;
            let seen_file = format!("{name}.seen");
            write(dir, &seen_file, &seen::encode(&coded.order.triangles.iter().map(|&t| best[triangles[t as usize]]).collect::<Vec<u32>>()))?;
            chunks.push(ProxyChunk { file, seen: Some(seen_file), triangles: triangles.len() as u64, bytes: coded.bytes.len() as u64 });
            if parts.len() == 1 {
                // Decoded vertex and triangle k are the level's `vertices[k]` and `triangles[k]`.
                let vertices = coded.order.vertices.iter().map(|&v| was[v as usize]).collect();
                whole = Some(CodedWhole {
                    bytes: coded.bytes,
                    vertices,
                    triangles: coded.order.triangles.iter().map(|&t| triangles[t as usize] as u32).collect(),
                });
            }
        }
        if i == 0 {
            write(dir, PROXY_GLB, &crate::scene_io::write::unlit_mesh_glb(&scene.name, &level.mesh.positions, &level.mesh.triangles, &colours))?;
            proxy.glb = Some(PROXY_GLB.to_string());
        }
        let (triangles, vertices) = (level.mesh.triangles.len() as u64, level.mesh.positions.len() as u64);
        let (file, seen) = (chunks[0].file.clone(), chunks[0].seen.clone());
        let bytes = chunks.iter().map(|c| c.bytes).sum();
        let chunks = if chunks.len() > 1 { chunks } else { Vec::new() };
        // A level coded whole that refines into the one before it: its vertex splits.
        if let (Some(stream), Some((finer_colours, finer_best)), Some(whole)) = (level.refines, finer.take(), whole) {
            let packets = write_splits(dir, (&file, whole, &best), stream, (&finer_colours, &finer_best), probes.len() as u32, params.bits)?;
            proxy.stream = Some(ProxyStream { from: i, to: i - 1, packets });
        }
        finer = Some((colours, best));
        proxy.levels.push(ProxyLevel { file, triangles, vertices, error: level.error, bytes, seen, chunks });
    }
    let sizes: Vec<String> = proxy.levels.iter().map(|l| format!("{} triangles in {} bytes", l.triangles, l.bytes)).collect();
    tracing::info!(
        "proxy: {}; depth maps {} bytes a probe ({:.2} s)",
        sizes.join(", "),
        depth_bytes / probes.len().max(1),
        started.elapsed().as_secs_f64()
    );
    write(dir, PROXY_LIST, serde_json::to_string_pretty(&proxy).expect("JSON of plain values").as_bytes())
}

/// A level coded in one part: its bytes, and per decoded vertex and
/// triangle, the level's.
struct CodedWhole {
    bytes: Vec<u8>,
    vertices: Vec<u32>,
    triangles: Vec<u32>,
}

/// Writes the vertex splits that rebuild the finer level from `coarse` (its
/// file, its coded bytes with their decoded vertex and triangle order, and
/// its point-to-go table per level triangle) as `proxy/splits-<k>.emvs`:
/// packets of `PACKET_TRIANGLES` (a few ms each to apply), a file bringing
/// back a chunk's worth. Triangle groups carry the point-to-go entries
/// (the probe count for none): the coarse level's, then `finer`'s (colours
/// per vertex and table per triangle of the finer level).
fn write_splits(
    dir: &Path,
    coarse: (&str, CodedWhole, &[u32]),
    mut stream: crate::proxy::progressive::Progressive,
    finer: (&[[u8; 3]], &[u32]),
    probes: u32,
    bits: u32,
) -> Result<Vec<exploremaps_format::ProxyPacket>, BundleError> {
    use exploremaps_format::{meshcode, splits, ProxyPacket};
    let (file, CodedWhole { bytes, vertices, triangles }, best) = coarse;
    let fail =
        |file: &str, e: exploremaps_format::edgebreaker::CodingError| BundleError::Proxy { path: dir.join(file).display().to_string(), source: e };
    // The coder predicts from the coarse level exactly as a viewer decodes it.
    let mut base = meshcode::decode(&bytes).map_err(|e| fail(file, e))?;
    base.groups = triangles.iter().map(|&t| best[t as usize].min(probes)).collect();
    stream.renumber_base(&vertices, &triangles);
    stream.colour(finer.0);
    stream.regroup(&finer.1.iter().map(|&p| p.min(probes)).collect::<Vec<u32>>());
    let packets = splits::encode(&base, &stream.refinements, bits, PACKET_TRIANGLES).map_err(|e| fail("proxy/splits-0.emvs", e))?;
    let (mut listed, mut file_bytes, mut files, mut first) = (Vec::new(), Vec::new(), 0, base.triangles.len() as u64);
    for (k, packet) in packets.iter().enumerate() {
        let file = format!("proxy/splits-{files}.emvs");
        listed.push(ProxyPacket {
            file: file.clone(),
            offset: file_bytes.len() as u64,
            bytes: packet.bytes.len() as u64,
            triangles: packet.triangles,
        });
        file_bytes.extend_from_slice(&packet.bytes);
        if packet.triangles - first >= CHUNK_TRIANGLES as u64 || k + 1 == packets.len() {
            write(dir, &file, &std::mem::take(&mut file_bytes))?;
            (files, first) = (files + 1, packet.triangles);
        }
    }
    Ok(listed)
}
