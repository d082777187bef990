//! How the two readings of the IDM follower's speed change the safe set (issue: "report how the
//! safe sets differ"): `cargo run -p solver --release --example idm_readings [-- POINTS HORIZON]`.

use solver::games::{Accel, FollowerSpeedModel, Idm, ThreeCarBaseline, ThreeCarIdm};
use solver::grid::{Grid, GridAxis};
use solver::hji::{solve, Boundary, Numerics, Stop};

fn main() {
    let mut args = std::env::args().skip(1);
    let points: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(21);
    let horizon: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let axis = |name: &str, lo: f64, hi: f64| GridAxis::new(name, lo, hi, points);
    let grid = Grid::new(vec![
        axis("gap_leader", -5.0, 75.0),
        axis("rel_speed_leader", -15.0, 15.0),
        axis("gap_follower", -5.0, 75.0),
        axis("rel_speed_follower", -15.0, 15.0),
    ])
    .expect("grid");
    let human = Accel {
        min: -1.5,
        max: 1.5,
    };
    let ego = Accel {
        min: -2.0,
        max: 2.0,
    };
    let idm = Idm {
        max_acceleration: 1.0,
        comfortable_deceleration: 1.5,
        desired_speed: 33.3,
        exponent: 4,
        jam_distance: 0.0,
    };
    let game = |speed| ThreeCarIdm {
        ego,
        leader: human,
        follower_clip: human,
        idm,
        time_gap: Accel { min: 1.0, max: 2.0 },
        follower_speed: speed,
        min_gap: 0.0,
    };
    let share = |v: &[f32]| v.iter().filter(|&&x| x > 0.0).count() as f64 / v.len() as f64;
    for boundary in [Boundary::Pessimistic, Boundary::Optimistic] {
        let n = Numerics {
            boundary,
            ..Numerics::default()
        };
        let stop = Stop::Horizon(horizon);
        let b = solve(
            &ThreeCarBaseline {
                ego,
                leader: human,
                follower: human,
                min_gap: 0.0,
            },
            &grid,
            n,
            stop,
            |_, _, _| {},
        )
        .expect("solves");
        println!("{boundary:?} baseline: {:.4}", share(&b.values));
        for (label, speed) in [
            (
                "nominal ego speed 20 m/s",
                FollowerSpeedModel::NominalEgoSpeed { ego_speed: 20.0 },
            ),
            (
                "adversarial v3, ego speed in [0, 40]",
                FollowerSpeedModel::Adversarial {
                    min_ego_speed: 0.0,
                    max_speed: 40.0,
                },
            ),
            (
                "adversarial v3, ego speed in [15, 40]",
                FollowerSpeedModel::Adversarial {
                    min_ego_speed: 15.0,
                    max_speed: 40.0,
                },
            ),
        ] {
            let s = solve(&game(speed), &grid, n, stop, |_, _, _| {}).expect("solves");
            println!(
                "{boundary:?} IDM, {label}: safe share {:.4} at {:.1} s (residual {:.3})",
                share(&s.values),
                s.time,
                s.residual
            );
        }
    }
}
