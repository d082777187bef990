//! The emergency authority: braking below the band where the band's floor at once cannot keep
//! the leader's worst case off the car, as far as the follower behind allows.

use firmware::{Controller, Fault, Inputs, Measurement, Mode, Track, DEFAULT_TABLE};

mod common;
use common::{ideal, table_for};

/// Three cars on a line: positions (m) and speeds (m/s), leader, ego, follower.
#[derive(Debug, Clone, Copy)]
struct Cars {
    x: [f64; 3],
    v: [f64; 3],
}

impl Cars {
    fn inputs(&self, now_us: u64) -> Inputs {
        let track = |gap: f64, rel: f64| {
            Measurement::new(
                Track {
                    gap: gap as f32,
                    rel_speed: rel as f32,
                },
                now_us,
            )
        };
        Inputs {
            leader: track(self.x[0] - self.x[1], self.v[0] - self.v[1]),
            follower: track(self.x[1] - self.x[2], self.v[1] - self.v[2]),
            ego_speed: Measurement::new(self.v[1] as f32, now_us),
            ego_acceleration: Measurement::new(0.0, now_us),
            driver: None,
            now_us,
        }
    }

    /// Moves every car for `h` seconds at its acceleration (each stops at zero speed).
    fn advance(&mut self, a: [f64; 3], h: f64) {
        for ((x, v), a) in self.x.iter_mut().zip(self.v.iter_mut()).zip(a) {
            let stop = if a < 0.0 { *v / -a } else { h };
            let t = stop.min(h);
            *x += *v * t + 0.5 * a * t * t;
            *v = (*v + a * t).max(0.0);
        }
    }
}

/// What a run did: the hardest command, the emergency flags, the least gaps, whether the rear
/// half was ever unknown after the braking and certified again later.
#[derive(Debug, Default)]
struct Run {
    hardest: f32,
    /// The first command flagged an emergency after the cut-in (the answer's level).
    first_answer: Option<f32>,
    /// The cars at the cut-in.
    at_cut_in: Option<Cars>,
    below_band_periods: usize,
    /// Seconds from the cut-in to the first command below the band.
    first_below_band: Option<f64>,
    /// Seconds from the cut-in to the first command above -0.5 m/s^2 after one below the
    /// band (the brake lights' release), and to the follower's braking.
    released: Option<f64>,
    follower_brakes: Option<f64>,
    /// The rear state when the lights were released: (gap, ego's speed, follower's speed).
    at_release: Option<(f32, f32, f32)>,
    unflagged_below_band: usize,
    after_emergency: usize,
    /// After the braking below the band, a step evaluated the certificate again (the rear
    /// half from the table).
    rear_known_again: bool,
    least_gap_leader: f64,
    least_gap_follower: f64,
}

/// Cruising for 2 s, then the leader replaced by a car `cut_gap` ahead at `cut_speed` that
/// brakes at `leader_braking` to a stop, and the follower put `follower_gap` behind at the
/// ego's speed; it holds its speed, and brakes at 6 m/s^2 once the ego has braked for 1.15 s
/// (its brake lights on), until the ego stops braking. 30 s, or until a collision.
fn cut_in(speed: f64, cut_gap: f64, cut_speed: f64, leader_braking: f64, follower_gap: f64) -> Run {
    cut_in_closing(
        ideal(),
        speed,
        cut_gap,
        cut_speed,
        leader_braking,
        (follower_gap, 0.0),
    )
}

