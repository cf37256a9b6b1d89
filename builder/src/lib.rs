//! The ExploreMaps builder: loads a scene and runs the pipeline stages on it.
//!
//! Stages, in pipeline order (see DESIGN.md section 2): `load` → `raycast` → …
//! Each stage is a pure function of its inputs plus a seed.

pub mod raycast;
