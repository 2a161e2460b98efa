//! What partial observations cannot see, named as motions of the mechanism.
//!
//! A direction `δ` in a forward model's unknowns moves every row's reached point `X_r` (the
//! instrument's target, in the base frame, where the row's readings take it) by
//! `∂X_r/∂x δ` ([`IdentificationProblem::reached_points`]). A direction the observations
//! cannot see (a null direction of the column-scaled Jacobian) or hardly see (its weakest
//! one) is then described by the motion of the reached points it causes, fitted by least
//! squares to the seven motions of a point set: a translation along `x`, `y`, `z`, a rotation
//! about `x`, `y`, `z` through the points' centroid, and a scale about it. For a bed probe:
//! heights cannot see a translation of the printer along `x`, `y` or `z` (the datum), nor a
//! turn about the bed's normal, and only nearly a common scale of its lengths.
//!
//! The null space is a subspace whose basis the SVD picks arbitrarily: its motions are named by
//! which of the seven motions lie in it (each, once the ones already named are taken out,
//! within [`CONTAINED`] of it); what is left is described as a combination.

use nalgebra::{DMatrix, DVector};

use super::observability::{unit_columns, with_a_row_per_column, RANK_TOLERANCE};
use super::problem::{IdentificationProblem, ReachedPoint};

/// The seven motions of a point set, in the order of [`motion_basis`]'s columns.
pub const MOTIONS: [&str; 7] = [
    "translation along x",
    "translation along y",
    "translation along z",
    "rotation about x",
    "rotation about y",
    "rotation about z",
    "scale",
];

/// The cosine above which a motion is taken as lying in a subspace (or as being a direction's
/// motion): 0.95, a motion at most 18° from it.
pub const CONTAINED: f64 = 0.95;

/// Terms of a combination below this share are left out of its description.
const NEGLIGIBLE: f64 = 0.1;

/// How the description of null directions that move no reached point ends.
pub const STILL: &str = "direction(s) moving no reached point";

/// A null direction's motion of the reached points at most this fraction of the motion a
/// column-scaled unit step of the unknowns produces is round-off: it moves no reached point.
const ROUND_OFF: f64 = 1e-8;

/// What a forward problem's observations cannot see and hardly see, as motions.
#[derive(Debug, Clone, PartialEq)]
pub struct UnseenMotions {
    /// The null space's motions of the reached points: named motions, then the rest as
    /// combinations (empty when the problem is full rank).
    pub unseen: Vec<String>,
    /// The weakest identified direction's motion, e.g. `≈ scale (0.98)`.
    pub weakest: String,
    /// The weakest identified direction's column-scaled singular value over the largest.
    pub weakest_ratio: f64,
}

/// The unseen and the weakest motions of `problem` at `x` from its Jacobian there, `None`
/// without forward rows (or when the reached points cannot be evaluated: the rank check
/// reports the Jacobian's own errors).
pub fn unseen_motions(
    problem: &IdentificationProblem<'_>,
    x: &DVector<f64>,
    jacobian: &DMatrix<f64>,
) -> Option<UnseenMotions> {
    let points = problem.reached_points(x).ok()?;
    if points.is_empty() || jacobian.ncols() == 0 {
        return None;
    }
    let (null, weakest, weakest_ratio) = scaled_directions(jacobian);
    let positions: Vec<[f64; 3]> = points.iter().map(|p| p.position).collect();
    let reference = unit_step_motion(&points, jacobian);
    let effects = columns(
        3 * points.len(),
        &null
            .column_iter()
            .map(|v| effect(&points, &v.into_owned()))
            .collect::<Vec<_>>(),
    );
    let unseen = if null.ncols() == 0 {
        Vec::new()
    } else {
        describe_span(&positions, &effects, reference)
    };
    // The weakest direction's motion beyond the unseen ones (which it may carry along: it is
    // orthogonal to them in the parameters, not in the motions).
    let span = orthonormal_span(&effects, ROUND_OFF * reference);
    let weakest = weakest.map_or_else(String::new, |v| {
        let mut moved = effect(&points, &v);
        for s in &span {
            moved -= s * s.dot(&moved);
        }
        describe_effect(&positions, &moved)
    });
    Some(UnseenMotions {
        unseen,
        weakest,
        weakest_ratio,
    })
}

