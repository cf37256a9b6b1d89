//! Draws what the viewer sees: a probe's cube map, a cross-fade between two
//! cube maps, or a frame of a path's 360° video (equirectangular, world
//! aligned), for a view. One full-screen triangle whose fragment shader turns
//! each pixel into a world direction and samples the source. The bundle's
//! faces follow the GPU cube-map convention (`exploremaps_format::cube_direction`),
//! so they upload as they are.

use crate::navigation::View;
use exploremaps_format::direction;

/// One triangle over the whole target (or viewport), passing each pixel's
/// normalised device coordinates on; shaders that draw a full-screen pass
/// begin with it.
pub(crate) const FULL_SCREEN: &str = r#"
struct VOut { @builtin(position) pos: vec4f, @location(0) ndc: vec2f };

@vertex fn vs(@builtin(vertex_index) i: u32) -> VOut {
    let p = vec2f(f32((i << 1u) & 2u), f32(i & 2u)) * 2.0 - 1.0;
    var o: VOut;
    o.pos = vec4f(p, 0.0, 1.0);
    o.ndc = p;
    return o;
}
"#;

const SHADER: &str = r#"
struct U { forward: vec4f, right: vec4f, up: vec4f, params: vec4f };
@group(0) @binding(0) var<uniform> u: U;
@group(0) @binding(1) var cube_a: texture_cube<f32>;
@group(0) @binding(2) var cube_b: texture_cube<f32>;
@group(0) @binding(3) var video: texture_2d<f32>;
@group(0) @binding(4) var samp: sampler;
@group(0) @binding(5) var tiles_a: texture_cube<f32>;
@group(0) @binding(6) var mask_a: texture_cube<f32>;
@group(0) @binding(7) var tiles_b: texture_cube<f32>;
@group(0) @binding(8) var mask_b: texture_cube<f32>;
@group(0) @binding(9) var nearest: sampler;


@fragment fn fs(v: VOut) -> @location(0) vec4f {
    // The lens (see Lens): the ray through a pixel leaves along forward, plus
    // right and up by its offsets (params.xy: per NDC unit; forward.w,
    // right.w: the frustum's off-axis shift). params.zw: fade toward cube_b, 1 for video.
    let nx = v.ndc.x * u.params.x + u.forward.w;
    let ny = v.ndc.y * u.params.y + u.right.w;
    let d = normalize(u.forward.xyz + u.right.xyz * nx + u.up.xyz * ny);
    // Tiles hold tour-oriented faces, read with z negated (see Tiled); where
    // the mask says a tile has not arrived, the whole cube shows.
    let t = vec3f(d.x, d.y, -d.z);
    let a = mix(textureSampleLevel(cube_a, samp, d, 0.0).rgb, textureSampleLevel(tiles_a, samp, t, 0.0).rgb, textureSampleLevel(mask_a, nearest, t, 0.0).r);
    let b = mix(textureSampleLevel(cube_b, samp, d, 0.0).rgb, textureSampleLevel(tiles_b, samp, t, 0.0).rgb, textureSampleLevel(mask_b, nearest, t, 0.0).r);
    // Equirectangular: s = yaw / 2π with yaw 0 toward −Z, t = 0 straight up.
    let yaw = atan2(d.x, -d.z);
    let st = vec2f(fract(yaw / 6.2831853), acos(clamp(d.y, -1.0, 1.0)) / 3.14159265);
    // One mip level, so sampling level 0 avoids derivative seams at s = 0.
    let e = textureSampleLevel(video, samp, st, 0.0).rgb;
    return vec4f(select(mix(a, b, u.params.z), e, u.params.w > 0.5), 1.0);
}
"#;

/// The camera's forward, right and up vectors for a view.
pub fn basis(view: &View) -> [[f32; 3]; 3] {
    let f = direction(view.yaw, view.pitch);
    // Right is forward × up; straight up or down it falls back to the yaw's right.
    let mut r = [-f[2], 0.0, f[0]];
    let len = (r[0] * r[0] + r[2] * r[2]).sqrt();
    if len < 1e-6 {
        r = [view.yaw.cos(), 0.0, view.yaw.sin()];
    } else {
        r = [r[0] / len, 0.0, r[2] / len];
    }
    let u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]];
    [f, r, u]
}

