//! Least-squares problems whose Jacobian is *bordered block-diagonal*: the unknowns are
//! `x = [own₀ | own₁ | … | own_{g−1} | shared]`, and every row belongs to one group `k` whose
//! Jacobian is non-zero only in `own_k`'s columns and in the shared columns.
//!
//! Such a problem arises when legs identified on their own (divide and conquer) also share a few
//! parameters, such as the pose of the measuring instrument: the normal matrix `JᵀJ` is then an
//! *arrowhead* (block diagonal plus a border of shared rows and columns), and a solver can
//! eliminate each group's block on its own (a Schur complement on the shared block) so that the
//! cost of a step grows linearly with the number of groups.
//!
//! This module only describes the structure; [`to_dense`] assembles the ordinary dense residual
//! vector and Jacobian (the reference any structured solver is checked against).

use std::fmt;

use argmin::core::{Jacobian, Operator};
use nalgebra::{DMatrix, DVector};

/// How the unknowns of a bordered problem are laid out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BorderedLayout {
    /// Number of own unknowns of each group, in the order of `x` (`own₀` first).
    pub own: Vec<usize>,
    /// Number of shared unknowns (they come last in `x`).
    pub shared: usize,
}

impl BorderedLayout {
    /// Total number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.own.iter().sum::<usize>() + self.shared
    }

    /// Offset in `x` of group `group`'s first own unknown.
    pub fn offset(&self, group: usize) -> usize {
        self.own[..group].iter().sum()
    }

    /// Offset in `x` of the first shared unknown.
    pub fn shared_offset(&self) -> usize {
        self.own.iter().sum()
    }
}

/// The rows of one group at one point: residuals and their derivatives.
#[derive(Debug, Clone, PartialEq)]
pub struct BorderedBlock {
    /// The group's residuals (`m_k` rows).
    pub residuals: DVector<f64>,
    /// `∂r/∂own_k`, `m_k × n_k`.
    pub own: DMatrix<f64>,
    /// `∂r/∂shared`, `m_k × s`.
    pub shared: DMatrix<f64>,
}

/// A least-squares problem with a bordered block-diagonal Jacobian.
///
/// The residual vector of the problem is the groups' residuals concatenated in group order;
/// its cost is `½‖r‖²`.
pub trait BorderedLeastSquares {
    /// The layout of the unknowns.
    fn layout(&self) -> BorderedLayout;

    /// Every group's residuals and Jacobian blocks at `x` (one block per group, in order).
    ///
    /// # Errors
    /// Whatever prevents the evaluation at `x` (for example a pose out of a leg's reach).
    fn bordered(&self, x: &DVector<f64>) -> Result<Vec<BorderedBlock>, argmin::core::Error>;
}

/// The dense residual vector and Jacobian of `blocks` laid out as `layout` says: rows in group
/// order, columns in the order of `x`.
///
/// # Panics
/// If the number of blocks or a block's dimensions do not match `layout` (a programming error
/// of the problem, not bad input).
pub fn to_dense(layout: &BorderedLayout, blocks: &[BorderedBlock]) -> (DVector<f64>, DMatrix<f64>) {
    assert_eq!(blocks.len(), layout.own.len(), "one block per group");
    let rows: usize = blocks.iter().map(|b| b.residuals.len()).sum();
    let mut r = DVector::zeros(rows);
    let mut jacobian = DMatrix::zeros(rows, layout.unknowns());
    let shared = layout.shared_offset();
    let mut row = 0;
    for (group, block) in blocks.iter().enumerate() {
        let m = block.residuals.len();
        let n = layout.own[group];
        assert_eq!(block.own.shape(), (m, n), "group {group}'s own block");
        assert_eq!(
            block.shared.shape(),
            (m, layout.shared),
            "group {group}'s shared block"
        );
        r.rows_mut(row, m).copy_from(&block.residuals);
        jacobian
            .view_mut((row, layout.offset(group)), (m, n))
            .copy_from(&block.own);
        jacobian
            .view_mut((row, shared), (m, layout.shared))
            .copy_from(&block.shared);
        row += m;
    }
    (r, jacobian)
}

/// Why blocks do not fit a layout (a programming error of the problem that produced them).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayoutMismatch(pub String);

impl fmt::Display for LayoutMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for LayoutMismatch {}

