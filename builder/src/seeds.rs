//! Every random choice of a run comes from the one `--seed` through this
//! module, so the same seed gives the same bundle at any thread count and no
//! two uses share numbers. Planning stages draw from named streams
//! ([`Stream`]: the seed mixed with the stream's own constant); the renderer
//! from a stream per (kind of work, index) ([`sampler`]), one per image, tile
//! or cache cell, so the order parallel work runs in cannot matter. Also
//! the one cosine-weighted direction every stage draws ([`cosine_direction`]).

use glam::{Vec2, Vec3};
use rand::SeedableRng;
use rand_pcg::{Pcg32, Pcg64Mcg};

/// Planning's streams. Each constant spells the first four letters of a
/// name in ASCII; they are the values every bundle so far was made with.
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
}

impl Stream {
    /// The stream's seed, for functions that take one.
    pub fn seed(self, seed: u64) -> u64 {
        seed ^ self as u64
    }

    pub fn rng(self, seed: u64) -> Pcg64Mcg {
        Pcg64Mcg::seed_from_u64(self.seed(seed))
    }
}

/// A generator for one stream of a render: (seed, kind of work, index),
/// mixed by SplitMix64's finaliser so neighbouring indices are unrelated.
pub fn sampler(seed: u64, stream: u64, index: u64) -> Pcg32 {
    let mut z = seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    Pcg32::seed_from_u64(z ^ (z >> 31))
}

/// A cosine-weighted direction about the unit normal `n` from two uniform
/// numbers in [0, 1): reachability, the facing test and every bounce.
pub fn cosine_direction(n: Vec3, u: Vec2) -> Vec3 {
    let (t1, t2) = n.any_orthonormal_pair();
    let r = u.x.sqrt();
    let phi = std::f32::consts::TAU * u.y;
    (t1 * (r * phi.cos()) + t2 * (r * phi.sin()) + n * (1.0 - u.x).max(0.0).sqrt()).normalize()
}
