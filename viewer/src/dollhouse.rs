//! The dollhouse: the scene's proxy (the builder's simplified, colour-baked
//! mesh) seen from outside and above, cut at a storey's ceiling so the rooms
//! show. The pure part (cameras, picking, where a tap leads) is unit-tested;
//! `DollhousePass` draws the mesh with a depth buffer.

use exploremaps_format::{meshcode::MeshData, seen::NONE, yaw_pitch, Graph};
use glam::{Mat4, Vec3, Vec4};

/// A decoded proxy level and its point-to-go table.
pub struct ProxyMesh {
    pub level: usize,
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// sRGB per vertex (grey when the level has none).
    pub colours: Vec<[u8; 3]>,
    /// Per triangle, the probe that sees it best (empty when the bundle has no table).
    pub seen: Vec<u32>,
    pub lo: Vec3,
    pub hi: Vec3,
}

impl ProxyMesh {
    pub fn new(level: usize, data: MeshData, seen: Vec<u32>) -> ProxyMesh {
        ProxyMesh::from_parts(level, vec![(data, seen)])
    }

    /// A level from its decoded parts (chunks), in order: their vertices and
    /// triangles one after the other. A part without colours is grey; one
    /// without a table has no probe for its triangles.
    pub fn from_parts(level: usize, parts: Vec<(MeshData, Vec<u32>)>) -> ProxyMesh {
        let mut mesh =
            ProxyMesh { level, positions: Vec::new(), triangles: Vec::new(), colours: Vec::new(), seen: Vec::new(), lo: Vec3::ZERO, hi: Vec3::ZERO };
        for (data, seen) in parts {
            let base = mesh.positions.len() as u32;
            let n = data.positions.len();
            mesh.positions.extend(data.positions.iter().map(|&p| Vec3::from(p)));
            mesh.colours.extend(if data.colours.len() == n { data.colours } else { vec![[170; 3]; n] });
            mesh.seen.extend(if seen.len() == data.triangles.len() { seen } else { vec![NONE; data.triangles.len()] });
            mesh.triangles.extend(data.triangles.iter().map(|t| t.map(|v| v + base)));
        }
        if !mesh.positions.is_empty() {
            (mesh.lo, mesh.hi) = mesh.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        }
        mesh
    }

    pub fn diagonal(&self) -> f32 {
        (self.hi - self.lo).length()
    }

