//! The web viewer's wasm module: only the viewer's `start`, exported for
//! web/index.html. Empty on other targets.

#[cfg(target_arch = "wasm32")]
pub use exploremaps_viewer::web::start;
