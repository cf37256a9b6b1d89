//! Headless GPU tests (lavapipe or llvmpipe on CPU; `WGPU_BACKEND` picks the
//! backend). With no adapter at all they fail, unless `EXPLOREMAPS_SKIP_GPU=1`
//! says this machine has no GPU stack (then they print SKIPPED).

use super::*;

pub(crate) fn gpu() -> Option<(wgpu::Device, wgpu::Queue)> {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        // SAFETY: set before any thread of this test reads the environment for it.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
    pollster::block_on(async {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = match instance.request_adapter(&wgpu::RequestAdapterOptions::default()).await {
            Ok(a) => a,
            Err(e) => {
                assert!(
                    std::env::var("EXPLOREMAPS_SKIP_GPU").is_ok_and(|v| v == "1"),
                    "no GPU adapter ({e}); install mesa-vulkan-drivers, or set EXPLOREMAPS_SKIP_GPU=1"
                );
                eprintln!("SKIPPED: no GPU adapter ({e})");
                return None;
            }
        };
        let limits = wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits());
        let desc = wgpu::DeviceDescriptor { label: None, required_limits: limits, ..Default::default() };
        Some(adapter.request_device(&desc).await.expect("a device on the adapter"))
    })
}

const SIZE: u32 = 64;

fn cube(device: &wgpu::Device, queue: &wgpu::Queue, faces: [&[u8]; 6], face_size: u32) -> Cube {
    let cube = Cube::new(device, face_size);
    for (f, pixels) in faces.iter().enumerate() {
        cube.write_face(queue, f, pixels);
    }
    cube
}

/// Renders `view` of a cube whose faces are `faces` into SIZE² RGBA8 pixels.
fn render(device: &wgpu::Device, queue: &wgpu::Queue, faces: [&[u8]; 6], face_size: u32, view: View) -> Vec<u8> {
    let c = cube(device, queue, faces, face_size);
    render_source(device, queue, Source::Cube(&c, None), view)
}

fn render_source(device: &wgpu::Device, queue: &wgpu::Queue, source: Source<'_>, view: View) -> Vec<u8> {
    let pass = PanoramaPass::new(device, wgpu::TextureFormat::Rgba8UnormSrgb);
    render_target(device, queue, SIZE, |encoder, target| {
        let mut rp = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: None,
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
        pass.draw(device, queue, &mut rp, &Lens::of_view(&view, 1.0), Shown { source, opacity: 1.0 });
    })
}

pub(crate) use crate::offscreen::render_target;

fn pixel(p: &[u8], x: u32, y: u32) -> [u8; 3] {
    let i = ((y * SIZE + x) * 4) as usize;
    [p[i], p[i + 1], p[i + 2]]
}

fn close(a: [u8; 3], b: [u8; 3]) -> bool {
    a.iter().zip(b).all(|(&x, y)| (x as i32 - y as i32).abs() <= 3)
}

