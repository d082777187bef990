//! The certificate: the front half in closed form at the worst corner of the measurement's
//! error box, the look-ahead that decides the command, the rear half from the table over the
//! box, and the ego's speed headroom (the argument is in the controller's module docs).

use table_format::front::{front_value, FrontModel};
use table_format::{Bounds, Game, Table};

use super::history::seconds;
use super::tracks::LeaderMemo;
use super::{Config, Controller, Fault};
use crate::math;

/// e^-5: what a first-order lag still passes on, after five time constants, of a command older
/// than that.
pub(super) const LAG_TAIL: f32 = 0.006_737_947;

/// The certificate at a state: its two halves, each as a margin over its level (m), and the
/// ego's speed headroom (m/s). The state is certified when both halves are positive and the
/// headroom is not negative ([`Certificate::is_certified`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Certificate {
    /// The front value less `front_margin`, m.
    pub front: f32,
    /// The rear value less the table's error bound and `rear_margin`, m.
    pub rear: f32,
    /// The ego's speed headroom, m/s: the domain's largest ego speed less the highest speed
    /// the ego can reach before braking at beta takes full effect. The ego's speed is the
    /// firmware's to keep in the domain, not an assumption: a negative headroom means the
    /// commands already issued can take it out.
    pub speed: f32,
}

impl Certificate {
    /// The smaller of the two halves' margins (m); when the speed headroom is negative, the
    /// headroom (m/s) if it is smaller still. Positive exactly when the state is certified (the
    /// units differ only on the uncertified side).
    pub fn margin(&self) -> f32 {
        let halves = math::min(self.front, self.rear);
        if self.speed < 0.0 {
            math::min(halves, self.speed)
        } else {
            halves
        }
    }

    /// Both halves positive and the speed headroom not negative.
    pub fn is_certified(&self) -> bool {
        self.front > 0.0 && self.rear > 0.0 && self.speed >= 0.0
    }
}

/// f32 rounding can lower a computed margin along a trajectory on which the exact one never
/// decreases (the front value's closed form and the plant are evaluated in f32; the property
/// test `never_decreases_along_the_ego_braking` in `table_format::front` allows
/// `1e-3 (1 + |F|)`, 1.5 mm at `F = 0.5 m`). A certified state (margin above zero) is claimed
/// to keep its margin above `-CERTIFICATE_TOLERANCE`, 1 cm.
pub const CERTIFICATE_TOLERANCE: f32 = 0.01;

/// How far below its level the rear value may read at a control period between the periods
/// `solver verify` proves it over, m ([`table_format::REAR_SAMPLE_TOLERANCE`]). `verify` (from
/// its version [`table_format::REAR_SAMPLE_VERIFIER`]) proves, for every certified cell, that
/// at every multiple of its shortest period inside the period that closes the cell's proof the
/// table's value stays above `level - REAR_SAMPLE_TOLERANCE` (measured on the deployed table:
/// at most 8.3 cm by its interval bounds); the firmware refuses a table with an older record.
/// So the rear half's claim at every 20 ms sample is `rear > -REAR_SAMPLE_TOLERANCE`, at the
/// proof's own periods `rear > 0`, and the gap to the follower stays above zero throughout.
pub const REAR_SAMPLE_TOLERANCE: f32 = table_format::REAR_SAMPLE_TOLERANCE;

/// How far below zero the ego's speed headroom may read, m/s: `f32` rounding of a speed near
/// 35 m/s (its spacing there is 3.8e-6 m/s) over a few operations.
pub const SPEED_TOLERANCE: f32 = 1e-3;

/// What the controller takes from the table's header once.
#[derive(Debug, Clone, Copy)]
pub(super) struct Model {
    /// The band `[-beta, a_max]`.
    pub(super) ego: Bounds,
    /// The leader's hardest braking, positive.
    pub(super) leader_braking: f32,
    pub(super) max_speed: f32,
    /// The fastest ego the controller certifies: the table's and the envelope's limit.
    pub(super) max_ego_speed: f32,
    /// The rear grid's lowest and highest gap, m.
    pub(super) gap_min: f32,
    pub(super) gap_max: f32,
    /// The smallest value on the rear grid's last gap face: the rear value beyond the grid.
    pub(super) beyond_grid: f32,
    pub(super) error_bound: f32,
}

