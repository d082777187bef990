//! The split certificate's volume beside the 4-D table's, on the states both cover.
//!
//! `cargo run -p solver --release --example split_volume -- REAR_TABLE [SAMPLES]`
//!
//! A state `(gap_leader, leader_speed, gap_follower, follower_speed, ego_speed)` is certified by
//! - the 4-D table (`firmware/tables/default.bin`, the paper's bounds, horizon 20 s, ego speed
//!   assumed at least 15 m/s): in its trusted box, table value above its error bound;
//! - the split certificate at braking level `beta` (the rear table's band): the front value in
//!   closed form is positive for a leader braking at `b_L`, and the rear table's value, less its
//!   quantization error, is above `rear_level`.
//!
//! Samples are uniform over gaps in [0, 75] m, ego speed in [15, 35] m/s and relative speeds in
//! [-15, 15] m/s with every speed in [0, 35] m/s (the 4-D grid's box); a second line covers
//! every ego speed in [0, 35] m/s, where the 4-D table certifies nothing.
use rand::{Rng, SeedableRng};
use table_format::front::{front_value, FrontModel};
use table_format::{Game, Table};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rear_path = args
        .first()
        .expect("usage: split_volume REAR_TABLE [SAMPLES]");
    let samples: usize = args.get(1).map_or(200_000, |s| s.parse().expect("samples"));
    let rear_bytes = std::fs::read(rear_path).expect("rear table");
    let rear = Table::parse(&rear_bytes).expect("rear table parses");
    let Game::RearIdm { ego, .. } = rear.header().game else {
        panic!("not a rear table")
    };
    let beta = -ego.min;
    let q = rear.header().error_bound.total();
    let default_table = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/tables/default.bin"
    ))
    .expect("firmware/tables/default.bin");
    let four = Table::parse(&default_table).expect("default table");
    let bound = four.header().error_bound.total();
    let rear_level = 0.5f32;
    println!(
        "rear table: beta {beta} m/s^2, quantization {q:.4} m, rear level {rear_level} m; \
         4-D table bound {bound:.4} m; {samples} samples"
    );
    println!("| ego speeds | leader braking b_L (m/s^2) | 4-D table certifies | split certifies | both | split only | 4-D only |");
    println!("|---|---|---|---|---|---|---|");
    for (label, low) in [("15-35 m/s", 15.0f32), ("0-35 m/s", 0.0)] {
        for bl in [3.5f32, 6.0, 8.0] {
            let model = FrontModel {
                leader_braking: bl,
                ego_braking: beta,
                response_time: 0.0,
                response_acceleration: 0.0,
                max_speed: 35.0,
            };
            let mut rng = rand::rngs::StdRng::seed_from_u64(7);
            let (mut n, mut c4, mut cs, mut both) = (0usize, 0usize, 0usize, 0usize);
            while n < samples {
                let ve: f32 = rng.random_range(low..35.0);
                let vg1: f32 = rng.random_range(-15.0..15.0);
                let vg2: f32 = rng.random_range(-15.0..15.0);
                let (vl, vf) = (ve + vg1, ve - vg2);
                if !(0.0..=35.0).contains(&vl) || !(0.0..=35.0).contains(&vf) {
                    continue;
                }
                let x1: f32 = rng.random_range(0.0..75.0);
                let x2: f32 = rng.random_range(0.0..75.0);
                n += 1;
                let z4 = [x1, vg1, x2, vg2];
                let four_ok = ve >= 15.0
                    && four.in_trusted_box(&z4)
                    && four.value_at(&z4).is_ok_and(|v| v - bound > 0.0);
                let split_ok = front_value(x1, vl, ve, &model) > 0.0
                    && rear
                        .value_at(&[x2, vf, ve])
                        .is_ok_and(|w| w - q > rear_level);
                c4 += usize::from(four_ok);
                cs += usize::from(split_ok);
                both += usize::from(four_ok && split_ok);
            }
            let pct = |k: usize| 100.0 * k as f64 / n as f64;
            println!(
                "| {label} | {bl} | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.1}% |",
                pct(c4),
                pct(cs),
                pct(both),
                pct(cs - both),
                pct(c4 - both)
            );
        }
    }
}
