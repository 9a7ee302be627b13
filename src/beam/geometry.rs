//! The reference line of a beam and its section frames: straight, a circular arc, or a
//! polyline, with pre-twist (constant rate or a table of angles).
//!
//! Along arc length s the *untwisted* frame `F(s)` (columns: tangent t, n₂, n₃) is carried
//! without twist: constant on a straight segment, turned about the arc's axis on an arc, and
//! turned by the smallest rotation taking one tangent into the next at a polyline corner. The
//! section frame is `R(s) = F(s) R₁(θ(s))` with θ the pre-twist angle about axis 1, so its
//! material curvature is `k₀ = R₁(θ)ᵀ Fᵀ F′ + θ′ e₁` (eq. (1)'s reference curvature).

pub use crate::math::default_axes::default_e2;
use crate::math::rotation::exp_map;
use crate::math::vec3::{M3, V3};

#[derive(Clone, Debug)]
enum Shape {
    Straight {
        p0: V3<f64>,
    },
    /// Turning by +s/radius about `axis` (unit, oriented so the angle is positive).
    Arc {
        center: V3<f64>,
        axis: V3<f64>,
        radius: f64,
        r0: V3<f64>,
    },
}

#[derive(Clone, Debug)]
struct Segment {
    s0: f64,
    len: f64,
    shape: Shape,
    /// Untwisted frame at the segment's start.
    frame0: M3<f64>,
}

#[derive(Clone, Debug)]
enum Twist {
    Rate(f64),
    /// Arc lengths and angles, piecewise linear.
    Table(Vec<f64>, Vec<f64>),
}

#[derive(Clone, Debug)]
pub struct ReferenceLine {
    segments: Vec<Segment>,
    twist: Twist,
    length: f64,
}

/// The path of a beam's reference line, its end points resolved.
#[derive(Clone, Debug)]
pub enum LinePath {
    /// Straight segments through the points (at least two).
    Polyline(Vec<V3<f64>>),
    /// A circular arc from `start`, turning by `angle` (rad) right-handedly about `axis`
    /// through `center`; it must reach `end`.
    Arc {
        start: V3<f64>,
        end: V3<f64>,
        center: V3<f64>,
        axis: V3<f64>,
        angle: f64,
    },
}

/// Pre-twist of the sections about the line.
#[derive(Clone, Debug)]
pub enum Pretwist {
    /// Constant rate, rad/m.
    Rate(f64),
    /// Angles (rad) at fractions `eta` of the length, piecewise linear.
    Table { eta: Vec<f64>, angle: Vec<f64> },
}

/// End point of the arc from `start` turning by `angle` about `axis` through `center`.
pub fn arc_end(start: V3<f64>, center: V3<f64>, axis: V3<f64>, angle: f64) -> V3<f64> {
    let axis = axis.scale_f(1.0 / axis.norm().max(1e-300));
    center + exp_map(&axis.scale_f(angle)).mul_v(&(start - center))
}

/// The smallest rotation taking unit vector `a` into unit vector `b` (not antiparallel).
fn align(a: &V3<f64>, b: &V3<f64>) -> M3<f64> {
    let axis = a.cross(b);
    let s = axis.norm();
    if s < 1e-15 {
        return M3::identity();
    }
    let angle = s.atan2(a.dot(b));
    exp_map(&axis.scale_f(angle / s))
}

impl ReferenceLine {
    /// The line along `path`, its sections' axis 2 starting along `e2` (projected normal to
    /// the line; a default normal if `None`), pre-twisted by `twist`. Errors say what is wrong
    /// with the geometry, for the validator to attach to the beam.
    pub fn new(
        path: &LinePath,
        e2: Option<V3<f64>>,
        twist: &Pretwist,
    ) -> Result<ReferenceLine, String> {
        let segments = match path {
            LinePath::Arc {
                start,
                end,
                center,
                axis,
                angle,
            } => vec![arc_segment((*center, *axis, *angle), *start, *end, e2)?],
            LinePath::Polyline(pts) => polyline_segments(pts, e2)?,
        };
        let length = segments.iter().map(|s| s.len).sum::<f64>();
        let twist = match twist {
            Pretwist::Table { eta, angle } => {
                Twist::Table(eta.iter().map(|e| e * length).collect(), angle.clone())
            }
            Pretwist::Rate(rate) => Twist::Rate(*rate),
        };
        Ok(ReferenceLine {
            segments,
            twist,
            length,
        })
    }

    pub fn length(&self) -> f64 {
        self.length
    }

    pub fn segment_count(&self) -> usize {
        self.segments.len()
    }

