//! The usable workspace of a mechanism (validated `workspace` block): the region, an inward
//! safety margin, and ranges for the measured coordinates the region does not cover.

use rand::Rng;

use super::region::Region;

/// The usable workspace of a mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Workspace {
    /// Region of the end-effector point: in x, y (planar) or in x, y, z (spatial).
    pub region: Region,
    /// Inward safety margin, metres.
    pub margin: f64,
    /// `[min, max]` for coordinates 2..6 (z roll pitch yaw) that vary; `None` keeps the home
    /// value (z of a spatial region comes from the region, never from a range).
    pub ranges: [Option<[f64; 2]>; 6],
    /// Candidate grid spacing for pose selection, metres.
    pub grid: Option<f64>,
    /// Evenly spaced values of each ranged coordinate in the candidate grid.
    pub range_levels: usize,
    /// Smallest allowed serial (type I) measure of a candidate pose.
    pub serial_threshold: f64,
    /// Smallest allowed parallel (type II) measure of a candidate pose.
    pub parallel_threshold: f64,
}

/// Default smallest serial and parallel singularity measures of a candidate pose.
pub const DEFAULT_SINGULARITY_THRESHOLD: f64 = 0.05;
/// Default number of values of each ranged coordinate in the candidate grid.
pub const DEFAULT_RANGE_LEVELS: usize = 9;

impl Workspace {
    /// Is the pose inside the region, at least `margin` from its boundary, and within the ranges?
    pub fn contains(&self, pose: &[f64; 6]) -> bool {
        // 1e-12 m: grid points exactly on the usable boundary stay in despite round-off.
        self.region.depth([pose[0], pose[1], pose[2]]) >= self.margin - 1e-12
            && self
                .ranges
                .iter()
                .zip(pose)
                .all(|(range, value)| range.is_none_or(|[lo, hi]| (lo..=hi).contains(value)))
    }

    /// A uniformly random pose of the usable workspace (x, y — and z for a spatial region — by
    /// rejection in the bounding box, the ranged coordinates uniform, the others at `home`);
    /// `None` if 100 000 draws all fell outside (an empty usable workspace).
    pub fn sample(&self, home: &[f64; 6], rng: &mut impl Rng) -> Option<[f64; 6]> {
        let (lo, hi) = self.region.bounds();
        let z_bounds = self.region.z_bounds();
        for _ in 0..100_000 {
            let mut pose = *home;
            pose[0] = rng.random_range(lo[0]..=hi[0]);
            pose[1] = rng.random_range(lo[1]..=hi[1]);
            if let Some([low, high]) = z_bounds {
                pose[2] = rng.random_range(low..=high);
            }
            for (value, range) in pose.iter_mut().zip(&self.ranges).skip(2) {
                if let Some([min, max]) = range {
                    *value = rng.random_range(*min..=*max);
                }
            }
            if self.contains(&pose) {
                return Some(pose);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn workspace(region: Region, margin: f64, ranges: [Option<[f64; 2]>; 6]) -> Workspace {
        Workspace {
            region,
            margin,
            ranges,
            grid: None,
            range_levels: DEFAULT_RANGE_LEVELS,
            serial_threshold: DEFAULT_SINGULARITY_THRESHOLD,
            parallel_threshold: DEFAULT_SINGULARITY_THRESHOLD,
        }
    }

    #[test]
    fn samples_respect_margin_and_ranges() {
        use rand::SeedableRng;
        let mut ranges = [None; 6];
        ranges[5] = Some([-0.5, 0.5]);
        let region = Region::Disc {
            centre: [0.0, 0.0],
            radius: 0.2,
        };
        let workspace = workspace(region, 0.05, ranges);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for _ in 0..200 {
            let pose = workspace.sample(&[0.0; 6], &mut rng).unwrap();
            assert!(pose[0].hypot(pose[1]) <= 0.15 + 1e-12);
            assert!(pose[5].abs() <= 0.5);
        }
    }

    #[test]
    fn spatial_samples_fill_the_solid_and_leave_unranged_coordinates_at_home() {
        use rand::SeedableRng;
        let mut ranges = [None; 6];
        ranges[3] = Some([-0.1, 0.1]);
        let region = Region::Ball {
            centre: [0.0, 0.0, 1.0],
            radius: 0.2,
        };
        let workspace = workspace(region, 0.02, ranges);
        let home = [0.0, 0.0, 1.0, 0.0, 0.3, 0.0];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let (mut below, mut above) = (false, false);
        for _ in 0..200 {
            let pose = workspace.sample(&home, &mut rng).unwrap();
            let distance = (pose[0].powi(2) + pose[1].powi(2) + (pose[2] - 1.0).powi(2)).sqrt();
            assert!(distance <= 0.18 + 1e-12);
            assert!(pose[3].abs() <= 0.1);
            assert_eq!((pose[4], pose[5]), (0.3, 0.0));
            below |= pose[2] < 0.95;
            above |= pose[2] > 1.05;
        }
        assert!(below && above, "z varies over the ball");
    }
}
