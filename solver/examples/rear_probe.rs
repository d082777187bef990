//! Probe: the rear game's sampled-data value on a grid.
use solver::games::{Accel, Idm, RearIdm};
use solver::grid::{Grid, GridAxis};
use solver::semi_lagrangian::iterate;
use std::time::Instant;

fn main() {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let beta = args.first().copied().unwrap_or(3.5) as f32;
    let dx = args.get(1).copied().unwrap_or(1.0);
    let dv = args.get(2).copied().unwrap_or(1.0);
    let bf = args.get(3).copied().unwrap_or(6.0) as f32;
    let h = args.get(4).copied().unwrap_or(0.1) as f32;
    let game = RearIdm {
        ego: Accel {
            min: -beta,
            max: 2.0,
        },
        follower_clip: Accel { min: -bf, max: 2.0 },
        idm: Idm {
            max_acceleration: 1.0,
            comfortable_deceleration: 1.5,
            desired_speed: 33.3,
            exponent: 4,
            jam_distance: 2.0,
        },
        time_gap: Accel { min: 1.0, max: 2.0 },
        max_speed: 35.0,
        min_gap: 0.0,
    };
    let nx = (150.0 / dx) as usize + 1;
    let nv = (35.0 / dv) as usize + 1;
    let grid = Grid::new(vec![
        GridAxis::new("gap_follower", -2.0, 148.0, nx),
        GridAxis::new("follower_speed", 0.0, 35.0, nv),
        GridAxis::new("ego_speed", 0.0, 35.0, nv),
    ])
    .unwrap();
    let t0 = Instant::now();
    let sol = iterate(&game, &grid, h, 1e-4, 20000, |k, r, v| {
        if k % 200 == 0 {
            let safe = v.iter().filter(|&&x| x > 0.5).count() as f64 / v.len() as f64;
            println!(
                "it={k} residual={r:.5} share(W>0.5)={safe:.4} ({:.1}s)",
                t0.elapsed().as_secs_f64()
            );
        }
    });
    println!(
        "converged {} iterations {} residual {:.2e} wall {:.1}s",
        sol.converged,
        sol.iterations,
        sol.residual,
        t0.elapsed().as_secs_f64()
    );
    for &(x, vf, ve) in &[
        (10.0, 0.0, 0.0),
        (3.0, 0.0, 0.0),
        (45.0, 30.0, 30.0),
        (30.0, 30.0, 30.0),
        (20.0, 20.0, 20.0),
        (60.0, 30.0, 30.0),
        (15.0, 10.0, 10.0),
        (40.0, 20.0, 25.0),
    ] {
        println!(
            "W({x}, {vf}, {ve}) = {:.3}",
            grid.interpolate(&sol.values, &[x, vf, ve])
        );
    }
    for v in [0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0] {
        let mut g = None;
        let mut x = 0.0;
        while x < 147.0 {
            if grid.interpolate(&sol.values, &[x, v, v]) > 0.5 {
                g = Some(x);
                break;
            }
            x += 0.25;
        }
        println!("equal speeds {v}: smallest gap with W>0.5: {g:?}");
    }
}
