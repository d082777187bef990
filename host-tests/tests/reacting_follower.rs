//! The closed loop's follower that reacts like a person ([`Follower::IdmReacting`]).

use host_tests::humans::{Humans, REACTION_TIME};
use host_tests::sim::Car;
use host_tests::{Follower, Leader};
use rand::rngs::StdRng;
use rand::SeedableRng;
use table_format::Table;

/// The ego brakes at 3.5 m/s^2 from 1 s to 4 s; the follower,
/// 20 m behind at the ego's 25 m/s: the reacting follower keeps the acceleration it had when
/// the ego's lights came on for its whole reaction time, then drives by its IDM (at the range's
/// closest time gap) again. The instant IDM answers the braking within 0.1 s.
#[test]
fn the_reacting_follower_holds_its_acceleration_until_it_reacts() {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    let h = 0.02f32;
    let run = |follower: Follower| {
        let mut rng = StdRng::seed_from_u64(1);
        let mut humans = Humans::new(&table, Leader::Comfortable, follower, &mut rng).unwrap();
        let mut ego = Car { x: 0.0, v: 25.0 };
        let mut behind = Car { x: -20.0, v: 25.0 };
        let mut out = Vec::new();
        for k in 0..300 {
            let t = k as f32 * h;
            let leader = Car {
                x: ego.x + 1e3,
                v: 25.0,
            };
            let (_, a) = humans.accelerations(t, h, [leader, ego, behind], &mut rng);
            out.push((t, a));
            let a_ego = if (1.0..4.0).contains(&t) { -3.5 } else { 0.0 };
            ego.advance(a_ego, h);
            behind.advance(a, h);
        }
        out
    };
    let reacting = run(Follower::IdmReacting);
    let instant = run(Follower::IdmWorstCase);
    // The ego's speed first falls over the period from 1.00 s: the lights are seen at 1.02 s.
    let on = 1.02f32;
    let at = |v: &[(f32, f32)], t: f32| v.iter().find(|p| p.0 >= t - 1e-4).unwrap().1;
    let held = at(&reacting, on - h);
    for &(t, a) in &reacting {
        if t >= on && t < on + REACTION_TIME - 1e-3 {
            assert_eq!(a, held, "at {t}");
        }
    }
    let after = at(&reacting, on + REACTION_TIME + h);
    assert!(after < held - 1.0, "{after} after {held}");
    assert!(
        at(&instant, on + 0.1) < held - 0.1,
        "{}",
        at(&instant, on + 0.1)
    );
}
