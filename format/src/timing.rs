//! How a camera moves along a path, shared by the builder (the camera keys
//! its transition videos are rendered at) and the viewer (gliding along a
//! path it has no video for, and the overlay's position on a video), so
//! both put the camera at the same place at the same time: slow in and slow
//! out ([`ease`]) over the path's arc length ([`ArcLength`]).

/// The fraction of a path's length reached at fraction `t` of its duration:
/// smoothstep, so the camera starts and stops without a jolt.
pub fn ease(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A polyline measured along its length.
pub struct ArcLength<'a> {
    points: &'a [[f32; 3]],
    /// Length from the first point to each point.
    cumulative: Vec<f32>,
}

fn distance(a: [f32; 3], b: [f32; 3]) -> f32 {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

impl<'a> ArcLength<'a> {
    pub fn new(points: &'a [[f32; 3]]) -> ArcLength<'a> {
        let mut cumulative = Vec::with_capacity(points.len());
        cumulative.push(0.0f32);
        for w in points.windows(2) {
            cumulative.push(cumulative[cumulative.len() - 1] + distance(w[0], w[1]));
        }
        ArcLength { points, cumulative }
    }

    pub fn length(&self) -> f32 {
        self.cumulative[self.cumulative.len() - 1]
    }

    /// The point at fraction `s` (0 to 1) of the length; the first point of
    /// a polyline of one point, the origin of an empty one.
    pub fn at(&self, s: f32) -> [f32; 3] {
        let p = self.points;
        if p.len() < 2 {
            return p.first().copied().unwrap_or_default();
        }
        let at = s * self.length();
        let c = &self.cumulative;
        let seg = c.partition_point(|&x| x <= at).clamp(1, p.len() - 1) - 1;
        let l = (c[seg + 1] - c[seg]).max(1e-12);
        let f = ((at - c[seg]) / l).clamp(0.0, 1.0);
        let (a, b) = (p[seg], p[seg + 1]);
        [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ease_starts_and_stops_at_rest() {
        assert_eq!((ease(0.0), ease(0.5), ease(1.0)), (0.0, 0.5, 1.0));
        assert_eq!((ease(-1.0), ease(2.0)), (0.0, 1.0));
        // Slow at both ends: the first and last tenth cover under 3 % each.
        assert!(ease(0.1) < 0.03 && ease(0.9) > 0.97);
    }

    #[test]
    fn points_along_a_polyline_go_by_length_not_by_vertex() {
        // A 1-long segment then a 3-long one, with a repeated point between.
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 3.0, 0.0]];
        let arc = ArcLength::new(&p);
        assert_eq!(arc.length(), 4.0);
        assert_eq!(arc.at(0.0), [0.0, 0.0, 0.0]);
        assert_eq!(arc.at(0.125), [0.5, 0.0, 0.0]);
        assert_eq!(arc.at(0.5), [1.0, 1.0, 0.0]);
        assert_eq!(arc.at(1.0), [1.0, 3.0, 0.0]);
        assert_eq!(arc.at(2.0), [1.0, 3.0, 0.0]);
        assert_eq!(ArcLength::new(&p[..1]).at(0.5), [0.0, 0.0, 0.0]);
        assert_eq!(ArcLength::new(&[]).at(0.5), [0.0; 3]);
    }
}
