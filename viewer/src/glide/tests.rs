//! Headless GPU tests of the glide (as the panorama pass's: lavapipe or
//! llvmpipe; `EXPLOREMAPS_SKIP_GPU=1` where there is no GPU stack), in a
//! room whose panoramas and depth are known exactly: a box 8 × 3 × 4 with
//! each wall its own colour under a checker of 1-unit squares.

use super::*;
use crate::navigation::View;
use crate::panorama::tests::{gpu, render_target};
use crate::panorama::{PanoramaPass, Shown, Source};
use exploremaps_format::cube_direction;

const SIZE: u32 = 128;
const FACE: u32 = 128;
const HI: Vec3 = Vec3::new(8.0, 3.0, 4.0);

/// Where the ray from `eye` along `d` leaves the room, and at what distance.
fn exit(eye: Vec3, d: Vec3) -> (Vec3, f32) {
    let t = (0..3)
        .map(|k| {
            if d[k] > 1e-9 {
                (HI[k] - eye[k]) / d[k]
            } else if d[k] < -1e-9 {
                -eye[k] / d[k]
            } else {
                f32::INFINITY
            }
        })
        .fold(f32::INFINITY, f32::min);
    (eye + d * t, t)
}

/// The colour of a point on the room's walls (sRGB bytes).
fn colour(p: Vec3) -> [u8; 4] {
    let wall = (0..3).find_map(|k| {
        if p[k] < 1e-3 {
            Some(2 * k)
        } else if p[k] > HI[k] - 1e-3 {
            Some(2 * k + 1)
        } else {
            None
        }
    });
    let base = [[200, 60, 60], [60, 200, 60], [60, 60, 200], [200, 200, 60], [60, 200, 200], [200, 60, 200]][wall.unwrap_or(0)];
    // The checker over the wall's own two coordinates (not the one across it, which wavers at its bound).
    let across = wall.map_or(0, |w| w / 2);
    let checker = (0..3).filter(|&k| k != across).map(|k| p[k].floor() as i32).sum::<i32>().rem_euclid(2) == 0;
    let k = if checker { 1.0 } else { 0.55 };
    [(base[0] as f32 * k) as u8, (base[1] as f32 * k) as u8, (base[2] as f32 * k) as u8, 255]
}

/// The panorama from `eye`, FACE² faces.
fn panorama(device: &wgpu::Device, queue: &wgpu::Queue, eye: Vec3) -> Cube {
    let cube = Cube::new(device, FACE);
    for face in 0..6 {
        let pixels: Vec<u8> = (0..FACE * FACE)
            .flat_map(|i| {
                let (s, t) = (((i % FACE) as f32 + 0.5) / FACE as f32, ((i / FACE) as f32 + 0.5) / FACE as f32);
                colour(exit(eye, Vec3::from(cube_direction(face, s, t)).normalize()).0)
            })
            .collect();
        cube.write_face(queue, face, &pixels);
    }
    cube
}

/// The depth cube from `eye`, 32 cells a face edge.
fn depth(eye: Vec3) -> DepthCube {
    let corners = 6 * 33 * 33;
    let distances: Vec<Option<f32>> =
        (0..corners).map(|i| Some(exit(eye, Vec3::from(exploremaps_format::depthcube::corner_direction(32, i))).1)).collect();
    DepthCube::new(32, 0.01, 100.0, &distances)
}

fn camera(eye: Vec3, view: &View) -> Camera {
    Camera { eye, forward: Vec3::from(exploremaps_format::direction(view.yaw, view.pitch)), fov_y: view.fov_y }
}

fn draw_panorama(device: &wgpu::Device, queue: &wgpu::Queue, source: Source, view: &View) -> Vec<u8> {
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
        pass.draw(device, queue, &mut rp, view, 1.0, Shown { source, opacity: 1.0 });
    })
}