    /// The nearest triangle the ray `origin + t·dir` (t > 0) hits at a point
    /// no higher than `cut`, and its `t`. Both sides of a triangle count.
    pub fn pick(&self, origin: Vec3, dir: Vec3, cut: f32) -> Option<(usize, f32)> {
        let mut best: Option<(usize, f32)> = None;
        for (i, t) in self.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|v| self.positions[v as usize]);
            // Möller and Trumbore.
            let (e1, e2) = (b - a, c - a);
            let p = dir.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-12 {
                continue;
            }
            let s = origin - a;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = dir.dot(q) / det;
            let t = e2.dot(q) / det;
            if u < 0.0 || v < 0.0 || u + v > 1.0 || t <= 1e-6 || best.is_some_and(|(_, bt)| t >= bt) {
                continue;
            }
            if (origin + dir * t).y <= cut {
                best = Some((i, t));
            }
        }
        best
    }

    /// The proxy cut by the plane at height `y`: a segment per triangle that
    /// crosses it (x and z of both ends), the walls' outlines on a floor plan.
    pub fn section(&self, y: f32) -> Vec<[f32; 4]> {
        let mut out = Vec::new();
        for t in &self.triangles {
            let p = t.map(|v| self.positions[v as usize]);
            let above = p.map(|q| q.y >= y);
            if above.iter().all(|&a| a) || above.iter().all(|&a| !a) {
                continue;
            }
            // The two edges whose ends are on either side.
            let mut ends = (0..3).filter(|&i| above[i] != above[(i + 1) % 3]).map(|i| {
                let (a, b) = (p[i], p[(i + 1) % 3]);
                a.lerp(b, (y - a.y) / (b.y - a.y))
            });
            if let (Some(a), Some(b)) = (ends.next(), ends.next()) {
                out.push([a.x, a.z, b.x, b.z]);
            }
        }
        out
    }

    /// Where a tap on `triangle` at `point` leads: the probe that sees it
    /// best by the builder's table, else (no table, or a triangle no probe
    /// sees) the probe with the largest |cos θ| / d² among those the proxy
    /// does not hide it from, else the nearest. `None` without probes.
    pub fn destination(&self, graph: &Graph, triangle: usize, point: Vec3) -> Option<u32> {
        let n = graph.probes.len() as u32;
        if let Some(&p) = self.seen.get(triangle).filter(|&&p| p != NONE && p < n) {
            return Some(p);
        }
        let [a, b, c] = self.triangles.get(triangle)?.map(|v| self.positions[v as usize]);
        let normal = (b - a).cross(c - a).normalize_or_zero();
        let slack = 1e-3 * self.diagonal();
        let score = |eye: Vec3| {
            let d = point - eye;
            let dist = d.length().max(1e-6);
            let hidden = self.pick(eye, d / dist, f32::INFINITY).is_some_and(|(_, t)| t < dist - slack);
            (!hidden).then(|| (normal.dot(d).abs() / dist).max(0.05) / (dist * dist))
        };
        let seen = graph.probes.iter().filter_map(|p| Some((p.id, score(Vec3::from(p.position))?))).max_by(|x, y| x.1.total_cmp(&y.1));
        seen.map(|(id, _)| id).or_else(|| {
            graph.probes.iter().min_by(|x, y| Vec3::from(x.position).distance(point).total_cmp(&Vec3::from(y.position).distance(point))).map(|p| p.id)
        })
    }
}

/// Decodes a proxy level's files (already read) into what
/// [`crate::app::Loaded::Proxy`] carries; an error names the file at fault.
pub fn decode_level(mesh_file: &str, mesh: &[u8], seen_file: Option<(&str, &[u8])>, probes: u32) -> Result<(MeshData, Vec<u32>), (String, String)> {
    let data = exploremaps_format::meshcode::decode(mesh).map_err(|e| (mesh_file.to_string(), e.to_string()))?;
    let seen = match seen_file {
        Some((file, bytes)) => {
            exploremaps_format::seen::decode(bytes, data.triangles.len(), probes).map_err(|e| (file.to_string(), e.to_string()))?
        }
        None => Vec::new(),
    };
    Ok((data, seen))
}

/// A proxy level being refined by vertex splits as their packets arrive
/// (the builder's stream, [`exploremaps_format::splits`]); the triangles'
/// groups carry their point-to-go entries ([`exploremaps_format::ProxyStream`]).
pub struct Refining {
    refiner: exploremaps_format::splits::Refiner,
    probes: u32,
}

impl Refining {
    /// Starts from the coarse level's files (already read); an error names
    /// the file at fault.
    pub fn new(base_file: &str, base: &[u8], seen_file: Option<(&str, &[u8])>, probes: u32) -> Result<Refining, (String, String)> {
        let (mut data, seen) = decode_level(base_file, base, seen_file, probes)?;
        data.groups = if seen.is_empty() { vec![probes; data.triangles.len()] } else { seen.iter().map(|&p| p.min(probes)).collect() };
        let refiner = exploremaps_format::splits::Refiner::new(data).map_err(|e| (base_file.to_string(), e.to_string()))?;
        Ok(Refining { refiner, probes })
    }

    /// Applies the next packet (from `file`).
    pub fn apply(&mut self, file: &str, packet: &[u8]) -> Result<(), (String, String)> {
        self.refiner.apply_packet(packet).map_err(|e| (file.to_string(), e.to_string()))
    }

