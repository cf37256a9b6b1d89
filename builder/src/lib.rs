//! The ExploreMaps builder: loads a scene and runs the pipeline stages on it.
//!
//! Stages, in pipeline order (DESIGN.md section 2): `load` (scene files into a
//! `Scene`) → `raycast` (Embree, the only module that talks to it) → … the
//! planning and rendering stages land here one module each.

pub mod coverage;
pub mod explore;
pub mod export;
pub mod files;
pub mod freespace;
pub mod load;
pub mod raycast;

pub use exploremaps_scenes as scenes;