impl Model {
    pub(super) fn front(&self, response_time: f32, response_acceleration: f32) -> FrontModel {
        FrontModel {
            leader_braking: self.leader_braking,
            ego_braking: -self.ego.min,
            response_time,
            response_acceleration,
            max_speed: self.max_speed,
        }
    }
}
pub(super) fn model_of(table: &Table<'_>, config: &Config) -> Result<Model, Fault> {
    let envelope = &config.envelope;
    let header = table.header();
    let Game::ThreeCarSplit {
        ego,
        leader,
        max_speed,
        ..
    } = header.game
    else {
        return Err(Fault::WrongGame);
    };
    let (Some(gaps), Some(follower_speeds), Some(ego_speeds)) = (
        table.axis_bounds(0),
        table.axis_bounds(1),
        table.axis_bounds(2),
    ) else {
        return Err(Fault::WrongGame);
    };
    if ego.min < envelope.min_acceleration || ego.max > envelope.max_acceleration {
        return Err(Fault::TableOutsideEnvelope);
    }
    match header.verification {
        Some(v)
            if v.is_complete()
                && v.rear_margin == config.rear_margin
                && v.verifier >= table_format::REAR_SAMPLE_VERIFIER => {}
        _ => return Err(Fault::TableNotVerified),
    }
    // The rear table must cover every speed the game allows: the domain check below relies on
    // it.
    let covers = |b: Bounds| b.min <= 0.0 && b.max >= max_speed;
    if table.dims() != 3 || !covers(follower_speeds) || !covers(ego_speeds) {
        return Err(Fault::WrongGame);
    }
    // The last gap face is the last `points(1) * points(2)` nodes (C order).
    let nodes = table.node_count();
    let face = header
        .axes
        .get(1)
        .zip(header.axes.get(2))
        .map_or(0, |(a, b)| a.points as usize * b.points as usize);
    let beyond_grid = (nodes.saturating_sub(face)..nodes)
        .filter_map(|n| table.value_at_node(n))
        .fold(f32::INFINITY, math::min);
    Ok(Model {
        ego,
        leader_braking: -leader.min,
        max_speed,
        max_ego_speed: math::min(max_speed, envelope.max_speed),
        gap_min: gaps.min,
        gap_max: gaps.max,
        beyond_grid,
        error_bound: header.error_bound.total(),
    })
}