/// [`cut_in`] with the follower `(gap, faster)`: `faster` m/s faster than the ego at the
/// cut-in, and the controller configured by `config`.
fn cut_in_closing(
    config: firmware::Config,
    speed: f64,
    cut_gap: f64,
    cut_speed: f64,
    leader_braking: f64,
    (follower_gap, faster): (f64, f64),
) -> Run {
    let beta = -3.5f32;
    let mut c = Controller::new(DEFAULT_TABLE, config);
    let mut cars = Cars {
        x: [200.0, 0.0, -follower_gap],
        v: [speed, speed, speed],
    };
    let h = 0.02;
    let mut run = Run {
        least_gap_leader: f64::INFINITY,
        least_gap_follower: f64::INFINITY,
        ..Run::default()
    };
    let mut first_braking: Option<f64> = None;
    for k in 0..1_500u64 {
        let t = k as f64 * h;
        if k == 100 {
            cars.x[0] = cars.x[1] + cut_gap;
            cars.v[0] = cut_speed;
            // The follower as the run asks, whatever the law did before.
            cars.x[2] = cars.x[1] - follower_gap;
            cars.v[2] = cars.v[1] + faster;
            run.at_cut_in = Some(cars);
        }
        let cmd = c.step(&cars.inputs(k * 20_000));
        let a = cmd.acceleration;
        run.hardest = run.hardest.min(a);
        if k >= 100 && cmd.emergency && cmd.takeover && run.first_answer.is_none() {
            run.first_answer = Some(a);
        }
        if a > -0.5 && run.below_band_periods > 0 && run.released.is_none() {
            run.released = Some(t - 2.0);
            run.at_release = Some((
                (cars.x[1] - cars.x[2]) as f32,
                cars.v[1] as f32,
                cars.v[2] as f32,
            ));
        }
        if a < beta {
            run.below_band_periods += 1;
            run.first_below_band = run.first_below_band.or(Some(t - 2.0));
            if !(cmd.emergency && cmd.takeover) {
                run.unflagged_below_band += 1;
            }
        }
        if cmd.fault == Some(Fault::AfterEmergencyBraking) {
            assert_eq!(cmd.mode, Mode::Uncertified, "{k}: {cmd:?}");
            run.after_emergency += 1;
        } else if run.after_emergency > 0 && cmd.fault.is_none() && cmd.margin.is_some() {
            run.rear_known_again = true;
        }
        // The follower sees the lights while the ego brakes (the ideal plant: its acceleration
        // is the command); a release restarts its reaction.
        first_braking = match first_braking {
            _ if k < 100 || a >= 0.0 => None,
            Some(t0) => Some(t0),
            None => Some(t),
        };
        let a_leader = if k >= 100 { -leader_braking } else { 0.0 };
        let a_follower = match first_braking {
            Some(t0) if t - t0 >= 1.15 => {
                run.follower_brakes = run.follower_brakes.or(Some(t - 2.0));
                -6.0
            }
            _ => 0.0,
        };
        cars.advance([a_leader, f64::from(a), a_follower], h);
        run.least_gap_leader = run.least_gap_leader.min(cars.x[0] - cars.x[1]);
        run.least_gap_follower = run.least_gap_follower.min(cars.x[1] - cars.x[2]);
        if run.least_gap_leader <= 0.0 || run.least_gap_follower <= 0.0 {
            break;
        }
    }
    run
}

/// A car cutting in 12 m ahead at 15 m/s in front of an ego at 20 m/s, then braking at
/// 6 m/s^2: the band's 3.5 m/s^2 hits it (checked below), the emergency authority avoids it,
/// with no follower near (150 m back). Every command below the band is flagged an emergency
/// with the takeover request; afterwards the rear half is unknown until a follower
/// measurement taken after the braking's effect, then evaluated again.
#[test]
fn a_cut_in_the_band_cannot_answer_gets_the_emergency_authority() {
    let run = cut_in(20.0, 12.0, 15.0, 6.0, 150.0);
    assert!(run.least_gap_leader > 0.0, "{run:?}");
    assert!(run.hardest < -3.5 - 1.0, "{run:?}");
    assert!(run.hardest >= -8.0, "{run:?}");
    assert!(run.below_band_periods > 0, "{run:?}");
    assert_eq!(run.unflagged_below_band, 0, "{run:?}");
    assert!(run.after_emergency > 0, "{run:?}");
    assert!(run.rear_known_again, "{run:?}");
    // The band alone: the same cut-in with the emergency authority at the band's level.
    let band_only = {
        let mut cars = Cars {
            x: [12.0, 0.0, -150.0],
            v: [15.0, 20.0, 20.0],
        };
        let mut least = f64::INFINITY;
        for _ in 0..1_000 {
            cars.advance([-6.0, -3.5, 0.0], 0.02);
            least = least.min(cars.x[0] - cars.x[1]);
        }
        least
    };
    assert!(band_only < 0.0, "the band alone avoids it: {band_only}");
}

/// The same cut-in with a follower 10 m behind at the ego's speed: a follower that reacts
/// 1.15 s after the brake lights come on cannot follow much more than the band there at once;
/// the answer is the hardest level it allows (found to 0.02 m/s^2: about 3.8 m/s^2 at first,
/// 4.5 at the most before the car ahead is hit), where a follower far back allows the full
/// 8 m/s^2 at once. The car ahead is hit, not the ego from behind: the trade the certificate
/// refuses to make.
#[test]
fn a_close_follower_holds_the_emergency_authority_back() {
    let far = cut_in(20.0, 12.0, 15.0, 6.0, 150.0);
    let close = cut_in(20.0, 12.0, 15.0, 6.0, 10.0);
    assert!(far.first_below_band.is_some_and(|t| t < 0.1), "{far:?}");
    assert!(far.first_answer.is_some_and(|a| a < -7.9), "{far:?}");
    let first = close.first_answer.expect("the cut-in is answered");
    assert!(first < -3.5 - 0.1 && first > -4.5, "{close:?}");
    assert!(close.hardest > -5.0, "{close:?}");
    assert!(close.least_gap_leader <= 0.0, "{close:?}");
    assert!(close.least_gap_follower > 0.0, "{close:?}");
}

