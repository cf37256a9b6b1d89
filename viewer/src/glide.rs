//! A glide: a path drawn from its two ends' panoramas and depth, with no
//! video. Each end's depth cube ([`exploremaps_format::depthcube`]) becomes
//! a mesh, a vertex at each lattice corner where the probe sees it
//! (sky: very far away), drawn from the moving camera with the probe's cube
//! map looked up along the direction from the probe. Where a triangle
//! spans a depth step (a rubber sheet between a near edge and what lies
//! behind it, nearly parallel to the probe's rays), it is marked unsure.
//! The two ends are drawn into targets of their own and blended by where the
//! camera is and how sure each is; at an end, the camera at the probe sees
//! exactly its panorama (every pixel's ray from the probe meets the mesh
//! where the probe's own ray did).

use crate::panorama::{mask_texture, Cube, Lens, Tiled};
use exploremaps_format::depthcube::DepthCube;
use glam::{Mat4, Vec3};
use std::collections::HashMap;
use wgpu::util::DeviceExt;

const MESH_SHADER: &str = r#"
struct U { view_proj: mat4x4f, probe: vec4f };
@group(0) @binding(0) var<uniform> u: U;
@group(0) @binding(1) var cube: texture_cube<f32>;
@group(0) @binding(2) var tiles: texture_cube<f32>;
@group(0) @binding(3) var mask: texture_cube<f32>;
@group(0) @binding(4) var samp: sampler;
@group(0) @binding(5) var nearest: sampler;

struct VOut { @builtin(position) pos: vec4f, @location(0) world: vec3f };

@vertex fn vs(@location(0) p: vec3f) -> VOut {
    var o: VOut;
    o.pos = u.view_proj * vec4f(p, 1.0);
    o.world = p;
    return o;
}

struct FOut { @location(0) colour: vec4f, @builtin(frag_depth) depth: f32 };

@fragment fn fs(v: VOut) -> FOut {
    let d = v.world - u.probe.xyz;
    // Tiles hold tour-oriented faces, read with z negated (see panorama.rs).
    let t = vec3f(d.x, d.y, -d.z);
    let c = mix(textureSampleLevel(cube, samp, d, 0.0).rgb, textureSampleLevel(tiles, samp, t, 0.0).rgb, textureSampleLevel(mask, nearest, t, 0.0).r);
    // How squarely the probe saw this triangle: a rubber sheet across a
    // depth step lies along the probe's rays. A surface seen more obliquely
    // than a few cells' angle (u.probe.w) is sampled too sparsely to tell
    // from one.
    let n = cross(dpdx(v.world), dpdy(v.world));
    let facing = abs(dot(n, d)) / max(length(n) * length(d), 1e-20);
    let sure = smoothstep(u.probe.w, 3.0 * u.probe.w, facing);
    // Alpha 0 is nothing drawn; anything drawn weighs at least a little.
    // An unsure fragment is pushed far back (reversed depth: toward 0), so
    // that it fills only where nothing sure of this end lies behind it.
    var o: FOut;
    o.colour = vec4f(c, 0.02 + 0.98 * sure);
    // (Behind the sky too, which lies 10⁴ far distances away.)
    o.depth = select(v.pos.z * 1e-9, v.pos.z, sure > 0.5);
    return o;
}
"#;

const BLEND_SHADER: &str = r#"
// t: 0 at the departure, 1 at the arrival; tol: how much nearer (as a
// fraction) one end's sure surface must be to hide the other's.
// origin: the target's viewport corner (a headset eye's), in pixels.
struct U { t: f32, tol: f32, origin: vec2f };
@group(0) @binding(0) var<uniform> u: U;
@group(0) @binding(1) var a: texture_2d<f32>;
@group(0) @binding(2) var b: texture_2d<f32>;
// Depth read as plain floats: WebGL2's shaders cannot fetch texels of a
// depth texture bound for comparison.
@group(0) @binding(3) var depth_a: texture_2d<f32>;
@group(0) @binding(4) var depth_b: texture_2d<f32>;

@vertex fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4f {
    let p = vec2f(f32((i << 1u) & 2u), f32(i & 2u)) * 2.0 - 1.0;
    return vec4f(p, 0.0, 1.0);
}

// Whether a sure surface at reversed depth `near` (larger is nearer) hides
// what lies at `far`.
fn hides(alpha: f32, near: f32, far: f32) -> f32 {
    return select(0.0, 1.0, alpha > 0.9 && near > far * (1.0 + u.tol));
}