    /// The mesh as it now is, and its point-to-go table.
    pub fn snapshot(&self) -> (MeshData, Vec<u32>) {
        let mesh = self.refiner.mesh.clone();
        let seen = mesh.groups.iter().map(|&p| if p < self.probes { p } else { NONE }).collect();
        (mesh, seen)
    }
}

/// A perspective camera: where it is, where it looks, its vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    /// Unit.
    pub forward: Vec3,
    pub fov_y: f32,
}

/// Near and far planes for an eye at `eye` seeing a mesh within `extent`
/// of `centre`.
fn depth_range(eye: Vec3, centre: Vec3, extent: f32) -> (f32, f32) {
    let far = eye.distance(centre) + extent;
    ((1e-3 * extent).max(far * 1e-5), far)
}

/// World to camera coordinates for a camera at `eye` whose right, up and
/// forward are the given unit vectors (the camera looks down its −Z).
pub(crate) fn view_matrix(eye: Vec3, (r, u, f): (Vec3, Vec3, Vec3)) -> Mat4 {
    let b = -f;
    Mat4::from_cols(
        Vec4::new(r.x, u.x, b.x, 0.0),
        Vec4::new(r.y, u.y, b.y, 0.0),
        Vec4::new(r.z, u.z, b.z, 0.0),
        Vec4::new(-r.dot(eye), -u.dot(eye), -b.dot(eye), 1.0),
    )
}

impl Camera {
    /// Right and up vectors (up is +Y as far as the view allows).
    fn basis(&self) -> (Vec3, Vec3) {
        let right = self.forward.cross(Vec3::Y).try_normalize().unwrap_or(Vec3::X);
        (right, right.cross(self.forward))
    }

    /// World to the camera's space (right-handed: x right, y up, looking down −z).
    pub fn view(&self) -> Mat4 {
        let (r, u) = self.basis();
        view_matrix(self.eye, (r, u, self.forward))
    }

    /// World to clip space (right-handed, depth 0 at `near` to 1 at `far`).
    pub fn view_proj(&self, aspect: f32, near: f32, far: f32) -> Mat4 {
        let view = self.view();
        let f = 1.0 / (0.5 * self.fov_y).tan();
        let depth = far / (near - far);
        let proj = Mat4::from_cols(
            Vec4::new(f / aspect, 0.0, 0.0, 0.0),
            Vec4::new(0.0, f, 0.0, 0.0),
            Vec4::new(0.0, 0.0, depth, -1.0),
            Vec4::new(0.0, 0.0, near * depth, 0.0),
        );
        proj * view
    }

    /// The unit direction through pixel (x, y) of a `w` × `h` target (y down).
    pub fn ray(&self, x: f32, y: f32, w: f32, h: f32) -> Vec3 {
        let (right, up) = self.basis();
        let t = (0.5 * self.fov_y).tan();
        let (nx, ny) = (2.0 * x / w - 1.0, 1.0 - 2.0 * y / h);
        (self.forward + right * (nx * t * w / h) + up * (ny * t)).normalize()
    }

    /// Pixel of `p` on a `w` × `h` target (y down), if in front of the camera.
    pub fn project(&self, p: Vec3, w: f32, h: f32) -> Option<[f32; 2]> {
        let q = self.view_proj(w / h, 1e-3, 1.0) * p.extend(1.0);
        (q.w > 1e-6).then(|| [(q.x / q.w + 1.0) * 0.5 * w, (1.0 - q.y / q.w) * 0.5 * h])
    }

    /// Between `self` (t = 0) and `to` (t = 1).
    pub fn lerp(&self, to: &Camera, t: f32) -> Camera {
        let forward = self.forward.lerp(to.forward, t).try_normalize().unwrap_or(to.forward);
        Camera { eye: self.eye.lerp(to.eye, t), forward, fov_y: self.fov_y + (to.fov_y - self.fov_y) * t }
    }
}