/// A cut-in the band's floor at once answers (40 m ahead at 21 m/s, braking at 2 m/s^2)
/// gets no braking below the band.
#[test]
fn a_cut_in_the_band_answers_gets_no_emergency_braking() {
    let run = cut_in(20.0, 40.0, 21.0, 2.0, 150.0);
    assert!(run.least_gap_leader > 0.0, "{run:?}");
    assert!(run.hardest >= -3.5 - 1e-6, "{run:?}");
    assert!(run.first_answer.is_some(), "{run:?}");
    assert_eq!(run.below_band_periods, 0, "{run:?}");
    assert_eq!(run.after_emergency, 0, "{run:?}");
}

/// A cut-in that needs less than the band's floor gets less: a car 55 m ahead at the ego's
/// 20 m/s, inside the certified gap (about 60 m) but far from the worst case, is answered at
/// once with the gentlest braking that keeps its worst case (braking at 6 m/s^2 from the
/// cut-in) clear, flagged an emergency with the takeover request, not with the band's
/// 3.5 m/s^2: held, that level keeps the front margin against the worst case, and 85% of it
/// would not. The promise is kept in closed loop: the same cut-in braking at 6 m/s^2 to a
/// stop is not hit.
#[test]
fn a_cut_in_that_needs_less_than_the_band_gets_less() {
    let cruising = cut_in(20.0, 55.0, 20.0, 0.0, 150.0);
    let answer = cruising.first_answer.expect("the cut-in is answered");
    assert!(answer > -3.0 && answer <= -0.5, "{cruising:?}");
    assert!(cruising.hardest > -3.0, "{cruising:?}");
    assert!(cruising.least_gap_leader > 40.0, "{cruising:?}");
    // The answer's level held from the cut-in keeps the worst case clear by the front
    // margin (0.5 m); 85% of it does not: it is near the gentlest that does.
    let held = |level: f64| {
        let mut cars = cruising.at_cut_in.expect("a cut-in");
        let mut least = f64::INFINITY;
        for _ in 0..2_000 {
            cars.advance([-6.0, level, 0.0], 0.01);
            least = least.min(cars.x[0] - cars.x[1]);
        }
        least
    };
    assert!(held(f64::from(answer)) > 0.5 - 0.01, "{answer}");
    assert!(held(0.85 * f64::from(answer)) < 0.5, "{answer}");
    let braking = cut_in(20.0, 55.0, 20.0, 6.0, 150.0);
    assert_eq!(braking.first_answer, Some(answer), "{braking:?}");
    assert!(braking.least_gap_leader > 0.0, "{braking:?}");
    assert_eq!(braking.below_band_periods, 0, "{braking:?}");
}

/// With the emergency authority at the band's level (none), the first cut-in is braked at
/// the band's floor and hits the car ahead.
#[test]
fn without_an_emergency_authority_the_band_is_the_limit() {
    let mut config = ideal();
    config.certificate.emergency.braking.level = 3.5;
    let mut c = Controller::new(table_for(&config), config);
    let cars = Cars {
        x: [12.0, 0.0, -150.0],
        v: [15.0, 20.0, 20.0],
    };
    let cmd = c.step(&cars.inputs(1_000_000));
    assert_eq!(cmd.acceleration, -3.5, "{cmd:?}");
    let mut c = Controller::new(DEFAULT_TABLE, ideal());
    let cmd = c.step(&cars.inputs(1_000_000));
    assert!(cmd.acceleration < -3.5 && cmd.emergency, "{cmd:?}");
}

