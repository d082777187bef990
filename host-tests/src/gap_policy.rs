//! `host-tests gap-policy`: the certificate's steady-following gap and the gap policy at each
//! setting, the braking a follower that reacts like a person allows, and what two braking
//! authorities would cost in distance, printed, drawn and written to `gap-policy.json`.

use anyhow::{Context, Result};
use table_format::rear::{allowed_braking, rear_gap_built_up, EgoBuildUp, ReactingFollower};

use crate::floor::reacting_follower_acceleration;
use crate::humans::HumanModel;
use crate::sim::{lowest_gap, Actuator, ActuatorModel, Car};

/// The error box around the worst measurement of a follower `time_gap` seconds behind (plus
/// the IDM's jam distance) an ego at `v`, both at `v`: the gap read short (the range's error
/// taken against it), then every state within the declared error of that reading.
pub(crate) struct RearBox {
    /// The gap's interval, m.
    pub(crate) gap: (f32, f32),
    /// The ego's speed's interval, m/s.
    pub(crate) ego: (f32, f32),
    /// The follower's speed's interval, m/s (the range rate's error on each of two readings).
    pub(crate) follower: (f32, f32),
}

impl RearBox {
    fn around(config: &firmware::Config, model: &HumanModel, time_gap: f32, v: f32) -> Self {
        let table_format::FollowerModel::Idm { idm, .. } = model.follower;
        RearBox::around_gap(config, idm.jam_distance + time_gap * v, v)
    }

    /// The box around the worst measurement of a follower `gap` behind an ego at `v`, both
    /// at `v`.
    pub(crate) fn around_gap(config: &firmware::Config, gap: f32, v: f32) -> Self {
        let error = config.sensors.error;
        let measured = gap - (error.range + error.range_relative * gap);
        let ego_measured = v - (error.ego_speed + error.ego_speed_relative * v);
        let ego_low = error.ego_speed(ego_measured).0;
        let ego_high = error
            .ego_speed(v + error.ego_speed + error.ego_speed_relative * v)
            .1;
        RearBox {
            gap: error.range(measured),
            ego: (ego_low, ego_high),
            follower: (
                (ego_low - 2.0 * error.range_rate).max(0.0),
                ego_high + 2.0 * error.range_rate,
            ),
        }
    }
}

/// The hardest braking, up to the declared emergency authority's
/// ([`firmware::EmergencyDeclaration::braking`]), that a `follower` `time_gap` seconds behind
/// (plus the IDM's jam distance, at the ego's speed `v`) allows an ego whose firmware argues
/// with `config`: judged at the worst corner of the error box around the worst measurement of
/// the true state (the gap read short and then taken shorter, the follower fastest, the ego
/// slowest). The ego's braking shows at the latest `delay` seconds after the measurement, and
/// the follower reacts `reaction_time` after that, so its reaction is taken `delay` longer,
/// with the ego braking up to the level from the measurement on (an ego that brakes later
/// covers more). The follower is taken as given: the firmware's own
/// ([`firmware::Certifier::reacting_follower`]) keeps up to its IDM's largest acceleration
/// until it reacts. `None` where not even holding the ego's speed keeps the rear margin.
pub fn braking_a_follower_allows(
    config: &firmware::Config,
    model: &HumanModel,
    follower: &ReactingFollower,
    delay: f32,
    time_gap: f32,
    v: f32,
) -> Option<f32> {
    allowed_at_the_worst_corner(config, model, follower, delay, None, time_gap, v)
}

/// The braking the firmware's two-authority argument allows a `follower` `time_gap` seconds
/// behind (plus the IDM's jam distance, at the ego's speed `v`) in steady following:
/// [`braking_a_follower_allows`] with the commands the ego issued since the measurement
/// credited, as its rear check credits them (`firmware::controller`'s `RearCorner::gap_after`:
/// the least command since the measurement for the track's age at the check, then the level at
/// once, an instant actuator being the worst). From steady following the commands are zero.
/// The worse of a track as fresh as the radar delivers one (`latency`) and one as old
/// (`latency + cycle`), the braking taken to show a period and `lights` seconds after the check.
pub fn braking_the_firmware_allows(
    config: &firmware::Config,
    model: &HumanModel,
    follower: &ReactingFollower,
    lights: f32,
    time_gap: f32,
    v: f32,
) -> Option<f32> {
    let sensors = config.sensors;
    let period = config.period_us as f32 * 1e-6;
    [sensors.latency_us, sensors.latency_us + sensors.cycle_us]
        .into_iter()
        .map(|age_us| {
            let age = age_us as f32 * 1e-6;
            let issued = EgoBuildUp {
                acceleration: 0.0,
                commands: 0.0,
                known_for: age,
                lag: 0.0,
            };
            let delay = age + period + lights;
            allowed_at_the_worst_corner(config, model, follower, delay, Some(issued), time_gap, v)
        })
        .try_fold(f32::INFINITY, |least, level| level.map(|l| least.min(l)))
}

/// [`braking_a_follower_allows`] with the ego's braking credited with its actuator's build-up
/// in closed form ([`table_format::rear::rear_gap_built_up`]): from steady following (its
/// acceleration and the commands already issued at zero), the commands in force for
/// `known_for` seconds from the measurement are those already issued (the track's age at the
/// check plus the declared dead time), then the level, through the declared lag. The same
/// error box, follower and `delay`. A lever, not the firmware's argument: it needs an actuator
/// no faster than the declared dead time and lag, where the firmware declares one no slower
/// (a brute-force integration of the same actuator, [`braking_a_follower_allows_through`],
/// agrees with it).
pub fn braking_a_follower_allows_built_up(
    config: &firmware::Config,
    model: &HumanModel,
    follower: &ReactingFollower,
    delay: f32,
    known_for: f32,
    time_gap: f32,
    v: f32,
) -> Option<f32> {
    let build_up = EgoBuildUp {
        acceleration: 0.0,
        commands: 0.0,
        known_for,
        lag: EgoActuator::declared(config).lag,
    };
    allowed_at_the_worst_corner(config, model, follower, delay, Some(build_up), time_gap, v)
}

/// The hardest braking up to the emergency authority's that the rear keeps its margin for, to
/// 1e-3 m/s^2, at the worst corner of the box around the worst measurement of a follower
/// `time_gap` behind at `v`, its reaction `delay` later; the ego braking at the level at once
/// from the measurement, or credited with `build_up`.
fn allowed_at_the_worst_corner(
    config: &firmware::Config,
    model: &HumanModel,
    follower: &ReactingFollower,
    delay: f32,
    build_up: Option<EgoBuildUp>,
    time_gap: f32,
    v: f32,
) -> Option<f32> {
    let rear = RearBox::around(config, model, time_gap, v);
    let later = ReactingFollower {
        reaction_time: follower.reaction_time + delay,
        ..*follower
    };
    let (gap, ego, behind) = (rear.gap.0, rear.ego.0, rear.follower.1);
    let margin = config.certificate.rear_margin;
    let ceiling = config.certificate.emergency.braking.level;
    match build_up {
        None => allowed_braking(gap, ego, behind, &later, margin, ceiling),
        Some(b) => table_format::rear::hardest_clearing(
            |level| rear_gap_built_up(gap, ego, behind, level, 0.0, &b, &later) - margin,
            0.0,
            ceiling,
            1e-3,
        ),
    }
}

