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
pub mod cluster;
pub mod connect;
pub mod coverage;
pub mod explore;
pub mod export;
pub mod files;
pub mod freespace;
pub mod load;
pub mod order;
pub mod orient;
pub mod pipeline;
pub mod proxy;
pub mod raycast;
pub mod render;
pub mod renderer;
pub mod report;
pub mod scale;
pub mod seeds;
pub mod smooth;
#[cfg(test)]
mod testing;
pub mod tiles;
pub mod tour;
pub mod video;
pub mod visibility;
pub mod walk;

pub use exploremaps_scenes as scenes;