/// After braking below the band, the brakes are released (a command above -0.5 m/s^2) only
/// where the follower allows it: where, its reaction starting again, the band's floor keeps it
/// clear (`rear_gap_after` at the band's level, exact here: exact sensors, an ideal
/// actuator). Followers 15-30 m back, 2-4 m/s faster than the ego when a car cuts in 6-8 m
/// ahead, 0.5-1 m/s slower: the car ahead would allow the release earlier (by 0.12-0.4 s,
/// measured with the rule removed).
#[test]
fn the_brakes_are_released_only_where_the_follower_allows_it() {
    use firmware::table_format::rear::{rear_gap_after, ReactingFollower};
    let follower = ReactingFollower {
        // The reaction, from the release at the earliest (the rule takes it later, from when
        // the lights are next on for sure).
        reaction_time: 1.15,
        reaction_acceleration: 1.0,
        braking: 6.0,
        jerk: f32::INFINITY,
        max_speed: 35.0,
    };
    for (gap, faster) in [(30.0, 4.0), (20.0, 3.0), (15.0, 2.0)] {
        for (cut_gap, cut_speed) in [(8.0, 9.0), (7.5, 9.4), (6.0, 9.5)] {
            let run = cut_in_closing(ideal(), 10.0, cut_gap, cut_speed, 0.0, (gap, faster));
            assert!(run.below_band_periods > 0, "{run:?}");
            assert!(run.least_gap_leader > 0.0, "{run:?}");
            let (g, ego, behind) = run.at_release.unwrap();
            let clear = rear_gap_after(g, ego, behind, 3.5, 0.0, &follower);
            assert!(
                clear > 0.0,
                "{gap} {faster} {cut_gap}: {clear} at release, {run:?}"
            );
        }
    }
}

/// The lights' hold: the emergency answer's first command is counted on to light the brake
/// lights (the rear check credits the follower's reaction from then), so no later command is
/// gentler until they are on for sure, whatever the front says. A car cuts in 12 m ahead,
/// 5 m/s slower, braking at 6 m/s^2, and is gone again one period later (the old leader
/// 200 m ahead): the answer brakes below the band at once, and the next periods hold it
/// through the declared 0.1 s dead time, although the front is certified again; then the
/// command is free, and comes back above the band.
#[test]
fn the_emergency_answer_holds_its_braking_until_its_lights_are_on() {
    let mut c = Controller::new(DEFAULT_TABLE, firmware::Config::default());
    let mut cars = Cars {
        x: [200.0, 0.0, -150.0],
        v: [20.0, 20.0, 20.0],
    };
    let h = 0.02;
    let mut commands = Vec::new();
    for k in 0..200u64 {
        if k == 100 {
            cars.x[0] = cars.x[1] + 12.0;
            cars.v[0] = 15.0;
        }
        if k == 101 {
            cars.x[0] = cars.x[1] + 200.0;
            cars.v[0] = cars.v[1];
        }
        let cmd = c.step(&cars.inputs(k * 20_000));
        if k >= 100 {
            commands.push(cmd.acceleration);
            if cmd.acceleration < -3.5 {
                assert!(
                    cmd.emergency && cmd.takeover,
                    "{k}: unflagged below the band: {cmd:?}"
                );
            }
        }
        let a_leader = if k == 100 { -6.0 } else { 0.0 };
        cars.advance([a_leader, f64::from(cmd.acceleration), 0.0], h);
    }
    let first = commands[0];
    assert!(
        first < -3.5,
        "the answer brakes below the band: {commands:?}"
    );
    // The dead time (5 periods) at least, the lag's crossing of -1.3 m/s^2 after it.
    for (k, a) in commands.iter().enumerate().take(6) {
        assert!(
            *a <= first,
            "period {k} after the cut-in: {a} above {first}: {commands:?}"
        );
    }
    assert!(
        commands.iter().any(|a| *a > -3.5),
        "released once the lights are on: {commands:?}"
    );
}