/// Where direction `d` lands on a `width` × `height` target showing `view`
/// (pixels, y down), if it is in front of the camera.
pub fn project(view: &View, d: [f32; 3], width: f32, height: f32) -> Option<[f32; 2]> {
    let [f, r, u] = basis(view);
    let dot = |a: [f32; 3]| a[0] * d[0] + a[1] * d[1] + a[2] * d[2];
    let z = dot(f);
    if z <= 1e-3 {
        return None;
    }
    let t = (0.5 * view.fov_y).tan();
    let (x, y) = (dot(r) / (z * t * width / height), dot(u) / (z * t));
    Some([(x + 1.0) * 0.5 * width, (1.0 - y) * 0.5 * height])
}

/// The unit world direction through pixel (x, y) of a `width` × `height`
/// target showing `view`: the inverse of [`project`].
pub fn unproject(view: &View, x: f32, y: f32, width: f32, height: f32) -> [f32; 3] {
    let [f, r, u] = basis(view);
    let t = (0.5 * view.fov_y).tan();
    let (nx, ny) = ((2.0 * x / width - 1.0) * t * width / height, (1.0 - 2.0 * y / height) * t);
    let d = [f[0] + r[0] * nx + u[0] * ny, f[1] + r[1] * nx + u[1] * ny, f[2] + r[2] * nx + u[2] * ny];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    d.map(|c| c / len)
}

/// How pixels map to world directions: a camera's forward, right and up,
/// and for a pixel at normalised device coordinates (x, y) the ray
/// forward + right·(x·scale.x + shift.x) + up·(y·scale.y + shift.y). A
/// window's view is centred; a headset eye's frustum is off-axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    pub basis: [[f32; 3]; 3],
    pub scale: [f32; 2],
    pub shift: [f32; 2],
}

impl Lens {
    /// A window's view with `aspect` = width / height.
    pub fn of_view(view: &View, aspect: f32) -> Lens {
        let t = (0.5 * view.fov_y).tan();
        Lens { basis: basis(view), scale: [t * aspect, t], shift: [0.0, 0.0] }
    }

    /// A camera turned by `rotation` from looking down −Z with +Y up (the
    /// WebXR convention), seen through `projection` (column-major, OpenGL
    /// clip space): x_ndc = (P₀₀·x + P₀₂·z) / −z, so x / −z = (x_ndc + P₀₂) / P₀₀.
    pub fn of_eye(rotation: glam::Quat, projection: &glam::Mat4) -> Lens {
        let p = projection.to_cols_array();
        let (forward, right, up) = (rotation * glam::Vec3::NEG_Z, rotation * glam::Vec3::X, rotation * glam::Vec3::Y);
        Lens { basis: [forward.into(), right.into(), up.into()], scale: [1.0 / p[0], 1.0 / p[5]], shift: [p[8] / p[0], p[9] / p[5]] }
    }
}

impl Lens {
    /// Clip space from world for an eye at `eye` looking through this lens
    /// (with the lens's x / −z = x_ndc·scale + shift, and so for y: clip x =
    /// (x + shift·z) / scale, clip w = −z). Depth runs from 0 at `near` to 1
    /// at `far`; with no `far`, reversed (1 at `near`, 0 at infinity), which
    /// keeps the far-away sky's precision.
    pub fn view_proj(&self, eye: glam::Vec3, near: f32, far: Option<f32>) -> glam::Mat4 {
        use glam::Vec4;
        let ([sx, sy], [ox, oy]) = (self.scale, self.shift);
        let (zz, zw) = far.map_or((0.0, near), |far| (far / (near - far), near * far / (near - far)));
        let proj = glam::Mat4::from_cols(
            Vec4::new(1.0 / sx, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 1.0 / sy, 0.0, 0.0),
            Vec4::new(ox / sx, oy / sy, zz, -1.0),
            Vec4::new(0.0, 0.0, zw, 0.0),
        );
        let [f, r, u] = self.basis.map(glam::Vec3::from);
        proj * crate::dollhouse::view_matrix(eye, (r, u, f))
    }

