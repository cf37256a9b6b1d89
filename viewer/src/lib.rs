//! The ExploreMaps viewer: navigation (pure logic of where the viewer is,
//! looks and goes), the interface layout (pure), and the GPU passes that draw
//! panoramas, videos and the interface with wgpu.

pub mod app;
pub mod dollhouse;
pub mod glide;
pub mod headset;
#[cfg(not(target_arch = "wasm32"))]
pub mod native;
pub mod navigation;
#[cfg(not(target_arch = "wasm32"))]
pub mod offscreen;
pub mod overlay;
pub mod panorama;
pub mod ui;
#[cfg(target_arch = "wasm32")]
pub mod web;
