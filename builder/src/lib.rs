//! The ExploreMaps builder: loads a scene and runs the pipeline stages on it.
//!
//! Stages, in pipeline order (DESIGN.md section 2), one module each:
//! `load` (scene files into a `Scene`) → `raycast` (Embree; the only module
//! that talks to it) → `freespace` → `explore` → `coverage`; `report` draws the
//! pictures, `pipeline` wires the stages, `bundle` writes the result (with
//! `render`, `tiles`, `video` and `proxy`, the light 3D stand-in of the
//! scene), `tour` exports a bundle to other tour viewers; `export` (scenes
//! out as OBJ/GLB) and `files` are utilities.

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
pub mod report;
pub mod smooth;
pub mod tiles;
pub mod tour;
pub mod video;
pub mod walk;
#[cfg(test)]
mod testing;

pub use exploremaps_scenes as scenes;