@fragment fn fs(@builtin(position) pos: vec4f) -> @location(0) vec4f {
    let at = vec2i(pos.xy - u.origin);
    let pa = textureLoad(a, at, 0);
    let pb = textureLoad(b, at, 0);
    let za = textureLoad(depth_a, at, 0).r;
    let zb = textureLoad(depth_b, at, 0).r;
    // Where one end's sure surface lies well in front of the other's, the
    // other saw something this ray does not reach (the wall behind a
    // pillar): it steps back. Not near an end, whose own view is exact
    // there (the other's lattice cuts corners by a little).
    let wa = (1.0 - u.t) * pa.a * (1.0 - 0.98 * hides(pb.a, zb, za) * smoothstep(0.0, 0.25, u.t));
    let wb = u.t * pb.a * (1.0 - 0.98 * hides(pa.a, za, zb) * smoothstep(0.0, 0.25, 1.0 - u.t));
    if (wa + wb <= 0.0) {
        return vec4f(0.0);
    }
    return vec4f((pa.rgb * wa + pb.rgb * wb) / (wa + wb), 1.0);
}
"#;

/// Distance of the sky from a probe, in multiples of the depth cube's far
/// distance (twice the scene's diagonal): far enough that it stays put while
/// the camera moves through the scene.
const SKY: f32 = 1e4;
/// How much nearer (a fraction of the distance) one end's sure surface must
/// be than the other's to hide it, beyond what the lattices' chords account
/// for (twice the cell's angle: a cell across a room's corner cuts it).
const OCCLUSION_TOLERANCE: f32 = 0.05;
const TARGET: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A probe's depth cube as a mesh on the GPU.
pub struct GlideMesh {
    vertices: wgpu::Buffer,
    pub probe: Vec3,
    cells: u32,
    /// The nearest distance the probe sees (for the camera's near plane).
    pub nearest: f32,
}

impl GlideMesh {
    pub fn new(device: &wgpu::Device, cube: &DepthCube, probe: [f32; 3]) -> GlideMesh {
        let probe = Vec3::from(probe);
        let sky = SKY * cube.far;
        let mut nearest = f32::INFINITY;
        let positions: Vec<[f32; 3]> = cube
            .codes
            .iter()
            .enumerate()
            .map(|(i, &code)| {
                let d = cube.distance(code).unwrap_or(sky);
                nearest = nearest.min(d);
                (probe + Vec3::from(cube.corner_direction(i)) * d).to_array()
            })
            .collect();
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("glide mesh"),
            contents: &positions.iter().flatten().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>(),
            usage: wgpu::BufferUsages::VERTEX,
        });
        GlideMesh { vertices, probe, cells: cube.size, nearest }
    }

    /// Bytes of GPU memory it holds (its share of the lattice's indices aside).
    pub fn bytes(&self) -> u64 {
        self.vertices.size()
    }
}

/// What one end of a glide shows: its mesh and its panorama (a whole cube,
/// with the tiles of a sharper level that have arrived).
pub struct End<'a> {
    pub mesh: &'a GlideMesh,
    pub cube: &'a Cube,
    pub tiles: Option<&'a Tiled>,
}

/// A glide's frame: from where, seen how, toward what, and how far from the departure.
pub struct GlideFrame<'a> {
    pub eye: Vec3,
    pub lens: Lens,
    pub from: End<'a>,
    pub to: End<'a>,
    /// 0 at the departure, 1 at the arrival.
    pub t: f32,
}

/// How far a camera at `eye` is from the departure toward the arrival, 0 to
/// 1, by its distances to the two probes: the ends' share of the blend.
pub fn toward(eye: Vec3, from: Vec3, to: Vec3) -> f32 {
    let (a, b) = (eye.distance(from), eye.distance(to));
    if a + b > 0.0 {
        a / (a + b)
    } else {
        0.0
    }
}

/// Offscreen targets of one size: each end's colour and depth.
struct Targets {
    size: (u32, u32),
    colour: [wgpu::TextureView; 2],
    depth: [wgpu::TextureView; 2],
}

