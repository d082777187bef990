//! Closed-loop checks on small campaigns of 120 s episodes (the full campaign is
//! `host-tests/benches/campaign.sh`): the firmware on its default table, from starts over the
//! whole certified set, standstill included, with the delays its default configuration covers
//! at their limits: measurements 5 periods (100 ms) old, an actuator dead time of 100 ms and a
//! lag of 0.3 s.

use firmware::Config;
use host_tests::campaign::{run_episode, run_group, Episode, GroupSummary};
use host_tests::sim::ActuatorModel;
use host_tests::{Follower, Leader, SensorModel};
use table_format::Table;

/// The firmware's declared limits: 100 ms dead time, 0.3 s lag.
const ACTUATOR_AT_LIMITS: ActuatorModel = ActuatorModel {
    dead_time: 0.1,
    lag: 0.3,
};

/// Exact measurements, 5 periods old (the stale limit).
const LATE: SensorModel = SensorModel {
    gap_noise: 0.0,
    speed_noise: 0.0,
    latency_periods: [5; 3],
    dropout: 0.0,
};

fn table() -> Table<'static> {
    Table::parse(firmware::DEFAULT_TABLE).unwrap()
}

fn group(leader: Leader, follower: Follower, episodes: usize, seed: u64) -> GroupSummary {
    let t = table();
    let template = Episode {
        leader,
        follower,
        seconds: 120.0,
        sensors: LATE,
        actuator: ACTUATOR_AT_LIMITS,
        config: Config::default(),
        seed,
    };
    run_group(&t, firmware::DEFAULT_TABLE, template, episodes, &|| {}).0
}

#[test]
fn certified_starts_stay_certified_for_120_s_against_humans_that_keep_to_the_model() {
    let mut total = 0;
    let mut standstill_starts = 0;
    for (i, leader) in [Leader::StopAndGo, Leader::Random, Leader::HardBrake]
        .into_iter()
        .enumerate()
    {
        for (j, follower) in [
            Follower::IdmFixed,
            Follower::IdmRandom,
            Follower::IdmSwitching,
            Follower::IdmWorstCase,
        ]
        .into_iter()
        .enumerate()
        {
            let s = group(leader, follower, 12, 1000 * (4 * i + j) as u64 + 7);
            assert_eq!(s.episodes, 12, "could not sample certified starts");
            assert_eq!(s.collisions, 0, "{leader:?} leader, {follower:?} follower");
            assert_eq!(
                s.certificate_losses, 0,
                "{leader:?} leader, {follower:?} follower: the certificate was lost ({:?})",
                s.certificate_losses_by_mode
            );
            if leader == Leader::StopAndGo {
                assert!(
                    s.mean_leader_stops >= 3.0,
                    "the stop-and-go leader stopped {} times in 120 s",
                    s.mean_leader_stops
                );
            }
            standstill_starts += s.standstill_starts;
            total += s.episodes;
        }
    }
    assert_eq!(total, 144);
    assert!(standstill_starts > 0, "no start at standstill");
}

#[test]
fn a_follower_outside_the_model_breaks_the_certificate() {
    // The paper's point: against a follower free to accelerate (the baseline), the certificate
    // means nothing. The campaign must see it: every episode loses the rear half, and most
    // collide.
    let s = group(Leader::StopAndGo, Follower::Unbounded, 30, 5);
    println!(
        "unbounded follower: {} collisions, {} losses in {}",
        s.collisions, s.certificate_losses, s.episodes
    );
    assert_eq!(s.certificate_losses, s.episodes);
    assert_eq!(s.certificate_losses_by_mode.rear, s.episodes);
    assert!(s.collisions as f64 / s.episodes as f64 > 0.5);
}

#[test]
fn an_actuator_slower_than_declared_breaks_the_certificate_and_the_campaign_says_so() {
    // The firmware covers 100 ms of dead time; the car has 400 ms. Its look-ahead brakes too
    // late, and the campaign must see it: certificate losses, and every collision after one.
    let t = table();
    let (mut collisions, mut losses) = (0, 0);
    for seed in 0..40 {
        let e = Episode {
            leader: Leader::StopAndGo,
            follower: Follower::IdmRandom,
            seconds: 120.0,
            sensors: LATE,
            actuator: ActuatorModel {
                dead_time: 0.4,
                lag: 0.3,
            },
            config: Config::default(),
            seed,
        };
        let o = run_episode(&t, firmware::DEFAULT_TABLE, &e, None).unwrap();
        losses += usize::from(o.certificate_lost.is_some());
        if let Some(at) = o.collision_time {
            collisions += 1;
            let lost = o
                .certificate_lost
                .expect("a collision without a certificate loss");
            assert!(lost.0 <= at, "lost at {} s, collided at {at} s", lost.0);
        }
    }
    println!("dead time 400 ms: {collisions} collisions, {losses} losses in 40");
    assert!(
        losses > 0,
        "a slower actuator never defeated the certificate: the loss detector is suspect"
    );
}

#[test]
fn sensor_noise_and_dropouts_are_outside_the_certificate_and_reported() {
    // Noise is not in the argument; dropouts on top of 5 periods of latency make tracks stale,
    // a fault with the minimum-risk manoeuvre.
    let t = table();
    let noisy = SensorModel {
        gap_noise: 0.2,
        speed_noise: 0.05,
        latency_periods: [5; 3],
        dropout: 0.05,
    };
    let (mut collisions, mut losses, mut stale) = (0, 0, 0);
    for seed in 0..40 {
        let e = Episode {
            leader: Leader::StopAndGo,
            follower: Follower::IdmRandom,
            seconds: 120.0,
            sensors: noisy,
            actuator: ACTUATOR_AT_LIMITS,
            config: Config::default(),
            seed,
        };
        let o = run_episode(&t, firmware::DEFAULT_TABLE, &e, None).unwrap();
        losses += usize::from(o.certificate_lost.is_some());
        stale += usize::from(o.minimum_risk_share > 0.0);
        if let Some(at) = o.collision_time {
            collisions += 1;
            let lost = o
                .certificate_lost
                .expect("a collision without a certificate loss");
            assert!(lost.0 <= at, "lost at {} s, collided at {at} s", lost.0);
        }
    }
    println!("noise, 5 % dropouts: {collisions} collisions, {losses} losses, {stale} with stale tracks in 40");
    assert!(
        stale > 0,
        "dropouts after 5 periods of latency never made a track stale"
    );
}
