//! The nominal ACC law: what a comfortable ACC would command, before the certificate has its
//! say. It knows nothing of the certificate; the certificate never trusts it.

use table_format::Bounds;

use super::{Controller, ISO_15622_LIMITS};
use crate::inputs::Track;
use crate::math;

impl Controller<'_> {
    /// The nominal ACC law: constant time gap with a speed set-point, limited to ISO 15622 and
    /// then to the band.
    pub(super) fn nominal(&self, leader: Track, ego_speed: f32, ego: Bounds) -> f32 {
        let c = &self.config;
        let speed_law = c.speed_gain * (c.set_speed - ego_speed);
        let law = if math::is_finite(leader.gap) {
            let desired = c.standstill_gap + c.time_gap * ego_speed;
            let gap_law = c.gap_gain * (leader.gap - desired) + c.rel_speed_gain * leader.rel_speed;
            math::min(gap_law, speed_law)
        } else {
            speed_law
        };
        let law = math::clamp(law, ISO_15622_LIMITS.0, ISO_15622_LIMITS.1);
        math::clamp(law, ego.min, ego.max)
    }
}