/// The dollhouse camera: turning around a target, from above.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub target: Vec3,
    /// Viewing direction, the viewer's convention (yaw 0 toward −Z, pitch < 0 down).
    pub yaw: f32,
    pub pitch: f32,
    pub distance: f32,
    pub fov_y: f32,
    /// The size of what is framed, bounding zoom and pan.
    pub radius: f32,
}

const ORBIT_FOV: f32 = 0.8;
const MIN_PITCH: f32 = -1.55;
const MAX_PITCH: f32 = -0.1;

impl Orbit {
    /// The whole box `lo..hi` in view on a target of aspect ratio `aspect`,
    /// looking down 40° toward `yaw`, as close as that allows.
    pub fn framing(lo: Vec3, hi: Vec3, yaw: f32, aspect: f32) -> Orbit {
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        let target = (lo + hi) / 2.0;
        let mut orbit = Orbit { target, yaw, pitch: -0.7, distance: 0.0, fov_y: ORBIT_FOV, radius };
        let (right, up) = orbit.camera().basis();
        let forward = Vec3::from(exploremaps_format::direction(yaw, orbit.pitch));
        // A corner at (x, y, z) in the camera's frame around the target is in
        // view when |x| ≤ (d + z) tan(h/2) and |y| ≤ (d + z) tan(v/2); a tenth spare.
        let tan_v = 0.9 * (0.5 * ORBIT_FOV).tan();
        let tan_h = tan_v * aspect.max(0.1);
        orbit.distance = (0..8)
            .map(|i| {
                let corner =
                    Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z })
                        - target;
                let (x, y, z) = (corner.dot(right), corner.dot(up), corner.dot(forward));
                (x.abs() / tan_h).max(y.abs() / tan_v) - z
            })
            .fold(0.1 * radius, f32::max);
        orbit
    }

    pub fn camera(&self) -> Camera {
        let forward = Vec3::from(exploremaps_format::direction(self.yaw, self.pitch));
        Camera { eye: self.target - forward * self.distance, forward, fov_y: self.fov_y }
    }

    pub fn turn(&mut self, d_yaw: f32, d_pitch: f32) {
        self.yaw = (self.yaw + d_yaw).rem_euclid(std::f32::consts::TAU);
        self.pitch = (self.pitch + d_pitch).clamp(MIN_PITCH, MAX_PITCH);
    }

    /// factor < 1 moves closer.
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.distance = (self.distance * factor).clamp(0.05 * self.radius, 5.0 * self.radius);
        }
    }

    /// Moves the target so the scene follows a drag of (dx, dy) pixels on a
    /// target `height` pixels high.
    pub fn pan(&mut self, dx: f32, dy: f32, height: f32) {
        let (right, up) = self.camera().basis();
        let per_px = 2.0 * self.distance * (0.5 * self.fov_y).tan() / height.max(1.0);
        let moved = self.target - (right * dx - up * dy) * per_px;
        // Keep the target within reach of the scene.
        self.target = moved.clamp(self.target - Vec3::splat(self.radius * 2.0), self.target + Vec3::splat(self.radius * 2.0));
    }
}

/// The view direction (yaw, pitch) from `eye` toward a point.
pub fn facing(eye: Vec3, toward: Vec3) -> (f32, f32) {
    yaw_pitch((toward - eye).try_normalize().unwrap_or(Vec3::NEG_Z).to_array())
}

/// The storeys' floors, and the heights the dollhouse cuts at.
#[derive(Clone, Debug, PartialEq)]
pub struct Floors {
    pub heights: Vec<f32>,
    /// Eye height above a floor, scene units.
    pub eye: f32,
}

impl Floors {
    /// The builder's storeys; for bundles written before it listed them,
    /// where probes stand on floors, the floors under the probes (within
    /// half an eye height of each other counted as one).
    pub fn of(graph: &Graph) -> Floors {
        let eye = graph.scene.eye_height_m.map_or(0.0, |e| e / graph.scene.metres_per_unit.max(1e-6));
        let mut heights = graph.proxy.as_ref().map(|p| p.floors.clone()).unwrap_or_default();
        if heights.is_empty() && eye > 0.0 {
            let mut under: Vec<f32> = graph.probes.iter().map(|p| p.position[1] - eye).collect();
            under.sort_by(f32::total_cmp);
            for h in under {
                if heights.last().is_none_or(|&last| h - last > 0.5 * eye) {
                    heights.push(h);
                }
            }
        }
        Floors { heights, eye }
    }

