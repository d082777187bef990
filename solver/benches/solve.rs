//! The solver's speed and memory on hj_reachability's reference problem (docs/numerics.md quotes
//! both side by side; `bash solver/benches/compare_hj_reachability.sh` measures them): the paper's
//! 4-D baseline, u2 in [-2, 2], u1, u3 in [-1.5, 1.5], l = min(x1, x2), x in [-5, 45] m, v in [-10,
//! 10] m/s, T = 3 s, WENO5 + TVD-RK3, CFL 0.75, global Lax-Friedrichs, extrapolating boundary.
//!
//! `cargo bench -p solver --bench solve -- [POINTS ...] [--repeat N]` (default: 21 31, 3 repeats).
//! Prints, per grid, the median wall time of the solve, the steps, the share of nodes with
//! V > 1 mm, and the process's peak resident memory so far (run one grid per process for a clean
//! peak: `-- 41`). `solver/benches/compare_hj_reachability.sh` runs hj_reachability beside it.

use std::time::Instant;

use solver::games::{Accel, ThreeCarBaseline};
use solver::grid::{Grid, GridAxis};
use solver::hji::{solve, Boundary, Dissipation, Numerics, Obstacle, RkOrder, Stop};
use solver::scheme::Spatial;

fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() {
    let mut points = Vec::new();
    let mut repeat = 3usize;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--repeat" => repeat = args.next().and_then(|s| s.parse().ok()).unwrap_or(3),
            "--bench" => {}
            other => {
                if let Ok(p) = other.parse::<usize>() {
                    points.push(p);
                }
            }
        }
    }
    if points.is_empty() {
        points = vec![21, 31];
    }
    let game = ThreeCarBaseline {
        ego: Accel {
            min: -2.0,
            max: 2.0,
        },
        leader: Accel {
            min: -1.5,
            max: 1.5,
        },
        follower: Accel {
            min: -1.5,
            max: 1.5,
        },
        min_gap: 0.0,
    };
    let numerics = Numerics {
        spatial: Spatial::Weno5,
        rk: RkOrder::Three,
        cfl: 0.75,
        dissipation: Dissipation::Global,
        boundary: Boundary::Extrapolate,
        obstacle: Obstacle::Freeze,
    };
    println!("threads: {}", rayon::current_num_threads());
    println!(
        "| grid | steps | solve median (s) | solve runs (s) | share V > 1 mm | peak RSS (MB) |"
    );
    println!("|---|---|---|---|---|---|");
    for n in points {
        let axis = |name: &str, lo: f64, hi: f64| GridAxis::new(name, lo, hi, n);
        let grid = Grid::new(vec![
            axis("gap_leader", -5.0, 45.0),
            axis("rel_speed_leader", -10.0, 10.0),
            axis("gap_follower", -5.0, 45.0),
            axis("rel_speed_follower", -10.0, 10.0),
        ])
        .expect("valid grid");
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..repeat.max(1) {
            let t0 = Instant::now();
            let s =
                solve(&game, &grid, numerics, Stop::Horizon(3.0), |_, _, _| {}).expect("solves");
            times.push(t0.elapsed().as_secs_f64());
            last = Some(s);
        }
        let s = last.expect("at least one run");
        let share = s.values.iter().filter(|&&v| v > 1e-3).count() as f64 / s.values.len() as f64;
        let mut sorted = times.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let runs: Vec<String> = times.iter().map(|t| format!("{t:.2}")).collect();
        println!(
            "| {n}^4 | {} | {median:.2} | {} | {share:.3} | {:.0} |",
            s.steps,
            runs.join(" "),
            peak_rss_mb()
        );
    }
}