#[test]
fn known_views_show_the_right_faces_the_right_way_up() {
    let Some((device, queue)) = gpu() else { return };
    // A solid colour a face, except −Z: white in its top half, black in the bottom.
    let colours: [[u8; 3]; 6] = [[255, 0, 0], [0, 255, 255], [0, 255, 0], [255, 0, 255], [0, 0, 255], [255, 255, 0]];
    let n = 8u32;
    let faces: Vec<Vec<u8>> = (0..6)
        .map(|f| {
            (0..n * n)
                .flat_map(|i| {
                    let c = if f == 5 {
                        if i / n < n / 2 {
                            [255, 255, 255]
                        } else {
                            [0, 0, 0]
                        }
                    } else {
                        colours[f]
                    };
                    [c[0], c[1], c[2], 255]
                })
                .collect()
        })
        .collect();
    let faces: [&[u8]; 6] = std::array::from_fn(|f| faces[f].as_slice());
    let fov = 0.5;
    let centre = |yaw: f32, pitch: f32| pixel(&render(&device, &queue, faces, n, View { yaw, pitch, fov_y: fov }), SIZE / 2, SIZE / 2);
    use std::f32::consts::{FRAC_PI_2, PI};
    assert!(close(centre(FRAC_PI_2, 0.0), colours[0]), "yaw π/2 looks at +X: {:?}", centre(FRAC_PI_2, 0.0));
    assert!(close(centre(PI, 0.0), colours[4]), "yaw π looks at +Z: {:?}", centre(PI, 0.0));
    assert!(close(centre(-FRAC_PI_2, 0.0), colours[1]), "yaw −π/2 looks at −X");
    assert!(close(centre(0.3, FRAC_PI_2), colours[2]), "straight up is +Y");
    assert!(close(centre(0.3, -FRAC_PI_2), colours[3]), "straight down is −Y");
    // Toward −Z, a little up is the face's top half (white), a little down its bottom (black).
    assert!(close(centre(0.0, 0.2), [255, 255, 255]), "up on −Z: {:?}", centre(0.0, 0.2));
    assert!(close(centre(0.0, -0.2), [0, 0, 0]), "down on −Z: {:?}", centre(0.0, -0.2));
    // And the image is upright: its top row shows the white half, its bottom row the black.
    let looking = render(&device, &queue, faces, n, View { yaw: 0.0, pitch: 0.0, fov_y: fov });
    assert!(close(pixel(&looking, SIZE / 2, 2), [255, 255, 255]) && close(pixel(&looking, SIZE / 2, SIZE - 3), [0, 0, 0]));
    // Wide enough to see the side faces: +X on the right, −X on the left.
    let wide = render(&device, &queue, faces, n, View { yaw: 0.0, pitch: 0.0, fov_y: 2.0 });
    assert!(close(pixel(&wide, SIZE - 1, SIZE / 2), colours[0]), "right edge: {:?}", pixel(&wide, SIZE - 1, SIZE / 2));
    assert!(close(pixel(&wide, 0, SIZE / 2), colours[1]), "left edge: {:?}", pixel(&wide, 0, SIZE / 2));
}

fn solid(n: u32, c: [u8; 3]) -> Vec<u8> {
    (0..n * n).flat_map(|_| [c[0], c[1], c[2], 255]).collect()
}

#[test]
fn a_cross_fade_mixes_the_two_cubes() {
    let Some((device, queue)) = gpu() else { return };
    let (red, blue) = (solid(4, [255, 0, 0]), solid(4, [0, 0, 255]));
    let a = cube(&device, &queue, [&red[..]; 6], 4);
    let b = cube(&device, &queue, [&blue[..]; 6], 4);
    let view = View { yaw: 0.4, pitch: 0.1, fov_y: 1.0 };
    let at = |t: f32| pixel(&render_source(&device, &queue, Source::Fade((&a, None), (&b, None), t), view), SIZE / 2, SIZE / 2);
    assert!(close(at(0.0), [255, 0, 0]) && close(at(1.0), [0, 0, 255]), "{:?} {:?}", at(0.0), at(1.0));
    // Halfway in linear light is 0.5, which sRGB encodes as 188.
    assert!(close(at(0.5), [188, 0, 188]), "halfway: {:?}", at(0.5));
}

#[test]
fn video_frames_are_sampled_as_world_aligned_equirectangular_images() {
    let Some((device, queue)) = gpu() else { return };
    // Four vertical bands by yaw: [−Z..+X) red, [+X..+Z) green, [+Z..−X) blue, [−X..−Z) white.
    let (w, h) = (64u32, 32u32);
    let bands = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]];
    let rgba: Vec<u8> = (0..w * h)
        .flat_map(|i| {
            let c = bands[((i % w) * 4 / w) as usize];
            [c[0], c[1], c[2], 255]
        })
        .collect();
    let video = VideoTexture::new(&device, w, h);
    video.write(&queue, &rgba);
    use std::f32::consts::PI;
    for (k, band) in bands.iter().enumerate() {
        let yaw = (k as f32 + 0.5) * PI / 2.0;
        let p = pixel(&render_source(&device, &queue, Source::Video(&video), View { yaw, pitch: 0.0, fov_y: 0.3 }), SIZE / 2, SIZE / 2);
        assert!(close(p, *band), "yaw {yaw}: {p:?}");
    }
}

