//! Draws the interface over the panorama: solid or thumbnail-textured strips
//! and discs (bars, map, markers), as instanced quads. Each shape is a strip
//! from `a` to `b` (pixels) `width` wide, so rectangles, map lines and dots are
//! one kind of instance. Thumbnails live in one 2D array texture, a layer each.

/// One shape. `layer` < 0 is a solid colour, else a thumbnail layer tinted by `colour`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shape {
    pub a: [f32; 2],
    pub b: [f32; 2],
    pub width: f32,
    pub layer: f32,
    /// 1 draws the ellipse inscribed in the strip, 0 the whole strip.
    pub round: f32,
    pub colour: [f32; 4],
}

impl Shape {
    /// An axis-aligned rectangle (x, y, w, h in pixels, y down).
    pub fn rect(x: f32, y: f32, w: f32, h: f32, colour: [f32; 4]) -> Shape {
        Shape { a: [x, y + h / 2.0], b: [x + w, y + h / 2.0], width: h, layer: -1.0, round: 0.0, colour }
    }

    pub fn thumbnail(x: f32, y: f32, w: f32, h: f32, layer: u32) -> Shape {
        Shape { layer: layer as f32, colour: [1.0; 4], ..Shape::rect(x, y, w, h, [1.0; 4]) }
    }

    pub fn disc(cx: f32, cy: f32, r: f32, colour: [f32; 4]) -> Shape {
        Shape { a: [cx - r, cy], b: [cx + r, cy], width: 2.0 * r, layer: -1.0, round: 1.0, colour }
    }

    pub fn line(a: [f32; 2], b: [f32; 2], width: f32, colour: [f32; 4]) -> Shape {
        Shape { a, b, width, layer: -1.0, round: 0.0, colour }
    }

    fn bytes(&self) -> [u8; 44] {
        let v = [
            self.a[0],
            self.a[1],
            self.b[0],
            self.b[1],
            self.width,
            self.layer,
            self.round,
            self.colour[0],
            self.colour[1],
            self.colour[2],
            self.colour[3],
        ];
        let mut out = [0; 44];
        for (i, x) in v.iter().enumerate() {
            out[4 * i..4 * i + 4].copy_from_slice(&x.to_le_bytes());
        }
        out
    }
}

const SHADER: &str = r#"
struct U { screen: vec4f };
@group(0) @binding(0) var<uniform> u: U;
@group(0) @binding(1) var thumbs: texture_2d_array<f32>;
@group(0) @binding(2) var samp: sampler;

struct I { @location(0) ab: vec4f, @location(1) wlr: vec3f, @location(2) colour: vec4f };
struct VOut { @builtin(position) pos: vec4f, @location(0) uv: vec2f, @location(1) colour: vec4f, @location(2) @interpolate(flat) lr: vec2f };

@vertex fn vs(@builtin(vertex_index) v: u32, i: I) -> VOut {
    let corner = vec2f(f32(v & 1u), f32((v >> 1u) & 1u));
    let a = i.ab.xy;
    let b = i.ab.zw;
    let along = b - a;
    let len = max(length(along), 1e-6);
    let n = vec2f(-along.y, along.x) / len;
    let p = a + along * corner.x + n * (corner.y - 0.5) * i.wlr.x;
    var o: VOut;
    o.pos = vec4f(p.x / u.screen.x * 2.0 - 1.0, 1.0 - p.y / u.screen.y * 2.0, 0.0, 1.0);
    o.uv = corner;
    o.colour = i.colour;
    o.lr = i.wlr.yz;
    return o;
}

@fragment fn fs(v: VOut) -> @location(0) vec4f {
    if v.lr.y > 0.5 && length(v.uv - 0.5) > 0.5 { discard; }
    var c = v.colour;
    let t = textureSampleLevel(thumbs, samp, v.uv, i32(max(v.lr.x, 0.0)), 0.0);
    if v.lr.x >= 0.0 { c = vec4f(c.rgb * t.rgb, c.a); }
    return vec4f(c.rgb * c.a, c.a);
}
"#;

/// Thumbnails are stored at this size (16:9, like the bundle's thumbnails).
pub const THUMB_W: u32 = 192;
pub const THUMB_H: u32 = 108;
/// WebGL2 guarantees 256 array layers; probes beyond show as plain tiles.
pub const MAX_THUMBS: u32 = 256;

pub struct OverlayPass {
    pipeline: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    uniforms: wgpu::Buffer,
    instances: Option<wgpu::Buffer>,
    pub thumbs: wgpu::Texture,
    pub thumb_count: u32,
}

impl OverlayPass {
    /// `thumb_count` layers of THUMB_W × THUMB_H, filled later.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat, thumb_count: u32) -> OverlayPass {
        let thumb_count = thumb_count.clamp(1, MAX_THUMBS);
        // Two layers at least, so WebGL2 binds it as an array.
        let thumbs = crate::panorama::image_texture(device, "thumbnails", THUMB_W, THUMB_H, thumb_count.max(2));
        let shader =
            device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("overlay"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("overlay"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("overlay screen"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let view = thumbs.create_view(&wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::D2Array), ..Default::default() });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("overlay"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&sampler) },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("overlay"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("overlay"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 44,
                    step_mode: wgpu::VertexStepMode::Instance,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x3, 2 => Float32x4],
                })],
            },
            primitive: wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::TriangleStrip, ..Default::default() },
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        OverlayPass { pipeline, bind, uniforms, instances: None, thumbs, thumb_count }
    }

    /// Uploads a thumbnail (THUMB_W × THUMB_H RGBA8) into its layer.
    pub fn write_thumbnail(&self, queue: &wgpu::Queue, layer: u32, rgba: &[u8]) {
        if layer >= self.thumb_count {
            return;
        }
        crate::panorama::write_layer(queue, &self.thumbs, layer, THUMB_W, THUMB_H, rgba);
    }

    /// Draws `shapes` in order over a target `width` × `height` pixels.
    pub fn draw(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, pass: &mut wgpu::RenderPass<'_>, shapes: &[Shape], width: f32, height: f32) {
        if shapes.is_empty() {
            return;
        }
        let bytes: Vec<u8> = shapes.iter().flat_map(|s| s.bytes()).collect();
        let needed = bytes.len() as u64;
        if self.instances.as_ref().is_none_or(|b| b.size() < needed) {
            self.instances = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("overlay shapes"),
                size: needed.next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let instances = self.instances.as_ref().expect("made above");
        queue.write_buffer(instances, 0, &bytes);
        let screen: Vec<u8> = [width, height, 0.0, 0.0].iter().flat_map(|x| x.to_le_bytes()).collect();
        queue.write_buffer(&self.uniforms, 0, &screen);
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.set_vertex_buffer(0, instances.slice(..needed));
        pass.draw(0..4, 0..shapes.len() as u32);
    }
}