/// Mean absolute difference of two RGBA8 images' colours, in levels, and
/// the share of pixels more than 24 levels off in some channel.
fn difference(a: &[u8], b: &[u8]) -> (f32, f32) {
    let (mut sum, mut far, mut n) = (0.0, 0, 0);
    for (p, q) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        let d: Vec<i32> = (0..3).map(|k| (p[k] as i32 - q[k] as i32).abs()).collect();
        sum += d.iter().sum::<i32>() as f32 / 3.0;
        far += usize::from(d.iter().any(|&x| x > 24));
        n += 1;
    }
    (sum / n as f32, far as f32 / n as f32)
}

#[test]
fn a_glide_shows_each_panorama_at_its_end_and_the_room_as_it_is_between() {
    let Some((device, queue)) = gpu() else { return };
    let (a, b) = (Vec3::new(1.5, 1.6, 1.2), Vec3::new(6.5, 1.6, 2.8));
    let (cube_a, cube_b) = (panorama(&device, &queue, a), panorama(&device, &queue, b));
    let (mesh_a, mesh_b) = (GlideMesh::new(&device, &depth(a), a.into()), GlideMesh::new(&device, &depth(b), b.into()));
    let mut pass = GlidePass::new(&device, wgpu::TextureFormat::Rgba8UnormSrgb);
    let mut glide = |eye: Vec3, t: f32, view: &View| {
        render_target(&device, &queue, SIZE, |encoder, target| {
            let mut frame = crate::dollhouse::FrameTarget { device: &device, queue: &queue, encoder, view: target, width: SIZE, height: SIZE };
            let from = End { mesh: &mesh_a, cube: &cube_a, tiles: None };
            let to = End { mesh: &mesh_b, cube: &cube_b, tiles: None };
            pass.draw(&mut frame, &GlideFrame { camera: camera(eye, view), aspect: 1.0, from, to, t });
        })
    };
    for (yaw, pitch) in [(0.3f32, -0.2f32), (2.0, 0.1), (-1.2, 0.5), (3.0, -0.6)] {
        let view = View { yaw, pitch, fov_y: 1.2 };
        // At the departure, the glide is the departure's panorama.
        let start = glide(a, 0.0, &view);
        let (mean, far) = difference(&start, &draw_panorama(&device, &queue, Source::Cube(&cube_a, None), &view));
        assert!(mean < 1.5 && far < 0.005, "at the start, looking {yaw},{pitch}: {mean} levels, {far} far off");
        // Half way, it is the room seen from there (a panorama made there),
        // and far closer to it than a cross-fade of the two ends.
        let middle = (a + b) / 2.0;
        let truth = draw_panorama(&device, &queue, Source::Cube(&panorama(&device, &queue, middle), None), &view);
        let (mean, far) = difference(&glide(middle, 0.5, &view), &truth);
        let fade = draw_panorama(&device, &queue, Source::Fade((&cube_a, None), (&cube_b, None), 0.5), &view);
        let (fade_mean, _) = difference(&fade, &truth);
        // (Measured: 1.7-3.0 levels and 3-7 % of pixels, at the checker's
        // edges, which two resamplings blur; a cross-fade is 32-41 levels off.)
        assert!(mean < 4.0 && far < 0.1, "half way, looking {yaw},{pitch}: {mean} levels, {far} far off");
        assert!(mean * 5.0 < fade_mean, "half way, looking {yaw},{pitch}: glide {mean} against a cross-fade's {fade_mean}");
    }
}

#[test]
fn the_lattice_covers_each_face_with_two_triangles_a_cell() {
    let indices = lattice_indices(4);
    assert_eq!(indices.len(), 6 * 16 * 6);
    assert!(indices.iter().all(|&i| i < 6 * 25));
    // Every corner of the lattice is used.
    let used: std::collections::BTreeSet<u32> = indices.iter().copied().collect();
    assert_eq!(used.len(), 6 * 25);
}
