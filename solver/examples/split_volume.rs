//! The split certificate's volume beside the 4-D table's, on the states both cover, and its
//! sensitivity to the bounds: the leader's hardest braking `b_L`, the ego's braking level
//! `beta` and the follower's hardest braking (one rear table per pair).
//!
//! `cargo run -p solver --release --example split_volume -- PLOT.png FOUR_D_TABLE REAR_TABLE...`
//! (`solver/benches/sensitivity.sh` runs it on the deployment and sensitivity tables).
//!
//! A state `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)` is certified by
//! - the 4-D table (`out/three-car-idm-4d-table/table.bin`, the firmware's table before the
//!   split: the paper's bounds, horizon 20 s, ego speed assumed at least 15 m/s): in its trusted
//!   box, table value above its error bound;
//! - the split certificate at braking level `beta` (the rear table's band), with the firmware's
//!   default levels: the front value in closed form for a leader braking at `b_L` is above
//!   `FRONT_LEVEL`, and the rear table's value, less its error bound, above `REAR_LEVEL`.
//!
//! Samples (200,000, fixed seed) are uniform over gaps in [0, 75] m, relative speeds in
//! [-15, 15] m/s and every speed in [0, 35] m/s (the 4-D grid's box), for ego speeds in
//! [15, 35] m/s (where the 4-D table speaks) and in [0, 35] m/s.
use plotters::style::{RGBColor, BLACK, BLUE, CYAN, GREEN, MAGENTA, RED};
use rand::{Rng, SeedableRng};
use solver::output::draw_curves;
use table_format::front::{front_value, FrontModel};
use table_format::{Game, Table};

/// The front value the split certificate asks for, m (the firmware's `front_margin`).
const FRONT_LEVEL: f32 = 0.5;
/// The rear value the split certificate asks for, m (the firmware's `rear_margin`).
const REAR_LEVEL: f32 = 0.0;
const SAMPLES: usize = 200_000;

/// A sampled state: gaps and speeds.
struct State {
    x1: f32,
    vl: f32,
    x2: f32,
    vf: f32,
    ve: f32,
}

fn samples(low_ego_speed: f32) -> Vec<State> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let mut out = Vec::with_capacity(SAMPLES);
    while out.len() < SAMPLES {
        let ve: f32 = rng.random_range(low_ego_speed..35.0);
        let vl = ve + rng.random_range(-15.0f32..15.0);
        let vf = ve - rng.random_range(-15.0f32..15.0);
        if !(0.0..=35.0).contains(&vl) || !(0.0..=35.0).contains(&vf) {
            continue;
        }
        let x1 = rng.random_range(0.0f32..75.0);
        let x2 = rng.random_range(0.0f32..75.0);
        out.push(State { x1, vl, x2, vf, ve });
    }
    out
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [plot, four_path, rears @ ..] = args.as_slice() else {
        panic!("usage: split_volume PLOT.png FOUR_D_TABLE REAR_TABLE...");
    };
    assert!(!rears.is_empty(), "no rear table given");
    let four_bytes = std::fs::read(four_path).expect("the 4-D table");
    let four = Table::parse(&four_bytes).expect("the 4-D table parses");
    assert_eq!(four.dims(), 4, "{four_path} is not a 4-D table");
    let bound = four.header().error_bound.total();
    let leader_brakings = [3.5f32, 4.0, 5.0, 6.0, 7.0, 8.0];
    let sets = [("15-35", samples(15.0)), ("0-35", samples(0.0))];
    let four_share: Vec<f64> = sets
        .iter()
        .map(|(_, states)| {
            let n = states
                .iter()
                .filter(|s| {
                    let z = [s.x1, s.vl - s.ve, s.x2, s.ve - s.vf];
                    s.ve >= 15.0
                        && four.in_trusted_box(&z)
                        && four.value_at(&z).is_ok_and(|v| v - bound > 0.0)
                })
                .count();
            100.0 * n as f64 / states.len() as f64
        })
        .collect();
    println!("4-D table (error bound {bound:.4} m): certifies {:.1}% of the states with ego speeds 15-35 m/s, {:.1}% over 0-35 m/s", four_share[0], four_share[1]);
    println!();
    println!("| beta (m/s^2) | follower braking (m/s^2) | b_L (m/s^2) | certified, ego 15-35 m/s | certified, ego 0-35 m/s | rear alone, 0-35 m/s |");
    println!("|---|---|---|---|---|---|");
    let palette = [RED, BLUE, GREEN, MAGENTA, CYAN, BLACK];
    let mut labels = Vec::new();
    let mut curves = Vec::new();
    for (k, path) in rears.iter().enumerate() {
        let bytes = std::fs::read(path).expect("rear table");
        let rear = Table::parse(&bytes).expect("rear table parses");
        let Game::ThreeCarSplit {
            ego, follower_clip, ..
        } = rear.header().game
        else {
            panic!("{path}: not a rear table")
        };
        let beta = -ego.min;
        let q = rear.header().error_bound.total();
        let rear_ok = |s: &State| {
            rear.value_at(&[s.x2, s.vf, s.ve])
                .is_ok_and(|w| w - q > REAR_LEVEL)
        };
        let rear_alone = sets[1].1.iter().filter(|s| rear_ok(s)).count();
        let mut points = Vec::new();
        for bl in leader_brakings {
            let model = FrontModel::step(bl, beta, 0.0, 0.0, 35.0);
            let share: Vec<f64> = sets
                .iter()
                .map(|(_, states)| {
                    let n = states
                        .iter()
                        .filter(|s| {
                            front_value(s.x1, s.vl, s.ve, &model) > FRONT_LEVEL && rear_ok(s)
                        })
                        .count();
                    100.0 * n as f64 / states.len() as f64
                })
                .collect();
            println!(
                "| {beta} | {} | {bl} | {:.1}% | {:.1}% | {:.1}% |",
                -follower_clip.min,
                share[0],
                share[1],
                100.0 * rear_alone as f64 / SAMPLES as f64
            );
            points.push((f64::from(bl), share[1]));
        }
        labels.push(format!(
            "split, beta {beta}, follower braking {} m/s^2",
            -follower_clip.min
        ));
        curves.push((palette[k % palette.len()], points));
    }
    labels.push("4-D table (paper's bounds; nothing below 15 m/s)".into());
    curves.push((
        RGBColor(120, 120, 120),
        leader_brakings
            .iter()
            .map(|&b| (f64::from(b), four_share[1]))
            .collect(),
    ));
    let drawn: Vec<solver::output::Curve<'_>> = labels
        .iter()
        .zip(curves)
        .map(|(l, (c, p))| (l.as_str(), c, p))
        .collect();
    draw_curves(
        std::path::Path::new(plot),
        "Certified share of sampled states (ego speeds 0-35 m/s)",
        "leader's hardest braking b_L (m/s^2)",
        "certified (% of samples)",
        &drawn,
    )
    .expect("plot");
    println!("\nwrote {plot}");
}
