//! The rear game's sampled-data value under grid refinement, on a low-speed domain (speeds in
//! [0, 8] m/s, gaps in [-2, 30] m), where the rest point that sets the whole plateau lives:
//! `cargo run -p solver --release --example rear_probe` (about 6 minutes on two cores);
//! `-- uneven` instead solves the whole speed range (0-35 m/s, gaps to 150 m) on breakpoint
//! axes fine only near the rest point (about 5 and 20 minutes for its two rows).
//!
//! The true value is at most the jam distance `s0 = 2 m` everywhere (the follower creeps up to
//! `s0` behind a stopped ego) and close to it wherever the follower is comfortably far back;
//! the printed plateau shows how much of that margin the grid's resolution keeps.
use std::time::Instant;

use solver::games::{Accel, RearGame};
use solver::grid::{Grid, GridAxis};
use solver::semi_lagrangian::{iterate, Breakpoints};
use table_format::{Bounds, FollowerModel, IdmParameters};

fn main() {
    let game = RearGame {
        ego: Accel {
            min: -3.5,
            max: 2.0,
        },
        follower: FollowerModel::Idm {
            clip: Bounds::new(-6.0, 2.0),
            idm: IdmParameters::HIGHWAY,
            time_gap: Bounds::new(1.0, 2.0),
        },
        max_speed: 8.0,
        min_gap: 0.0,
        follower_robustness: 0.0,
    };
    println!("| spacing (m, m/s) | period (s) | nodes | iterations | wall (s) | W(10, 0, 0) | W(20, 5, 5) | W(3, 0, 0) |");
    println!("|---|---|---|---|---|---|---|---|");
    let uniform = std::env::args().nth(1).as_deref() != Some("uneven");
    for spacing in [1.0, 0.5, 0.25, 0.125].into_iter().filter(|_| uniform) {
        for h in [0.1f32, 0.5] {
            let grid = Breakpoints::from_uniform(
                &Grid::new(vec![
                    GridAxis::new("gap_follower", -2.0, 30.0, (32.0 / spacing) as usize + 1),
                    GridAxis::new("follower_speed", 0.0, 8.0, (8.0 / spacing) as usize + 1),
                    GridAxis::new("ego_speed", 0.0, 8.0, (8.0 / spacing) as usize + 1),
                ])
                .expect("grid"),
            )
            .expect("three axes");
            let t0 = Instant::now();
            let out = iterate(&game, &grid, h, 1e-5, 100_000, |_, _, _| {});
            let at = |x: f32, vf: f32, ve: f32| grid.interpolate(&out.values, &[x, vf, ve]);
            println!(
                "| {spacing} | {h} | {} | {} | {:.1} | {:.3} | {:.3} | {:.3} |",
                grid.len(),
                out.iterations,
                t0.elapsed().as_secs_f64(),
                at(10.0, 0.0, 0.0),
                at(20.0, 5.0, 5.0),
                at(3.0, 0.0, 0.0)
            );
        }
    }
    if uniform {
        return;
    }
    // The whole speed range, fine only near the rest point (small gaps, low speeds).
    let full = RearGame {
        max_speed: 35.0,
        ..game
    };
    println!();
    println!("| rest-point spacing (m, m/s) | period (s) | nodes | iterations | wall (s) | W(10, 0, 0) | W(45, 30, 30) | W(3, 0, 0) |");
    println!("|---|---|---|---|---|---|---|---|");
    let h = 0.1f32;
    for fine in [0.25f32, 0.125] {
        let speed = Breakpoints::piecewise(
            0.0,
            &[(1.0, fine), (3.0, 2.0 * fine), (8.0, 0.25), (35.0, 0.5)],
        );
        let gap = Breakpoints::piecewise(
            -1.0,
            &[
                (1.0, 0.25),
                (4.0, fine),
                (10.0, 2.0 * fine),
                (40.0, 0.5),
                (80.0, 1.0),
                (150.0, 2.0),
            ],
        );
        let grid = Breakpoints::new(vec![
            ("gap_follower".into(), gap),
            ("follower_speed".into(), speed.clone()),
            ("ego_speed".into(), speed),
        ])
        .expect("grid");
        let t0 = Instant::now();
        let out = iterate(&full, &grid, h, 1e-5, 100_000, |_, _, _| {});
        let at = |x: f32, vf: f32, ve: f32| grid.interpolate(&out.values, &[x, vf, ve]);
        println!(
            "| {fine} | {h} | {} | {} | {:.1} | {:.3} | {:.3} | {:.3} |",
            grid.len(),
            out.iterations,
            t0.elapsed().as_secs_f64(),
            at(10.0, 0.0, 0.0),
            at(45.0, 30.0, 30.0),
            at(3.0, 0.0, 0.0)
        );
    }
}
