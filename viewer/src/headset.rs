//! What a headset shows beyond the panorama, and how a visitor moves in it:
//! targets where paths leave and at the probes nearby, the one a
//! controller's ray (or the gaze, held for a second) points at, and a veil
//! that narrows the view while moving (the usual comfort measure against
//! motion sickness). The app draws them into each eye ([`crate::app::App::render_eyes`]);
//! the browser's session is `web/xr.rs`.

use crate::app::Eye;
use crate::navigation::Navigator;
use crate::overlay::Shape;
use exploremaps_format::direction;
use glam::Vec3;

/// Where a target leads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal {
    Path(u32),
    Probe(u32),
}

/// A target around the visitor: where it leads, and the unit direction it is seen in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    pub goal: Goal,
    pub direction: Vec3,
}

/// How far off a target a ray may point and still pick it (radians, about 7°).
pub const POINT_ANGLE: f32 = 0.12;
/// Seconds the gaze rests on a target to pick it, where there is no controller.
pub const DWELL_S: f32 = 1.0;
/// A target's radius on screen, as an angle (radians).
const TARGET_ANGLE: f32 = 0.035;

/// The targets at the current probe: each path's departure (a little below
/// its horizon, where the window puts its marker) and each other probe
/// within `near` that no path from here reaches and `blocked` (from, to)
/// does not hide.
pub fn targets(nav: &Navigator, near: f32, blocked: impl Fn(Vec3, Vec3) -> bool) -> Vec<Target> {
    let choices = nav.path_bar();
    let mut out: Vec<Target> = choices
        .iter()
        .map(|c| {
            let (yaw, pitch) = nav.departure(c.path, c.reversed);
            Target { goal: Goal::Path(c.path), direction: Vec3::from(direction(yaw, pitch - 0.25)) }
        })
        .collect();
    let here = Vec3::from(nav.graph().probes[nav.probe() as usize].position);
    for p in &nav.graph().probes {
        let there = Vec3::from(p.position);
        let d = there - here;
        if p.id == nav.probe() || d.length() > near || d.length() < 1e-4 || choices.iter().any(|c| c.to == p.id) || blocked(here, there) {
            continue;
        }
        out.push(Target { goal: Goal::Probe(p.id), direction: d.normalize() });
    }
    out
}

/// The target `ray` points at: the nearest in angle, within [`POINT_ANGLE`].
pub fn pointed(targets: &[Target], ray: Vec3) -> Option<usize> {
    let ray = ray.try_normalize()?;
    let cos = POINT_ANGLE.cos();
    targets.iter().enumerate().map(|(i, t)| (i, t.direction.dot(ray))).filter(|&(_, c)| c >= cos).max_by(|a, b| a.1.total_cmp(&b.1)).map(|(i, _)| i)
}

/// A headset's state in the app: the targets at the current probe (found
/// for `key`: the probe and the proxy's triangle count), what points at
/// them, and the veil's pass.
pub struct Headset {
    pub targets: Vec<Target>,
    pub key: Option<(u32, usize)>,
    pub pointed: Option<usize>,
    pub gaze: Gaze,
    /// Where the pointer points (world direction).
    pub ray: Option<Vec3>,
    pub veil: VeilPass,
}

impl Headset {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Headset {
        Headset { targets: Vec::new(), key: None, pointed: None, gaze: Gaze::default(), ray: None, veil: VeilPass::new(device, format) }
    }
}

/// A gaze resting on a target: picks it once held for [`DWELL_S`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gaze {
    on: Option<usize>,
    held_s: f32,
}

impl Gaze {
    /// The gaze now on `pointed` for `dt_s` more: the target picked, if this completes the hold.
    pub fn update(&mut self, pointed: Option<usize>, dt_s: f32) -> Option<usize> {
        if pointed != self.on {
            *self = Gaze { on: pointed, held_s: 0.0 };
            return None;
        }
        self.held_s += dt_s;
        if self.on.is_some() && self.held_s >= DWELL_S {
            let picked = self.on;
            *self = Gaze::default();
            return picked;
        }
        None
    }

    /// How far through the hold, 0 to 1.
    pub fn progress(&self) -> f32 {
        if self.on.is_some() {
            (self.held_s / DWELL_S).min(1.0)
        } else {
            0.0
        }
    }
}

/// The shapes one eye sees (pixels of its viewport): a disc a target, the pointed one
/// larger and highlighted, its ring filling as a gaze holds, and a small
/// cursor where the ray points.
pub fn eye_shapes(targets: &[Target], pointed: Option<usize>, gaze: f32, ray: Option<Vec3>, eye: &Eye) -> Vec<Shape> {
    let [_, _, w, h] = eye.viewport;
    let at = |d: Vec3| eye.lens.project(d).map(|[nx, ny]| [(nx + 1.0) * 0.5 * w, (1.0 - ny) * 0.5 * h]);
    // Pixels per radian near the middle of the eye.
    let scale = 0.5 * h / eye.lens.scale[1];
    let r = TARGET_ANGLE * scale;
    let mut out = Vec::new();
    for (i, t) in targets.iter().enumerate() {
        let Some([x, y]) = at(t.direction) else { continue };
        let chosen = pointed == Some(i);
        let radius = if chosen { 1.4 * r } else { r };
        let colour = if chosen { [1.0, 0.82, 0.3, 1.0] } else { [1.0, 1.0, 1.0, 0.9] };
        out.push(Shape::disc(x, y, radius + 0.15 * r, [0.0, 0.0, 0.0, 0.5]));
        out.push(Shape::disc(x, y, radius, colour));
        if chosen && gaze > 0.0 {
            out.push(Shape::disc(x, y, radius * gaze, [0.2, 0.6, 1.0, 1.0]));
        }
    }
    if let Some([x, y]) = ray.and_then(at) {
        out.push(Shape::disc(x, y, 0.3 * r, [0.2, 0.6, 1.0, 0.9]));
    }
    out
}

#[cfg(test)]
mod tests;

const VEIL_SHADER: &str = r#"
@group(0) @binding(0) var<uniform> strength: vec4f;


@fragment fn fs(v: VOut) -> @location(0) vec4f {
    // Clear in the middle, darkening toward the edges of the eye.
    return vec4f(0.0, 0.0, 0.0, strength.x * smoothstep(0.35, 0.95, length(v.ndc)));
}
"#;

/// Darkens the edges of each eye's view while moving, by `strength` (0 to 1).
pub struct VeilPass {
    pipeline: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind: wgpu::BindGroup,
}

impl VeilPass {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> VeilPass {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("veil"),
            source: wgpu::ShaderSource::Wgsl(format!("{}{VEIL_SHADER}", crate::panorama::FULL_SCREEN).into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("veil"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("veil"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("veil"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState { module: &shader, entry_point: Some("vs"), buffers: &[], compilation_options: Default::default() },
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs"),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                compilation_options: Default::default(),
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("veil"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("veil"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() }],
        });
        VeilPass { pipeline, uniforms, bind }
    }

    /// Sets how strong the veil is for the draws of the next submission.
    pub fn set(&self, queue: &wgpu::Queue, strength: f32) {
        let bytes: Vec<u8> = [strength.clamp(0.0, 1.0), 0.0, 0.0, 0.0].iter().flat_map(|x| x.to_le_bytes()).collect();
        queue.write_buffer(&self.uniforms, 0, &bytes);
    }

    /// Draws it over the pass's viewport.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.draw(0..3, 0..1);
    }
}