/// `config` with sensors that measure the gap, the range rate and the ego's speed exactly (the
/// rest of the sensors' declaration as it was): the levers' "known exactly".
pub fn with_exact_sensors(config: firmware::Config) -> firmware::Config {
    let mut exact = config;
    exact.sensors.error = table_format::MeasurementError {
        range: 0.0,
        range_relative: 0.0,
        range_rate: 0.0,
        ego_speed: 0.0,
        ego_speed_relative: 0.0,
        ..config.sensors.error
    };
    exact
}

/// The ego's actuator as the firmware declares it, for [`braking_a_follower_allows_through`]:
/// the commands take force after `dead_time` (s) through a first-order lag of `lag` (s), and
/// the braking's command builds up at `jerk` (m/s^3; `f32::INFINITY`: at once).
#[derive(Debug, Clone, Copy)]
pub struct EgoActuator {
    /// The brake's dead time, s.
    pub dead_time: f32,
    /// Its first-order lag, s.
    pub lag: f32,
    /// The build-up of the braking's command, m/s^3.
    pub jerk: f32,
}

impl EgoActuator {
    /// Its dead time and lag, as the plant's [`Actuator`] takes them.
    pub fn model(&self) -> ActuatorModel {
        ActuatorModel {
            dead_time: self.dead_time,
            lag: self.lag,
        }
    }

    /// The one `config` declares, with the emergency authority's build-up.
    pub fn declared(config: &firmware::Config) -> Self {
        EgoActuator {
            dead_time: config.plant.actuator_dead_time_us as f32 * 1e-6,
            lag: config.plant.actuator_lag_us as f32 * 1e-6,
            jerk: config.certificate.emergency.braking.jerk,
        }
    }
}

/// [`braking_a_follower_allows`] with the ego's braking through `actuator` (from steady
/// following: its acceleration and commands at zero, the braking's command issued at the
/// measurement's time, the earliest) instead of at its level at once from the measurement;
/// the same error box, follower and `delay` before its reaction starts. The least gap is
/// found by the plant's integration (1 ms steps, each exact for the step's mean acceleration:
/// the closed loop's [`Actuator`], [`Car::advance`] and [`lowest_gap`]), and the level by
/// [`table_format::rear::hardest_clearing`] to 1e-3 m/s^2. With no dead time, no lag
/// and a braking at once it is the closed form's figure (a test holds it to 0.01 m/s^2).
///
/// A lever, not a figure of the firmware: its rear check brakes the ego at the level at once
/// (`table_format::rear::rear_gap_after` has no build-up for the car ahead of the follower),
/// which is what this credits.
pub fn braking_a_follower_allows_through(
    config: &firmware::Config,
    model: &HumanModel,
    follower: &ReactingFollower,
    actuator: EgoActuator,
    delay: f32,
    time_gap: f32,
    v: f32,
) -> Option<f32> {
    let rear = RearBox::around(config, model, time_gap, v);
    let margin = config.certificate.rear_margin;
    let start = [rear.gap.0, rear.ego.0, rear.follower.1];
    table_format::rear::hardest_clearing(
        |level| least_rear_gap(start, level, actuator, follower, delay) - margin,
        0.0,
        config.certificate.emergency.braking.level,
        1e-3,
    )
}

/// The least gap (m) behind an ego braking at `level` through `actuator` from `[gap,
/// ego_speed, follower_speed]`, the `follower` reacting `delay` seconds late
/// ([`braking_a_follower_allows_through`]): the plant's own actuator ([`Actuator`]), cars
/// ([`Car::advance`]) and least gap within each step ([`lowest_gap`]), 1 ms steps.
fn least_rear_gap(
    [gap, ego_speed, follower_speed]: [f32; 3],
    level: f32,
    actuator: EgoActuator,
    follower: &ReactingFollower,
    delay: f32,
) -> f32 {
    const STEP_US: u64 = 1_000;
    let h = STEP_US as f32 * 1e-6;
    let mut brake = Actuator::new(actuator.model());
    let reacts_at = follower.reaction_time + delay;
    let top = follower.max_speed.max(follower_speed);
    let mut ego = Car {
        x: 0.0,
        v: ego_speed,
    };
    let mut behind = Car {
        x: -gap,
        v: follower_speed,
    };
    let mut least = gap;
    // Until both cars stand (or 60 s: both stop from 70 m/s within it).
    for k in 0..60_000u64 {
        if ego.v <= 0.0 && behind.v <= 0.0 {
            break;
        }
        let t = k as f32 * h;
        // The braking's command, built up at the declared jerk from the measurement's time.
        let command = if actuator.jerk.is_infinite() {
            -level
        } else {
            -(actuator.jerk * t).min(level)
        };
        brake.request(k * STEP_US, command);
        let a_ego = brake.advance(k * STEP_US, STEP_US);
        let a_follower = reacting_follower_acceleration(follower, t, reacts_at, behind.v, top);
        least = least.min(lowest_gap(ego, a_ego, behind, a_follower, h));
        ego.advance(a_ego, h);
        behind.advance(a_follower, h);
        behind.v = behind.v.min(top);
    }
    least
}

/// `follower` credited, until it reacts, with what its IDM does at the most inviting corner of
/// the error box of [`braking_a_follower_allows`] (the longest gap, the slowest follower, the
/// fastest ego, the range's closest time gap), and at least holding its speed, instead of its
/// IDM's largest acceleration. What a follower that holds its acceleration from steady
/// following through its reaction does ([`crate::humans::Follower::IdmReacting`]); the
/// firmware does not argue with it (it does not know the follower's acceleration when its
/// lights come on), so it is a lever, not a figure of the firmware.
pub fn crediting_its_idm(
    config: &firmware::Config,
    model: &HumanModel,
    follower: &ReactingFollower,
    time_gap: f32,
    v: f32,
) -> ReactingFollower {
    let rear = RearBox::around(config, model, time_gap, v);
    let tmin = model.parameter_range().0;
    let idm_now = model.follower_acceleration(rear.follower.0, rear.ego.1, rear.gap.1, tmin);
    ReactingFollower {
        reaction_acceleration: idm_now.max(0.0),
        ..*follower
    }
}

