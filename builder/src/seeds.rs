//! Every random choice of a run comes from the one `--seed` through this
//! module, so the same seed gives the same bundle at any thread count and no
//! two uses share numbers. Planning stages draw from named streams
//! ([`Stream`]: the seed and the stream's own constant, mixed, so that a
//! stream drawn inside another stays apart from both) and, for many parallel
//! draws (one per sample, per cluster), from their numbered substreams
//! ([`substream`]); the renderer from a stream per (kind of work, image,
//! index) ([`sampler`], [`Work`], [`image`]), one per pixel, gather point or
//! cache cell, so the order parallel work runs in cannot matter. Also the one cosine-weighted direction every
//! stage draws ([`cosine_direction`]).

use glam::{Vec2, Vec3};
use rand::SeedableRng;
use rand_pcg::{Pcg32, Pcg64Mcg};

/// Planning's streams. Each constant spells the first four letters of a
/// name in ASCII.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u64)]
pub enum Stream {
    /// Area-uniform surface samples (`samples::surface_samples`).
    Surface = 0x636f_7665, // "cove"
    /// The samples added so that every object has its minimum.
    Strata = 0x7374_7261, // "stra"
    /// Greedy exploration's selection samples.
    Greedy = 0x6772_6565, // "gree"
    /// The occlusion-driven exploration's random steps.
    Explore = 0x6578_706c, // "expl"
    /// Synthesis' selection samples.
    Synthesis = 0x7379_6e74, // "synt"
    /// Witness points of path finding.
    Connect = 0x636f_6e6e, // "conn"
    /// The random orders the thumbnail bar's order is compared with.
    Order = 0x6f72_6465, // "orde"
    /// The random baseline placement coverage is compared with.
    Baseline = 0x7261_6e64, // "rand"
    /// Surface samples that decide which way a scene faces.
    Facing = 0x6661_6365, // "face"
    /// Rays from those samples.
    Outward = 0x6f75_7473, // "outs"
    /// Points of the box that tell an object from a place.
    Kind = 0x6b69_6e64, // "kind"
    /// Greedy exploration's random candidates.
    Candidates = 0x6361_6e64, // "cand"
    /// The directions a surface sample is reached by, per sample.
    Reach = 0x7265_6163, // "reac"
    /// Synthesis' annealing, per cluster.
    Anneal = 0x616e_6e65, // "anne"
}

impl Stream {
    /// Every stream (the test below keeps them apart).
    pub const ALL: [Stream; 14] = [
        Stream::Surface,
        Stream::Strata,
        Stream::Greedy,
        Stream::Explore,
        Stream::Synthesis,
        Stream::Connect,
        Stream::Order,
        Stream::Baseline,
        Stream::Facing,
        Stream::Outward,
        Stream::Kind,
        Stream::Candidates,
        Stream::Reach,
        Stream::Anneal,
    ];

    /// The stream's seed, for functions that take one.
    pub fn seed(self, seed: u64) -> u64 {
        mix(seed ^ self as u64)
    }

    pub fn rng(self, seed: u64) -> Pcg64Mcg {
        Pcg64Mcg::seed_from_u64(self.seed(seed))
    }
}

/// The seed of the `index`-th of many parallel draws from a stream's `seed`
/// (never the stream's seed itself, which its first draw would share).
pub fn substream(seed: u64, index: u64) -> u64 {
    mix(seed.wrapping_add(index.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15)))
}

