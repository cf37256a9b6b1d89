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

/// The room, with a pillar standing in it or not.
#[derive(Clone, Copy)]
struct Room {
    pillar: Option<(Vec3, Vec3)>,
}

/// A pillar off the line between the test's probes, 0.8 × 0.6, floor to ceiling.
const PILLAR: (Vec3, Vec3) = (Vec3::new(3.6, 0.0, 2.8), Vec3::new(4.4, 3.0, 3.4));

impl Room {
    /// What the ray from `eye` along `d` meets first, and at what distance.
    fn hit(self, eye: Vec3, d: Vec3) -> (Vec3, f32) {
        let slab = |k: usize, lo: f32, hi: f32| {
            if d[k].abs() < 1e-9 {
                return if (lo..=hi).contains(&eye[k]) { (f32::NEG_INFINITY, f32::INFINITY) } else { (f32::INFINITY, f32::NEG_INFINITY) };
            }
            let (a, b) = ((lo - eye[k]) / d[k], (hi - eye[k]) / d[k]);
            (a.min(b), a.max(b))
        };
        // Out of the room: the nearest far side of its slabs.
        let mut t = (0..3).map(|k| slab(k, 0.0, HI[k]).1).fold(f32::INFINITY, f32::min);
        if let Some((lo, hi)) = self.pillar {
            let (enter, leave) = (0..3).map(|k| slab(k, lo[k], hi[k])).fold((0.0f32, f32::INFINITY), |(a, b), (c, e)| (a.max(c), b.min(e)));
            if enter <= leave && enter < t {
                t = enter;
            }
        }
        (eye + d * t, t)
    }

    /// The colour of a point on the room's walls or the pillar (sRGB bytes).
    fn colour(self, p: Vec3) -> [u8; 4] {
        let on_pillar = self.pillar.is_some_and(|(lo, hi)| (0..3).all(|k| p[k] > lo[k] - 1e-3 && p[k] < hi[k] + 1e-3));
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
        if on_pillar && wall != Some(2) && wall != Some(3) {
            return [240, 240, 240, 255];
        }
        [(base[0] as f32 * k) as u8, (base[1] as f32 * k) as u8, (base[2] as f32 * k) as u8, 255]
    }

    /// The panorama from `eye`, FACE² faces.
    fn panorama(self, device: &wgpu::Device, queue: &wgpu::Queue, eye: Vec3) -> Cube {
        let cube = Cube::new(device, FACE);
        for face in 0..6 {
            let pixels: Vec<u8> = (0..FACE * FACE)
                .flat_map(|i| {
                    let (s, t) = (((i % FACE) as f32 + 0.5) / FACE as f32, ((i / FACE) as f32 + 0.5) / FACE as f32);
                    self.colour(self.hit(eye, Vec3::from(cube_direction(face, s, t)).normalize()).0)
                })
                .collect();
            cube.write_face(queue, face, &pixels);
        }
        cube
    }