    /// Element spans `(segment, s_start, s_end)`: `elements` shared among the segments in
    /// proportion to their lengths, at least one each, uniform within a segment.
    pub fn element_spans(&self, elements: usize) -> Vec<(usize, f64, f64)> {
        let n = self.segments.len();
        let mut count: Vec<usize> = self
            .segments
            .iter()
            .map(|s| ((elements as f64 * s.len / self.length).round() as usize).max(1))
            .collect();
        // Adjust to the requested total, taking from / giving to the longest elements.
        while count.iter().sum::<usize>() > elements.max(n) {
            let k = (0..n)
                .filter(|&k| count[k] > 1)
                .min_by(|&a, &b| {
                    let la = self.segments[a].len / count[a] as f64;
                    let lb = self.segments[b].len / count[b] as f64;
                    la.total_cmp(&lb)
                })
                .expect("more elements than segments");
            count[k] -= 1;
        }
        while count.iter().sum::<usize>() < elements {
            let k = (0..n)
                .max_by(|&a, &b| {
                    let la = self.segments[a].len / count[a] as f64;
                    let lb = self.segments[b].len / count[b] as f64;
                    la.total_cmp(&lb)
                })
                .expect("one segment at least");
            count[k] += 1;
        }
        let mut spans = Vec::new();
        for (k, seg) in self.segments.iter().enumerate() {
            let le = seg.len / count[k] as f64;
            for e in 0..count[k] {
                let a = seg.s0 + le * e as f64;
                let b = if e + 1 == count[k] {
                    seg.s0 + seg.len
                } else {
                    a + le
                };
                spans.push((k, a, b));
            }
        }
        spans
    }

    /// Point of segment `k` at arc length `s`.
    pub fn point(&self, k: usize, s: f64) -> V3<f64> {
        let seg = &self.segments[k];
        match &seg.shape {
            Shape::Straight { p0 } => *p0 + seg.frame0.col(0).scale_f(s - seg.s0),
            Shape::Arc {
                center,
                axis,
                radius,
                r0,
            } => *center + exp_map(&axis.scale_f((s - seg.s0) / radius)).mul_v(r0),
        }
    }

    fn untwisted(&self, k: usize, s: f64) -> M3<f64> {
        let seg = &self.segments[k];
        match &seg.shape {
            Shape::Straight { .. } => seg.frame0,
            Shape::Arc { axis, radius, .. } => {
                exp_map(&axis.scale_f((s - seg.s0) / radius)).mul_m(&seg.frame0)
            }
        }
    }

    /// Pre-twist angle and its rate at arc length `s`.
    fn twist(&self, s: f64) -> (f64, f64) {
        match &self.twist {
            Twist::Rate(k) => (k * s, *k),
            Twist::Table(ss, a) => {
                let j = ss.windows(2).position(|w| s < w[1]).unwrap_or(ss.len() - 2);
                let rate = (a[j + 1] - a[j]) / (ss[j + 1] - ss[j]);
                (a[j] + rate * (s - ss[j]), rate)
            }
        }
    }

    /// Section frame of segment `k` at arc length `s`: columns `[t, e₂, e₃]`.
    pub fn section_triad(&self, k: usize, s: f64) -> M3<f64> {
        let (theta, _) = self.twist(s);
        self.untwisted(k, s).mul_m(&exp_map(&V3([theta, 0.0, 0.0])))
    }

    /// Reference curvature in the section frame: `[k₁, k₂, k₃]`, rad/m.
    pub fn curvature(&self, k: usize, s: f64) -> V3<f64> {
        let (theta, rate) = self.twist(s);
        let seg = &self.segments[k];
        let bend = match &seg.shape {
            Shape::Straight { .. } => V3::zero(),
            // Fᵀ F′ = F₀ᵀ ã F₀ / ρ: the axis in the (constant) frame components, over ρ.
            Shape::Arc { axis, radius, .. } => seg.frame0.tmul_v(axis).scale_f(1.0 / radius),
        };
        exp_map(&V3([theta, 0.0, 0.0])).tmul_v(&bend) + V3([rate, 0.0, 0.0])
    }

    /// The segment holding arc length `s` (the later one at a corner).
    pub fn segment_at(&self, s: f64) -> usize {
        self.segments
            .iter()
            .rposition(|seg| s >= seg.s0 - 1e-12 * self.length)
            .unwrap_or(0)
    }
}

