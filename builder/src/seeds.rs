//! Every random choice of a run comes from the one `--seed` through this
//! module, so the same seed gives the same bundle at any thread count and no
//! two uses share numbers. Planning stages draw from named streams
//! ([`Stream`]: the seed and the stream's own constant, mixed, so that a
//! stream drawn inside another stays apart from both) and, for many parallel
//! draws (one per sample, per cluster), from their numbered substreams
//! ([`substream`]); the renderer from a stream per (kind of work, index)
//! ([`sampler`]), one per image, tile or cache cell, so the order parallel
//! work runs in cannot matter. Also the one cosine-weighted direction every
//! stage draws ([`cosine_direction`]).

use glam::{Vec2, Vec3};
use rand::SeedableRng;
use rand_pcg::{Pcg32, Pcg64Mcg};

/// Planning's streams. Each constant spells the first four letters of a
/// name in ASCII.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u64)]
pub enum Stream {
    /// Area-uniform surface samples (`coverage::surface_samples`).
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

/// A generator for one stream of a render: (seed, kind of work, index),
/// mixed so neighbouring indices are unrelated.
pub fn sampler(seed: u64, stream: u64, index: u64) -> Pcg32 {
    Pcg32::seed_from_u64(mix(seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03)))
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
}