/// Runs the command: prints its tables, writes `gap-policy.json` and the plots to `out`.
pub fn run(out: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let bytes = firmware::DEFAULT_TABLE;
    let configs = [
        (
            "no ramp",
            firmware::Config {
                certificate: firmware::CertificateConfig {
                    brake_jerk: f32::INFINITY,
                    ..firmware::Config::default().certificate
                },
                ..firmware::Config::default()
            },
        ),
        (
            "ramp at 5 m/s^3",
            firmware::Config {
                certificate: firmware::CertificateConfig {
                    brake_jerk: 5.0,
                    ..firmware::Config::default().certificate
                },
                ..firmware::Config::default()
            },
        ),
        ("ramp at 2.5 m/s^3 (default)", firmware::Config::default()),
    ];
    let speeds: Vec<f32> = (0..=70).map(|k| k as f32 * 0.5).collect();
    let mut rows = Vec::new();
    println!("| speed [m/s] | certified steady gap, no ramp [m] | with a ramp at 5 m/s^3 [m] | at 2.5 m/s^3 (default) [m] | gap policy at 1.0 / 1.4 / 1.8 / 2.2 s [m] |");
    println!("|---|---|---|---|---|");
    let mut series: Vec<(String, Vec<(f32, f32)>)> = Vec::new();
    for (name, config) in configs {
        let c = firmware::Controller::new(bytes, config);
        anyhow::ensure!(c.table().is_some(), "the default table is refused");
        series.push((
            format!("certified, {name}"),
            speeds.iter().map(|&v| (v, c.steady_gap(v))).collect(),
        ));
    }
    let mut policies = Vec::new();
    for setting in 0..firmware::controller::TIME_GAP_SETTINGS as u8 {
        let config = firmware::Config {
            law: firmware::LawConfig {
                time_gap_setting: setting,
                ..firmware::Config::default().law
            },
            ..firmware::Config::default()
        };
        let c = firmware::Controller::new(bytes, config);
        policies.push((
            config.time_gap(setting),
            speeds
                .iter()
                .map(|&v| (v, c.desired_gap(v)))
                .collect::<Vec<_>>(),
        ));
    }
    for (k, &v) in speeds.iter().enumerate() {
        if k % 10 == 0 {
            println!(
                "| {v:.0} | {:.1} | {:.1} | {:.1} | {} |",
                series[0].1[k].1,
                series[1].1[k].1,
                series[2].1[k].1,
                policies
                    .iter()
                    .map(|p| format!("{:.1}", p.1[k].1))
                    .collect::<Vec<_>>()
                    .join(" / ")
            );
        }
        rows.push(serde_json::json!({
            "speed_m_s": v,
            "certified_gap_no_ramp_m": series[0].1[k].1,
            "certified_gap_ramp_5_m": series[1].1[k].1,
            "certified_gap_ramp_2_5_m": series[2].1[k].1,
            "gap_policy_m": policies.iter().map(|p| serde_json::json!({"time_gap_s": p.0, "gap_m": p.1[k].1})).collect::<Vec<_>>(),
        }));
    }
    // The cost in certified volume: the share of front states (gap 0-150 m by 1 m, leader and
    // ego 0-35 m/s by 0.5 m/s) certified for an ego at rest in its actuator with the declared
    // delays, braking along each configuration's ramp.
    let declared = firmware::Config::default();
    let response =
        (declared.plant.actuator_dead_time_us + declared.plant.actuator_lag_us) as f32 * 1e-6;
    let mut shares = Vec::new();
    for (name, config) in configs {
        let c = firmware::Certifier::new(table_format::Table::parse(bytes)?, &config)
            .map_err(|f| anyhow::anyhow!("the default table is refused: {f:?}"))?;
        let (mut certified, mut all) = (0u64, 0u64);
        for g in 0..=150 {
            for l in 0..=70 {
                for e in 0..=70 {
                    let state = [g as f32, l as f32 * 0.5, 1e4, 0.0, e as f32 * 0.5];
                    all += 1;
                    if c.certificate_with_response(state, response, 0.0)
                        .is_some_and(|x| x.front > 0.0)
                    {
                        certified += 1;
                    }
                }
            }
        }
        let share = 100.0 * certified as f64 / all as f64;
        println!(
            "front-certified share of (gap 0-150 m, leader and ego 0-35 m/s), {name}: {share:.2}%"
        );
        shares.push(
            serde_json::json!({"configuration": name, "front_certified_share_percent": share}),
        );
    }
    let allowed = braking_at_exact_states(bytes)?;
    let authorities = gaps_with_two_authorities(bytes, out)?;
    let floors = floors_under_every_certificate(bytes)?;
    let report = serde_json::json!({
        "by_speed": rows,
        "front_certified_share": shares,
        "braking_the_follower_allows": allowed,
        "two_authorities": authorities,
        "floors": floors,
    });
    std::fs::write(
        out.join("gap-policy.json"),
        serde_json::to_string_pretty(&report)?,
    )?;
    let file = out.join("gap-policy.png");
    crate::plots::gap_policy(&file, &series, &policies)?;
    println!("{}", file.display());
    Ok(())
}

/// The hardest braking a follower that reacts like a person allows the ego at exact states (no
/// measurement error, no delay), at equal speeds with the follower 0.6, 1 and 2 s behind
/// (`table_format::rear`): R157's careful driver, a follower that holds its speed as the careful
/// driver does and then brakes at the table's follower clip at once, and the firmware's
/// follower ([`firmware::Certifier::reacting_follower`]: up to the IDM's top until it reacts,
/// then its clip at once). Printed as a table; returned for the report.
fn braking_at_exact_states(bytes: &[u8]) -> Result<serde_json::Value> {
    let table = table_format::Table::parse(bytes)?;
    let model = crate::humans::HumanModel::of(&table)
        .ok_or_else(|| anyhow::anyhow!("the default table is not a split table"))?;
    let careful = ReactingFollower::careful_driver(model.max_speed);
    let at_clip = ReactingFollower {
        braking: -model.follower_clip().0,
        jerk: f32::INFINITY,
        ..careful
    };
    let argued = firmware::Certifier::new(table_format::Table::parse(bytes)?, &Default::default())
        .map_err(|f| anyhow::anyhow!("the default table is refused: {f:?}"))?
        .reacting_follower();
    let followers = [
        (
            "careful driver (its speed held for 1.15 s, then 7.59 m/s^2 over 0.6 s)",
            careful,
        ),
        (
            "its speed held for 1.15 s, then the model's clip at once",
            at_clip,
        ),
        (
            "the firmware's: up to the IDM's top for 1.15 s, then its clip at once",
            argued,
        ),
    ];
    let time_gaps = [0.6f32, 1.0, 2.0];
    let ceiling = 12.0;
    println!();
    println!("The hardest ego braking [m/s^2] a follower reacting after 1.15 s allows, at equal speeds (12: any a car can do; -: none):");
    println!("| speed [m/s] | follower | 0.6 s behind | 1 s behind | 2 s behind |");
    println!("|---|---|---|---|---|");
    let mut rows = Vec::new();
    for v in [10.0f32, 20.0, 30.0] {
        for (name, f) in followers {
            let allowed: Vec<Option<f32>> = time_gaps
                .iter()
                .map(|&t| allowed_braking(t * v, v, v, &f, 0.0, ceiling))
                .collect();
            let cell = |b: &Option<f32>| b.map_or("-".to_string(), |b| format!("{b:.2}"));
            println!(
                "| {v:.0} | {name} | {} |",
                allowed.iter().map(cell).collect::<Vec<_>>().join(" | ")
            );
            rows.push(serde_json::json!({
                "speed_m_s": v,
                "follower": name,
                "by_time_gap": time_gaps.iter().zip(&allowed).map(|(t, b)| {
                    serde_json::json!({"time_gap_s": t, "allowed_braking_m_s2": b})
                }).collect::<Vec<_>>(),
            }));
        }
    }
    Ok(serde_json::Value::Array(rows))
}

