//! The touch surfaces of a model's instrument as bounds of its workspace. A target that
//! declares `touch` (a bed probe's nozzle, `touch: 0.0`) cannot pass through the surface where
//! it reports that value: the bed is as much a boundary of where the platform can go as a
//! singularity. At the home orientation and the instrument's nominal values, what the
//! instrument reports of the target is an affine function `g(p)` of the platform's position
//! `p`, so the surface is a plane in position space and its distance from the home position
//! is `|g(home) − touch| / ‖∇g‖` (the gradient from dual numbers).

use num_dual::Dual64;

use crate::measure::targets::observe_in;
use crate::model::Mechanism;

/// One touch surface, seen from the home position.
#[derive(Debug, Clone, PartialEq)]
pub struct TouchSurface {
    /// The target that touches it.
    pub target: String,
    /// `g(home) − touch`: how far the target is from the surface at home, in the reported
    /// coordinate's unit (metres).
    pub gap: f64,
    /// `∇g` over the platform's position `[x, y, z]` (dimensionless).
    pub gradient: [f64; 3],
}

impl TouchSurface {
    /// The distance from the home position to the plane of platform positions where the target
    /// touches, metres (infinite when moving the platform does not move the target across
    /// it).
    pub fn clearance(&self) -> f64 {
        let norm = self.gradient.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 0.0 {
            self.gap.abs() / norm
        } else {
            f64::INFINITY
        }
    }

    /// The surface's trace in the plane through `centre` (the home position) spanned by the
    /// position coordinates `axes`, clipped to the box `(lo, hi)` of that plane: the segment's
    /// two ends, or `None` when the plane does not cross the surface inside the box.
    pub fn trace(
        &self,
        centre: [f64; 3],
        axes: [usize; 2],
        (lo, hi): ([f64; 2], [f64; 2]),
    ) -> Option<[[f64; 2]; 2]> {
        // g = gap + a·(u − u0) + b·(v − v0) = 0 in the plane's coordinates (u, v).
        let (a, b) = (self.gradient[axes[0]], self.gradient[axes[1]]);
        let (u0, v0) = (centre[axes[0]], centre[axes[1]]);
        let on = |u: f64, v: f64| self.gap + a * (u - u0) + b * (v - v0);
        // Where the line meets each side of the box.
        let mut ends: Vec<[f64; 2]> = Vec::new();
        if b.abs() > f64::EPSILON * a.abs() {
            for u in [lo[0], hi[0]] {
                let v = v0 - (self.gap + a * (u - u0)) / b;
                if (lo[1]..=hi[1]).contains(&v) {
                    ends.push([u, v]);
                }
            }
        }
        if a.abs() > f64::EPSILON * b.abs() {
            for v in [lo[1], hi[1]] {
                let u = u0 - (self.gap + b * (v - v0)) / a;
                if (lo[0]..=hi[0]).contains(&u) {
                    ends.push([u, v]);
                }
            }
        }
        ends.sort_by(|p, q| p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1])));
        ends.dedup_by(|p, q| (p[0] - q[0]).abs() + (p[1] - q[1]).abs() < 1e-12);
        let first = *ends.first()?;
        let last = *ends.last()?;
        let scale = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        let crosses = (first[0] - last[0]).hypot(first[1] - last[1]) > 1e-9 * scale;
        debug_assert!(on(first[0], first[1]).abs() <= 1e-6 * (1.0 + self.gap.abs()));
        crosses.then_some([first, last])
    }
}

/// The touch surfaces of `mechanism`'s instrument (seen through the forward kinematics, at its
/// nominal values), seen from the home position `centre` at the home orientation; none
/// without a target that declares `touch`.
pub fn touch_surfaces(mechanism: &Mechanism, centre: [f64; 3]) -> Vec<TouchSurface> {
    let Some(instrument) = mechanism.forward_instrument() else {
        return Vec::new();
    };
    let shared: Vec<Dual64> = instrument
        .nominal()
        .iter()
        .map(|&v| Dual64::from(v))
        .collect();
    let mut pose = mechanism.home_pose;
    pose[..3].copy_from_slice(&centre);
    let mut at = 0;
    let mut surfaces = Vec::new();
    for target in &instrument.targets {
        let first = at;
        at += target.pose_indices().len();
        let Some(touch) = target.touch else {
            continue;
        };
        let mut gap = 0.0;
        let mut gradient = [0.0; 3];
        for (k, slope) in gradient.iter_mut().enumerate() {
            let mut seeded = pose.map(Dual64::from);
            seeded[k] = seeded[k].derivative();
            let value = observe_in(instrument, &shared, &seeded)[first];
            gap = value.re - touch;
            *slope = value.eps;
        }
        surfaces.push(TouchSurface {
            target: target.name.clone(),
            gap,
            gradient,
        });
    }
    surfaces
}

#[cfg(test)]
mod tests {
    use super::TouchSurface;

    /// A bed 0.03 m below, tilted: the distance to a plane `n·p = d` by hand, and its trace in
    /// the x–z plane through the centre where `z` solves the plane's equation at each end.
    #[test]
    fn a_tilted_plane_is_as_far_as_its_normal_distance_and_traced_where_it_holds() {
        let gradient = [0.1, -0.2, 1.0];
        let surface = TouchSurface {
            target: "nozzle".into(),
            gap: 0.03,
            gradient,
        };
        let norm = (0.01_f64 + 0.04 + 1.0).sqrt();
        assert!((surface.clearance() - 0.03 / norm).abs() < 1e-15);
        let centre = [0.0, 0.0, 0.05];
        let [a, b] = surface
            .trace(centre, [0, 2], ([-0.2, -0.3], [0.2, 0.8]))
            .expect("a trace");
        for p in [a, b] {
            let g = 0.03 + 0.1 * p[0] + (p[1] - 0.05);
            assert!(g.abs() < 1e-15, "{p:?}");
        }
        assert_eq!((a[0], b[0]), (-0.2, 0.2), "from side to side");
        // A level bed is not crossed in the horizontal plane through home.
        let level = TouchSurface {
            gradient: [0.0, 0.0, 1.0],
            ..surface.clone()
        };
        assert!((level.clearance() - 0.03).abs() < 1e-15);
        assert!(level
            .trace(centre, [0, 1], ([-0.2, -0.2], [0.2, 0.2]))
            .is_none());
        let unmoved = TouchSurface {
            gradient: [0.0; 3],
            ..surface
        };
        assert!(unmoved.clearance().is_infinite());
    }
}