    /// Where direction `d` shows, in normalised device coordinates, if in
    /// front of the camera: the inverse of the shader's ray.
    pub fn project(&self, d: glam::Vec3) -> Option<[f32; 2]> {
        let [f, r, u] = self.basis.map(glam::Vec3::from);
        let z = d.dot(f);
        (z > 1e-3).then(|| [(d.dot(r) / z - self.shift[0]) / self.scale[0], (d.dot(u) / z - self.shift[1]) / self.scale[1]])
    }
}

/// The uniforms as the shader reads them.
fn uniforms(lens: &Lens, fade: f32, video: bool) -> [f32; 16] {
    let [f, r, u] = lens.basis;
    let video = if video { 1.0 } else { 0.0 };
    [f[0], f[1], f[2], lens.shift[0], r[0], r[1], r[2], lens.shift[1], u[0], u[1], u[2], 0.0, lens.scale[0], lens.scale[1], fade, video]
}

/// An RGBA8 sRGB image texture of `layers` layers, sampled and written by
/// copies (RENDER_ATTACHMENT too: browsers copy decoded images in with a draw).
pub(crate) fn image_texture(device: &wgpu::Device, label: &str, width: u32, height: u32, layers: u32) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: layers },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8UnormSrgb,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    })
}

/// Uploads RGBA8 pixels, `width` × `height`, into layer `layer` of `texture`.
pub(crate) fn write_layer(queue: &wgpu::Queue, texture: &wgpu::Texture, layer: u32, width: u32, height: u32, rgba: &[u8]) {
    queue.write_texture(
        wgpu::TexelCopyTextureInfo { texture, mip_level: 0, origin: wgpu::Origin3d { x: 0, y: 0, z: layer }, aspect: wgpu::TextureAspect::All },
        rgba,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * width), rows_per_image: Some(height) },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
}

/// A probe's panorama on the GPU: six square RGBA8 sRGB faces.
pub struct Cube {
    pub texture: wgpu::Texture,
    pub(crate) view: wgpu::TextureView,
    pub size: u32,
}

impl Cube {
    /// An empty cube; fill it with [`Cube::write_face`] (or, on the web, by
    /// copying decoded images into its layers).
    pub fn new(device: &wgpu::Device, size: u32) -> Cube {
        let texture = image_texture(device, "panorama cube", size, size, 6);
        let view = texture.create_view(&wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::Cube), ..Default::default() });
        Cube { texture, view, size }
    }

    /// Uploads face `face` (bundle order) from RGBA8 pixels, `size`² of them.
    pub fn write_face(&self, queue: &wgpu::Queue, face: usize, rgba: &[u8]) {
        write_layer(queue, &self.texture, face as u32, self.size, self.size, rgba);
    }

    /// Bytes of GPU memory it holds.
    pub fn bytes(&self) -> u64 {
        6 * 4 * u64::from(self.size) * u64::from(self.size)
    }
}

/// The tour viewers' face in each cube slot (+X, −X, +Y, −Y, +Z, −Z) of a
/// [`Tiled`] cube: tour faces are the GPU faces of the mirror image in z
/// (`exploremaps_format::Tiles::face_coordinates`), so they go in as they
/// are, each tile at its own place, and are read with z negated.
pub const TILE_SLOTS: [char; 6] = ['r', 'l', 'u', 'd', 'f', 'b'];

/// A sharper level of a probe's cube filled tile by tile from its tile
/// pyramid: the tiles (tour orientation, [`TILE_SLOTS`]) and a mask cube of
/// a texel a tile saying which have arrived.
pub struct Tiled {
    pub cube: Cube,
    mask: wgpu::Texture,
    pub(crate) mask_view: wgpu::TextureView,
    /// Tile edge and tiles across a face.
    pub tile: u32,
    pub across: u32,
    arrived: Vec<bool>,
}