/// The GPU side of drawing glides into targets of one format.
pub struct GlidePass {
    mesh: wgpu::RenderPipeline,
    mesh_layout: wgpu::BindGroupLayout,
    blend: wgpu::RenderPipeline,
    blend_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    nearest: wgpu::Sampler,
    uniforms: [wgpu::Buffer; 2],
    blend_uniforms: wgpu::Buffer,
    blank_cube: Cube,
    blank_mask: wgpu::TextureView,
    /// The lattice's triangles by cell count: (indices, count).
    lattices: HashMap<u32, (wgpu::Buffer, u32)>,
    targets: Option<Targets>,
}

impl GlidePass {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> GlidePass {
        let (mesh, mesh_layout) = mesh_pipeline(device);
        let (blend, blend_layout) = blend_pipeline(device, format);
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("glide"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let nearest = device.create_sampler(&wgpu::SamplerDescriptor { label: Some("glide tile mask"), ..Default::default() });
        let uniform = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let blank_mask = mask_texture(device, 1)
            .create_view(&wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::Cube), ..Default::default() });
        GlidePass {
            mesh,
            mesh_layout,
            blend,
            blend_layout,
            sampler,
            nearest,
            uniforms: [uniform("glide departure", 80), uniform("glide arrival", 80)],
            blend_uniforms: uniform("glide blend", 16),
            blank_cube: Cube::new(device, 1),
            blank_mask,
            lattices: HashMap::new(),
            targets: None,
        }
    }

    /// Draws the glide's frame into `target` (`width` × `height`), over
    /// what is there where neither end has anything to show.
    pub fn draw(&mut self, frame: &mut crate::dollhouse::FrameTarget, glide: &GlideFrame) {
        self.draw_in(frame, glide, [0.0, 0.0]);
    }

    /// As [`GlidePass::draw`], into the `width` × `height` viewport at
    /// `origin` (pixels from the top left) of a larger target: a headset eye's.
    pub fn draw_in(&mut self, frame: &mut crate::dollhouse::FrameTarget, glide: &GlideFrame, origin: [f32; 2]) {
        let crate::dollhouse::FrameTarget { device, queue, ref mut encoder, view: target, width, height } = *frame;
        self.ensure_targets(device, width, height);
        let near = 0.5 * glide.from.mesh.nearest.min(glide.to.mesh.nearest).max(1e-6);
        let view_proj = glide.lens.view_proj(glide.eye, near, None);
        for (k, end) in [&glide.from, &glide.to].into_iter().enumerate() {
            self.draw_end(device, queue, encoder, k, end, view_proj);
        }
        let tolerance = OCCLUSION_TOLERANCE + 2.0 * cell_angle(glide.from.mesh.cells.min(glide.to.mesh.cells));
        queue.write_buffer(&self.blend_uniforms, 0, &le_bytes(&[glide.t.clamp(0.0, 1.0), tolerance, origin[0], origin[1]]));
        let targets = self.targets.as_ref().expect("made above");
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glide blend"),
            layout: &self.blend_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.blend_uniforms.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&targets.colour[0]) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&targets.colour[1]) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&targets.depth[0]) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&targets.depth[1]) },
            ],
        });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("glide blend"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_viewport(origin[0], origin[1], width as f32, height as f32, 0.0, 1.0);
        pass.set_pipeline(&self.blend);
        pass.set_bind_group(0, &bind, &[]);
        pass.draw(0..3, 0..1);
    }

    /// One end's mesh into its own target (`k`: 0 departure, 1 arrival).
    fn draw_end(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, encoder: &mut wgpu::CommandEncoder, k: usize, end: &End, view_proj: Mat4) {
        let (indices, count) = self.lattice(device, end.mesh.cells);
        let mut uniforms = view_proj.to_cols_array().to_vec();
        uniforms.extend(end.mesh.probe.extend(cell_angle(end.mesh.cells)).to_array());
        queue.write_buffer(&self.uniforms[k], 0, &le_bytes(&uniforms));
        let (tiles, mask) = end.tiles.map_or((&self.blank_cube.view, &self.blank_mask), |t| (&t.cube.view, &t.mask_view));
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glide end"),
            layout: &self.mesh_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.uniforms[k].as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&end.cube.view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(tiles) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(mask) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::Sampler(&self.nearest) },
            ],
        });
        let targets = self.targets.as_ref().expect("made before the ends");
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("glide end"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &targets.colour[k],
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store },
            })],
            // Reversed depth: 1 at the near plane, 0 at infinity.
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth[k],
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.mesh);
        pass.set_bind_group(0, &bind, &[]);
        pass.set_vertex_buffer(0, end.mesh.vertices.slice(..));
        pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..count, 0, 0..1);
    }

    /// The triangles of a lattice of `cells` cells a face edge (two a cell).
    fn lattice(&mut self, device: &wgpu::Device, cells: u32) -> (wgpu::Buffer, u32) {
        let (buffer, count) = self.lattices.entry(cells).or_insert_with(|| {
            let indices = lattice_indices(cells);
            let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("glide lattice"),
                contents: &indices.iter().flat_map(|i| i.to_le_bytes()).collect::<Vec<u8>>(),
                usage: wgpu::BufferUsages::INDEX,
            });
            (buffer, indices.len() as u32)
        });
        (buffer.clone(), *count)
    }

    fn ensure_targets(&mut self, device: &wgpu::Device, width: u32, height: u32) {
        let size = (width.max(1), height.max(1));
        if self.targets.as_ref().is_some_and(|t| t.size == size) {
            return;
        }
        let texture = |label, format, usage| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let colour = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        self.targets = Some(Targets {
            size,
            colour: [texture("glide departure", TARGET, colour), texture("glide arrival", TARGET, colour)],
            depth: [texture("glide departure depth", DEPTH, colour), texture("glide arrival depth", DEPTH, colour)],
        });
    }
}