impl Controller<'_> {
    /// The certificate at the true state `(gap_leader, leader_speed, gap_follower,
    /// follower_speed, ego_speed)`, with the same domain rules as the control step: `None`
    /// outside the domain or without a table. For tests and campaigns, which judge the
    /// certificate on the state the firmware cannot see exactly.
    pub fn certificate(&self, state: [f32; 5]) -> Option<Certificate> {
        self.certificate_with_response(state, 0.0, 0.0)
    }

    /// [`Controller::certificate`] for an ego whose acceleration is at most
    /// `response_acceleration` for `response_time` seconds before braking at beta takes effect
    /// (its actuator's dead time and lag, with the commands still in its pipeline).
    pub fn certificate_with_response(
        &self,
        state: [f32; 5],
        response_time: f32,
        response_acceleration: f32,
    ) -> Option<Certificate> {
        let (table, model) = self.table.as_ref().ok()?;
        let [gap_leader, leader_speed, gap_follower, follower_speed, ego_speed] = state;
        let rear = rear_value(
            table,
            model,
            (gap_follower, gap_follower),
            (follower_speed, follower_speed),
            (ego_speed, ego_speed),
        )
        .ok()?;
        let front = front_value(
            gap_leader,
            leader_speed,
            ego_speed,
            &model.front(response_time, response_acceleration),
        );
        let peak =
            ego_speed + math::max(response_acceleration, 0.0) * math::max(response_time, 0.0);
        Some(self.certificate_of(front, rear, model.max_ego_speed - peak, model))
    }

    pub(super) fn certificate_of(
        &self,
        front: f32,
        rear: f32,
        speed: f32,
        model: &Model,
    ) -> Certificate {
        Certificate {
            front: front - self.config.front_margin,
            rear: rear - model.error_bound - self.config.rear_margin,
            speed,
        }
    }

    /// An upper bound of the ego's acceleration since `t_0` until braking at beta takes full
    /// effect: the largest command issued since `t_0`, less the dead time and five lag time
    /// constants, plus what older commands can still add through the lag (at most e^-5 of the
    /// band's width); the band's top before the first command.
    pub(super) fn pending(&self, t_0: u64, model: &Model) -> f32 {
        self.issued
            .largest_since(t_0, self.command_span_us(), model.ego.max)
            + self.lag_tail(model)
    }

    /// What commands older than five lag time constants can still add through the lag, at
    /// most: e^-5 of the band's width (none without a lag).
    pub(super) fn lag_tail(&self, model: &Model) -> f32 {
        if self.config.actuator_lag_us > 0 {
            LAG_TAIL * (model.ego.max - model.ego.min)
        } else {
            0.0
        }
    }

    /// The front half applied to a `proposal` (module docs: the delays, the measurement error,
    /// the ego's speed): the certified front value and speed headroom of the state, and the
    /// command, which is the proposal under the speed cap if its look-ahead passes, else the
    /// gentlest braking that passes, at most beta.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn enforce_front(
        &self,
        model: &Model,
        leader: &LeaderMemo,
        ego_speed: f32,
        t_e: u64,
        now: u64,
        pending: f32,
        proposal: f32,
    ) -> FrontCheck {
        let c = &self.config;
        let h = seconds(u64::from(c.period_us));
        let dead = seconds(u64::from(c.actuator_dead_time_us));
        let lag = seconds(u64::from(c.actuator_lag_us));
        let t_m = leader.at_us;
        // The worst point of the error box (module docs): the least gap, the slowest leader
        // (the ego's lowest speed at `t_m` plus the least range rate), the fastest ego; the
        // front value is non-decreasing in the first two and non-increasing in the third.
        let sensors = &c.sensors;
        let gap = sensors.range(leader.track.gap).0;
        let (ego_low, ego_high) = leader.ego;
        let leader_at_m = math::max(ego_low + sensors.range_rate(leader.track.rel_speed).0, 0.0);
        let age = seconds(now.saturating_sub(t_m));
        // The certified front value: braking at beta, commanded since the current run of such
        // commands began, or from now.
        let braking_from = self.braking_since_us.unwrap_or(now).min(now);
        let braking_age = seconds(braking_from.saturating_sub(t_m));
        let value = front_value(
            gap,
            leader_at_m,
            ego_high,
            &model.front(braking_age + dead + lag, pending),
        );
        // The speed headroom (module docs): until the braking takes full effect the ego's
        // speed grows at most at `pending` from its measurement's highest.
        let ego_now = sensors.ego_speed(ego_speed).1;
        let since_e = |t: u64| seconds(t.saturating_sub(t_e));
        let headroom = model.max_ego_speed
            - (ego_now + math::max(pending, 0.0) * (since_e(braking_from) + dead + lag));
        // The look-ahead (module docs): `u` held for one period before the braking at beta.
        // Its response acceleration is `max(pending, u + tail)`: the lag averages every command
        // ever issued, and the window's older ones (up to the band's top) still pass `tail` on
        // top of `u` (found in review for issue 20: with `max(pending, u)` the next step's
        // `pending`, `u + tail`, could exceed what the look-ahead had assumed).
        let tail = self.lag_tail(model);
        let response = |u: f32| math::max(pending, u + tail);
        // First the speed: the largest command whose response keeps the ego in the domain.
        let response_end = since_e(now) + h + dead + lag;
        let room = model.max_ego_speed - (ego_now + math::max(pending, 0.0) * response_end);
        let speed_cap = if room < 0.0 {
            // Nothing passes: brake at beta (which keeps a certified headroom, module docs).
            model.ego.min
        } else if response_end > 0.0 {
            math::max(
                (model.max_ego_speed - ego_now) / response_end - tail,
                model.ego.min,
            )
        } else {
            model.ego.max
        };
        let capped = math::min(proposal, speed_cap);
        let margin_front = c.front_margin;
        let ahead = |u: f32| {
            front_value(
                gap,
                leader_at_m,
                ego_high,
                &model.front(age + h + dead + lag, response(u)),
            )
        };
        let at_capped = ahead(capped);
        let passes = room >= 0.0 && at_capped > margin_front;
        let command = if room < 0.0 {
            model.ego.min
        } else if passes {
            capped
        } else {
            least_braking(capped, at_capped, model.ego.min, value, margin_front, |u| {
                ahead(u) > margin_front
            })
        };
        let command = math::clamp(command, model.ego.min, model.ego.max);
        FrontCheck {
            command,
            overridden: !passes || capped < proposal,
            value,
            headroom,
        }
    }
}

