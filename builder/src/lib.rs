//! The ExploreMaps builder: loads a scene and runs the pipeline on it.
//!
//! Two stages a user runs, each a module that reads as its list of steps:
//! `pipeline` (`exploremaps plan`: raycast → freespace (with `walk`) →
//! explore → cluster → orient → connect → smooth → order → coverage, pictures
//! by `report`) and `render` (`exploremaps render`: the jobs a planned bundle
//! lacks, pictured by `renderer`, videos by `video`, tour tiles by `tiles`,
//! the 3D stand-in by `proxy`). `load` reads scene files; `raycast` is the
//! only module that talks to Embree; `bundle` writes the folder; `tour`
//! exports a bundle to other tour viewers; `export` (scenes out as OBJ/GLB),
//! `files` and `seeds` (every random stream) are utilities.

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