impl Tiled {
    pub fn new(device: &wgpu::Device, size: u32, tile: u32) -> Tiled {
        let across = size.div_ceil(tile);
        let mask = mask_texture(device, across);
        let mask_view = mask.create_view(&wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::Cube), ..Default::default() });
        Tiled { cube: Cube::new(device, size), mask, mask_view, tile, across, arrived: vec![false; (6 * across * across) as usize] }
    }

    fn index(&self, slot: usize, x: u32, y: u32) -> usize {
        (slot as u32 * self.across * self.across + y * self.across + x) as usize
    }

    pub fn has(&self, slot: usize, x: u32, y: u32) -> bool {
        self.arrived[self.index(slot, x, y)]
    }

    pub fn count(&self) -> usize {
        self.arrived.iter().filter(|a| **a).count()
    }

    /// Marks tile (x, y) of slot `slot` as in (its pixels written at
    /// (x, y) × tile of layer `slot` of `cube`).
    pub fn arrived(&mut self, queue: &wgpu::Queue, slot: usize, x: u32, y: u32) {
        let i = self.index(slot, x, y);
        self.arrived[i] = true;
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.mask,
                mip_level: 0,
                origin: wgpu::Origin3d { x, y, z: slot as u32 },
                aspect: wgpu::TextureAspect::All,
            },
            &[255],
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(1), rows_per_image: Some(1) },
            wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
        );
    }

    /// Writes RGBA8 pixels of a tile, `width` × `height`, at its place.
    pub fn write_tile(&mut self, queue: &wgpu::Queue, slot: usize, (x, y): (u32, u32), (width, height): (u32, u32), rgba: &[u8]) {
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.cube.texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: x * self.tile, y: y * self.tile, z: slot as u32 },
                aspect: wgpu::TextureAspect::All,
            },
            rgba,
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * width), rows_per_image: Some(height) },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        self.arrived(queue, slot, x, y);
    }

    pub fn bytes(&self) -> u64 {
        self.cube.bytes()
    }

    /// Puts a tile in: checks its size (edge tiles may be cut short) and
    /// writes it at its place.
    pub fn put(&mut self, gpu: &crate::app::Gpu, slot: usize, x: u32, y: u32, pixels: TilePixels) -> Result<(), String> {
        let want = ((self.cube.size - x * self.tile).min(self.tile), (self.cube.size - y * self.tile).min(self.tile));
        match pixels {
            TilePixels::Rgba { width, height, rgba } => {
                if (width, height) != want {
                    return Err(format!("is {width}×{height}, but the tile pyramid says {}×{}", want.0, want.1));
                }
                self.write_tile(&gpu.queue, slot, (x, y), (width, height), &rgba);
            }
            #[cfg(target_arch = "wasm32")]
            TilePixels::Bitmap(image) => {
                if (image.width(), image.height()) != want {
                    return Err(format!("is {}×{}, but the tile pyramid says {}×{}", image.width(), image.height(), want.0, want.1));
                }
                gpu.queue.copy_external_image_to_texture(
                    &wgpu::CopyExternalImageSourceInfo {
                        source: wgpu::ExternalImageSource::ImageBitmap(image),
                        origin: wgpu::Origin2d::ZERO,
                        flip_y: false,
                    },
                    wgpu::CopyExternalImageDestInfo {
                        texture: &self.cube.texture,
                        mip_level: 0,
                        origin: wgpu::Origin3d { x: x * self.tile, y: y * self.tile, z: slot as u32 },
                        aspect: wgpu::TextureAspect::All,
                        color_space: wgpu::PredefinedColorSpace::Srgb,
                        premultiplied_alpha: false,
                    },
                    wgpu::Extent3d { width: want.0, height: want.1, depth_or_array_layers: 1 },
                );
                self.arrived(&gpu.queue, slot, x, y);
            }
        }
        Ok(())
    }
}

