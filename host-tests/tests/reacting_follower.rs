//! The closed loop's follower that reacts like a person ([`Follower::IdmReacting`]).

use host_tests::humans::{Humans, REACTION_TIME};
use host_tests::sim::Car;
use host_tests::{Follower, Leader};
use rand::rngs::StdRng;
use rand::SeedableRng;
use table_format::Table;

/// The ego brakes at 3.5 m/s^2 from 1 s to 4 s, its lights sampled each period as the loop's
/// world samples them (on from the 1.00 s sample, seen by the humans from the next period, as
/// on since a period before the sample, the earliest they can have come on); the follower,
/// 20 m behind at the ego's 25 m/s: the reacting follower keeps the acceleration it had when
/// it saw the lights for its whole reaction time, counted from then, and drives by its IDM (at
/// the range's closest time gap) again. The instant IDM answers the braking within 0.1 s.
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
        let mut lights: Option<f32> = None;
        for k in 0..300 {
            let t = k as f32 * h;
            let leader = Car {
                x: ego.x + 1e3,
                v: 25.0,
            };
            // As the loop gives them: the earliest they can have come on, a period before
            // the sample (`World::lights_on_at_the_earliest`).
            let earliest = lights.map(|on| on - h);
            let (_, a) = humans.accelerations(t, h, [leader, ego, behind], earliest, &mut rng);
            out.push((t, a));
            let a_ego = if (1.0 - 1e-4..4.0).contains(&t) {
                -3.5
            } else {
                0.0
            };
            lights = (a_ego < -1.3).then(|| lights.unwrap_or(t));
            ego.advance(a_ego, h);
            behind.advance(a, h);
        }
        out
    };
    let reacting = run(Follower::IdmReacting);
    let instant = run(Follower::IdmWorstCase);
    // The lights are sampled on at 1.00 s and seen at 1.02 s; the clock starts at 0.98 s.
    let (seen, on) = (1.0 + h, 1.0 - h);
    let at = |v: &[(f32, f32)], t: f32| v.iter().find(|p| p.0 >= t - 1e-4).unwrap().1;
    let held = at(&reacting, seen - h);
    for &(t, a) in &reacting {
        if t >= seen - 1e-4 && t < on + REACTION_TIME - 1e-3 {
            assert_eq!(a, held, "at {t}");
        }
    }
    // It reacts in the first period from its reaction time after the earliest onset.
    assert_ne!(at(&reacting, on + REACTION_TIME), held);
    let after = at(&reacting, on + REACTION_TIME + h);
    assert!(after < held - 1.0, "{after} after {held}");
    assert!(
        at(&instant, seen + 0.1) < held - 0.1,
        "{}",
        at(&instant, seen + 0.1)
    );
}