/// What the front half made of a proposed command ([`Controller::enforce_front`]).
pub(super) struct FrontCheck {
    /// The command, at most the proposal.
    pub(super) command: f32,
    /// The speed cap lowered the proposal, or its look-ahead failed.
    pub(super) overridden: bool,
    /// The state's certified front value, m.
    pub(super) value: f32,
    /// The state's speed headroom, m/s.
    pub(super) headroom: f32,
}

/// The rear value over a box of rear states: the intervals of `gap_follower`, the follower's
/// speed and the ego's speed (`(lowest, highest)`). The table's least value over the box
/// inside the grid ([`Table::least_over_box`]: exact for the multilinear interpolation, one
/// lookup for a point), the last gap face's smallest value beyond it (module docs), and
/// [`Fault::OutsideDomain`] below the grid or above the speed range; [`Fault::RearBoxTooWide`]
/// for a box the step does not evaluate.
pub(super) fn rear_value(
    table: &Table<'_>,
    model: &Model,
    (gap_low, gap_high): (f32, f32),
    follower_speed: (f32, f32),
    ego_speed: (f32, f32),
) -> Result<f32, Fault> {
    if gap_low.is_nan() || gap_high.is_nan() || gap_low < model.gap_min {
        return Err(Fault::OutsideDomain { axis: 0 });
    }
    let within = |(low, high): (f32, f32), max: f32| low >= 0.0 && high <= max && low <= high;
    if !within(follower_speed, model.max_speed) {
        return Err(Fault::OutsideDomain { axis: 1 });
    }
    if !within(ego_speed, model.max_ego_speed) {
        return Err(Fault::OutsideDomain { axis: 2 });
    }
    if gap_low > model.gap_max {
        return Ok(model.beyond_grid);
    }
    // Beyond the grid's last gap the value is at least the last face's smallest.
    let beyond = if gap_high > model.gap_max {
        model.beyond_grid
    } else {
        f32::INFINITY
    };
    let gap_high = math::min(gap_high, model.gap_max);
    let lo = [gap_low, follower_speed.0, ego_speed.0];
    let hi = [gap_high, follower_speed.1, ego_speed.1];
    // Measurements of one time and exact sensors leave a point: one lookup.
    let inside = if lo == hi {
        table.value_at(&lo)
    } else {
        table.least_over_box(&lo, &hi)
    };
    inside.map(|w| math::min(w, beyond)).map_err(|e| match e {
        table_format::Error::BoxTooWide { axis } => Fault::RearBoxTooWide {
            axis: u8::try_from(axis).unwrap_or(u8::MAX),
        },
        table_format::Error::OutOfDomain { axis }
        | table_format::Error::NonFiniteState { axis } => Fault::OutsideDomain {
            axis: u8::try_from(axis).unwrap_or(u8::MAX),
        },
        _ => Fault::OutsideDomain { axis: 0 },
    })
}

/// The override's command: a gentler braking than `beta_command` where one passes the
/// look-ahead, else `beta_command` itself.
///
/// The look-ahead's front value `F(u)` (the command `u` held for a period, then braking at
/// beta) is non-increasing in `u`: a harder-accelerating ego is ahead of a gentler one at every
/// instant. It is known at the refused command (`F(refused) <= margin`) and at `beta_command`
/// (`F(beta) = front`, braking from now). Over one period it is nearly affine in `u` (the
/// extra speed `(u + beta) h` is what matters), so the secant's root, pulled 10% towards
/// `beta`, is a candidate; it is used only if the look-ahead passes it, else the midpoint
/// between it and `beta`, else `beta`. Two evaluations at most (the control step's budget:
/// each costs about 560 instructions on the Cortex-M4F). Whatever is returned either passed the
/// look-ahead or is the braking at beta, which keeps a certified front value (module docs).
/// Braking no harder than needed spares the follower and the jerk.
pub(super) fn least_braking(
    refused: f32,
    at_refused: f32,
    beta_command: f32,
    front: f32,
    margin: f32,
    passes: impl Fn(f32) -> bool,
) -> f32 {
    let drop = front - at_refused;
    if !(front > margin && drop > 0.0) {
        return beta_command;
    }
    let share = 0.9 * (front - margin) / drop;
    let candidate = beta_command + math::clamp(share, 0.0, 1.0) * (refused - beta_command);
    if passes(candidate) {
        return candidate;
    }
    let halfway = 0.5 * (beta_command + candidate);
    if passes(halfway) {
        halfway
    } else {
        beta_command
    }
}