/// The null directions (columns, in the unknowns' units) of `jacobian` column-scaled, its
/// weakest identified direction and that direction's singular value over the largest.
fn scaled_directions(jacobian: &DMatrix<f64>) -> (DMatrix<f64>, Option<DVector<f64>>, f64) {
    let n = jacobian.ncols();
    let norms: Vec<f64> = jacobian.column_iter().map(|c| c.norm()).collect();
    // The rank check's scaling and padding (observability.rs), so the same null space.
    let svd = with_a_row_per_column(unit_columns(jacobian)).svd(false, true);
    let v_t = svd.v_t.expect("asked for V");
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let largest = order.first().map_or(0.0, |&i| svd.singular_values[i]);
    let unscaled = |i: usize| {
        DVector::from_iterator(
            n,
            v_t.row(i)
                .iter()
                .zip(&norms)
                .map(|(v, &norm)| if norm > 0.0 { v / norm } else { *v }),
        )
    };
    let rank = order
        .iter()
        .filter(|&&i| svd.singular_values[i] > RANK_TOLERANCE * largest)
        .count();
    let null: Vec<DVector<f64>> = order[rank..].iter().map(|&i| unscaled(i)).collect();
    let weakest = rank.checked_sub(1).map(|k| order[k]);
    let ratio = weakest.map_or(0.0, |i| svd.singular_values[i] / largest);
    (columns(n, &null), weakest.map(unscaled), ratio)
}

/// The largest motion of the reached points that a column-scaled unit step of one unknown
/// produces (`e_j / ‖J_j‖`, the size of the steps the null directions are taken at): the yard
/// against which a null direction's motion is round-off.
fn unit_step_motion(points: &[ReachedPoint], jacobian: &DMatrix<f64>) -> f64 {
    let n = jacobian.ncols();
    jacobian
        .column_iter()
        .enumerate()
        .filter(|(_, c)| c.norm() > 0.0)
        .map(|(j, c)| {
            let mut step = DVector::zeros(n);
            step[j] = 1.0 / c.norm();
            effect(points, &step).norm()
        })
        .filter(|m| m.is_finite())
        .fold(0.0, f64::max)
}

/// The matrix of `vectors` (each of length `rows`) as columns; `rows` × 0 for none.
fn columns(rows: usize, vectors: &[DVector<f64>]) -> DMatrix<f64> {
    DMatrix::from_fn(rows, vectors.len(), |i, j| vectors[j][i])
}

/// The reached points' motion (3 per row) under the change `direction` of the unknowns.
fn effect(points: &[ReachedPoint], direction: &DVector<f64>) -> DVector<f64> {
    let mut moved = DVector::zeros(3 * points.len());
    for (r, point) in points.iter().enumerate() {
        moved
            .rows_mut(3 * r, 3)
            .gemv(1.0, &point.moves, direction, 0.0);
    }
    moved
}

/// The seven motions' effects on `points` (3 per point), each column of unit norm (zero when
/// the motion moves no point: a rotation of a single point about its centroid).
pub fn motion_basis(points: &[[f64; 3]]) -> DMatrix<f64> {
    let m = points.len().max(1) as f64;
    let centre: [f64; 3] = std::array::from_fn(|k| points.iter().map(|p| p[k]).sum::<f64>() / m);
    let mut basis = DMatrix::zeros(3 * points.len(), 7);
    for (r, p) in points.iter().enumerate() {
        let d: [f64; 3] = std::array::from_fn(|k| p[k] - centre[k]);
        for k in 0..3 {
            basis[(3 * r + k, k)] = 1.0;
            basis[(3 * r + k, 6)] = d[k];
        }
        // ω × d for ω the unit vector along x, y, z.
        let rotations = [[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]];
        for (axis, motion) in rotations.iter().enumerate() {
            for k in 0..3 {
                basis[(3 * r + k, 3 + axis)] = motion[k];
            }
        }
    }
    for mut column in basis.column_iter_mut() {
        let norm = column.norm();
        if norm > 0.0 {
            column /= norm;
        }
    }
    basis
}

