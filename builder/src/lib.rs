//! The ExploreMaps builder: loads a scene and runs the pipeline on it.
//!
//! The folders are the pipeline. `scene_io` reads scene files (and writes
//! scenes out); `plan` is `exploremaps plan` (raycast → scale → freespace
//! (with `walk`) → explore → cluster → orient → connect → smooth → order →
//! coverage, pictures by `report`; its `mod.rs` lists them in order);
//! `render` is `exploremaps render` (the jobs a planned bundle lacks,
//! pictured by `tracer`, videos by `video`, tour tiles by `tiles`, the 3D
//! stand-in by `proxy`); `bundle` writes the folder; `export` is
//! `exploremaps export` (a bundle as a tour for other viewers). `raycast` is
//! the only module that talks to Embree; `files`, `seeds` (every random
//! stream) and `colour` (sRGB) are utilities. No top-level module depends on
//! one that depends on it (`tests/layout.rs`).

pub mod bundle;
pub mod colour;
pub mod export;
pub mod files;
pub mod plan;
pub mod proxy;
pub mod raycast;
pub mod render;
pub mod scene_io;
pub mod seeds;
#[cfg(test)]
mod testing;
pub mod tiles;
pub mod tracer;
pub mod video;

pub use exploremaps_scenes as scenes;