/// A follower closing on the ego caps the law's acceleration (`LAW_FOLLOWER_HORIZON_S`):
/// behind a follower 30 m back closing at 3 m/s, at 20 m/s, the gap policy for the braking the
/// follower would allow 4 s on is at least 1.5 m longer than the one for the braking it allows
/// now (36.0 m and 29.4 m here at the driver's 1.0 s). With the leader at the ego's speed
/// halfway between the two, the law (set speed 30 m/s) does not accelerate towards the shorter
/// one after its first period (which has no look-ahead yet); behind a follower 30 m back at the
/// ego's speed it does. A cancel forgets the cap.
#[test]
fn a_closing_follower_caps_the_laws_acceleration() {
    let config = firmware::Config {
        certificate: firmware::CertificateConfig {
            authorities: firmware::Authorities::Two,
            ..ideal().certificate
        },
        // The driver's shortest time gap, 1.0 s: 24 m at 20 m/s.
        law: firmware::LawConfig {
            time_gap_setting: 0,
            set_speed: 30.0,
            ..ideal().law
        },
        ..ideal()
    };
    let leader_braking = match firmware::table_format::Table::parse(DEFAULT_TABLE)
        .unwrap()
        .header()
        .game
    {
        firmware::table_format::Game::ThreeCarSplit { leader, .. } => -leader.min,
        g => panic!("not a split table: {g:?}"),
    };
    let v = 20.0;
    let period = config.period_us;
    let h = f64::from(period) * 1e-6;
    // The policies now and 4 s on behind the closing follower, a leader far ahead.
    let mut probe = Controller::new(DEFAULT_TABLE, config);
    let far = Cars {
        x: [300.0, 0.0, -30.0],
        v: [v, v, v + 3.0],
    };
    probe.step(&far.inputs(0));
    probe.step(&far.inputs(u64::from(period)));
    let now = probe.desired_gap(v as f32);
    let ahead = probe
        .braking_ahead()
        .map(|b| probe.desired_gap_over(v as f32, leader_braking, b))
        .expect("a follower closing to look ahead at");
    assert!(ahead >= now + 1.5, "ahead {ahead} m, now {now} m");
    // A cancel forgets it with the commands it capped: the first period after a resume is
    // capped by its own look-ahead, not by the one from before the cancel.
    let mut cancelled = probe.clone();
    cancelled.request(firmware::DriverRequest::Cancel).unwrap();
    assert_eq!(cancelled.braking_ahead(), None);
    let gap = f64::from(now + ahead) / 2.0;
    // The hardest acceleration commanded over 0.6 s after the first period, behind a
    // follower 30 m back `faster` than the ego.
    let most = |faster: f64| {
        let mut c = Controller::new(DEFAULT_TABLE, config);
        let mut cars = Cars {
            x: [gap, 0.0, -30.0],
            v: [v, v, v + faster],
        };
        let mut most = f32::NEG_INFINITY;
        for k in 0..30u64 {
            let a = c.step(&cars.inputs(k * u64::from(period))).acceleration;
            // (The first period has no look-ahead to cap it with.)
            if k > 0 {
                most = most.max(a);
            }
            cars.advance([0.0, f64::from(a), 0.0], h);
        }
        most
    };
    let closing = most(3.0);
    assert!(
        closing <= 1e-3,
        "behind a closing follower: {closing} m/s^2"
    );
    let held = most(0.0);
    assert!(
        held >= 0.2,
        "behind a follower at the ego's speed: {held} m/s^2"
    );
}

/// With two authorities the rear check credits the commands the ego issued since the
/// follower's measurement (`least_issued_since`): the ego kept at least their least for the
/// track's age, then brakes at most at the level. In steady following at 30 m/s behind a
/// follower 1 s back at the same speed, the declared errors and delays, tracks 130 ms old and
/// nothing else changing, the hardest braking the follower allows the look-ahead rises once
/// the commands since the engagement reach back far enough (the declared dead time, five lag
/// time constants and a period before the measurement: 1.75 s in all), by about 0.15 m/s^2:
/// what 0.13 s of coasting is worth in the closed form.
#[test]
fn the_commands_issued_since_the_measurement_are_credited() {
    let config = firmware::Config {
        certificate: firmware::CertificateConfig {
            authorities: firmware::Authorities::Two,
            ..firmware::Config::default().certificate
        },
        law: firmware::LawConfig {
            set_speed: 30.0,
            ..firmware::Config::default().law
        },
        ..firmware::Config::default()
    };
    let period = u64::from(config.period_us);
    let age = 130_000u64;
    let cars = Cars {
        x: [400.0, 0.0, -32.0],
        v: [30.0, 30.0, 30.0],
    };
    let mut c = Controller::new(DEFAULT_TABLE, config);
    let mut allowed = Vec::new();
    for k in 0..150u64 {
        let now = age + k * period;
        let mut inputs = cars.inputs(now);
        inputs.leader.timestamp_us = now - age;
        inputs.follower.timestamp_us = now - age;
        let command = c.step(&inputs);
        assert!(command.acceleration.abs() < 0.5, "{command:?}");
        allowed.push(c.allowed_braking().map(|b| b.level));
    }
    let at = |t_us: u64| allowed[(t_us / period) as usize].expect("a level is allowed");
    let (before, after) = (at(1_000_000), at(2_900_000));
    assert!(
        after >= before + 0.1 && after <= before + 0.25,
        "before {before} m/s^2, after {after} m/s^2"
    );
}