/// One motion of the points, `effect` (3 per point), described: `≈ scale (0.98)` when one of
/// the seven motions is within [`CONTAINED`] of it, else the least-squares combination of
/// them (terms of at least 0.1) and the share no motion explains, a deformation.
pub fn describe_effect(points: &[[f64; 3]], effect: &DVector<f64>) -> String {
    let norm = effect.norm();
    if norm == 0.0 || !norm.is_finite() {
        return "moves no reached point".into();
    }
    let unit = effect / norm;
    let basis = motion_basis(points);
    let cosines: Vec<f64> = basis.column_iter().map(|b| b.dot(&unit)).collect();
    let (best, cosine) = cosines
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map(|(j, &c)| (j, c))
        .expect("seven motions");
    if cosine.abs() >= CONTAINED {
        return format!("≈ {} ({:.2})", MOTIONS[best], cosine.abs());
    }
    let coefficients = basis
        .clone()
        .svd(true, true)
        .solve(&unit, 1e-12)
        .unwrap_or_else(|_| DVector::zeros(7));
    let deformation = (&unit - &basis * &coefficients).norm();
    let mut terms: Vec<(usize, f64)> = coefficients
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, c)| c.abs() >= NEGLIGIBLE)
        .collect();
    terms.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    let mut text = combination(&terms);
    if deformation >= NEGLIGIBLE {
        if !text.is_empty() {
            text.push_str(" and ");
        }
        text.push_str(&format!("a deformation ({deformation:.2})"));
    }
    text
}

/// `0.71 translation along x − 0.70 rotation about z`.
fn combination(terms: &[(usize, f64)]) -> String {
    let mut text = String::new();
    for (k, &(j, c)) in terms.iter().enumerate() {
        let sign = match (k, c < 0.0) {
            (0, true) => "-",
            (0, false) => "",
            (_, true) => " - ",
            (_, false) => " + ",
        };
        text.push_str(&format!("{sign}{:.2} {}", c.abs(), MOTIONS[j]));
    }
    text
}

/// An orthonormal basis of the span of `effects`' columns (directions of singular values
/// above `round_off`; empty for no columns or only round-off ones).
fn orthonormal_span(effects: &DMatrix<f64>, round_off: f64) -> Vec<DVector<f64>> {
    if effects.ncols() == 0 {
        return Vec::new();
    }
    let svd = effects.clone().svd(true, false);
    let u = svd.u.expect("asked for U");
    svd.singular_values
        .iter()
        .enumerate()
        .filter(|(_, &s)| s > round_off && s.is_finite())
        .map(|(i, _)| u.column(i).into_owned())
        .collect()
}

