//! The closed loop's followers that react like a person: [`Follower::IdmReacting`], the
//! two-authority certificate's, and [`Follower::IdmAfterReacting`], which drives by its IDM
//! once it has reacted (beyond the certificate's model).

use firmware::{Certifier, Config};
use host_tests::humans::Humans;
use host_tests::sim::Car;
use host_tests::{Follower, Leader};
use rand::rngs::StdRng;
use rand::SeedableRng;
use table_format::Table;

/// The ego brakes at 3.5 m/s^2 from 1 s to 4 s, its lights sampled each period as the loop's
/// world samples them (on from the 1.00 s sample, seen by the humans from the next period, as
/// on since a period before the sample, the earliest they can have come on); the follower
/// `gap` metres behind at the ego's 25 m/s. Returns `(t, follower's acceleration)` per period.
fn run(table: &Table<'_>, follower: Follower, gap: f32) -> Vec<(f32, f32)> {
    let h = 0.02f32;
    let reacting = Certifier::new(table.clone(), &Config::default())
        .unwrap()
        .reacting_follower();
    let mut rng = StdRng::seed_from_u64(1);
    let mut humans = Humans::new(table, Leader::Comfortable, follower, reacting, &mut rng).unwrap();
    let mut ego = Car { x: 0.0, v: 25.0 };
    let mut behind = Car { x: -gap, v: 25.0 };
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
}

fn at(v: &[(f32, f32)], t: f32) -> f32 {
    v.iter().find(|p| p.0 >= t - 1e-4).unwrap().1
}

/// The reacting follower keeps the acceleration it had when it saw the lights for its whole
/// reaction time, counted from their earliest onset, then brakes at the model's whole level
/// (6 m/s^2) until the lights go off, and drives by its IDM (at the range's closest time gap)
/// again. The instant IDM answers the braking within 0.1 s.
#[test]
fn the_reacting_follower_holds_its_acceleration_then_brakes_at_its_level() {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    let h = 0.02f32;
    let reaction = Certifier::new(table.clone(), &Config::default())
        .unwrap()
        .reacting_follower()
        .reaction_time;
    for gap in [20.0, 80.0] {
        let reacting = run(&table, Follower::IdmReacting, gap);
        let instant = run(&table, Follower::IdmWorstCase, gap);
        // The lights are sampled on at 1.00 s and seen at 1.02 s; the clock starts at 0.98 s.
        let (seen, on) = (1.0 + h, 1.0 - h);
        let held = at(&reacting, seen - h);
        for &(t, a) in &reacting {
            if t >= seen - 1e-4 && t < on + reaction - 1e-3 {
                assert_eq!(a, held, "{gap} m behind, at {t}");
            } else if t >= on + reaction - 1e-3 && t < 4.0 {
                assert_eq!(a, -6.0, "{gap} m behind, at {t}");
            }
        }
        // The lights go off after 4 s: its IDM again.
        assert!(at(&reacting, 4.2) > -6.0, "{gap} m behind");
        if gap < 50.0 {
            assert!(
                at(&instant, seen + 0.1) < held - 0.1,
                "{}",
                at(&instant, seen + 0.1)
            );
        }
    }
}

/// Far back (80 m at equal speeds), the follower that drives by its IDM once it has reacted
/// brakes far less than the model's 6 m/s^2: the follower the certificate does not cover.
#[test]
fn the_follower_after_its_reaction_by_its_idm_brakes_less_than_the_model() {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    let beyond = run(&table, Follower::IdmAfterReacting, 80.0);
    let declared = run(&table, Follower::IdmReacting, 80.0);
    let after = at(&beyond, 2.3);
    assert!(after > -3.0, "{after}");
    assert_eq!(at(&declared, 2.3), -6.0);
    assert!(!Follower::IdmAfterReacting.in_model_for(firmware::Authorities::Two));
    assert!(Follower::IdmReacting.in_model_for(firmware::Authorities::Two));
}