/// The section frame at a line's start with tangent `t`: e₂ from the hint (or the default
/// [`default_e2`]) made normal to `t`.
fn start_frame(t: V3<f64>, e2_hint: Option<V3<f64>>) -> Result<M3<f64>, String> {
    let trial = e2_hint.unwrap_or_else(|| default_e2(t));
    let e2 = trial - t.scale_f(trial.dot(&t));
    if e2.norm() < 1e-8 * trial.norm().max(1e-300) {
        return Err("e2 is parallel to the beam axis at the start; give an e2 normal to it".into());
    }
    let e2 = e2.scale_f(1.0 / e2.norm());
    Ok(M3::from_cols(t, e2, t.cross(&e2)))
}

/// A circular arc from `start` about `axis` through `center` by `angle`, which must end at
/// `end`.
fn arc_segment(
    (center, axis, angle): (V3<f64>, V3<f64>, f64),
    start: V3<f64>,
    end: V3<f64>,
    user_e2: Option<V3<f64>>,
) -> Result<Segment, String> {
    let an = axis.norm();
    if an.is_nan() || an <= 0.0 || !angle.is_finite() || angle == 0.0 {
        return Err("arc: axis must be nonzero and angle a nonzero number of radians".into());
    }
    if angle.abs() > 2.0 * std::f64::consts::PI * (1.0 + 1e-12) {
        return Err(format!("arc: |angle| must not exceed 2π (got {angle})"));
    }
    let r0 = start - center;
    let axis = axis.scale_f(angle.signum() / an);
    let radius = r0.norm();
    if radius == 0.0 {
        return Err("arc: the start point is the centre".into());
    }
    if r0.dot(&axis).abs() > 1e-9 * radius {
        return Err(format!(
            "arc: the start point is not in the plane through the centre normal to the axis (out of plane by {:.3e} m)",
            r0.dot(&axis).abs()
        ));
    }
    let t = axis.cross(&r0).scale_f(1.0 / radius);
    // By default axis 3 is the arc's axis: in-plane bending is κ₃.
    let frame0 = start_frame(t, user_e2.or(Some(axis.cross(&t))))?;
    let reach = arc_end(start, center, axis, angle.abs());
    if (reach - end).norm() > 1e-9 * radius.max(1.0) {
        return Err(format!(
            "arc: ends at {:?}, not at the given end {:?}; leave out `end` or make it match",
            reach.0, end.0
        ));
    }
    Ok(Segment {
        s0: 0.0,
        len: radius * angle.abs(),
        shape: Shape::Arc {
            center,
            axis,
            radius,
            r0,
        },
        frame0,
    })
}