/// What the certified steady gap and the gap policy would be with two braking authorities:
/// the comfort band as today and the declared emergency braking, as hard as a follower
/// that reacts like a person allows (`table_format::rear`), against leaders braking at 6 and at
/// 9.8 m/s^2. Everything else is the deployed firmware's argument: its delays, sensor errors
/// and margins ([`firmware::Controller::steady_gap_with`]). The follower sits at the IDM's
/// jam distance plus its time gap behind, at the ego's speed, and the braking it allows is
/// taken where the firmware would see it: at the worst corner of the error box around the worst
/// measurement of it, with the track as old as the radar delivers it and the period and the
/// brake's dead time before the braking shows. The followers: the firmware's own
/// ([`firmware::Certifier::reacting_follower`]), the same reacting at once, and R157's careful
/// driver (who holds its speed until it reacts); the levers at 30 m/s add the firmware's
/// follower credited with its IDM's output ([`crediting_its_idm`]) and the ego's build-up
/// credited in the rear ([`braking_a_follower_allows_through`]). Printed, drawn to
/// `gap-policy-authorities.png` and returned for the report.
fn gaps_with_two_authorities(bytes: &[u8], out: &std::path::Path) -> Result<serde_json::Value> {
    let Deployed {
        model,
        config,
        comfort,
        argued,
    } = Deployed::on(bytes)?;
    let declared = config.certificate.emergency;
    let full = declared.braking;
    let followers = [
        (
            "instant (the paper's IDM at its clip)",
            ReactingFollower {
                reaction_time: 0.0,
                ..argued
            },
        ),
        (
            "the firmware's: up to the IDM's top for 1.15 s, then its clip at once",
            argued,
        ),
        (
            "R157's careful driver (its speed held for 1.15 s, then 7.59 m/s^2 over 0.6 s)",
            ReactingFollower::careful_driver(model.max_speed),
        ),
    ];
    let comfort_braking = firmware::Braking {
        level: -model.band_min,
        jerk: config.certificate.brake_jerk,
    };
    let lights = lights_from_steady_following(&config);
    let delay = learnt_after(&config) + lights;
    let allows = |f: &ReactingFollower, time_gap: f32, v: f32| {
        braking_the_firmware_allows(&config, &model, f, lights, time_gap, v)
    };
    let speeds = [10.0f32, 20.0, 30.0];
    let follower_gaps = [0.6f32, 1.0, 2.0];
    let settings: Vec<f32> = (0..firmware::controller::TIME_GAP_SETTINGS)
        .map(|k| config.time_gap(k as u8))
        .collect();
    let mut by_setting = Vec::new();
    for setting in 0..settings.len() {
        let mut law = config.law;
        law.time_gap_setting = setting as u8;
        by_setting.push(firmware::Controller::new(
            bytes,
            firmware::Config { law, ..config },
        ));
    }
    let cell = |g: f32| {
        if g.is_finite() {
            format!("{g:.1}")
        } else {
            "-".to_string()
        }
    };
    println!();
    println!("Two braking authorities: comfort (the band, {:.1} m/s^2 at {:.1} m/s^3) and emergency ({:.1} m/s^2 at {:.1} m/s^3) as far as the follower allows; the certified steady gap and the gap policy at the settings {} s [m] (-: no braking certified):", comfort_braking.level, comfort_braking.jerk, full.level, full.jerk, settings.iter().map(|t| format!("{t}")).collect::<Vec<_>>().join(" / "));
    println!("| leader [m/s^2] | speed [m/s] | follower | behind [s] | allowed braking [m/s^2] | certified steady gap [m] | gap policy [m] |");
    println!("|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for leader in [6.0f32, 9.8] {
        for &v in &speeds {
            let mut report = |follower: &str,
                              behind: Option<f32>,
                              braking: Option<firmware::Braking>| {
                let steady =
                    braking.map_or(f32::INFINITY, |b| comfort.steady_gap_with(v, leader, b));
                let policy: Vec<f32> = by_setting
                    .iter()
                    .map(|c| braking.map_or(f32::INFINITY, |b| c.desired_gap_over(v, leader, b)))
                    .collect();
                println!(
                    "| {leader} | {v:.0} | {follower} | {} | {} | {} | {} |",
                    behind.map_or("-".to_string(), |t| format!("{t}")),
                    braking.map_or("-".to_string(), |b| format!("{:.2}", b.level)),
                    cell(steady),
                    policy
                        .iter()
                        .map(|&g| cell(g))
                        .collect::<Vec<_>>()
                        .join(" / ")
                );
                rows.push(serde_json::json!({
                    "leader_braking_m_s2": leader,
                    "speed_m_s": v,
                    "follower": follower,
                    "follower_time_gap_s": behind,
                    "braking_m_s2": braking.map(|b| b.level),
                    "braking_jerk_m_s3": braking.map(|b| b.jerk),
                    "certified_steady_gap_m": steady.is_finite().then_some(steady),
                    "gap_policy_m": settings.iter().zip(&policy).map(|(t, g)| {
                        serde_json::json!({"time_gap_s": t, "gap_m": g.is_finite().then_some(*g)})
                    }).collect::<Vec<_>>(),
                }));
            };
            report(
                "comfort band only (today's certificate)",
                None,
                Some(comfort_braking),
            );
            report("none", None, Some(full));
            for (name, f) in &followers {
                for &t in &follower_gaps {
                    let braking = allows(f, t, v).map(|level| firmware::Braking { level, ..full });
                    report(name, Some(t), braking);
                }
            }
        }
    }
    // What would reach the targets at 30 m/s against a 9.8 m/s^2 leader: the follower
    // credited with its IDM's output until it reacts, the rear known exactly and at once, a
    // faster brake (lag 0.1 s), the ego's own build-up credited in the rear check.
    let v = 30.0f32;
    let exact = with_exact_sensors(config);
    let credited = crediting_its_idm(&config, &model, &argued, 1.0, v);
    let credited_exact = crediting_its_idm(&exact, &model, &argued, 1.0, v);
    let declared_rear = allows(&argued, 1.0, v);
    let credited_rear = allows(&credited, 1.0, v);
    let exact_rear = braking_a_follower_allows(&exact, &model, &argued, 0.0, 1.0, v);
    let both_rear = braking_a_follower_allows(&exact, &model, &credited_exact, 0.0, 1.0, v);
    let actuator = EgoActuator::declared(&config);
    let through_rear =
        braking_a_follower_allows_through(&config, &model, &argued, actuator, delay, 1.0, v);
    // Known exactly, with the declared delays: what the measurement's errors cost.
    let through_known =
        braking_a_follower_allows_through(&exact, &model, &argued, actuator, delay, 1.0, v);
    // Known exactly and at once, but its reaction from when the actuator lights the brakes.
    let through_exact =
        braking_a_follower_allows_through(&exact, &model, &argued, actuator, lights, 1.0, v);
    // The closed form's credit: the commands already issued known for the track's age at the
    // check (the delay less the lights' bound) and the dead time; with exact sensors, a fresh
    // measurement (the dead time alone).
    let dead_time = actuator.dead_time;
    let built_up_rear = braking_a_follower_allows_built_up(
        &config,
        &model,
        &argued,
        delay,
        delay - lights + dead_time,
        1.0,
        v,
    );
    let built_up_exact =
        braking_a_follower_allows_built_up(&exact, &model, &argued, lights, dead_time, 1.0, v);
    let mut faster = config;
    faster.plant.actuator_lag_us = 100_000;
    let faster = firmware::Controller::new(bytes, faster);
    let at = |c: &firmware::Controller<'_>, b: Option<f32>| {
        b.map_or(f32::INFINITY, |level| {
            c.steady_gap_with(v, 9.8, firmware::Braking { level, ..full })
        })
    };
    // The follower where its IDM holds its speed behind the ego with the range's closest time
    // gap (54.8 m at 30 m/s, not 2 m + 30 m: near its desired speed its free-road term slows
    // it), the firmware's argument and the build-up by integration there.
    let steady = idm_steady_gap(&model, model.parameter_range().0, v)
        .ok_or_else(|| anyhow::anyhow!("the IDM has no steady state at {v} m/s"))?;
    let table_format::FollowerModel::Idm { idm, .. } = model.follower;
    let steady_time_gap = (steady - idm.jam_distance) / v;
    let steady_rear = allows(&argued, steady_time_gap, v);
    let steady_through = braking_a_follower_allows_through(
        &config,
        &model,
        &argued,
        actuator,
        delay,
        steady_time_gap,
        v,
    );
    let at_steady_state = format!(
        "the follower at its IDM's steady state ({steady:.1} m behind), the firmware's argument"
    );
    let at_steady_state_through = format!(
        "the follower at its IDM's steady state ({steady:.1} m), the build-up by integration"
    );
    // Each lever: what changes, the braking it allows, and the firmware it is measured with.
    let levers = [
        ("declared errors and delays (the firmware's argument)", declared_rear, &comfort),
        ("the follower credited with its IDM's output until it reacts", credited_rear, &comfort),
        ("the follower known exactly and at once", exact_rear, &comfort),
        ("known exactly and at once, and credited with its IDM's output", both_rear, &comfort),
        ("a brake lag of 0.1 s (declared 0.3 s)", declared_rear, &faster),
        ("all three", both_rear, &faster),
        ("the ego's dead time and lag credited in the rear check, in closed form (rear_gap_built_up; not argued by the firmware: it needs an actuator no faster than declared)", built_up_rear, &comfort),
        ("that, and the follower known exactly and at once (its reaction from the lights)", built_up_exact, &comfort),
        ("the ego's build-up credited in the rear check, by integration (dead time, lag and its 12 m/s^3 ramp)", through_rear, &comfort),
        ("the build-up by integration, and the follower known exactly (the declared delays)", through_known, &comfort),
        ("the build-up by integration, and the follower known exactly and at once (its reaction from the lights)", through_exact, &comfort),
        (at_steady_state.as_str(), steady_rear, &comfort),
        (at_steady_state_through.as_str(), steady_through, &comfort),
    ]
    .map(|(name, b, c)| (name, b, at(c, b)));
    println!();
    println!(
        "At 30 m/s against a 9.8 m/s^2 leader, the firmware's follower 1 s behind (up to the IDM's top for 1.15 s, then its clip at once):"
    );
    println!("| what changes | braking it allows [m/s^2] | certified steady gap [m] |");
    println!("|---|---|---|");
    for (name, b, g) in levers {
        println!(
            "| {name} | {} | {} |",
            b.map_or("-".to_string(), |b| format!("{b:.2}")),
            cell(g)
        );
    }
    let alone = at(&comfort, Some(full.level));
    println!(
        "With no follower: certified {}; the gap policy at {} s {} (its room: the gap for closing at {} m/s, plus {} m).",
        cell(alone),
        settings[0],
        cell(by_setting[0].desired_gap_over(v, 9.8, full)),
        config.law.gap_room_speed,
        config.law.gap_room,
    );
    let levers_json: Vec<serde_json::Value> = levers
        .iter()
        .map(|(name, b, g)| {
            serde_json::json!({"what": name, "allowed_braking_m_s2": b, "certified_steady_gap_m": g.is_finite().then_some(*g)})
        })
        .collect();
    rows.push(serde_json::json!({"levers_at_30_m_s_leader_9_8_idm_follower_1_s": levers_json}));

    // The build-up credited soundly: the declaration bounds the actuator from the slow side
    // only, and the rear needs the fast one. The ego's braking through the fastest actuator a
    // vehicle might declare (the lowest acceleration at every instant, for commands that only
    // fall) with the follower's reaction from the slowest's lights (the latest).
    println!();
    println!(
        "The build-up credited soundly, at {v:.0} m/s against 9.8 m/s^2: the ego braking through the fastest actuator declared, the follower reacting from the slowest's lights ({:.2} s after the measurement), at 2 m + 1 s of speed and at its IDM's steady state ({steady:.1} m):",
        delay
    );
    println!("| fastest actuator declared: dead time / lag [s] | braking allowed, 1 s behind [m/s^2] | certified steady gap [m] | at the IDM's steady state [m/s^2] | certified steady gap [m] |");
    println!("|---|---|---|---|---|");
    let mut sound = Vec::new();
    for (dead_time, lag) in [
        (0.0f32, 0.0f32),
        (0.05, 0.1),
        (0.05, 0.2),
        (actuator.dead_time, actuator.lag),
    ] {
        let fastest = EgoActuator {
            dead_time,
            lag,
            ..actuator
        };
        let behind =
            braking_a_follower_allows_through(&config, &model, &argued, fastest, delay, 1.0, v);
        let at_steady = braking_a_follower_allows_through(
            &config,
            &model,
            &argued,
            fastest,
            delay,
            steady_time_gap,
            v,
        );
        let level = |b: Option<f32>| b.map_or("-".to_string(), |b| format!("{b:.2}"));
        println!(
            "| {dead_time} / {lag} | {} | {} | {} | {} |",
            level(behind),
            cell(at(&comfort, behind)),
            level(at_steady),
            cell(at(&comfort, at_steady))
        );
        sound.push(serde_json::json!({
            "fastest_dead_time_s": dead_time,
            "fastest_lag_s": lag,
            "allowed_braking_1_s_behind_m_s2": behind,
            "certified_steady_gap_1_s_behind_m": behind.map(|b| at(&comfort, Some(b))),
            "allowed_braking_at_the_idm_steady_state_m_s2": at_steady,
            "certified_steady_gap_at_the_idm_steady_state_m": at_steady.map(|b| at(&comfort, Some(b))),
        }));
    }
    rows.push(serde_json::json!({"sound_build_up_at_30_m_s_leader_9_8": sound}));

    // The plot: leaders at 6 and 9.8 m/s^2 in rows; no follower, then the firmware's follower
    // 0.6, 1 and 2 s behind, then at its IDM's steady state with the closest time gap, in
    // columns.
    let speeds: Vec<f32> = (0..=70).map(|k| k as f32 * 0.5).collect();
    let mut panels = Vec::new();
    let argued_follower = followers[1].1;
    let know = learnt_after(&config);
    let closest = model.parameter_range().0;
    /// Where a panel's follower is.
    #[derive(Clone, Copy)]
    enum Behind {
        Nobody,
        At(f32),
        IdmSteady,
    }
    // The follower's time gap behind the ego at `v` (`Some(None)`: no follower; `None`: none
    // that holds its speed there, the IDM at or above its desired speed).
    let time_gap_at = |behind: Behind, v: f32| match behind {
        Behind::Nobody => Some(None),
        Behind::At(t) => Some(Some(t)),
        Behind::IdmSteady => idm_steady_gap(&model, closest, v)
            .map(|g| Some((g - idm.jam_distance) / v.max(f32::MIN_POSITIVE))),
    };
    for leader in [6.0f32, 9.8] {
        let columns = [
            Behind::Nobody,
            Behind::At(0.6),
            Behind::At(1.0),
            Behind::At(2.0),
            Behind::IdmSteady,
        ];
        for behind in columns {
            let braking_at = |v: f32| match time_gap_at(behind, v)? {
                None => Some(full),
                Some(t) => {
                    allows(&argued_follower, t, v).map(|level| firmware::Braking { level, ..full })
                }
            };
            let certified: Vec<(f32, f32)> = speeds
                .iter()
                .map(|&v| {
                    let g = braking_at(v)
                        .map_or(f32::INFINITY, |b| comfort.steady_gap_with(v, leader, b));
                    (v, g)
                })
                .collect();
            let comfort_only = speeds
                .iter()
                .map(|&v| (v, comfort.steady_gap_with(v, leader, comfort_braking)))
                .collect();
            let policies = settings
                .iter()
                .zip(&by_setting)
                .map(|(&t, c)| {
                    let gaps = speeds
                        .iter()
                        .map(|&v| {
                            (
                                v,
                                braking_at(v)
                                    .map_or(f32::INFINITY, |b| c.desired_gap_over(v, leader, b)),
                            )
                        })
                        .collect();
                    (t, gaps)
                })
                .collect();
            let floor = speeds
                .iter()
                .map(|&v| {
                    let f = |follower_gap: f32| {
                        let scene = floor_scene(&config, leader, v, argued_follower, follower_gap);
                        crate::floor::floor(&scene, actuator, know, full.level)
                    };
                    let g = match time_gap_at(behind, v) {
                        None => f32::INFINITY,
                        Some(None) => f(f32::INFINITY).alone,
                        Some(Some(t)) => f(idm.jam_distance + t * v).gap,
                    };
                    (v, g)
                })
                .collect();
            panels.push(crate::plots::GapPanel {
                title: match behind {
                    Behind::Nobody => format!("leader {leader} m/s^2, no follower"),
                    Behind::At(t) => format!("leader {leader} m/s^2, follower {t} s behind"),
                    Behind::IdmSteady => {
                        format!("leader {leader} m/s^2, follower's IDM steady ({closest} s)")
                    }
                },
                certified,
                comfort_only,
                policies,
                floor,
            });
        }
    }
    let file = out.join("gap-policy-authorities.png");
    crate::plots::gap_policy_panels(
        &file,
        "Gap policy with the emergency authority the follower leaves (the firmware's follower: up to the IDM's top for 1.15 s, then its clip)",
        2,
        &panels,
    )?;
    println!("{}", file.display());
    Ok(serde_json::Value::Array(rows))
}