/// The angle a cell of a `cells`-cell lattice spans at a face's centre, radians.
fn cell_angle(cells: u32) -> f32 {
    (2.0 / cells.max(1) as f32).atan()
}

fn le_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Two triangles a cell, face by face, over the corners in
/// [`DepthCube::corner_direction`] order.
fn lattice_indices(cells: u32) -> Vec<u32> {
    let n = cells + 1;
    let mut indices = Vec::with_capacity(36 * (cells * cells) as usize);
    for face in 0..6 {
        for row in 0..cells {
            for column in 0..cells {
                let i = face * n * n + row * n + column;
                indices.extend([i, i + 1, i + n + 1, i, i + n + 1, i + n]);
            }
        }
    }
    indices
}

fn mesh_pipeline(device: &wgpu::Device) -> (wgpu::RenderPipeline, wgpu::BindGroupLayout) {
    let shader =
        device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("glide mesh"), source: wgpu::ShaderSource::Wgsl(MESH_SHADER.into()) });
    let entry = |binding, visibility, ty| wgpu::BindGroupLayoutEntry { binding, visibility, ty, count: None };
    let cube = wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Float { filterable: true },
        view_dimension: wgpu::TextureViewDimension::Cube,
        multisampled: false,
    };
    let fragment = wgpu::ShaderStages::FRAGMENT;
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("glide mesh"),
        entries: &[
            entry(
                0,
                wgpu::ShaderStages::VERTEX_FRAGMENT,
                wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
            ),
            entry(1, fragment, cube),
            entry(2, fragment, cube),
            entry(3, fragment, cube),
            entry(4, fragment, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)),
            entry(5, fragment, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)),
        ],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("glide mesh"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("glide mesh"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: 12,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x3],
            })],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format: TARGET, blend: None, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    });
    (pipeline, layout)
}

fn blend_pipeline(device: &wgpu::Device, format: wgpu::TextureFormat) -> (wgpu::RenderPipeline, wgpu::BindGroupLayout) {
    let shader = device
        .create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("glide blend"), source: wgpu::ShaderSource::Wgsl(BLEND_SHADER.into()) });
    let entry = |binding, ty| wgpu::BindGroupLayoutEntry { binding, visibility: wgpu::ShaderStages::FRAGMENT, ty, count: None };
    let texture = wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Float { filterable: false },
        view_dimension: wgpu::TextureViewDimension::D2,
        multisampled: false,
    };
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("glide blend"),
        entries: &[
            entry(0, wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None }),
            entry(1, texture),
            entry(2, texture),
            entry(3, texture),
            entry(4, texture),
        ],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("glide blend"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("glide blend"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState { module: &shader, entry_point: Some("vs"), compilation_options: Default::default(), buffers: &[] },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            // Over what is there, where neither end drew (alpha 0).
            targets: &[Some(wgpu::ColorTargetState { format, blend: Some(wgpu::BlendState::ALPHA_BLENDING), write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    });
    (pipeline, layout)
}

#[cfg(test)]
mod tests;
