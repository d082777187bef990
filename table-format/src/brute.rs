//! Brute-force integration the property tests share: two cars in one lane, one step.

/// Advances a pair of cars by `dt` seconds, the car ahead at `ahead` m/s accelerating at
/// `a_ahead` and the car behind at `behind` m/s at `a_behind` (each held at or above zero
/// speed), `gap` metres between them: the trapezoid of each speed over the step.
pub(crate) fn advance(
    gap: &mut f64,
    ahead: &mut f64,
    behind: &mut f64,
    (a_ahead, a_behind): (f64, f64),
    dt: f64,
) {
    let next_ahead = (*ahead + a_ahead * dt).max(0.0);
    let next_behind = (*behind + a_behind * dt).max(0.0);
    *gap += 0.5 * (*ahead + next_ahead) * dt - 0.5 * (*behind + next_behind) * dt;
    *ahead = next_ahead;
    *behind = next_behind;
}