/// The motions of the points a subspace of effects (its columns, each the motion of a
/// column-scaled unit step) holds: each of the seven motions lying in it, named, then the rest
/// of it described by [`describe_effect`], and the directions that move no point counted. A
/// motion of at most [`ROUND_OFF`] of `reference` (the motion a column-scaled unit step of one
/// unknown produces, [`unit_step_motion`]) is round-off: no motion.
pub fn describe_span(points: &[[f64; 3]], effects: &DMatrix<f64>, reference: f64) -> Vec<String> {
    let k = effects.ncols();
    let mut described = Vec::new();
    let span = orthonormal_span(effects, ROUND_OFF * reference);
    if span.is_empty() {
        described.push(format!("{k} {STILL}"));
        return described;
    }
    let basis = motion_basis(points);
    // Greedy: the motion closest to the span first, each taken out of the others.
    let coverage = |b: &DVector<f64>| span.iter().map(|s| s.dot(b).powi(2)).sum::<f64>().sqrt();
    let mut order: Vec<usize> = (0..7).collect();
    order.sort_by(|&a, &b| {
        coverage(&basis.column(b).into_owned()).total_cmp(&coverage(&basis.column(a).into_owned()))
    });
    let mut named: Vec<DVector<f64>> = Vec::new();
    let mut found = Vec::new();
    for j in order {
        if named.len() == span.len() {
            break;
        }
        let mut b = basis.column(j).into_owned();
        for n in &named {
            b -= n * n.dot(&b);
        }
        let norm = b.norm();
        if norm < NEGLIGIBLE {
            continue;
        }
        b /= norm;
        if coverage(&b) >= CONTAINED {
            found.push(j);
            named.push(b);
        }
    }
    found.sort_unstable();
    described.extend(found.iter().map(|&j| MOTIONS[j].to_string()));
    // The span's part the named motions leave, described direction by direction.
    let mut rest: Vec<DVector<f64>> = Vec::new();
    for s in &span {
        let mut v = s.clone();
        for n in named.iter().chain(&rest) {
            v -= n * n.dot(&v);
        }
        let norm = v.norm();
        if norm > 0.5 && named.len() + rest.len() < span.len() {
            rest.push(v / norm);
        }
    }
    described.extend(rest.iter().map(|v| describe_effect(points, v)));
    if span.len() < k {
        described.push(format!("{} {STILL}", k - span.len()));
    }
    described
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a tilted grid (not coplanar with a coordinate plane, spread in 3-D).
    fn points() -> Vec<[f64; 3]> {
        let mut points = Vec::new();
        for i in 0..4 {
            for j in 0..3 {
                let (x, y) = (0.1 * i as f64 - 0.15, 0.07 * j as f64 - 0.07);
                points.push([x, y, 0.3 + 0.2 * x - 0.1 * y + 0.05 * (x * y)]);
            }
        }
        points
    }

    /// The yard is the largest motion of a column-scaled unit step: with columns of norm 2 and
    /// 0.5 and one point moving (1, 0, 0) and (0, 3, 4) per unit of each unknown, steps 1/2 and
    /// 2 move it by 0.5 and 10. A column of zeros (an unknown no row sees) takes no step.
    #[test]
    fn the_yard_is_the_largest_motion_of_a_scaled_unit_step() {
        let point = |moves: DMatrix<f64>| ReachedPoint {
            position: [0.0, 0.0, 0.0],
            moves,
        };
        let moves = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 7.0, 0.0, 3.0, 7.0, 0.0, 4.0, 7.0]);
        let jacobian = DMatrix::from_row_slice(2, 3, &[2.0, 0.0, 0.0, 0.0, 0.5, 0.0]);
        let yard = unit_step_motion(&[point(moves)], &jacobian);
        assert!((yard - 10.0).abs() < 1e-12, "{yard}");
    }

    /// The motion `j` of `points`, at an arbitrary size, not normalised.
    fn motion(points: &[[f64; 3]], j: usize, size: f64) -> DVector<f64> {
        motion_basis(points).column(j) * size
    }

    #[test]
    fn a_single_motion_is_named_with_its_cosine() {
        let p = points();
        for (j, name) in MOTIONS.iter().enumerate() {
            assert_eq!(
                describe_effect(&p, &motion(&p, j, -3e-4)),
                format!("≈ {name} (1.00)")
            );
        }
        assert_eq!(
            describe_effect(&p, &DVector::zeros(3 * p.len())),
            "moves no reached point"
        );
    }

    #[test]
    fn a_combination_is_described_by_its_terms() {
        let p = points();
        let effect = motion(&p, 0, 0.6) - motion(&p, 5, 0.8);
        let text = describe_effect(&p, &effect);
        assert!(text.contains("translation along x"), "{text}");
        assert!(
            text.contains("- 0.80 rotation about z") || text.starts_with("-0.80 rotation about z"),
            "{text}"
        );
        assert!(!text.contains("deformation"), "{text}");
        // A shear of the points is no motion.
        let shear = DVector::from_iterator(3 * p.len(), p.iter().flat_map(|q| [q[1], 0.0, 0.0]));
        assert!(describe_effect(&p, &shear).contains("deformation"));
    }

    #[test]
    fn a_span_of_motions_mixed_by_its_basis_names_each_motion() {
        let p = points();
        // Four motions mixed arbitrarily, as an SVD's null basis would give them.
        let pure = [0, 1, 2, 5].map(|j| motion(&p, j, 1.0));
        let mix = [
            [0.5, -0.5, 0.5, 0.5],
            [0.5, 0.5, -0.5, 0.5],
            [0.3, 0.1, 0.2, -0.9],
            [0.7, 0.0, 0.7, 0.1],
        ];
        // At the size a unit change of the scaled parameters moves the points (micrometres).
        let columns: Vec<DVector<f64>> = mix
            .iter()
            .map(|w| w.iter().zip(&pure).map(|(c, m)| m * (1e-6 * c)).sum())
            .collect();
        let mut named = describe_span(&p, &DMatrix::from_columns(&columns), 1e-6);
        named.sort();
        assert_eq!(
            named,
            [
                "rotation about z",
                "translation along x",
                "translation along y",
                "translation along z"
            ]
        );
    }

    #[test]
    fn motions_that_are_not_orthogonal_are_each_named() {
        let p = points();
        // On the tilted grid the rotations about x and z move the points alike in part (the
        // grid's z follows its x): the second is named once the first is taken out of it.
        let basis = motion_basis(&p);
        let overlap = basis.column(3).dot(&basis.column(5)).abs();
        assert!(overlap > 0.05, "overlap {overlap}");
        let columns = [
            motion(&p, 3, 0.8) + motion(&p, 5, 0.6),
            motion(&p, 3, -0.6) + motion(&p, 5, 0.8),
        ];
        let named = describe_span(&p, &DMatrix::from_columns(&columns), 1.0);
        assert_eq!(named, ["rotation about x", "rotation about z"]);
    }

    #[test]
    fn a_span_with_a_deformation_and_a_still_direction_says_so() {
        let p = points();
        let shear = DVector::from_iterator(3 * p.len(), p.iter().flat_map(|q| [q[1], 0.0, 0.0]));
        let columns = [motion(&p, 2, 1.0), shear, DVector::zeros(3 * p.len())];
        let named = describe_span(&p, &DMatrix::from_columns(&columns), 1.0);
        assert_eq!(named.len(), 3, "{named:?}");
        assert_eq!(named[0], "translation along z");
        assert!(named[1].contains("deformation"), "{named:?}");
        assert_eq!(named[2], "1 direction(s) moving no reached point");
    }

    #[test]
    fn round_off_motions_move_no_reached_point_whatever_their_shape() {
        let p = points();
        // Null directions that move the points by round-off (1e-14 of a unit step's motion),
        // shaped like motions and like noise: none is named, each is counted.
        let noise = DVector::from_iterator(
            3 * p.len(),
            (0..3 * p.len()).map(|i| 1e-14 * ((i * 7919 % 13) as f64 - 6.0)),
        );
        let columns = [motion(&p, 0, 1e-14), motion(&p, 5, 3e-14), noise.clone()];
        let named = describe_span(&p, &DMatrix::from_columns(&columns), 1.0);
        assert_eq!(named, ["3 direction(s) moving no reached point"]);
        // Beside a real motion, the round-off ones are still counted, not named.
        let columns = [motion(&p, 2, 0.5), noise];
        let named = describe_span(&p, &DMatrix::from_columns(&columns), 1.0);
        assert_eq!(
            named,
            [
                "translation along z",
                "1 direction(s) moving no reached point"
            ]
        );
    }
}