/// The kinds of work a render draws random numbers for. As [`Stream`], each
/// constant spells four letters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u64)]
pub enum Work {
    /// A pixel's samples (index: the pixel; antialiasing's extra samples
    /// after the last pixel).
    Pixels = 0x7069_7865, // "pixe"
    /// A frame's gather points (index: the grid point).
    Gather = 0x6761_7468, // "gath"
    /// The near field's gather points.
    NearGather = 0x6e65_6172, // "near"
    /// Sunlight at the radiance cache's cells (index: the cell).
    CacheSun = 0x7375_6e73, // "suns"
    /// The radiance cache's gathers (index: the cell).
    CacheGather = 0x6361_6368, // "cach"
    /// A stand-in's baked colour at one of its points (index: 0).
    Bake = 0x6261_6b65, // "bake"
    /// The reference's light tables: rays from its viewpoints (index: the ray).
    LightPilot = 0x7069_6c6f, // "pilo"
    /// ... sunlit points of each cell of the sun's disc of the box.
    LightCells = 0x6365_6c6c, // "cell"
    /// ... bounce rays that leave the box, toward the sky.
    LightExits = 0x6578_6974, // "exit"
}

impl Work {
    /// Every kind (the test below keeps their streams apart).
    pub const ALL: [Work; 9] = [
        Work::Pixels,
        Work::Gather,
        Work::NearGather,
        Work::CacheSun,
        Work::CacheGather,
        Work::Bake,
        Work::LightPilot,
        Work::LightCells,
        Work::LightExits,
    ];
}

/// Which image a render is drawing: the top byte says what kind, the next
/// three the probe, path or level, the low four the face, frame or vertex,
/// so that no two images of a bundle share a number.
pub mod image {
    /// Face `face` of probe `probe`'s cube map; the faces follow in order.
    pub fn cube(probe: u32) -> u64 {
        id(1, probe, 0)
    }

    /// Probe `probe`'s thumbnail.
    pub fn thumbnail(probe: u32) -> u64 {
        id(2, probe, 0)
    }

    /// The first frame of path `path`'s video; frame i is `video(path) + i`.
    pub fn video(path: u32) -> u64 {
        id(3, path, 0)
    }

    /// Vertex `vertex` of level `level` of the stand-in mesh, baked.
    pub fn bake(level: u32, vertex: u32) -> u64 {
        id(4, level, vertex)
    }

    /// The `k`-th quick view exposure is metered from.
    pub fn exposure(k: u32) -> u64 {
        id(5, k, 0)
    }

    /// Face 0 of the panorama part way along path `path` at its camera key
    /// `k` (below 2^29); the faces follow in order.
    pub fn waypoint(path: u32, k: u32) -> u64 {
        id(6, path, 6 * k)
    }

    /// Work that belongs to no image: the radiance cache, the reference's
    /// light tables.
    pub const NONE: u64 = 0;

    /// Objects past 2^24 (16 million probes, paths or levels) would run
    /// into the next kind; no bundle comes near.
    fn id(kind: u64, object: u32, index: u32) -> u64 {
        debug_assert!(object < 1 << 24, "image object {object} out of range");
        kind << 56 | ((object as u64) & 0xFF_FFFF) << 32 | index as u64
    }
}

/// A generator for one stream of a render: (seed, kind of work, image,
/// index), each mixed in turn, so that no two (work, image) pairs share a
/// stream however their numbers relate, and neighbouring indices are
/// unrelated.
pub fn sampler(seed: u64, work: Work, image: u64, index: u64) -> Pcg32 {
    Pcg32::seed_from_u64(mix(render_stream(seed, work, image) ^ index))
}

/// The stream of one kind of work in one image.
fn render_stream(seed: u64, work: Work, image: u64) -> u64 {
    mix(mix(seed ^ work as u64) ^ image)
}

