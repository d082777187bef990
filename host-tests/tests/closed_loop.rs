//! Closed-loop checks on small campaigns (seconds of CI time; the full campaign is
//! `host-tests/benches/campaign.sh`). The default table certifies 20 s; the firmware uses it
//! receding (the same table at every instant), which a finite-horizon value does not certify
//! for its whole horizon, so episodes here run half of it, 10 s.

use host_tests::campaign::{run_episode, run_group, Episode};
use host_tests::{Follower, Leader, SensorModel, Start};
use table_format::Table;

fn table() -> Table<'static> {
    Table::parse(firmware::DEFAULT_TABLE).unwrap()
}

fn group(
    start: Start,
    leader: Leader,
    follower: Follower,
    episodes: usize,
    seed: u64,
) -> (usize, usize) {
    group_over(start, leader, follower, episodes, seed, 10.0)
}

fn group_over(
    start: Start,
    leader: Leader,
    follower: Follower,
    episodes: usize,
    seed: u64,
    seconds: f32,
) -> (usize, usize) {
    let t = table();
    let template = Episode {
        start,
        leader,
        follower,
        seconds,
        sensors: SensorModel::IDEAL,
        seed,
    };
    let (summary, _) = run_group(&t, firmware::DEFAULT_TABLE, template, episodes, &|| {});
    (summary.episodes, summary.collisions)
}

#[test]
fn certified_starts_survive_humans_that_keep_to_the_model() {
    let mut total = 0;
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
            let (n, collisions) = group(
                Start::Certified,
                leader,
                follower,
                25,
                1000 * (4 * i + j) as u64 + 7,
            );
            assert_eq!(n, 25, "could not sample certified starts");
            assert_eq!(collisions, 0, "{leader:?} leader, {follower:?} follower");
            total += n;
        }
    }
    assert_eq!(total, 300);
}

#[test]
fn starts_just_outside_the_safe_set_collide_under_worst_case_humans() {
    // Over the table's horizon (20 s): a start it does not certify is one the worst case can
    // bring to a collision within that time.
    let (n, collisions) = group_over(
        Start::JustOutside,
        Leader::WorstCase,
        Follower::IdmWorstCase,
        40,
        99,
        20.0,
    );
    let fraction = collisions as f64 / n as f64;
    println!("just outside, worst-case humans, 20 s: {collisions} of {n}");
    assert!(
        fraction > 0.5,
        "only {fraction} collide: the set would be needlessly conservative"
    );
}

#[test]
fn without_the_idm_structure_certified_starts_are_not_safe() {
    // The paper's point: against a follower free to accelerate (the baseline), the table's
    // certificate means nothing; many certified starts end in a collision.
    let (n, collisions) = group(
        Start::Certified,
        Leader::WorstCase,
        Follower::Unbounded,
        40,
        5,
    );
    println!("certified starts, unbounded follower: {collisions} of {n}");
    assert!(collisions as f64 / n as f64 > 0.2);
    // Given time, none is: a leader braking to a stop and the baseline's worst-case follower
    // (full acceleration) close the space between them whatever the ego does.
    let (n, collisions) = group_over(
        Start::Certified,
        Leader::HardBrake,
        Follower::Unbounded,
        30,
        11,
        30.0,
    );
    println!(
        "certified starts, hard-braking leader, unbounded follower, 30 s: {collisions} of {n}"
    );
    assert_eq!(collisions, n, "a start survived the baseline's worst case");
}

#[test]
fn sensor_noise_latency_and_dropouts_are_survived_or_reported() {
    let t = table();
    let noisy = SensorModel {
        gap_noise: 0.2,
        speed_noise: 0.05,
        latency_periods: 2,
        dropout: 0.05,
    };
    let mut collisions = 0;
    for seed in 0..20 {
        let e = Episode {
            start: Start::Certified,
            leader: Leader::Random,
            follower: Follower::IdmRandom,
            seconds: 10.0,
            sensors: noisy,
            seed,
        };
        let o = run_episode(&t, firmware::DEFAULT_TABLE, &e, None).unwrap();
        collisions += usize::from(o.collided);
        assert_eq!(
            o.minimum_risk_share, 0.0,
            "5% dropouts never make data stale"
        );
    }
    assert_eq!(collisions, 0);
}