    /// The storey a point at eye height stands on.
    pub fn of_point(&self, y: f32) -> Option<usize> {
        let floor = y - 0.5 * self.eye;
        self.heights.iter().rposition(|&h| h <= floor).or((!self.heights.is_empty()).then_some(0))
    }

    /// What is hidden above when storey `k` is shown: a little above head
    /// height, or below the next storey's floor if that comes first.
    pub fn cut(&self, k: Option<usize>) -> f32 {
        let Some(&h) = k.and_then(|k| self.heights.get(k)) else { return f32::INFINITY };
        let next = k.and_then(|k| self.heights.get(k + 1)).map_or(f32::INFINITY, |&n| h + 0.8 * (n - h));
        (h + 1.3 * self.eye).min(next)
    }
}

const SHADER: &str = r#"
struct U { view_proj: mat4x4f, cut: vec4f, fill: vec4f };
@group(0) @binding(0) var<uniform> u: U;

struct VOut { @builtin(position) pos: vec4f, @location(0) colour: vec3f, @location(1) y: f32 };

fn linear(c: vec3f) -> vec3f {
    return select(pow((c + 0.055) / 1.055, vec3f(2.4)), c / 12.92, c <= vec3f(0.04045));
}

@vertex fn vs(@location(0) p: vec3f, @location(1) c: vec4f) -> VOut {
    var o: VOut;
    o.pos = u.view_proj * vec4f(p, 1.0);
    o.colour = linear(c.rgb);
    o.y = p.y;
    return o;
}

@fragment fn fs(v: VOut, @builtin(front_facing) front: bool) -> @location(0) vec4f {
    if (v.y > u.cut.x) {
        discard;
    }
    // cut.z: back faces dark, so solids cut open show their section (the
    // floor plan's walls); it needs solids wound outward, as most are.
    if (!front && u.cut.z > 0.5) {
        return vec4f(0.02, 0.02, 0.025, 1.0);
    }
    return vec4f(v.colour * u.cut.y, 1.0);
}

// The floor plan's background: one triangle over the viewport.
@vertex fn vs_fill(@builtin(vertex_index) i: u32) -> @builtin(position) vec4f {
    return vec4f(vec2f(f32((i << 1u) & 2u), f32(i & 2u)) * 2.0 - 1.0, 1.0, 1.0);
}

@fragment fn fs_fill() -> @location(0) vec4f {
    return u.fill;
}
"#;

const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth24Plus;
/// The dollhouse's background, also where no proxy is drawn yet.
pub const BACKGROUND: wgpu::Color = wgpu::Color { r: 0.06, g: 0.065, b: 0.075, a: 1.0 };

/// The floor plan's background (linear RGB).
const PLAN_BACKGROUND: [f32; 4] = [0.012, 0.013, 0.018, 1.0];

/// Where a frame is drawn: the GPU, the frame's command encoder, and its
/// target of `width` × `height` pixels.
pub struct FrameTarget<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    pub encoder: &'a mut wgpu::CommandEncoder,
    pub view: &'a wgpu::TextureView,
    pub width: u32,
    pub height: u32,
}

/// The shader's uniforms: the camera, the cut height, `brightness` scaling
/// the proxy's colours (the plan is dimmed so the map's dots and lines stand
/// out on it), whether cut walls show their sections, and the colour they
/// and the background are filled with.
struct Uniforms {
    view_proj: Mat4,
    cut: f32,
    brightness: f32,
    sections: bool,
    fill: [f32; 4],
}