/// Straight segments through `pts`, each segment's frame the previous one turned onto its
/// direction (no twist about the line).
fn polyline_segments(pts: &[V3<f64>], user_e2: Option<V3<f64>>) -> Result<Vec<Segment>, String> {
    let mut segments = Vec::new();
    let mut frame: Option<M3<f64>> = None;
    let mut s0 = 0.0;
    for (k, w) in pts.windows(2).enumerate() {
        let d = w[1] - w[0];
        let len = d.norm();
        if len == 0.0 {
            return Err(format!(
                "points {k} and {} of the beam's line coincide",
                k + 1
            ));
        }
        let t = d.scale_f(1.0 / len);
        let f = match frame {
            None => start_frame(t, user_e2)?,
            Some(prev) => {
                let t_prev = prev.col(0);
                if t_prev.dot(&t) < -1.0 + 1e-9 {
                    return Err(format!(
                        "the line folds back on itself at via point {}",
                        k - 1
                    ));
                }
                align(&t_prev, &t).mul_m(&prev)
            }
        };
        segments.push(Segment {
            s0,
            len,
            shape: Shape::Straight { p0: w[0] },
            frame0: f,
        });
        frame = Some(f);
        s0 += len;
    }
    Ok(segments)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Material curvature of a frame field by central differences: axial(Rᵀ R′).
    fn fd_curvature(f: impl Fn(f64) -> M3<f64>, s: f64) -> V3<f64> {
        let d = 1e-6;
        let r = f(s);
        let dr = (f(s + d) - f(s - d)).scale_f(0.5 / d);
        let w = r.transpose().mul_m(&dr);
        V3([w.0[2][1], w.0[0][2], w.0[1][0]])
    }

    #[test]
    fn the_default_section_frame_turns_continuously_with_the_beam() {
        let frame = |t: V3<f64>| start_frame(t, None).unwrap();
        // Horizontal beams: axis 3 is +z whatever the azimuth (it used to flip to −z past
        // ~26° from x), so blades patterned about z have patterned frames.
        for k in 0..72 {
            let a = (k as f64 * 5.0).to_radians();
            let f = frame(V3([a.cos(), a.sin(), 0.0]));
            assert!(
                (f.col(2) - V3([0.0, 0.0, 1.0])).norm() < 1e-15,
                "azimuth {k}·5°"
            );
        }
        // Over the sphere (away from the vertical, where ẑ × t vanishes), neighbouring
        // directions 1° apart have frames 1° apart: no flip anywhere.
        for i in 1..179 {
            for j in 0..360 {
                let (p, a) = ((i as f64).to_radians(), (j as f64).to_radians());
                let (p2, a2) = (p + 1f64.to_radians(), a + 1f64.to_radians());
                let t = |p: f64, a: f64| V3([p.sin() * a.cos(), p.sin() * a.sin(), p.cos()]);
                let (f, g) = (frame(t(p, a)), frame(t(p2.min(179f64.to_radians()), a2)));
                // e₂ = ẑ × t/|ẑ × t| depends on the azimuth only: 1° turns it by 0.01745; a
                // flip would change it by up to 2.
                assert!(
                    (f.col(1) - g.col(1)).norm() < 0.0175,
                    "polar {i}°, azimuth {j}°"
                );
            }
        }
        // A vertical beam takes +y.
        assert!((frame(V3([0.0, 0.0, 1.0])).col(1) - V3([0.0, 1.0, 0.0])).norm() < 1e-15);
    }

    #[test]
    fn arc_frames_follow_the_tangent_and_their_curvature_is_exact() {
        let (start, center, axis) = (V3::zero(), V3([0.0, 2.0, 0.0]), V3([0.0, 0.0, 1.0]));
        let path = LinePath::Arc {
            start,
            end: arc_end(start, center, axis, 2.0),
            center,
            axis,
            angle: 2.0,
        };
        let line = ReferenceLine::new(&path, None, &Pretwist::Rate(0.3)).unwrap();
        assert!((line.length() - 4.0).abs() < 1e-14);
        for s in [0.3, 1.7, 3.9] {
            let d = 1e-6;
            let t = (line.point(0, s + d) - line.point(0, s - d)).scale_f(0.5 / d);
            let r = line.section_triad(0, s);
            // Tangent along axis 1; finite-difference accuracy ~d².
            assert!((t - r.col(0)).norm() < 1e-9, "s={s}");
            let k = line.curvature(0, s);
            let fd = fd_curvature(|x| line.section_triad(0, x), s);
            assert!((k - fd).norm() < 1e-8, "s={s}: {:?} vs {:?}", k.0, fd.0);
            // Curvature magnitude of the line 1/ρ = 0.5 and the twist 0.3.
            assert!((k.0[0] - 0.3).abs() < 1e-14);
            assert!(((k.0[1].powi(2) + k.0[2].powi(2)).sqrt() - 0.5).abs() < 1e-14);
        }
    }

    #[test]
    fn polyline_frames_turn_minimally_at_corners() {
        let path = LinePath::Polyline(vec![V3::zero(), V3([1.0, 0.0, 0.0]), V3([1.0, 1.0, 0.0])]);
        let e2 = Some(V3([0.0, 1.0, 0.0]));
        let line = ReferenceLine::new(&path, e2, &Pretwist::Rate(0.0)).unwrap();
        assert_eq!(line.segment_count(), 2);
        let f = line.section_triad(1, 1.5);
        // Turning by 90° about z takes (x, y) to (y, −x); axis 3 stays z.
        assert!((f.col(0) - V3([0.0, 1.0, 0.0])).norm() < 1e-14);
        assert!((f.col(1) - V3([-1.0, 0.0, 0.0])).norm() < 1e-14);
        let spans = line.element_spans(5);
        assert_eq!(spans.len(), 5);
        assert!(spans.iter().filter(|s| s.0 == 0).count() >= 2);
        assert!((spans[4].2 - 2.0).abs() < 1e-14);
    }

    #[test]
    fn twist_tables_interpolate_angles_and_give_their_rates() {
        let twist = Pretwist::Table {
            eta: vec![0.0, 0.5, 1.0],
            angle: vec![0.0, 0.4, 0.5],
        };
        let path = LinePath::Polyline(vec![V3::zero(), V3([2.0, 0.0, 0.0])]);
        let line = ReferenceLine::new(&path, None, &twist).unwrap();
        assert!((line.curvature(0, 0.5).0[0] - 0.4).abs() < 1e-14);
        assert!((line.curvature(0, 1.5).0[0] - 0.1).abs() < 1e-14);
        let r = line.section_triad(0, 1.5);
        let angle = r.col(1).0[2].atan2(r.col(1).0[1]);
        assert!((angle - 0.45).abs() < 1e-14);
    }
}
