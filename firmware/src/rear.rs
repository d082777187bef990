//! The rear half's lookup: the rear table's least value over a box of rear states.
//!
//! One responsibility: given a box `[lo, hi]` of states `(gap_follower, follower_speed,
//! ego_speed)` that holds the true rear state, return a value no larger than the table's
//! interpolated value anywhere in the box, within a bounded number of lookups.
//!
//! # Why a box
//! The rear state is combined from measurements of different times: the follower track (gap
//! and relative speed) from one instant, the ego's speed from another. The rear value is argued
//! at the follower track's time `t_f` (it holds for ever from any certified state, whatever the
//! ego does in the band), so the ego's speed is needed at `t_f`. From its own measurement at
//! `t_e` it is only known within the accelerations possible in between: an interval, and the
//! follower's speed (`ego_speed - rel_speed`) moves with it. Before, the two were subtracted as
//! if taken at one time: a follower at exactly 35 m/s read 35.017 m/s behind an accelerating ego
//! and left the domain (issue 19, C).
//!
//! # Why the candidates give the exact minimum
//! The table's value is multilinear on each cell. The grid's breakpoints cut the box into
//! sub-boxes that each lie in one cell, where the value is linear in each coordinate separately,
//! so its least value on a sub-box is at one of the sub-box's corners. Every such corner has, on
//! each axis, either an end of the box or a breakpoint strictly inside it. So the minimum over
//! those candidate points (at most `(MAX_INTERIOR + 2)^3`, one when the box is a point) is the
//! minimum over the box, up to `f32` rounding of the interpolation (about `1e-6` m, inside
//! `solver verify`'s tolerance). A box wider than [`MAX_INTERIOR`] breakpoints on an axis is
//! not evaluated: the controller reports `Fault::RearBoxTooWide` and treats the rear half as
//! unknown.

use table_format::Table;

/// Breakpoints strictly inside the box that are taken per axis, at most. With the default
/// configuration the ego's speed interval is at most `5.5 m/s^2 x 0.1 s = 0.55 m/s` wide, which
/// holds at most three of the deployed table's breakpoints (0.25 m/s apart at the finest).
pub const MAX_INTERIOR: usize = 4;

/// Why no least value was computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum BoxError {
    /// The box holds more than [`MAX_INTERIOR`] breakpoints on this axis.
    TooWide(u8),
    /// A corner of the box is outside the grid on this axis (or a coordinate is not finite).
    Outside(u8),
}

/// The candidates of one axis: `lo`, the breakpoints strictly inside `(lo, hi)`, and `hi`.
/// Returns how many were written.
fn candidates(
    table: &Table<'_>,
    axis: usize,
    lo: f32,
    hi: f32,
    out: &mut [f32; MAX_INTERIOR + 2],
) -> Result<usize, BoxError> {
    let tag = u8::try_from(axis).unwrap_or(u8::MAX);
    let Some(first) = out.first_mut() else {
        return Err(BoxError::TooWide(tag));
    };
    *first = lo;
    // A point (or NaN, which the lookup then refuses) has one candidate.
    if hi.partial_cmp(&lo) != Some(core::cmp::Ordering::Greater) {
        return Ok(1);
    }
    let points = table
        .header()
        .axes
        .get(axis)
        .map_or(0, |a| a.points as usize);
    // The first breakpoint above `lo`, by bisection over the indices (invariant: every
    // breakpoint below `low` is at most `lo`, and the answer is at most `high`).
    let (mut low, mut high) = (0usize, points);
    while low < high {
        let mid = low + (high - low) / 2;
        match table.breakpoint(axis, mid) {
            Some(b) if b <= lo => low = mid + 1,
            Some(_) => high = mid,
            None => return Err(BoxError::Outside(tag)),
        }
    }
    let mut n = 1usize;
    let mut index = low;
    while let Some(b) = table.breakpoint(axis, index) {
        if b >= hi {
            break;
        }
        if n > MAX_INTERIOR {
            return Err(BoxError::TooWide(tag));
        }
        if let Some(slot) = out.get_mut(n) {
            *slot = b;
        }
        n += 1;
        index += 1;
    }
    match out.get_mut(n) {
        Some(slot) => *slot = hi,
        None => return Err(BoxError::TooWide(tag)),
    }
    Ok(n + 1)
}

/// The least interpolated value over the box `[lo, hi]` (module docs). Every corner must lie in
/// the grid. Out of line: the common case, measurements of one time, never enters it, and the
/// control step stays as lean as before.
#[inline(never)]
pub(crate) fn least_over_box(
    table: &Table<'_>,
    lo: [f32; 3],
    hi: [f32; 3],
) -> Result<f32, BoxError> {
    let mut c = [[0f32; MAX_INTERIOR + 2]; 3];
    let mut n = [0usize; 3];
    for (axis, ((out, count), (l, h))) in c
        .iter_mut()
        .zip(n.iter_mut())
        .zip(lo.iter().zip(hi.iter()))
        .enumerate()
    {
        *count = candidates(table, axis, *l, *h, out)?;
    }
    let [c0, c1, c2] = &c;
    let [n0, n1, n2] = n;
    let mut least = f32::INFINITY;
    for &g in c0.iter().take(n0) {
        for &vf in c1.iter().take(n1) {
            for &ve in c2.iter().take(n2) {
                let w = table.value_at(&[g, vf, ve]).map_err(|e| match e {
                    table_format::Error::OutOfDomain { axis }
                    | table_format::Error::NonFiniteState { axis } => {
                        BoxError::Outside(u8::try_from(axis).unwrap_or(u8::MAX))
                    }
                    _ => BoxError::Outside(0),
                })?;
                if w < least {
                    least = w;
                }
            }
        }
    }
    Ok(least)
}