/// A tile as a platform decoded it.
pub enum TilePixels {
    Rgba {
        width: u32,
        height: u32,
        rgba: Vec<u8>,
    },
    /// Decoded by the browser, copied in by the GPU.
    #[cfg(target_arch = "wasm32")]
    Bitmap(web_sys::ImageBitmap),
}

/// The tiles of a `size` cube cut `tile` square that the view (`view` on a
/// target of ratio `aspect`) may show, as (slot, x, y), nearest its centre
/// first. A tile counts when the cone round it (centre to farthest corner)
/// meets the cone round the view (centre to corner of the screen): a few
/// more than the exact set, never fewer.
pub fn visible_tiles(view: &View, aspect: f32, size: u32, tile: u32) -> Vec<(usize, u32, u32)> {
    use glam::Vec3;
    let forward = Vec3::from(direction(view.yaw, view.pitch));
    let half = (0.5 * view.fov_y).tan();
    let reach = (half * (1.0 + aspect * aspect).sqrt()).atan();
    let across = size.div_ceil(tile);
    // Tour faces are read with z negated: a tile's world direction is the
    // slot's GPU direction mirrored in z.
    let at = |slot: usize, px: u32, py: u32| {
        let d = exploremaps_format::cube_direction(slot, px.min(size) as f32 / size as f32, py.min(size) as f32 / size as f32);
        Vec3::new(d[0], d[1], -d[2]).normalize()
    };
    let mut out = Vec::new();
    for slot in 0..6 {
        for y in 0..across {
            for x in 0..across {
                let (x0, y0, x1, y1) = (x * tile, y * tile, (x + 1) * tile, (y + 1) * tile);
                let centre = at(slot, (x0 + x1.min(size)) / 2, (y0 + y1.min(size)) / 2);
                let radius = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].iter().map(|&(a, b)| centre.angle_between(at(slot, a, b))).fold(0.0, f32::max);
                let off = forward.angle_between(centre);
                if off <= radius + reach {
                    out.push((off, slot, x, y));
                }
            }
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out.into_iter().map(|(_, slot, x, y)| (slot, x, y)).collect()
}

/// A cube of `across`² single-byte texels a face, zero (no tile yet).
pub(crate) fn mask_texture(device: &wgpu::Device, across: u32) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("tile mask"),
        size: wgpu::Extent3d { width: across, height: across, depth_or_array_layers: 6 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R8Unorm,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// The texture a path's video frames are copied into.
pub struct VideoTexture {
    pub texture: wgpu::Texture,
    view: wgpu::TextureView,
    pub width: u32,
    pub height: u32,
}

impl VideoTexture {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> VideoTexture {
        let texture = image_texture(device, "video frame", width, height, 1);
        let view = texture.create_view(&Default::default());
        VideoTexture { texture, view, width, height }
    }

    /// Uploads one frame of RGBA8 pixels.
    pub fn write(&self, queue: &wgpu::Queue, rgba: &[u8]) {
        write_layer(queue, &self.texture, 0, self.width, self.height, rgba);
    }
}

/// What a panorama pass draws, over what is there with `opacity` (1:
/// replaces it).
#[derive(Clone, Copy)]
pub struct Shown<'a> {
    pub source: Source<'a>,
    pub opacity: f32,
}

/// What to draw.
#[derive(Clone, Copy)]
pub enum Source<'a> {
    /// A whole cube, with the tiles of a sharper level that have arrived.
    Cube(&'a Cube, Option<&'a Tiled>),
    /// From the first cube to the second, by the fraction given.
    Fade((&'a Cube, Option<&'a Tiled>), (&'a Cube, Option<&'a Tiled>), f32),
    Video(&'a VideoTexture),
}

/// The GPU side of drawing panoramas into targets of one format.
pub struct PanoramaPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    uniforms: wgpu::Buffer,
    nearest: wgpu::Sampler,
    /// Bound where a source leaves a slot unused.
    blank_cube: Cube,
    blank_video: VideoTexture,
    blank_mask: wgpu::TextureView,
}

