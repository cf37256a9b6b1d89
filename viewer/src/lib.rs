//! The ExploreMaps viewer. So far: navigation, the pure logic of where the
//! viewer is, looks and goes. Rendering (wgpu), the native window and the web
//! entry point come with the viewer issue.

pub mod navigation;