#[test]
fn tile_slots_hold_tour_faces_read_with_z_negated() {
    use exploremaps_format::{cube_direction, Tiles, TILE_FACES};
    for (slot, &face) in TILE_SLOTS.iter().enumerate() {
        let j = TILE_FACES.iter().position(|&f| f == face).unwrap();
        for (s, t) in [(0.1, 0.2), (0.8, 0.6)] {
            let d = cube_direction(slot, s, t);
            let (sj, tj) = Tiles::face_coordinates(j, s, t);
            let e = cube_direction(j, sj, tj);
            assert!((0..3).all(|i| (e[i] - [d[0], d[1], -d[2]][i]).abs() < 1e-5), "slot {slot} holds {face}: {d:?} {e:?}");
        }
    }
}

#[test]
fn visible_tiles_are_those_ahead_nearest_first() {
    let view = View { yaw: 0.0, pitch: 0.0, fov_y: 0.6 };
    let tiles = visible_tiles(&view, 1.0, 4096, 512);
    // Looking toward −Z: the front face (slot 4) and its middle tiles first.
    assert!(tiles.len() < 6 * 64 / 4, "{} tiles", tiles.len());
    assert_eq!(tiles[0].0, 4);
    assert!([(3, 3), (3, 4), (4, 3), (4, 4)].contains(&(tiles[0].1, tiles[0].2)), "{:?}", tiles[0]);
    assert!(!tiles.iter().any(|t| t.0 == 5), "nothing behind");
    // Straight up: the top face.
    let up = visible_tiles(&View { yaw: 0.0, pitch: 1.5, fov_y: 0.6 }, 1.0, 4096, 512);
    assert_eq!(up[0].0, 2);
}

#[test]
fn tiles_show_over_the_whole_cube_where_they_have_arrived() {
    let Some((device, queue)) = gpu() else { return };
    let grey = vec![100u8; 4 * 8 * 8];
    let base = cube(&device, &queue, [&grey; 6], 8);
    let mut tiled = Tiled::new(&device, 64, 32);
    let red: Vec<u8> = (0..32 * 32).flat_map(|_| [220, 30, 30, 255]).collect();
    // The tour's front face (slot 4), its top-right tile: right of and above
    // the view toward −Z. The top face (slot 2), its top-left tile: toward
    // −X and +Z (the top edge of the tour's up face faces +Z).
    tiled.write_tile(&queue, 4, (1, 0), (32, 32), &red);
    tiled.write_tile(&queue, 2, (0, 0), (32, 32), &red);
    let look = |d: [f32; 3]| {
        let (yaw, pitch) = exploremaps_format::yaw_pitch(d);
        pixel(&render_source(&device, &queue, Source::Cube(&base, Some(&tiled)), View { yaw, pitch, fov_y: 0.2 }), SIZE / 2, SIZE / 2)
    };
    let is_red = |p: [u8; 3]| p[0] > 180 && p[1] < 80;
    assert!(is_red(look([0.5, 0.5, -1.0])), "front, top right: {:?}", look([0.5, 0.5, -1.0]));
    assert!(!is_red(look([-0.5, 0.5, -1.0])), "front, top left is the whole cube's");
    assert!(!is_red(look([0.5, -0.5, -1.0])), "front, bottom right too");
    assert!(is_red(look([-0.5, 1.0, 0.5])), "up, toward −X and +Z: {:?}", look([-0.5, 1.0, 0.5]));
    assert!(!is_red(look([0.5, 1.0, 0.5])) && !is_red(look([-0.5, 1.0, -0.5])), "the rest of the top is the whole cube's");
    assert_eq!(tiled.count(), 2);
}

/// OpenGL's projection (glFrustum's) of a frustum whose edges at depth 1
/// are [left, right, bottom, top], near 0.1, far 100: how WebXR gives an eye's.
pub(crate) fn gl_frustum([l, r, b, t]: [f32; 4]) -> glam::Mat4 {
    let (n, f) = (0.1, 100.0);
    let (l, r, b, t) = (l * n, r * n, b * n, t * n);
    glam::Mat4::from_cols_array(&[
        2.0 * n / (r - l),
        0.0,
        0.0,
        0.0,
        0.0,
        2.0 * n / (t - b),
        0.0,
        0.0,
        (r + l) / (r - l),
        (t + b) / (t - b),
        -(f + n) / (f - n),
        -1.0,
        0.0,
        0.0,
        -2.0 * f * n / (f - n),
        0.0,
    ])
}