/// Checks that `blocks` has one block per group of `layout` with matching dimensions.
///
/// # Errors
/// A message naming the first group whose block count or dimensions are wrong, expected vs
/// found.
pub fn check_blocks(
    layout: &BorderedLayout,
    blocks: &[BorderedBlock],
) -> Result<(), LayoutMismatch> {
    if blocks.len() != layout.own.len() {
        return Err(LayoutMismatch(format!(
            "bordered problem: {} blocks, expected one per group ({})",
            blocks.len(),
            layout.own.len()
        )));
    }
    for (k, block) in blocks.iter().enumerate() {
        let m = block.residuals.len();
        let expected = [(m, layout.own[k]), (m, layout.shared)];
        let found = [block.own.shape(), block.shared.shape()];
        for ((what, e), f) in ["own", "shared"].iter().zip(expected).zip(found) {
            if e != f {
                return Err(LayoutMismatch(format!(
                    "bordered problem: group {k}'s {what} block is {}×{}, expected {}×{}",
                    f.0, f.1, e.0, e.1
                )));
            }
        }
    }
    Ok(())
}

/// A bordered problem a solver can run: residuals ([`Operator`], the groups' rows concatenated
/// in group order, equal to the blocks' residuals) and blocks ([`BorderedLeastSquares`]).
/// Implemented for every such type.
pub trait BorderedProblem:
    Operator<Param = DVector<f64>, Output = DVector<f64>> + BorderedLeastSquares + Clone
{
}

impl<P> BorderedProblem for P where
    P: Operator<Param = DVector<f64>, Output = DVector<f64>> + BorderedLeastSquares + Clone
{
}

/// A bordered problem seen as an ordinary dense least-squares problem: the residuals are the
/// problem's own, the Jacobian is [`to_dense`] of its blocks. For the rare, small dense work
/// (a Gauss–Newton refinement, a comparison with a dense solver).
#[derive(Debug)]
pub struct DenseView<'a, P>(pub &'a P);

impl<P> Clone for DenseView<'_, P> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<P> Copy for DenseView<'_, P> {}

impl<P> Operator for DenseView<'_, P>
where
    P: Operator<Param = DVector<f64>, Output = DVector<f64>>,
{
    type Param = DVector<f64>;
    type Output = DVector<f64>;

    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, argmin::core::Error> {
        self.0.apply(x)
    }
}

