//! The two-car game on hj_reachability's reference grid (x in [-5, 45] m, v in [-10, 10] m/s,
//! T = 3 s, WENO5/RK3): distance between the computed and the exact safe-set boundary inside the
//! trusted box and at least 1 m/s from the low-speed face, at 51^2 to 401^2, for comparison with
//! hj_reachability's on the same grids (`bash solver/benches/compare_hj_reachability.sh` runs
//! both side by side; docs/numerics.md quotes the figures).
//! `cargo run -p solver --release --example two_car_accuracy`

use std::time::Instant;

use solver::exact::two_car_errors;
use solver::games::{Accel, TwoCar};
use solver::grid::{Grid, GridAxis};
use solver::hji::{solve, Boundary, Numerics, Stop};
use solver::trusted::agreement_box;

fn main() {
    let game = TwoCar {
        ego: Accel {
            min: -2.0,
            max: 2.0,
        },
        leader: Accel {
            min: -1.5,
            max: 1.5,
        },
        min_gap: 0.0,
    };
    println!(
        "| grid | solve (s) | trusted v range | max boundary error (m) | max value error (m) |"
    );
    println!("|---|---|---|---|---|");
    for n in [51, 101, 201, 401] {
        let axis = |name: &str, min: f64, max: f64| GridAxis::new(name, min, max, n);
        let grid = Grid::new(vec![
            axis("gap_leader", -5.0, 45.0),
            axis("rel_speed_leader", -10.0, 10.0),
        ])
        .expect("grid");
        let numerics = Numerics::default();
        let t0 = Instant::now();
        let lo = solve(&game, &grid, numerics, Stop::Horizon(3.0), |_, _, _| {}).expect("solves");
        let seconds = t0.elapsed().as_secs_f64();
        let hi = solve(
            &game,
            &grid,
            Numerics {
                boundary: Boundary::Optimistic,
                ..numerics
            },
            Stop::Horizon(3.0),
            |_, _, _| {},
        )
        .expect("solves");
        let mut bx = agreement_box(&grid, &lo.values, &hi.values, 0.01).expect("a trusted box");
        // Away from the low-speed face: at least 1 m/s inside it.
        let v = &grid.axes()[1];
        let inner = ((-9.0 - v.min) / v.spacing()).ceil() as usize;
        bx.lo[1] = bx.lo[1].max(inner);
        let e = two_car_errors(&grid, &lo.values, 3.0, -2.0, -1.5, 0.0, &bx);
        let b = bx.bounds(&grid);
        println!(
            "| {n}^2 | {seconds:.2} | [{:.1}, {:.1}] | {:.4} | {:.4} |",
            b[1].0, b[1].1, e.max_boundary_error, e.max_value_error
        );
    }
}