impl PanoramaPass {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> PanoramaPass {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("panorama"),
            source: wgpu::ShaderSource::Wgsl(format!("{FULL_SCREEN}{SHADER}").into()),
        });
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry { binding, visibility: wgpu::ShaderStages::FRAGMENT, ty, count: None };
        let texture = |dim| wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: dim,
            multisampled: false,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("panorama"),
            entries: &[
                entry(0, wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None }),
                entry(1, texture(wgpu::TextureViewDimension::Cube)),
                entry(2, texture(wgpu::TextureViewDimension::Cube)),
                entry(3, texture(wgpu::TextureViewDimension::D2)),
                entry(4, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)),
                entry(5, texture(wgpu::TextureViewDimension::Cube)),
                entry(6, texture(wgpu::TextureViewDimension::Cube)),
                entry(7, texture(wgpu::TextureViewDimension::Cube)),
                entry(8, texture(wgpu::TextureViewDimension::Cube)),
                entry(9, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("panorama"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("panorama"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState { module: &shader, entry_point: Some("vs"), compilation_options: Default::default(), buffers: &[] },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                // Blended by a constant: the opacity of a fade over the dollhouse.
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(wgpu::BlendState {
                        color: wgpu::BlendComponent {
                            src_factor: wgpu::BlendFactor::Constant,
                            dst_factor: wgpu::BlendFactor::OneMinusConstant,
                            operation: wgpu::BlendOperation::Add,
                        },
                        alpha: wgpu::BlendComponent::REPLACE,
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("panorama"),
            address_mode_u: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("panorama view"),
            size: 64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let nearest = device.create_sampler(&wgpu::SamplerDescriptor { label: Some("tile mask"), ..Default::default() });
        let blank_mask = mask_texture(device, 1)
            .create_view(&wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::Cube), ..Default::default() });
        PanoramaPass {
            pipeline,
            layout,
            sampler,
            uniforms,
            nearest,
            blank_cube: Cube::new(device, 1),
            blank_video: VideoTexture::new(device, 1, 1),
            blank_mask,
        }
    }

    /// Draws `shown` as seen in `view` into a pass over a target of aspect
    /// ratio `aspect`.
    pub fn draw(&self, device: &wgpu::Device, queue: &wgpu::Queue, pass: &mut wgpu::RenderPass<'_>, lens: &Lens, shown: Shown<'_>) {
        let Shown { source, opacity } = shown;
        let blank = (&self.blank_cube, None);
        let (a, b, video, fade) = match source {
            Source::Cube(c, t) => ((c, t), blank, &self.blank_video, 0.0),
            Source::Fade(a, b, t) => (a, b, &self.blank_video, t.clamp(0.0, 1.0)),
            Source::Video(v) => (blank, blank, v, 0.0),
        };
        let views = |t: Option<&Tiled>| {
            t.map(|t| (t.cube.view.clone(), t.mask_view.clone())).unwrap_or_else(|| (self.blank_cube.view.clone(), self.blank_mask.clone()))
        };
        let ((tiles_a, mask_a), (tiles_b, mask_b)) = (views(a.1), views(b.1));
        let (a, b) = (a.0, b.0);
        let u = uniforms(lens, fade, matches!(source, Source::Video(_)));
        let bytes: Vec<u8> = u.iter().flat_map(|x| x.to_le_bytes()).collect();
        queue.write_buffer(&self.uniforms, 0, &bytes);
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("panorama"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.uniforms.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&a.view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&b.view) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&video.view) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::TextureView(&tiles_a) },
                wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::TextureView(&mask_a) },
                wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(&tiles_b) },
                wgpu::BindGroupEntry { binding: 8, resource: wgpu::BindingResource::TextureView(&mask_b) },
                wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::Sampler(&self.nearest) },
            ],
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind, &[]);
        let o = f64::from(opacity.clamp(0.0, 1.0));
        pass.set_blend_constant(wgpu::Color { r: o, g: o, b: o, a: 1.0 });
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
pub(crate) mod tests;