/// The gap at which the follower's IDM, at its time gap `time_gap`, holds its speed behind an
/// ego at its own speed `v`: its steady state, m (bisection to 1 mm); `None` where none is
/// within 1 km (at or above its desired speed).
pub fn idm_steady_gap(model: &HumanModel, time_gap: f32, v: f32) -> Option<f32> {
    let accelerates = |gap: f32| model.follower_acceleration(v, v, gap, time_gap) > 0.0;
    let (mut lo, mut hi) = (0.0f32, 1000.0f32);
    if !accelerates(hi) {
        return None;
    }
    while hi - lo > 1e-3 {
        let mid = 0.5 * (lo + hi);
        if accelerates(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

/// The deployed table's humans, the default configuration, the firmware on it and the follower
/// its two-authority argument takes ([`firmware::Certifier::reacting_follower`]).
struct Deployed<'t> {
    model: HumanModel,
    config: firmware::Config,
    comfort: firmware::Controller<'t>,
    argued: ReactingFollower,
}

impl<'t> Deployed<'t> {
    fn on(bytes: &'t [u8]) -> Result<Self> {
        let table = table_format::Table::parse(bytes)?;
        let model = HumanModel::of(&table)
            .ok_or_else(|| anyhow::anyhow!("the default table is not a split table"))?;
        let config = firmware::Config::default();
        let comfort = firmware::Controller::new(bytes, config);
        let argued = comfort
            .certifier()
            .map(|c| c.reacting_follower())
            .ok_or_else(|| anyhow::anyhow!("the default table is refused"))?;
        Ok(Deployed {
            model,
            config,
            comfort,
            argued,
        })
    }
}

/// How late the ego learns of the leader's braking at the worst, s: a track as old as the
/// sensors declare (`latency + cycle`) and a control period.
pub(crate) fn learnt_after(config: &firmware::Config) -> f32 {
    let sensors = config.sensors;
    (sensors.latency_us + sensors.cycle_us + config.period_us) as f32 * 1e-6
}

/// How long after a measurement the firmware's argument takes the brake lights to come on
/// for sure, s, on top of `learnt_after` (a track's age and a period): from steady following
/// (the actuator's acceleration and commands at zero), braking along the emergency ramp
/// through the declared dead time and lag (`table_format::rear::lights_on_within`).
pub fn lights_from_steady_following(config: &firmware::Config) -> f32 {
    let actuator = EgoActuator::declared(config);
    let full = config.certificate.emergency.braking;
    config.certificate.emergency.lights_on_within(
        actuator.dead_time,
        actuator.lag,
        0.0,
        0.0,
        0.0,
        full.jerk,
        full.level,
    )
}

/// The floor's scene ([`crate::floor::Scene`]) with `config`'s margins and lights: every car at
/// `v`, the leader braking at up to `leader_braking`, `follower` `follower_gap` behind.
fn floor_scene(
    config: &firmware::Config,
    leader_braking: f32,
    v: f32,
    follower: ReactingFollower,
    follower_gap: f32,
) -> crate::floor::Scene {
    crate::floor::Scene {
        leader_speed: v,
        ego_speed: v,
        follower_speed: v,
        leader_braking,
        follower_gap,
        follower,
        lights_deceleration: config.certificate.emergency.lights_deceleration,
        front_margin: config.certificate.front_margin,
        rear_margin: config.certificate.rear_margin,
    }
}

/// The worst state the declared errors leave over the measurements of `scene` (every car at
/// the ego's speed), as `gap-policy` takes the firmware's argument: a measurement that errs
/// against the certificate, then the worst state within its box ([`RearBox`]). The ego at the
/// top of its speed's interval, the follower faster and the leader slower than it by the range
/// rate's error on each of two readings, the follower's gap at the bottom of its range's
/// interval. Both of the floor's conditions grow with each of these (the follower's stop moves
/// further than the leader's when both start faster: it brakes at less), so it is the worst
/// for both at once.
fn worst_measured(config: &firmware::Config, scene: crate::floor::Scene) -> crate::floor::Scene {
    let rear = RearBox::around_gap(config, scene.follower_gap, scene.ego_speed);
    let ego = rear.ego.1;
    let slower = rear.follower.1 - ego;
    crate::floor::Scene {
        leader_speed: (ego - slower).max(0.0),
        ego_speed: ego,
        follower_speed: rear.follower.1,
        follower_gap: rear.gap.0,
        ..scene
    }
}

/// One row of [`floor_rows`]: a steady-following scene, the floor under every certificate there
/// and the firmware's certified steady gap.
#[derive(Debug, Clone)]
pub struct FloorRow {
    /// The leader's hardest braking, m/s^2.
    pub leader_braking: f32,
    /// Every car's speed, m/s.
    pub speed: f32,
    /// Which follower, where.
    pub follower: String,
    /// The true gap from the follower to the ego, m.
    pub follower_gap: f32,
    /// The floor ([`crate::floor::floor`]), true gaps.
    pub floor: crate::floor::Floor,
    /// The floor as the least measured gap whose error box clears it, m.
    pub floor_measured: f32,
    /// The floor at the worst state the declared errors leave for a measurement of the scene
    /// (`worst_measured`), as a measured gap, m: what any certificate with these sensors needs
    /// at least.
    pub floor_with_errors: f32,
    /// The firmware's certified steady gap (a measured gap) with the braking the follower
    /// allows by its argument ([`braking_the_firmware_allows`]), m; `None` where it allows none.
    pub certified: Option<f32>,
}

/// The floor under every certificate of the model ([`crate::floor`]) beside the firmware's
/// certified steady gap, for each leader's braking in `leaders` and speed in `speeds`: the
/// firmware's follower 0.6, 1 and 2 s behind (plus the IDM's jam distance) and at its IDM's
/// steady state with the range's closest time gap ([`idm_steady_gap`]; where it has one), and
/// R157's careful driver 1 s behind. The leader's braking is learnt a track's age and a
/// period late, the worst the declaration allows; the default configuration and `bytes`' model.
pub fn floor_rows(bytes: &[u8], leaders: &[f32], speeds: &[f32]) -> Result<Vec<FloorRow>> {
    use crate::floor::floor;
    let Deployed {
        model,
        config,
        comfort,
        argued,
    } = Deployed::on(bytes)?;
    let declared = config.certificate.emergency;
    let full = declared.braking;
    let careful = ReactingFollower::careful_driver(model.max_speed);
    let table_format::FollowerModel::Idm { idm, .. } = model.follower;
    let closest = model.parameter_range().0;
    let sensors = config.sensors;
    let know = learnt_after(&config);
    let actuator = EgoActuator::declared(&config);
    let lights = lights_from_steady_following(&config);
    let as_measured = |g: f32| g * (1.0 + sensors.error.range_relative) + sensors.error.range;
    let mut rows = Vec::new();
    for &leader in leaders {
        for &v in speeds {
            let mut cases: Vec<(String, ReactingFollower, f32)> = [0.6f32, 1.0, 2.0]
                .iter()
                .map(|&t| {
                    (
                        format!("the firmware's, {t} s behind"),
                        argued,
                        idm.jam_distance + t * v,
                    )
                })
                .collect();
            if let Some(g) = idm_steady_gap(&model, closest, v) {
                cases.push((
                    format!("the firmware's, at its IDM's steady state ({closest} s)"),
                    argued,
                    g,
                ));
            }
            cases.push((
                "R157's careful driver, 1 s behind".to_string(),
                careful,
                idm.jam_distance + v,
            ));
            for (name, follower, follower_gap) in cases {
                let scene = floor_scene(&config, leader, v, follower, follower_gap);
                let worst = floor(&worst_measured(&config, scene), actuator, know, full.level);
                let floor = floor(&scene, actuator, know, full.level);
                let time_gap = (follower_gap - idm.jam_distance) / v;
                let certified =
                    braking_the_firmware_allows(&config, &model, &follower, lights, time_gap, v)
                        .map(|level| {
                            comfort.steady_gap_with(v, leader, firmware::Braking { level, ..full })
                        });
                rows.push(FloorRow {
                    leader_braking: leader,
                    speed: v,
                    follower: name,
                    follower_gap,
                    floor,
                    floor_measured: as_measured(floor.gap),
                    floor_with_errors: as_measured(worst.gap),
                    certified,
                });
            }
        }
    }
    Ok(rows)
}

/// [`floor_rows`] at leaders braking at 6 and 9.8 m/s^2 and 10, 20 and 30 m/s, and at 30 m/s
/// against 9.8 m/s^2 with the firmware's follower 1 s behind the best braking of
/// [`crate::floor::best_gentle_then_hard`]'s scan and the best single level
/// ([`crate::floor::best_level`]). Printed and returned for the report.
fn floors_under_every_certificate(bytes: &[u8]) -> Result<serde_json::Value> {
    use crate::floor::{best_gentle_then_hard, best_level};
    let Deployed { config, argued, .. } = Deployed::on(bytes)?;
    let declared = config.certificate.emergency;
    let full = declared.braking;
    let actuator = EgoActuator::declared(&config);
    let know = learnt_after(&config);
    let rows = floor_rows(bytes, &[6.0, 9.8], &[10.0, 20.0, 30.0])?;
    let lights = rows.first().map_or(f32::NAN, |r| r.floor.lights_at);
    let cell = |g: Option<f32>| g.map_or("-".to_string(), |g| format!("{g:.1}"));
    println!();
    println!(
        "The floor under every certificate of the model (host_tests::floor): the least true steady gap to the leader any braking of the ego keeps: the larger of the gap its hardest, earliest braking keeps alone and the gap for stopping behind the leader's stop and ahead of the follower's, the truth known, the leader's braking learnt {know:.2} s late (a track's age and a period), the lights at the earliest ({lights:.3} s: the ramp at {:.0} m/s^3 through the declared dead time and lag); as a measured gap (the range's error over it); beside the firmware's certified steady gap:",
        actuator.jerk
    );
    println!("| leader [m/s^2] | speed [m/s] | follower | its gap [m] | floor, true gap [m] | floor as a measured gap [m] | with the declared errors [m] | the firmware's certified steady gap [m] |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut json = Vec::new();
    for r in &rows {
        println!(
            "| {} | {:.0} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {} |",
            r.leader_braking,
            r.speed,
            r.follower,
            r.follower_gap,
            r.floor.gap,
            r.floor_measured,
            r.floor_with_errors,
            cell(r.certified)
        );
        json.push(serde_json::json!({
            "leader_braking_m_s2": r.leader_braking,
            "speed_m_s": r.speed,
            "follower": r.follower,
            "follower_gap_m": r.follower_gap,
            "floor_true_gap_m": r.floor.gap,
            "floor_behind_the_follower_m": r.floor.behind_the_follower,
            "floor_alone_m": r.floor.alone,
            "floor_measured_gap_m": r.floor_measured,
            "floor_with_the_declared_errors_m": r.floor_with_errors,
            "certified_steady_gap_m": r.certified,
        }));
    }
    let v = 30.0f32;
    let at = rows.iter().find(|r| {
        r.leader_braking == 9.8
            && r.speed == v
            && r.follower.ends_with(", 1 s behind")
            && r.follower.starts_with("the firmware's")
    });
    let scene = floor_scene(
        &config,
        9.8,
        v,
        argued,
        at.map_or(f32::NAN, |r| r.follower_gap),
    );
    let reaching = best_gentle_then_hard(&scene, actuator, know, full.level);
    let held = best_level(&scene, actuator, know, full.level);
    if let Some((gap, level)) = held {
        println!(
            "The firmware's form there (one level from the leader's braking on, the truth known, by brute force): {level:.2} m/s^2 keeps {gap:.1} m."
        );
    }
    if let (Some(r), Some((gap, b))) = (at, reaching) {
        println!(
            "At {v:.0} m/s against 9.8 m/s^2, the firmware's follower 1 s behind: floor {:.1} m ({:.1} m measured). A braking reaches it (brute force): lights at the earliest, {:.1} m/s^2 until {:.2} s, then {:.2} m/s^2 keeps {gap:.1} m. At this speed 1.8 s + 4 m is {:.1} m.",
            r.floor.gap,
            r.floor_measured,
            b.hold,
            b.switch_at,
            b.level,
            1.8 * v + 4.0
        );
    }
    json.push(serde_json::json!({
        "one_level_at_30_m_s_leader_9_8_firmware_follower_1_s": held.map(|(gap, level)| serde_json::json!({
            "gap_kept_m": gap,
            "level_m_s2": level,
        })),
        "reaching_the_floor_at_30_m_s_leader_9_8_firmware_follower_1_s": reaching.map(|(gap, b)| serde_json::json!({
            "gap_kept_m": gap,
            "hold_m_s2": b.hold,
            "switch_at_s": b.switch_at,
            "level_m_s2": b.level,
        })),
    }));
    Ok(serde_json::Value::Array(json))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The worst state of a measurement's box is worse than the measured scene in each of its
    /// four coordinates for both of the floor's conditions: putting any one back where the
    /// measurement has it (the ego's speed with the others' relative to it, the leader's or the
    /// follower's speed to the ego's, the follower's gap) raises neither (the claim
    /// `worst_measured` rests on). At 10, 20 and 30 m/s, the follower 1 s and 1.8 s behind.
    #[test]
    fn the_worst_measured_state_is_worst_in_every_coordinate() {
        let deployed = Deployed::on(firmware::DEFAULT_TABLE).unwrap();
        let config = deployed.config;
        let actuator = EgoActuator::declared(&config);
        let (know, full) = (
            learnt_after(&config),
            config.certificate.emergency.braking.level,
        );
        let floor = |s: &crate::floor::Scene| crate::floor::floor(s, actuator, know, full);
        for v in [10.0f32, 20.0, 30.0] {
            for gap in [2.0 + v, 2.0 + 1.8 * v] {
                let scene = floor_scene(&config, 9.8, v, deployed.argued, gap);
                let worst = worst_measured(&config, scene);
                assert!(worst.ego_speed > v && worst.leader_speed < worst.ego_speed);
                assert!(worst.follower_speed > worst.ego_speed && worst.follower_gap < gap);
                let at_worst = floor(&worst);
                let slower = worst.ego_speed - v;
                let back = [
                    crate::floor::Scene {
                        ego_speed: v,
                        leader_speed: worst.leader_speed - slower,
                        follower_speed: worst.follower_speed - slower,
                        ..worst
                    },
                    crate::floor::Scene {
                        leader_speed: worst.ego_speed,
                        ..worst
                    },
                    crate::floor::Scene {
                        follower_speed: worst.ego_speed,
                        ..worst
                    },
                    crate::floor::Scene {
                        follower_gap: gap,
                        ..worst
                    },
                ];
                for b in back {
                    let f = floor(&b);
                    assert!(
                        f.alone <= at_worst.alone + 1e-3
                            && f.behind_the_follower <= at_worst.behind_the_follower + 1e-3,
                        "{v} m/s, follower {gap} m: {b:?} gives {f:?}, the worst {at_worst:?}"
                    );
                }
            }
        }
    }
}