impl<P> Jacobian for DenseView<'_, P>
where
    P: BorderedLeastSquares,
{
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;

    /// # Errors
    /// The problem's error, or blocks that do not fit its layout.
    fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, argmin::core::Error> {
        let layout = self.0.layout();
        let blocks = self.0.bordered(x)?;
        check_blocks(&layout, &blocks)?;
        Ok(to_dense(&layout, &blocks).1)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::float_cmp)] // copies are exact

    use super::*;

    #[test]
    fn dense_assembly_places_each_block_in_its_rows_and_columns() {
        let layout = BorderedLayout {
            own: vec![1, 2],
            shared: 1,
        };
        assert_eq!(layout.unknowns(), 4);
        assert_eq!(layout.offset(1), 1);
        assert_eq!(layout.shared_offset(), 3);
        let blocks = vec![
            BorderedBlock {
                residuals: DVector::from_vec(vec![1.0]),
                own: DMatrix::from_row_slice(1, 1, &[2.0]),
                shared: DMatrix::from_row_slice(1, 1, &[3.0]),
            },
            BorderedBlock {
                residuals: DVector::from_vec(vec![4.0, 5.0]),
                own: DMatrix::from_row_slice(2, 2, &[6.0, 7.0, 8.0, 9.0]),
                shared: DMatrix::from_row_slice(2, 1, &[10.0, 11.0]),
            },
        ];
        let (r, j) = to_dense(&layout, &blocks);
        assert_eq!(r.as_slice(), &[1.0, 4.0, 5.0]);
        let expected = DMatrix::from_row_slice(
            3,
            4,
            &[
                2.0, 0.0, 0.0, 3.0, //
                0.0, 6.0, 7.0, 10.0, //
                0.0, 8.0, 9.0, 11.0,
            ],
        );
        assert_eq!(j, expected);
    }

    /// A block whose entries say where they come from: residual `100 g + i`, own derivative
    /// `100 g + 10 i + c`, shared derivative `−(100 g + 10 i + c)`.
    fn labelled_block(group: usize, rows: usize, own: usize, shared: usize) -> BorderedBlock {
        let g = 100.0 * group as f64;
        BorderedBlock {
            residuals: DVector::from_fn(rows, |i, _| g + i as f64),
            own: DMatrix::from_fn(rows, own, |i, c| g + (10 * i + c) as f64),
            shared: DMatrix::from_fn(rows, shared, |i, c| -(g + (10 * i + c) as f64)),
        }
    }

    fn three_groups() -> (BorderedLayout, Vec<BorderedBlock>) {
        let layout = BorderedLayout {
            own: vec![2, 3, 1],
            shared: 2,
        };
        let blocks = [(0, 3), (1, 4), (2, 2)]
            .iter()
            .map(|&(group, rows)| labelled_block(group, rows, layout.own[group], 2))
            .collect();
        (layout, blocks)
    }

    #[test]
    fn offsets_count_the_own_unknowns_of_every_earlier_group() {
        let (layout, blocks) = three_groups();
        assert_eq!(layout.unknowns(), 8);
        let offsets: Vec<usize> = (0..3).map(|g| layout.offset(g)).collect();
        assert_eq!(offsets, [0, 2, 5]);
        assert_eq!(layout.shared_offset(), 6);
        // Every entry of the dense Jacobian is the labelled one of its row's group, or zero.
        let (r, j) = to_dense(&layout, &blocks);
        assert_eq!(j.shape(), (9, 8));
        let mut row = 0;
        for (group, block) in blocks.iter().enumerate() {
            for i in 0..block.residuals.len() {
                assert_eq!(r[row], block.residuals[i]);
                for col in 0..8 {
                    let expected = if col >= 6 {
                        block.shared[(i, col - 6)]
                    } else if (offsets[group]..offsets[group] + layout.own[group]).contains(&col) {
                        block.own[(i, col - offsets[group])]
                    } else {
                        0.0
                    };
                    assert_eq!(j[(row, col)], expected, "row {row}, column {col}");
                }
                row += 1;
            }
        }
        assert_eq!(row, 9);
    }

    #[test]
    fn blocks_that_do_not_fit_the_layout_are_named_expected_vs_found() {
        let (layout, blocks) = three_groups();
        assert_eq!(check_blocks(&layout, &blocks), Ok(()));
        let message = |blocks: &[BorderedBlock]| check_blocks(&layout, blocks).unwrap_err().0;
        assert_eq!(
            message(&blocks[..2]),
            "bordered problem: 2 blocks, expected one per group (3)"
        );
        let mut wrong_own = blocks.clone();
        wrong_own[1] = labelled_block(1, 4, 2, 2);
        assert_eq!(
            message(&wrong_own),
            "bordered problem: group 1's own block is 4×2, expected 4×3"
        );
        let mut wrong_shared = blocks.clone();
        wrong_shared[2] = labelled_block(2, 2, 1, 3);
        assert_eq!(
            message(&wrong_shared),
            "bordered problem: group 2's shared block is 2×3, expected 2×2"
        );
        assert_eq!(
            LayoutMismatch("text".into()).to_string(),
            "text",
            "Display is the message"
        );
    }

    /// A bordered problem returning fixed blocks, whatever `x`.
    #[derive(Clone)]
    struct Fixed(BorderedLayout, Vec<BorderedBlock>);

    impl Operator for Fixed {
        type Param = DVector<f64>;
        type Output = DVector<f64>;

        fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, argmin::core::Error> {
            Ok(x * 2.0)
        }
    }

    impl BorderedLeastSquares for Fixed {
        fn layout(&self) -> BorderedLayout {
            self.0.clone()
        }

        fn bordered(&self, _: &DVector<f64>) -> Result<Vec<BorderedBlock>, argmin::core::Error> {
            Ok(self.1.clone())
        }
    }

    #[test]
    fn the_dense_view_is_the_problem_with_its_blocks_assembled() {
        let (layout, blocks) = three_groups();
        let x = DVector::from_fn(8, |i, _| i as f64);
        let problem = Fixed(layout.clone(), blocks.clone());
        let view = DenseView(&problem);
        let copy = view;
        assert_eq!(copy.apply(&x).unwrap(), &x * 2.0);
        assert_eq!(view.jacobian(&x).unwrap(), to_dense(&layout, &blocks).1);
        let misfit = Fixed(layout, blocks[..2].to_vec());
        let err = DenseView(&misfit).jacobian(&x).unwrap_err().to_string();
        assert_eq!(
            err,
            "bordered problem: 2 blocks, expected one per group (3)"
        );
    }
}
