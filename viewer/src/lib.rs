//! The ExploreMaps viewer. So far: navigation (the pure logic of where the
//! viewer is, looks and goes) and the panorama pass (a probe's cube map drawn
//! for a view with wgpu). The native window and the web entry point come next.

pub mod navigation;
pub mod panorama;
