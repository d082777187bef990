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
