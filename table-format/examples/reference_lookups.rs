//! The Rust reader's answers at random states, for other readers to match bit for bit (the
//! Python reader's CI check, `python/check_against_rust.py`).
//!
//! `cargo run -p table-format --example reference_lookups -- TABLE N OUT`
//! writes `OUT`: `N` records of `d` state coordinates (`f32`), the value (`f32`, NaN where the
//! reader refuses the state) and the policy (`u8`: 0 brake, 1 accelerate, 255 none), all
//! little-endian. With `TABLE` = `--synthetic PATH` it first writes a 4-D uniform table of
//! 16-bit values with policy bits to `PATH` and uses it (the solver's 4-D layout).
//!
//! States: 80% uniform over the grid's box, 10% on nodes exactly, 10% up to 10% outside it.

use table_format::{
    encode, Axis, Bounds, Game, Horizon, HorizonStatus, Spacing, Table, TableContents, ValueBits,
};

/// A small xorshift generator: reproducible without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn synthetic() -> Vec<u8> {
    let axis = |name, unit, min, max, points| Axis {
        name,
        unit,
        min,
        max,
        points,
        spacing: Spacing::Uniform,
    };
    let axes = [
        axis("gap_leader", "m", -5.0, 75.0, 9),
        axis("rel_speed_leader", "m/s", -15.0, 15.0, 7),
        axis("gap_follower", "m", -5.0, 75.0, 6),
        axis("rel_speed_follower", "m/s", -15.0, 15.0, 5),
    ];
    let n: usize = axes.iter().map(|a| a.points as usize).product();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let values: Vec<f32> = (0..n).map(|_| rng.unit() * 40.0 - 10.0).collect();
    // Ties of the vote: a checkerboard of bits on some axes.
    let accelerate: Vec<bool> = (0..n).map(|k| (k / 3 + k / 35) % 2 == 0).collect();
    let trusted: Vec<Bounds> = axes.iter().map(|a| Bounds::new(a.min, a.max)).collect();
    encode(&TableContents {
        game: Game::ThreeCarBaseline {
            ego: Bounds::new(-2.0, 2.0),
            leader: Bounds::new(-1.5, 1.5),
            follower: Bounds::new(-1.5, 1.5),
        },
        min_gap: 0.0,
        horizon: Horizon {
            seconds: 20.0,
            status: HorizonStatus::Fixed,
        },
        axes: &axes,
        breakpoints: &[],
        trusted_box: &trusted,
        interpolation_error: 0.5,
        value_bits: ValueBits::Sixteen,
        values: &values,
        accelerate: &accelerate,
    })
    .expect("the synthetic table encodes")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (bytes, rest) = match args.as_slice() {
        [flag, path, rest @ ..] if flag == "--synthetic" => {
            let bytes = synthetic();
            std::fs::write(path, &bytes).expect("writing the synthetic table");
            (bytes, rest)
        }
        [path, rest @ ..] => (std::fs::read(path).expect("reading the table"), rest),
        _ => panic!("usage: reference_lookups TABLE|--synthetic PATH N OUT"),
    };
    let [n, out] = rest else {
        panic!("usage: reference_lookups TABLE|--synthetic PATH N OUT");
    };
    let n: usize = n.parse().expect("N");
    let table = Table::parse(&bytes).expect("the table parses");
    let d = table.dims();
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let mut record = Vec::with_capacity(n * (4 * d + 5));
    for _ in 0..n {
        let kind = rng.unit();
        let state: Vec<f32> = (0..d)
            .map(|k| {
                let b = table.axis_bounds(k).expect("axis");
                let points = table.header().axes[k].points as usize;
                if kind < 0.1 {
                    let i = (rng.next() as usize) % points;
                    table.breakpoint(k, i).expect("node")
                } else if kind < 0.2 {
                    let span = b.max - b.min;
                    b.min - 0.1 * span + rng.unit() * 1.2 * span
                } else {
                    b.min + rng.unit() * (b.max - b.min)
                }
            })
            .collect();
        let value = table.value_at(&state).unwrap_or(f32::NAN);
        let policy = match table.policy_at(&state) {
            Ok(table_format::EgoAction::Brake) => 0u8,
            Ok(table_format::EgoAction::Accelerate) => 1,
            Err(_) => 255,
        };
        for x in &state {
            record.extend_from_slice(&x.to_le_bytes());
        }
        record.extend_from_slice(&value.to_le_bytes());
        record.push(policy);
    }
    std::fs::write(out, record).expect("writing the records");
    println!("{n} lookups of a {d}-axis table written to {out}");
}