/// The GPU side: the proxy's buffers and a depth buffer sized to the target.
/// The dollhouse and the floor plan each have their uniforms, so both may be
/// drawn in one frame.
pub struct DollhousePass {
    pipeline: wgpu::RenderPipeline,
    fill: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind: wgpu::BindGroup,
    plan_uniforms: wgpu::Buffer,
    plan_bind: wgpu::BindGroup,
    mesh: Option<(wgpu::Buffer, wgpu::Buffer, u32)>,
    depth: Option<(wgpu::TextureView, u32, u32)>,
}

impl DollhousePass {
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> DollhousePass {
        let shader =
            device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("dollhouse"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("dollhouse"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("dollhouse"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Unorm8x4];
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("dollhouse"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout { array_stride: 16, step_mode: wgpu::VertexStepMode::Vertex, attributes: &attributes })],
            },
            // Scene meshes are not consistently wound: both sides are drawn.
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
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
        let fill = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("floor plan background"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState { module: &shader, entry_point: Some("vs_fill"), compilation_options: Default::default(), buffers: &[] },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_fill"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let buffer = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 96,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let bind_group = |buffer: &wgpu::Buffer| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("dollhouse"),
                layout: &layout,
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
            })
        };
        let (uniforms, plan_uniforms) = (buffer("dollhouse view"), buffer("floor plan view"));
        let (bind, plan_bind) = (bind_group(&uniforms), bind_group(&plan_uniforms));
        DollhousePass { pipeline, fill, uniforms, bind, plan_uniforms, plan_bind, mesh: None, depth: None }
    }

    fn depth_view(&mut self, device: &wgpu::Device, width: u32, height: u32) -> wgpu::TextureView {
        if self.depth.as_ref().is_none_or(|d| (d.1, d.2) != (width, height)) {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("dollhouse depth"),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            });
            self.depth = Some((texture.create_view(&Default::default()), width, height));
        }
        self.depth.as_ref().expect("made above").0.clone()
    }

    fn write_uniforms(queue: &wgpu::Queue, buffer: &wgpu::Buffer, u: Uniforms) {
        let mut words: Vec<f32> = u.view_proj.to_cols_array().to_vec();
        words.extend([u.cut.min(f32::MAX), u.brightness, if u.sections { 1.0 } else { 0.0 }, 0.0]);
        words.extend(u.fill);
        queue.write_buffer(buffer, 0, &words.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
    }

    fn draw_mesh(&self, pass: &mut wgpu::RenderPass<'_>, bind: &wgpu::BindGroup) {
        if let Some((vertices, indices, count)) = &self.mesh {
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, bind, &[]);
            pass.set_vertex_buffer(0, vertices.slice(..));
            pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..*count, 0, 0..1);
        }
    }

    /// The floor plan: the proxy from straight above, cut at `cut`, into the
    /// square `rect` (x, y, size in pixels) of `target`, over a dark
    /// background: world (`centre`.x, `centre`.y as z) at the square's
    /// centre, `scale` pixels a scene unit, +X right and −Z up.
    pub fn draw_plan(&mut self, frame: &mut FrameTarget, rect: [f32; 3], centre: [f32; 2], scale: f32, cut: f32, lo_y: f32) {
        let FrameTarget { device, queue, ref mut encoder, view: target, width, height } = *frame;
        let [x, y, size] = rect;
        let (x0, y0) = (x.max(0.0).floor() as u32, y.max(0.0).floor() as u32);
        let (x1, y1) = (((x + size).ceil() as u32).min(width), ((y + size).ceil() as u32).min(height));
        if x1 <= x0 || y1 <= y0 || self.mesh.is_none() || scale.is_nan() || scale <= 0.0 {
            return;
        }
        // Nearly orthographic: a narrow view from far above.
        let half = 0.5 * size / scale;
        let top = if cut.is_finite() { cut } else { lo_y + 100.0 * half };
        let distance = 50.0 * half;
        let camera = Camera { eye: Vec3::new(centre[0], top + distance, centre[1]), forward: Vec3::NEG_Y, fov_y: 2.0 * (half / distance).atan() };
        let depth_range = distance + (top - lo_y).max(0.0) + half;
        let view_proj = camera.view_proj(1.0, 0.5 * distance, depth_range * 1.01);
        Self::write_uniforms(queue, &self.plan_uniforms, Uniforms { view_proj, cut, brightness: 0.45, sections: true, fill: PLAN_BACKGROUND });
        let depth = self.depth_view(device, width, height);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("floor plan"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_viewport(x, y, size, size, 0.0, 1.0);
        pass.set_scissor_rect(x0, y0, x1 - x0, y1 - y0);
        pass.set_pipeline(&self.fill);
        pass.set_bind_group(0, &self.plan_bind, &[]);
        pass.draw(0..3, 0..1);
        self.draw_mesh(&mut pass, &self.plan_bind);
    }

    /// Replaces the mesh drawn.
    pub fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, mesh: &ProxyMesh) {
        let mut vertices = Vec::with_capacity(16 * mesh.positions.len());
        for (p, c) in mesh.positions.iter().zip(&mesh.colours) {
            for x in p.to_array() {
                vertices.extend_from_slice(&x.to_le_bytes());
            }
            vertices.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
        let indices: Vec<u8> = mesh.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
        if indices.is_empty() {
            self.mesh = None;
            return;
        }
        let buffer = |label, usage: wgpu::BufferUsages, bytes: &[u8]| {
            let b = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.len() as u64,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            queue.write_buffer(&b, 0, bytes);
            b
        };
        self.mesh = Some((
            buffer("proxy vertices", wgpu::BufferUsages::VERTEX, &vertices),
            buffer("proxy indices", wgpu::BufferUsages::INDEX, &indices),
            3 * mesh.triangles.len() as u32,
        ));
    }

    /// Clears `target` and draws the mesh seen by `camera`, hiding what is
    /// above `cut`. `extent` bounds the depth range (the mesh's diagonal).
    pub fn draw(&mut self, frame: &mut FrameTarget, camera: &Camera, cut: f32, centre: Vec3, extent: f32) {
        let (near, far) = depth_range(camera.eye, centre, extent);
        let view_proj = camera.view_proj(frame.width as f32 / frame.height.max(1) as f32, near, far);
        let viewport = [0.0, 0.0, frame.width as f32, frame.height as f32];
        self.draw_mesh_pass(frame, view_proj, cut, wgpu::LoadOp::Clear(BACKGROUND), viewport);
    }

    /// Draws the whole mesh from `eye` through `lens` into `viewport` (x, y,
    /// width, height) of `frame`, over what is there: the colours behind a
    /// glide, in a window or a headset's eye.
    pub fn draw_through(
        &mut self,
        frame: &mut FrameTarget,
        (eye, lens): (Vec3, &crate::panorama::Lens),
        viewport: [f32; 4],
        centre: Vec3,
        extent: f32,
    ) {
        let (near, far) = depth_range(eye, centre, extent);
        self.draw_mesh_pass(frame, lens.view_proj(eye, near, Some(far)), f32::INFINITY, wgpu::LoadOp::Load, viewport);
    }

    fn draw_mesh_pass(&mut self, frame: &mut FrameTarget, view_proj: Mat4, cut: f32, load: wgpu::LoadOp<wgpu::Color>, viewport: [f32; 4]) {
        let FrameTarget { device, queue, ref mut encoder, view: target, width, height } = *frame;
        let depth = self.depth_view(device, width, height);
        Self::write_uniforms(queue, &self.uniforms, Uniforms { view_proj, cut, brightness: 1.0, sections: false, fill: PLAN_BACKGROUND });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("dollhouse"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let [x, y, w, h] = viewport;
        pass.set_viewport(x, y, w, h, 0.0, 1.0);
        self.draw_mesh(&mut pass, &self.bind);
    }
}

#[cfg(test)]
pub(crate) mod tests;