/// SplitMix64's finaliser: a bijection that spreads every input bit.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A cosine-weighted direction about the unit normal `n` from two uniform
/// numbers in [0, 1): reachability, the facing test and every bounce.
pub fn cosine_direction(n: Vec3, u: Vec2) -> Vec3 {
    let (t1, t2) = n.any_orthonormal_pair();
    let r = u.x.sqrt();
    let phi = std::f32::consts::TAU * u.y;
    (t1 * (r * phi.cos()) + t2 * (r * phi.sin()) + n * (1.0 - u.x).max(0.0).sqrt()).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    #[test]
    fn no_two_planning_streams_share_a_seed() {
        // Every stream, every stream drawn inside another (the samples of
        // exploration's and synthesis' targets, their reach), and the first
        // thousands of each one's substreams (a sample's reach, a cluster's
        // annealing), for a few run seeds: all apart.
        for run in [0u64, 1, 7, 42, u64::MAX] {
            let mut seen: HashMap<u64, String> = HashMap::new();
            let mut add = |seed: u64, what: String| {
                if let Some(was) = seen.insert(seed, what.clone()) {
                    panic!("run seed {run}: {what} and {was} share the seed {seed:#x}");
                }
            };
            for a in Stream::ALL {
                let sa = a.seed(run);
                add(sa, format!("{a:?}"));
                for k in 0..2000 {
                    add(substream(sa, k), format!("{a:?} #{k}"));
                }
                for b in Stream::ALL {
                    let sb = b.seed(sa);
                    add(sb, format!("{b:?} in {a:?}"));
                    for k in 0..200 {
                        add(substream(sb, k), format!("{b:?} in {a:?} #{k}"));
                    }
                }
            }
        }
        // The constants are distinct, and ALL lists each once.
        let mut constants: Vec<u64> = Stream::ALL.iter().map(|&s| s as u64).collect();
        constants.sort_unstable();
        constants.dedup();
        assert_eq!(constants.len(), Stream::ALL.len());
    }

    /// The images of a large bundle: 300 probes' cube faces and thumbnails,
    /// 600 paths of 400 frames and their most waypoints, 8 stand-in levels of 20,000 vertices, the
    /// exposure views, and the work of no image.
    fn images() -> Vec<(u64, String)> {
        let mut out = Vec::new();
        for p in 0..300 {
            out.extend((0..6).map(|f| (image::cube(p) + f, format!("probe {p} face {f}"))));
            out.push((image::thumbnail(p), format!("thumbnail {p}")));
        }
        for path in 0..600 {
            out.extend((0..400).map(|f| (image::video(path) + f, format!("path {path} frame {f}"))));
            // Waypoints stand at camera keys: every fiftieth key, to the most a path has.
            let waypoints = 0..crate::render::glide::MAX_WAYPOINTS as u32 * 6;
            out.extend(waypoints.map(|f| (image::waypoint(path, 50 * (f / 6)) + (f % 6) as u64, format!("path {path} waypoint face {f}"))));
        }
        for level in 0..8 {
            out.extend((0..20_000).map(|v| (image::bake(level, v), format!("level {level} vertex {v}"))));
        }
        out.extend((0..16).map(|k| (image::exposure(k), format!("exposure {k}"))));
        out.push((image::NONE, "no image".to_string()));
        out
    }

    #[test]
    fn no_two_render_streams_share_a_seed() {
        // Every image's number is its own, and every (work, image) pair's
        // stream too, for a few run seeds. (The streams the renderer used
        // before, a constant XORed into the image's number, collided: the
        // near field's gather of frame f of path p under 256 and the far
        // field's of the same frame of path p + 256.)
        let images = images();
        let mut ids: Vec<u64> = images.iter().map(|i| i.0).collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), images.len(), "two images share a number");
        for run in [0u64, 1, 42, u64::MAX] {
            let mut streams: Vec<(u64, u32)> = Vec::with_capacity(Work::ALL.len() * images.len());
            for (w, &work) in Work::ALL.iter().enumerate() {
                streams.extend(images.iter().enumerate().map(|(k, i)| (render_stream(run, work, i.0), (w * images.len() + k) as u32)));
            }
            streams.sort_unstable();
            for pair in streams.windows(2) {
                if pair[0].0 == pair[1].0 {
                    let name = |n: u32| format!("{:?} of {}", Work::ALL[n as usize / images.len()], images[n as usize % images.len()].1);
                    panic!("run seed {run}: {} and {} share a stream", name(pair[0].1), name(pair[1].1));
                }
            }
        }
        let mut constants: Vec<u64> = Work::ALL.iter().map(|&w| w as u64).collect();
        constants.sort_unstable();
        constants.dedup();
        assert_eq!(constants.len(), Work::ALL.len());
    }
}
