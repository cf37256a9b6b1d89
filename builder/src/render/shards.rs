//! Split renders: shard `i` of `n` renders every `n`-th job and writes its
//! manifest (`shards/<i>-of-<n>.json`, its settings) after its assets;
//! [`finalize`] then checks the whole bundle and writes graph.json once.

use super::{list_assets, path, probe::ProbeFiles, proxy};
use crate::bundle::{write_graph, BundleError};
use exploremaps_format::record::{ShardManifest, Timings};
use std::path::Path;

/// Which assets a shard renders: job `k` (probes first, then paths, then the
/// proxy) belongs to shard `k % count`. Shards of a split render (count > 1)
/// never touch graph.json: each writes its assets and then its manifest,
/// `shards/<index>-of-<count>.json`; [`finalize`] checks the whole and writes
/// graph.json once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    pub(super) fn manifest(&self) -> String {
        format!("shards/{}-of-{}.json", self.index, self.count)
    }
}

/// Completes a split render: reads the shards' manifests, checks that every
/// shard finished and every asset exists and decodes (JPEGs whole, each
/// video's first frame, each proxy level), then writes graph.json. Otherwise
/// an error lists each problem with the shard that owns it, and graph.json is
/// not written; files that do not decode are removed, so running their
/// shard again redoes them. Running it again is harmless. Returns the files
/// checked.
pub fn finalize(dir: &Path, graph: &mut exploremaps_format::Graph) -> Result<usize, BundleError> {
    let incomplete = |problems: Vec<String>| BundleError::Incomplete { dir: dir.display().to_string(), problems };
    let mut manifests: Vec<ShardManifest> = Vec::new();
    let mut paths: Vec<std::path::PathBuf> = std::fs::read_dir(dir.join("shards")).into_iter().flatten().flatten().map(|e| e.path()).collect();
    paths.sort();
    for path in paths.into_iter().filter(|p| p.extension().is_some_and(|e| e == "json")) {
        manifests.push(ShardManifest::read(&path).map_err(|e| incomplete(vec![e]))?);
    }
    let Some(first) = manifests.first() else {
        return Err(incomplete(vec!["no shard has finished (shards/ holds no manifest)".into()]));
    };
    let count = first.count;
    let mut problems = Vec::new();
    if let Some(odd) = manifests.iter().find(|m| m.count != first.count || m.render != first.render || m.levels != first.levels) {
        problems.push(format!(
            "shard {}/{} rendered with other settings or another shard count than shard {}/{count}; render every shard with the same options",
            odd.shard, odd.count, first.shard
        ));
    }
    let finished: std::collections::BTreeSet<usize> = manifests.iter().map(|m| m.shard).collect();
    for index in (0..count).filter(|i| !finished.contains(i)) {
        problems.push(format!("shard {index}/{count} has not finished (no shards/{index}-of-{count}.json)"));
    }
    // Every expected file, with its owner.
    let probes = graph.probes.len();
    let mut expected: Vec<(String, usize)> = Vec::new();
    let glides = first.render.transitions.is_some();
    for id in 0..probes {
        expected.extend(ProbeFiles::new(id, &first.levels, glides).all().into_iter().map(|f| (f, id)));
    }
    for id in 0..graph.paths.len() {
        expected.extend(path::expected(dir, id, glides).into_iter().map(|f| (f, probes + id)));
    }
    let proxy_job = probes + graph.paths.len();
    match proxy::listed(dir) {
        Some(proxy) => expected.extend(proxy::files(&proxy).into_iter().map(|f| (f, proxy_job))),
        None => expected.push((proxy::PROXY_LIST.to_string(), proxy_job)),
    }
    // A file that exists but does not decode goes, so its shard redoes it.
    let checked: Vec<Option<String>> = {
        use rayon::prelude::*;
        expected
            .par_iter()
            .map(|(name, job)| {
                let owner = format!("{name} (shard {}/{count})", job % count.max(1));
                match check_asset(dir, name) {
                    Ok(()) => None,
                    Err(None) => Some(format!("{owner}: missing")),
                    Err(Some(why)) => {
                        let _ = std::fs::remove_file(dir.join(name));
                        Some(format!("{owner}: {why}; removed"))
                    }
                }
            })
            .collect()
    };
    problems.extend(checked.into_iter().flatten());
    if !problems.is_empty() {
        return Err(incomplete(problems));
    }
    graph.stats.render = Some(first.render.clone());
    list_assets(dir, graph, &first.levels);
    graph.validate()?;
    write_graph(dir, graph, Timings::default())?;
    Ok(expected.len())
}

/// Whether a bundle file exists and decodes, by its kind: `Err(None)` when
/// it is missing, `Err(Some(why))` when it does not decode.
fn check_asset(dir: &Path, name: &str) -> Result<(), Option<String>> {
    let bytes = std::fs::read(dir.join(name)).map_err(|_| None)?;
    let bad = |e: &dyn std::fmt::Display| Some(format!("does not decode ({e})"));
    match name.rsplit('.').next().unwrap_or("") {
        "jpg" => image::load_from_memory_with_format(&bytes, image::ImageFormat::Jpeg).map(drop).map_err(|e| bad(&e)),
        "mp4" => match exploremaps_format::video::Mp4Decoder::new(bytes).map_err(|e| bad(&e))?.next_frame() {
            Ok(Some(_)) => Ok(()),
            Ok(None) => Err(Some("does not decode (no frame)".into())),
            Err(e) => Err(bad(&e)),
        },
        "emmc" => exploremaps_format::meshcode::decode(&bytes).map(drop).map_err(|e| bad(&e)),
        "seen" => exploremaps_format::seen::decode_runs(&bytes, None).map(drop).map_err(|e| bad(&e)),
        "emdm" => exploremaps_format::depthmap::DepthMap::decode(&bytes, u32::MAX).map(drop).map_err(|e| bad(&e)),
        "emdc" => exploremaps_format::depthcube::DepthCube::decode(&bytes).map(drop).map_err(|e| bad(&e)),
        // A path's transition record.
        "json" if name.starts_with("paths/") => serde_json::from_slice::<exploremaps_format::Transition>(&bytes).map(drop).map_err(|e| bad(&e)),
        // A packet applies to the mesh before it; alone, each one's frame is checked.
        "emvs" => exploremaps_format::splits::packets(&bytes).map(drop).map_err(|e| bad(&e)),
        "glb" => match std::panic::catch_unwind(|| gltf::Gltf::from_slice(&bytes)) {
            Ok(parsed) => parsed.map(drop).map_err(|e| bad(&e)),
            Err(_) => Err(bad(&"a panic in gltf")),
        },
        _ => Ok(()),
    }
}
