//! Draws a probe's cube-map panorama for a view: one full-screen triangle
//! whose fragment shader turns each pixel into a world direction and samples
//! the cube. The bundle's faces follow the GPU cube-map convention
//! (`exploremaps_format::cube_direction`), so they upload as they are.

use exploremaps_format::direction;

/// Where the viewer looks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Radians, the bundle's convention (0 toward −Z, π/2 toward +X).
    pub yaw: f32,
    /// Radians, positive up.
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

const SHADER: &str = r#"
struct U { forward: vec4f, right: vec4f, up: vec4f, params: vec4f };
@group(0) @binding(0) var<uniform> u: U;
@group(0) @binding(1) var cube: texture_cube<f32>;
@group(0) @binding(2) var samp: sampler;

struct VOut { @builtin(position) pos: vec4f, @location(0) ndc: vec2f };

@vertex fn vs(@builtin(vertex_index) i: u32) -> VOut {
    let p = vec2f(f32((i << 1u) & 2u), f32(i & 2u)) * 2.0 - 1.0;
    var o: VOut;
    o.pos = vec4f(p, 0.0, 1.0);
    o.ndc = p;
    return o;
}

@fragment fn fs(v: VOut) -> @location(0) vec4f {
    // params: tan(fov_y / 2), aspect.
    let d = u.forward.xyz + u.right.xyz * (v.ndc.x * u.params.x * u.params.y) + u.up.xyz * (v.ndc.y * u.params.x);
    return vec4f(textureSample(cube, samp, d).rgb, 1.0);
}
"#;

/// The camera basis and projection, as the shader reads them.
fn uniforms(view: &View, aspect: f32) -> [f32; 16] {
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
    [f[0], f[1], f[2], 0.0, r[0], r[1], r[2], 0.0, u[0], u[1], u[2], 0.0, (0.5 * view.fov_y).tan(), aspect, 0.0, 0.0]
}

/// The GPU side of drawing panoramas into targets of one format.
pub struct PanoramaPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    uniforms: wgpu::Buffer,
    bind: Option<wgpu::BindGroup>,
}

impl PanoramaPass {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> PanoramaPass {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("panorama"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry { binding, visibility: wgpu::ShaderStages::FRAGMENT, ty, count: None };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("panorama"),
            entries: &[
                entry(0, wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None }),
                entry(1, wgpu::BindingType::Texture { sample_type: wgpu::TextureSampleType::Float { filterable: true }, view_dimension: wgpu::TextureViewDimension::Cube, multisampled: false }),
                entry(2, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("panorama"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
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
                targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("panorama"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor { label: Some("panorama view"), size: 64, usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST, mapped_at_creation: false });
        PanoramaPass { pipeline, layout, sampler, uniforms, bind: None }
    }

    /// Uploads six RGBA8 sRGB faces, `size` pixels square, in the bundle's order.
    pub fn set_cube(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, size: u32, faces: [&[u8]; 6]) {
        let extent = wgpu::Extent3d { width: size, height: size, depth_or_array_layers: 6 };
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("panorama cube"),
            size: extent,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        for (layer, face) in faces.iter().enumerate() {
            queue.write_texture(
                wgpu::TexelCopyTextureInfo { texture: &texture, mip_level: 0, origin: wgpu::Origin3d { x: 0, y: 0, z: layer as u32 }, aspect: wgpu::TextureAspect::All },
                face,
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * size), rows_per_image: Some(size) },
                wgpu::Extent3d { width: size, height: size, depth_or_array_layers: 1 },
            );
        }
        let view = texture.create_view(&wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::Cube), ..Default::default() });
        self.bind = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("panorama"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.uniforms.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        }));
    }

    /// Draws the panorama as seen in `view` into a pass over a target of
    /// aspect ratio `aspect`; nothing before a cube is set.
    pub fn draw(&self, queue: &wgpu::Queue, pass: &mut wgpu::RenderPass<'_>, view: &View, aspect: f32) {
        let Some(bind) = &self.bind else { return };
        let u = uniforms(view, aspect);
        let bytes: Vec<u8> = u.iter().flat_map(|x| x.to_le_bytes()).collect();
        queue.write_buffer(&self.uniforms, 0, &bytes);
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests;
