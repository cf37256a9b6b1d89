//! Pictures for people: the coverage-versus-probe-count chart and views of the
//! scene with the surface no probe sees painted magenta. Pure functions from
//! results to images; writing them is the bundle's job.
//!
//! Views are ray cast with Embree: a top view (orthographic, looking down, with
//! everything above the navigable space cut away so interiors show their
//! floors) and perspective views from the most open navigable point. Shading:
//! grey by the angle to a fixed light; magenta where no probe sees the point
//! (tested per pixel with occlusion rays); dimmed on triangles where the
//! coverage metric found nothing reachable; in the top view, amber over free
//! space the navigable space leaves out; probes are green dots.

use crate::plan::coverage::CoverageReport;
use crate::plan::freespace::FreeSpace;
use crate::raycast::{Packing, Ray, RayScene};
use exploremaps_scenes::Scene;
use glam::Vec3;
use image::{Rgb, RgbImage};

const PROBE: Rgb<u8> = Rgb([40, 230, 60]);

/// Per triangle: whether the coverage metric found any of it reachable. A
/// triangle no sample landed on (small ones often) counts as reachable, so its
/// pixels are judged by the probes rather than dimmed.
fn reachable_triangles(scene: &Scene, report: &CoverageReport) -> Vec<bool> {
    let mut sampled = vec![false; scene.triangles.len()];
    let mut reachable = vec![false; scene.triangles.len()];
    for (i, &t) in report.samples.triangles.iter().enumerate() {
        sampled[t as usize] = true;
        reachable[t as usize] |= report.reached_side[i] != 0;
    }
    reachable.iter().zip(&sampled).map(|(&r, &s)| r || !s).collect()
}

#[derive(Clone, Copy, PartialEq)]
enum Seen {
    Unreachable,
    /// Free space the chosen navigable space leaves out (top view only).
    Excluded,
    Covered,
    Uncovered,
}

/// What a pixel's column holds, for the top view.
#[derive(Clone, Copy, PartialEq)]
enum Column {
    Navigable,
    /// Open space (free, in the box, outside solids) but nothing navigable.
    Excluded,
    Other,
}

fn shade(ray_dir: Vec3, normal: Vec3, seen: Seen) -> Rgb<u8> {
    let light = Vec3::new(0.35, 0.8, 0.5).normalize();
    let n = if normal.dot(ray_dir) > 0.0 { -normal } else { normal };
    let l = 0.35 + 0.65 * n.dot(light).abs();
    match seen {
        Seen::Uncovered => Rgb([(255.0 * l) as u8, 0, (220.0 * l) as u8]),
        Seen::Covered => {
            let g = (215.0 * l) as u8;
            Rgb([g, g, g])
        }
        Seen::Unreachable => {
            let g = (110.0 * l) as u8;
            Rgb([g, g, (g as f32 * 1.15) as u8])
        }
        Seen::Excluded => Rgb([(230.0 * l) as u8, (160.0 * l) as u8, (40.0 * l) as u8]),
    }
}

/// Casts one ray per pixel and paints each hit by whether a probe sees that very
/// point from the side the viewer sees it (an occlusion ray per probe, probes
/// in order, stopping at the first that sees it).
/// `ray_at` gives each pixel's ray and what its column holds: hits under
/// navigable space are judged by the probes, others drawn dimmed, or amber
/// where the column holds only free space the navigable space leaves out.
fn render(
    subject: &Subject<'_>,
    reachable: &[bool],
    (width, height): (u32, u32),
    background: Rgb<u8>,
    ray_at: impl Fn(f32, f32) -> (Ray, Column),
) -> RgbImage {
    let Subject { rays, probes, .. } = *subject;
    let (primary, column): (Vec<Ray>, Vec<Column>) =
        (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| ray_at(x as f32 + 0.5, y as f32 + 0.5)).unzip();
    let hits = rays.intersect_batch(&primary, Packing::Packets8);
    let mut seen: Vec<Option<Seen>> = hits
        .iter()
        .zip(&column)
        .map(|(h, &c)| {
            h.map(|h| match c {
                Column::Navigable if reachable[h.triangle as usize] => Seen::Uncovered,
                Column::Excluded => Seen::Excluded,
                _ => Seen::Unreachable,
            })
        })
        .collect();
    for &probe in probes {
        let open: Vec<usize> = (0..hits.len()).filter(|&k| seen[k] == Some(Seen::Uncovered)).collect();
        let (mut pixels, mut segments) = (Vec::new(), Vec::new());
        for k in open {
            let (r, h) = (&primary[k], hits[k].expect("uncovered pixels have hits"));
            let x = r.at(h.t);
            let viewer_side = (r.origin - x).dot(h.normal).signum();
            if (probe - x).dot(h.normal) * viewer_side > 0.0 {
                let lifted = x + h.normal * viewer_side * 1e-3 * (1.0 + x.abs().max_element());
                pixels.push(k);
                segments.push(Ray::segment(probe, lifted));
            }
        }
        for (k, blocked) in pixels.into_iter().zip(rays.occluded_batch(&segments, Packing::Packets8)) {
            if !blocked {
                seen[k] = Some(Seen::Covered);
            }
        }
    }
    let mut img = RgbImage::from_pixel(width, height, background);
    for (k, (r, h)) in primary.iter().zip(&hits).enumerate() {
        if let (Some(h), Some(s)) = (h, seen[k]) {
            img.put_pixel(k as u32 % width, k as u32 / width, shade(r.dir, h.normal, s));
        }
    }
    img
}