/// The ray the shader casts through a pixel at NDC (x, y), before normalising.
fn ray(lens: &Lens, x: f32, y: f32) -> glam::Vec3 {
    let [f, r, u] = lens.basis.map(glam::Vec3::from);
    f + r * (x * lens.scale[0] + lens.shift[0]) + u * (y * lens.scale[1] + lens.shift[1])
}

#[test]
fn a_headset_eye_with_a_centred_frustum_sees_what_the_window_view_does() {
    let view = View { yaw: 0.7, pitch: -0.3, fov_y: 1.4 };
    let rotation = crate::navigation::rotation_of(&view);
    let t = (0.5 * view.fov_y).tan();
    let eye = Lens::of_eye(rotation, &gl_frustum([-t * 0.9, t * 0.9, -t, t]));
    let window = Lens::of_view(&view, 0.9);
    for (x, y) in [(0.0, 0.0), (1.0, 1.0), (-1.0, 0.5), (0.3, -1.0)] {
        let (a, b) = (ray(&eye, x, y).normalize(), ray(&window, x, y).normalize());
        assert!(a.dot(b) > 0.99999, "at ({x}, {y}): eye {a} against window {b}");
    }
}

#[test]
fn an_off_axis_eye_frustum_reaches_its_own_edges() {
    // A left eye: wider toward the nose (right) than outward, taller above than below.
    let (l, r, b, t) = (-0.9f32, 1.2f32, -1.0f32, 1.3f32);
    let lens = Lens::of_eye(glam::Quat::IDENTITY, &gl_frustum([l, r, b, t]));
    for (x, y, expected) in [(-1.0, -1.0, glam::vec3(l, b, -1.0)), (1.0, 1.0, glam::vec3(r, t, -1.0)), (1.0, -1.0, glam::vec3(r, b, -1.0))] {
        let got = ray(&lens, x, y);
        assert!((got - expected).length() < 1e-4, "corner ({x}, {y}): {got} against {expected}");
    }
}

#[test]
fn a_lens_projects_points_as_the_dollhouse_camera_of_the_same_view_does() {
    let (eye, aspect) = (glam::Vec3::new(1.0, 1.6, -2.0), 16.0 / 9.0);
    for (yaw, pitch) in [(0.0, 0.0), (0.7, 0.3), (-2.5, -0.6)] {
        let view = View { yaw, pitch, fov_y: 1.1 };
        let lens = Lens::of_view(&view, aspect);
        let camera = crate::dollhouse::Camera { eye, forward: glam::Vec3::from(crate::navigation::direction(yaw, pitch)), fov_y: 1.1 };
        let (a, b) = (lens.view_proj(eye, 0.1, Some(50.0)), camera.view_proj(aspect, 0.1, 50.0));
        for p in [glam::Vec3::new(3.0, 2.0, -7.0), glam::Vec3::new(-4.0, 0.5, 6.0), glam::Vec3::new(0.5, 5.0, 1.0)] {
            let (qa, qb) = (a * p.extend(1.0), b * p.extend(1.0));
            assert!((qa / qa.w - qb / qb.w).abs().max_element() < 1e-4, "yaw {yaw}: {qa} against {qb}");
        }
    }
    // Without a far plane, depth is reversed: 1 at the near plane, toward 0 far away.
    let lens = Lens::of_view(&View { yaw: 0.0, pitch: 0.0, fov_y: 1.0 }, 1.0);
    let depth = |z: f32| {
        let q = lens.view_proj(glam::Vec3::ZERO, 0.5, None) * glam::Vec4::new(0.0, 0.0, z, 1.0);
        q.z / q.w
    };
    assert!((depth(-0.5) - 1.0).abs() < 1e-6 && depth(-1e6) < 1e-6);
}
