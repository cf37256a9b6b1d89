//! Writes the coded mesh's symbol priors (`format/src/meshcode/priors.rs`)
//! from training meshes: the 1 % and 10 % levels of six scenes, simplified
//! as the proxy bench does. The Crytek Sponza, on which the bench judges
//! connectivity, is left out. Run:
//! `cargo run --release -p exploremaps-builder --example connectivity_priors`
//! (needs the shared scenes beside the repository).

use exploremaps_builder::proxy::simplify::{simplify, SimplifyParams};
use exploremaps_builder::proxy::weld::weld_scene;
use exploremaps_builder::scene_io::{load, LoadOptions};
use exploremaps_format::meshcode;
use exploremaps_scenes::BuiltIn;
use std::path::Path;

use exploremaps_format::meshcode::CONTEXTS;
/// Symbols of the coded mesh's models (7 and a padding one).
const K: usize = 8;
/// Share of each prior spread evenly over the symbols.
const FLOOR: f64 = 0.05;
/// `Adaptive`'s total share: 2^15 less a quantile a symbol.
const SHARED: f64 = ((1 << 15) - K) as f64;

const HEADER: &str = "\
//! Version 6's starting distribution of each symbol context (see `context`),
//! as `Adaptive`'s bounds; None: uniform, as in version 5 (contexts no
//! training mesh reached). Each is the mean over training meshes of each
//! mesh's share of each symbol in the context, with 5 % spread evenly over
//! the seven symbols so that none starts near impossible. Many contexts all
//! but rule symbols out, which a uniform start pays to learn in each of 48
//! contexts. Written by `cargo run --release -p exploremaps-builder
//! --example connectivity_priors` from the 1 % and 10 % levels of six
//! scenes; the Crytek Sponza, on which the proxy bench judges connectivity,
//! is left out. Changing this table changes what version 6 files mean.

";

fn main() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    let mut scenes = vec![("gallery".to_string(), BuiltIn::Gallery.generate(1))];
    for file in [
        "stanford_bunny/bun_zipper.ply",
        "sponza_dabrovic/sponza.obj",
        "wooden_staircase/wooden_staircase.obj",
        "grey_white_room/grey_white_room.obj",
        "dream_apartment/dream_apartment.glb",
    ] {
        match load(&shared.join(file), &LoadOptions::default()) {
            Ok(scene) => scenes.push((file.to_string(), scene)),
            Err(e) => {
                eprintln!("error: {e}\n(the priors are made from all six scenes; put shared/scenes beside the repository)");
                std::process::exit(1);
            }
        }
    }
    // Per context: the sum over meshes of each mesh's shares, and how many meshes reached it.
    let mut shares = [[0f64; K]; CONTEXTS];
    let mut meshes = [0u32; CONTEXTS];
    for (name, scene) in &scenes {
        let (mesh, _) = weld_scene(scene, 1e-5 * scene.bounds().diagonal());
        for ratio in [0.1, 0.01] {
            let level =
                simplify(&mesh, &SimplifyParams { target_triangles: (mesh.triangles.len() as f64 * ratio) as usize, max_error: f32::INFINITY })
                    .compact();
            let symbols = meshcode::symbol_contexts(&level.to_coded()).expect("a simplified level codes");
            let mut counts = [[0u32; K]; CONTEXTS];
            for &(c, s) in &symbols {
                counts[c][s as usize] += 1;
            }
            for c in 0..CONTEXTS {
                let n: u32 = counts[c].iter().sum();
                if n > 0 {
                    meshes[c] += 1;
                    for s in 0..K {
                        shares[c][s] += counts[c][s] as f64 / n as f64;
                    }
                }
            }
            eprintln!("{name} at {ratio}: {} triangles, {} symbols", level.triangles.len(), symbols.len());
        }
    }
    let mut out = String::from(HEADER);
    out += "#[rustfmt::skip]\npub(super) const PRIORS: [Option<[u16; 8]>; super::CONTEXTS] = [\n";
    for c in 0..CONTEXTS {
        if meshes[c] == 0 {
            out += "    None,\n";
            continue;
        }
        let mut sum = 0.0;
        let bound: Vec<String> = (0..K)
            .map(|s| {
                if s < K - 1 {
                    sum += (1.0 - FLOOR) * shares[c][s] / meshes[c] as f64 + FLOOR / (K - 1) as f64;
                }
                // (The padding symbol, never coded, has no share.)
                let b = if s == K - 1 { SHARED } else { (sum * SHARED).round().min(SHARED) };
                format!("{}", b as u16)
            })
            .collect();
        out += &format!("    Some([{}]),\n", bound.join(", "));
    }
    out += "];\n";
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../format/src/meshcode/priors.rs");
    std::fs::write(&path, out).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    eprintln!("wrote {}", path.display());
}