fn dot(img: &mut RgbImage, x: f32, y: f32, colour: Rgb<u8>) {
    // A flat scene's view can place a point at infinity.
    if !(x.is_finite() && y.is_finite()) {
        return;
    }
    for dy in -2i32..=2 {
        for dx in -2i32..=2 {
            let (px, py) = ((x as i32).saturating_add(dx), (y as i32).saturating_add(dy));
            if dx * dx + dy * dy <= 5 && px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                img.put_pixel(px as u32, py as u32, colour);
            }
        }
    }
}

/// What the pictures show: the scene, its rays, the coverage report and
/// the probes that made it.
#[derive(Clone, Copy)]
pub struct Subject<'a> {
    pub scene: &'a Scene,
    pub rays: &'a RayScene,
    pub report: &'a CoverageReport,
    pub probes: &'a [Vec3],
}

/// Orthographic top view, `width` pixels across. Each pixel's ray starts at the
/// top of the navigable space in its column (a cutaway: interiors show their
/// floors, not their roofs); columns without navigable space show the roof,
/// amber where they hold free space the chosen space leaves out.
pub fn top_view(subject: &Subject<'_>, space: &FreeSpace, width: u32) -> RgbImage {
    let Subject { scene, report, probes, .. } = *subject;
    let reachable = reachable_triangles(scene, report);
    let b = scene.bounds();
    let e = b.extent();
    let height = ((width as f32 * e.z / e.x.max(1e-6)).round() as u32).clamp(1, 4 * width);
    let g = &space.grid;
    // Highest navigable voxel top per grid column (x, z), and whether the column
    // holds open space at all.
    let mut column_top = vec![f32::NAN; g.dims[0] * g.dims[2]];
    let mut column_open = vec![false; g.dims[0] * g.dims[2]];
    for i in 0..g.len() {
        let c = g.coords(i);
        let slot = c[0] + g.dims[0] * c[2];
        column_open[slot] |= space.open[i];
        if space.navigable[i] {
            let top = g.center(c).y + 0.5 * g.voxel;
            if column_top[slot].is_nan() || top > column_top[slot] {
                column_top[slot] = top;
            }
        }
    }
    let above = b.max.y + 0.01 * b.diagonal();
    // (ray origin, what the column holds).
    let start = |x: f32, z: f32| {
        let slot = g.cell(Vec3::new(x, g.origin.y + 0.5 * g.voxel, z)).map(|c| c[0] + g.dims[0] * c[2]);
        match slot {
            Some(k) if !column_top[k].is_nan() => (Vec3::new(x, column_top[k], z), Column::Navigable),
            Some(k) if column_open[k] => (Vec3::new(x, above, z), Column::Excluded),
            _ => (Vec3::new(x, above, z), Column::Other),
        }
    };
    let to_world = |x: f32, y: f32| (b.min.x + x / width as f32 * e.x, b.min.z + y / height as f32 * e.z);
    let mut img = render(subject, &reachable, (width, height), Rgb([24, 26, 32]), |x, y| {
        let (wx, wz) = to_world(x, y);
        let (origin, column) = start(wx, wz);
        (Ray::new(origin, Vec3::NEG_Y), column)
    });
    for p in probes {
        dot(&mut img, (p.x - b.min.x) / e.x * width as f32, (p.z - b.min.z) / e.z * height as f32, PROBE);
    }
    img
}