    /// The depth cube from `eye`, 32 cells a face edge.
    fn depth(self, eye: Vec3) -> DepthCube {
        let corners = 6 * 33 * 33;
        let distances: Vec<Option<f32>> =
            (0..corners).map(|i| Some(self.hit(eye, Vec3::from(exploremaps_format::depthcube::corner_direction(32, i))).1)).collect();
        DepthCube::new(32, 0.01, 100.0, &distances)
    }
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
        pass.draw(device, queue, &mut rp, &crate::panorama::Lens::of_view(view, 1.0), Shown { source, opacity: 1.0 });
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

/// The probes of the tests: the glide goes from A to B.
const A: Vec3 = Vec3::new(1.5, 1.6, 1.2);
const B: Vec3 = Vec3::new(6.5, 1.6, 2.8);

/// Draws glides from A to B in `room`: `glide(eye, t, view)`, SIZE² RGBA8.
fn glides(device: &wgpu::Device, queue: &wgpu::Queue, room: Room) -> impl FnMut(Vec3, f32, &View) -> Vec<u8> {
    let (cube_a, cube_b) = (room.panorama(device, queue, A), room.panorama(device, queue, B));
    let (mesh_a, mesh_b) = (GlideMesh::new(device, &room.depth(A), A.into()), GlideMesh::new(device, &room.depth(B), B.into()));
    let mut pass = GlidePass::new(device, wgpu::TextureFormat::Rgba8UnormSrgb);
    let (device, queue) = (device.clone(), queue.clone());
    move |eye: Vec3, t: f32, view: &View| {
        render_target(&device, &queue, SIZE, |encoder, target| {
            let mut frame = crate::dollhouse::FrameTarget { device: &device, queue: &queue, encoder, view: target, width: SIZE, height: SIZE };
            let from = End { mesh: &mesh_a, cube: &cube_a, tiles: None };
            let to = End { mesh: &mesh_b, cube: &cube_b, tiles: None };
            pass.draw(&mut frame, &GlideFrame { eye, lens: crate::panorama::Lens::of_view(view, 1.0), from, to, t });
        })
    }
}

#[test]
fn a_glide_shows_each_panorama_at_its_end_and_the_room_as_it_is_between() {
    let Some((device, queue)) = gpu() else { return };
    let room = Room { pillar: None };
    let mut glide = glides(&device, &queue, room);
    let (cube_a, cube_b) = (room.panorama(&device, &queue, A), room.panorama(&device, &queue, B));
    for (yaw, pitch) in [(0.3f32, -0.2f32), (2.0, 0.1), (-1.2, 0.5), (3.0, -0.6)] {
        let view = View { yaw, pitch, fov_y: 1.2 };
        // At the departure, the glide is the departure's panorama.
        let start = glide(A, 0.0, &view);
        let (mean, far) = difference(&start, &draw_panorama(&device, &queue, Source::Cube(&cube_a, None), &view));
        assert!(mean < 1.5 && far < 0.005, "at the start, looking {yaw},{pitch}: {mean} levels, {far} far off");
        // Half way, it is the room seen from there (a panorama made there),
        // and far closer to it than a cross-fade of the two ends.
        let middle = (A + B) / 2.0;
        let truth = draw_panorama(&device, &queue, Source::Cube(&room.panorama(&device, &queue, middle), None), &view);
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
fn where_one_end_sees_a_pillar_and_the_other_the_wall_behind_it_the_pillar_stands_whole() {
    let Some((device, queue)) = gpu() else { return };
    let room = Room { pillar: Some(PILLAR) };
    let mut glide = glides(&device, &queue, room);
    // Half way, looking toward +Z at the pillar 0.8 away: A sees its near
    // face, B (level with that face) only its side and the wall behind it.
    let middle = (A + B) / 2.0;
    let view = View { yaw: std::f32::consts::PI, pitch: -0.1, fov_y: 1.2 };
    let truth = draw_panorama(&device, &queue, Source::Cube(&room.panorama(&device, &queue, middle), None), &view);
    for t in [0.5, 0.4, 0.6] {
        let (mean, far) = difference(&glide(middle, t, &view), &truth);
        // (Measured: 5.6-6.2 levels, 5 % of pixels far off; blended by
        // position alone, the wall shows through the pillar: 29-38 levels,
        // 72 %.)
        assert!(mean < 8.0 && far < 0.08, "at {t}: {mean} levels, {far} far off");
    }
    // At the departure, still its panorama, though B's lattice cuts the pillar's corners.
    let cube_a = room.panorama(&device, &queue, A);
    let toward_pillar = View { yaw: 2.4, pitch: -0.1, fov_y: 1.2 };
    let (mean, far) = difference(&glide(A, 0.0, &toward_pillar), &draw_panorama(&device, &queue, Source::Cube(&cube_a, None), &toward_pillar));
    assert!(mean < 1.5 && far < 0.005, "at the start: {mean} levels, {far} far off");
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
