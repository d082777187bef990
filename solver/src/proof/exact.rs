//! The exact value of the two-car game, the analytic check of the engine.
//!
//! State `(x, v)`: gap and `v_leader - v_ego`; `x' = v`, `v' = u1 - u2`. Whatever the ego does,
//! the leader's best (for it) play is to brake as hard as it can, and the ego's best reply is to
//! brake as hard as it can too: the relative speed then changes at `a = leader_min - ego_min`
//! (for the paper's bounds `-1.5 + 2 = 0.5 m/s^2`). With `a > 0` the gap shrinks while `v < 0`
//! and reaches its minimum when `v` reaches 0, at `t* = -v / a`, unless the horizon `T` comes
//! first. So, with `t* = min(T, max(0, -v / a))` (and `t* = T` for `v < 0` when `a <= 0`):
//!
//! `V_T(x, v) = x + v t* + a t*^2 / 2 - min_gap`.
//!
//! For `v >= 0` this is `x - min_gap`: the gap never shrinks.

/// The exact finite-horizon value at `(x, v)`.
pub fn two_car_value(
    x: f64,
    v: f64,
    horizon: f64,
    ego_min: f64,
    leader_min: f64,
    min_gap: f64,
) -> f64 {
    let a = leader_min - ego_min;
    let t = if v >= 0.0 {
        0.0
    } else if a > 0.0 {
        (-v / a).min(horizon)
    } else {
        horizon
    };
    x + v * t + 0.5 * a * t * t - min_gap
}

/// The gap `x` on the exact safe-set boundary `V_T(x, v) = 0` at relative speed `v`.
pub fn two_car_boundary(v: f64, horizon: f64, ego_min: f64, leader_min: f64, min_gap: f64) -> f64 {
    min_gap - two_car_value(0.0, v, horizon, ego_min, leader_min, 0.0)
}

/// Accuracy of a computed two-car value against the exact one.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ExactComparison {
    /// Largest `|V - V_exact|` over nodes in the box where the exact value is at least 1 m above
    /// the solver's clip level, m.
    #[serde(rename = "max_value_error_m")]
    pub max_value_error: f64,
    /// Mean `|V - V_exact|` over the same nodes, m.
    #[serde(rename = "mean_value_error_m")]
    pub mean_value_error: f64,
    /// Largest distance in gap between the computed and exact safe-set boundaries (the first
    /// sign change along the gap axis, linearly interpolated), over speed nodes in the box, m.
    #[serde(rename = "max_boundary_error_m")]
    pub max_boundary_error: f64,
}

/// Compares `values` on a two-car `grid` with the exact value over the index box `bx`. The
/// solver holds values at the grid's lowest constraint value `x_min - min_gap` (the game for
/// `max(l, floor)`, same safe set), so the reference is clipped there too.
pub fn two_car_errors(
    grid: &crate::engine::grid::Grid,
    values: &[f32],
    horizon: f64,
    ego_min: f64,
    leader_min: f64,
    min_gap: f64,
    bx: &crate::proof::trusted::IndexBox,
) -> ExactComparison {
    let (xs, vs) = (&grid.axes()[0], &grid.axes()[1]);
    let floor = xs.min - min_gap;
    let exact =
        |x: f64, v: f64| two_car_value(x, v, horizon, ego_min, leader_min, min_gap).max(floor);
    let (mut max_err, mut sum_err, mut count) = (0f64, 0f64, 0usize);
    let mut max_boundary = 0f64;
    for j in bx.lo[1]..=bx.hi[1] {
        let v = vs.coordinate(j);
        let mut crossing = None;
        for i in bx.lo[0]..=bx.hi[0] {
            let x = xs.coordinate(i);
            let val = f64::from(values[i * vs.points + j]);
            let reference = exact(x, v);
            // Value errors away from the clip (its kink is not part of the game).
            if reference > floor + 1.0 {
                let e = (val - reference).abs();
                max_err = max_err.max(e);
                sum_err += e;
                count += 1;
            }
            if i > bx.lo[0] && crossing.is_none() {
                let prev = f64::from(values[(i - 1) * vs.points + j]);
                if prev <= 0.0 && val > 0.0 {
                    let xp = xs.coordinate(i - 1);
                    crossing = Some(xp + (x - xp) * (-prev) / (val - prev));
                }
            }
        }
        if let Some(xc) = crossing {
            let xb = two_car_boundary(v, horizon, ego_min, leader_min, min_gap);
            max_boundary = max_boundary.max((xc - xb).abs());
        }
    }
    ExactComparison {
        max_value_error: max_err,
        mean_value_error: sum_err / count.max(1) as f64,
        max_boundary_error: max_boundary,
    }
}