/// A 90° perspective view from `eye` toward `forward`, 4:3, sky blue where nothing is hit.
pub fn perspective_view(subject: &Subject<'_>, eye: Vec3, forward: Vec3, width: u32) -> RgbImage {
    let reachable = reachable_triangles(subject.scene, subject.report);
    let height = width * 3 / 4;
    let f = forward.normalize();
    let right = f.cross(Vec3::Y).normalize_or(Vec3::X);
    let up = right.cross(f);
    let aspect = height as f32 / width as f32;
    render(subject, &reachable, (width, height), Rgb([150, 190, 230]), |x, y| {
        let sx = 2.0 * x / width as f32 - 1.0;
        let sy = (1.0 - 2.0 * y / height as f32) * aspect;
        (Ray::new(eye, (f + right * sx + up * sy).normalize()), Column::Navigable)
    })
}

/// A coverage curve, (probes, covered fraction) points, and its colour.
pub type Curve<'a> = (&'a [(u32, f64)], Rgb<u8>);

/// Coverage against probe count: one polyline per curve (fractions in [0, 1]),
/// on a grid with lines every 10 % and every 10 probes; the y axis runs from
/// `floor` to 100 %. Colours: as given per curve. No text: the numbers are in
/// coverage.json.
pub fn coverage_chart(curves: &[Curve], floor: f64, width: u32, height: u32) -> RgbImage {
    let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    let max_n = curves.iter().flat_map(|(c, _)| c.iter().map(|p| p.0)).max().unwrap_or(1).max(1) as f32;
    let margin = 24.0;
    let (w, h) = (width as f32 - 2.0 * margin, height as f32 - 2.0 * margin);
    let to_px = |n: f32, f: f64| (margin + n / max_n * w, margin + h * (1.0 - ((f - floor) / (1.0 - floor)).clamp(0.0, 1.0) as f32));
    let grey = Rgb([225, 225, 225]);
    let mut k = 0.0;
    while k <= 1.0 + 1e-9 {
        let (_, y) = to_px(0.0, floor + (1.0 - floor) * k);
        line(&mut img, (margin, y), (margin + w, y), grey);
        k += 0.1;
    }
    let mut n = 0.0;
    while n <= max_n {
        let (x, _) = to_px(n, floor);
        line(&mut img, (x, margin), (x, margin + h), grey);
        n += 10.0;
    }
    let black = Rgb([40, 40, 40]);
    line(&mut img, (margin, margin), (margin, margin + h), black);
    line(&mut img, (margin, margin + h), (margin + w, margin + h), black);
    for (curve, colour) in curves {
        let mut last = to_px(0.0, floor);
        for &(n, f) in curve.iter() {
            let p = to_px(n as f32, f);
            line(&mut img, last, p, *colour);
            line(&mut img, (last.0, last.1 + 1.0), (p.0, p.1 + 1.0), *colour);
            last = p;
        }
    }
    img
}

fn line(img: &mut RgbImage, a: (f32, f32), b: (f32, f32), colour: Rgb<u8>) {
    let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as usize;
    for s in 0..=steps {
        let t = s as f32 / steps as f32;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        if x >= 0.0 && y >= 0.0 && (x as u32) < img.width() && (y as u32) < img.height() {
            img.put_pixel(x as u32, y as u32, colour);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chart_draws_each_curve_in_its_colour() {
        let explored = [(1, 0.5), (2, 0.9), (3, 1.0)];
        let img = coverage_chart(&[(&explored, Rgb([0, 160, 0]))], 0.0, 200, 120);
        let greens = img.pixels().filter(|p| p.0 == [0, 160, 0]).count();
        assert!(greens > 100, "{greens}");
        // The curve ends at 100 % at the right edge: top-right of the plot area.
        assert_eq!(img.get_pixel(200 - 24, 24).0, [0, 160, 0]);
    }

    #[test]
    fn dots_at_infinity_or_far_outside_are_left_out() {
        // A flat scene's top view divides by a zero extent: `plan` on one
        // triangle overflowed here.
        let mut img = RgbImage::new(8, 8);
        for (x, y) in [(f32::INFINITY, 1.0), (f32::NAN, 1.0), (1e30, -1e30), (i32::MAX as f32, 3.0)] {
            dot(&mut img, x, y, PROBE);
        }
        dot(&mut img, 4.0, 4.0, PROBE);
        assert_eq!(img.get_pixel(4, 4), &PROBE);
    }
}
