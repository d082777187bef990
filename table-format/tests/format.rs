//! Round trips, interpolation, quantization and corruption of whole tables.

use proptest::prelude::*;
use table_format::{
    encode, Axis, Bounds, EgoAction, Error, FollowerSpeed, Game, Horizon, HorizonStatus,
    IdmParameters, Table, TableContents, ValueBits,
};

const NAMES: [&str; 4] = [
    "gap_leader",
    "rel_speed_leader",
    "gap_follower",
    "rel_speed_follower",
];

fn idm_game() -> Game {
    Game::ThreeCarIdm {
        ego: Bounds::new(-2.0, 2.0),
        leader: Bounds::new(-1.5, 1.5),
        follower_clip: Bounds::new(-1.5, 1.5),
        idm: IdmParameters {
            max_acceleration: 1.0,
            comfortable_deceleration: 1.5,
            desired_speed: 33.3,
            exponent: 4,
            jam_distance: 0.0,
        },
        time_gap: Bounds::new(1.0, 2.0),
        follower_speed: FollowerSpeed::Adversarial {
            min_ego_speed: 0.0,
            max_speed: 40.0,
        },
    }
}

fn axes(points: [u32; 4]) -> Vec<Axis<'static>> {
    let ranges = [(-5.0, 45.0), (-10.0, 10.0), (-5.0, 45.0), (-10.0, 10.0)];
    (0..4)
        .map(|k| Axis {
            name: NAMES[k],
            unit: if k % 2 == 0 { "m" } else { "m/s" },
            min: ranges[k].0,
            max: ranges[k].1,
            points: points[k],
            spacing: table_format::Spacing::Uniform,
        })
        .collect()
}

fn coords(axis: &Axis<'_>) -> Vec<f32> {
    (0..axis.points)
        .map(|i| axis.uniform_coordinate(i))
        .collect()
}

/// A 4-D table whose node values are `f` at the nodes and whose policy bit is `bit`.
fn table_of(
    points: [u32; 4],
    bits: ValueBits,
    f: impl Fn([f32; 4]) -> f32,
    bit: impl Fn([f32; 4]) -> bool,
) -> Vec<u8> {
    let axes = axes(points);
    let c: Vec<Vec<f32>> = axes.iter().map(coords).collect();
    let mut values = Vec::new();
    let mut accelerate = Vec::new();
    for a in &c[0] {
        for b in &c[1] {
            for d in &c[2] {
                for e in &c[3] {
                    values.push(f([*a, *b, *d, *e]));
                    accelerate.push(bit([*a, *b, *d, *e]));
                }
            }
        }
    }
    let trusted: Vec<Bounds> = axes
        .iter()
        .map(|a| Bounds::new(a.min + 1.0, a.max - 1.0))
        .collect();
    encode(&TableContents {
        game: idm_game(),
        min_gap: 0.0,
        horizon: Horizon {
            seconds: 3.0,
            status: HorizonStatus::Fixed,
        },
        axes: &axes,
        breakpoints: &[],
        trusted_box: &trusted,
        interpolation_error: 0.05,
        value_bits: bits,
        values: &values,
        accelerate: &accelerate,
    })
    .expect("encodes")
}

fn multilinear(z: [f32; 4]) -> f32 {
    0.5 * z[0] - 0.2 * z[1] * z[2] / 10.0 + 0.01 * z[0] * z[3] + 0.001 * z[0] * z[1] * z[2] * z[3]
        - 3.0
}

fn small() -> Vec<u8> {
    table_of([4, 3, 5, 3], ValueBits::Sixteen, multilinear, |z| {
        z[3] > 0.0
    })
}

#[test]
fn round_trip_keeps_header_and_node_values() {
    let bytes = small();
    let table = Table::parse(&bytes).expect("parses");
    let h = table.header();
    assert_eq!(h.game, idm_game());
    assert_eq!(h.axes.len(), 4);
    assert_eq!(h.axes[2].name, "gap_follower");
    assert_eq!(h.axes[1].unit, "m/s");
    assert_eq!(table.node_count(), 4 * 3 * 5 * 3);
    assert_eq!(h.error_bound.interpolation, 0.05);
    let axes = axes([4, 3, 5, 3]);
    let mut node = 0;
    for i in 0..4 {
        for j in 0..3 {
            for k in 0..5 {
                for l in 0..3 {
                    let z = [
                        axes[0].uniform_coordinate(i),
                        axes[1].uniform_coordinate(j),
                        axes[2].uniform_coordinate(k),
                        axes[3].uniform_coordinate(l),
                    ];
                    let v = table.value_at_node(node).unwrap();
                    assert!(v <= multilinear(z), "conservative at node {node}");
                    assert!(multilinear(z) - v <= h.error_bound.quantization + 1e-6);
                    let expected = if z[3] > 0.0 {
                        EgoAction::Accelerate
                    } else {
                        EgoAction::Brake
                    };
                    assert_eq!(table.action_at_node(node), Some(expected));
                    assert_eq!(table.policy_at(&z).unwrap(), expected, "node {node}");
                    node += 1;
                }
            }
        }
    }
    assert_eq!(table.value_at_node(node), None);
    assert_eq!(table.action_at_node(node), None);
}

#[test]
fn header_size_and_bytes_per_node_are_as_documented() {
    let n = 4 * 3 * 5 * 3;
    let bytes16 = table_of([4, 3, 5, 3], ValueBits::Sixteen, multilinear, |_| true);
    let bytes8 = table_of([4, 3, 5, 3], ValueBits::Eight, multilinear, |_| true);
    let header_len = u16::from_le_bytes([bytes16[6], bytes16[7]]) as usize;
    assert_eq!(bytes16.len(), 8 + header_len + 2 * n + n.div_ceil(8) + 4);
    assert_eq!(bytes8.len(), 8 + header_len + n + n.div_ceil(8) + 4);
    println!("4-D IDM header: {header_len} bytes");
    assert!(header_len < 256, "header is {header_len} bytes");
}

#[test]
fn interpolation_reproduces_multilinear_functions() {
    let bytes = small();
    let table = Table::parse(&bytes).unwrap();
    let tol = table.header().error_bound.quantization + 1e-4;
    let mut rng = 12345u64;
    let mut next = || {
        rng = rng
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (rng >> 40) as f32 / (1u64 << 24) as f32
    };
    for _ in 0..2000 {
        let z = [
            -5.0 + 50.0 * next(),
            -10.0 + 20.0 * next(),
            -5.0 + 50.0 * next(),
            -10.0 + 20.0 * next(),
        ];
        let v = table.value_at(&z).unwrap();
        let exact = multilinear(z);
        assert!(
            (v - exact).abs() <= tol,
            "at {z:?}: table {v}, exact {exact}"
        );
        assert!(v <= exact + 1e-4, "not conservative at {z:?}");
    }
}

#[test]
fn eight_bit_quantization_is_conservative_and_bounded() {
    let f = |z: [f32; 4]| (z[0] * 0.37).sin() * 20.0 + z[2] - z[1] * z[3] * 0.3;
    let bytes = table_of([5, 4, 6, 4], ValueBits::Eight, f, |_| false);
    let table = Table::parse(&bytes).unwrap();
    let q = table.header().quantization;
    assert_eq!(q.bits, 8);
    let e = table.header().error_bound.quantization;
    assert!(
        e <= q.scale * 1.0001,
        "error {e} above one step {}",
        q.scale
    );
    assert!(e > 0.0);
    let axes = axes([5, 4, 6, 4]);
    let mut node = 0;
    for i in 0..5 {
        for j in 0..4 {
            for k in 0..6 {
                for l in 0..4 {
                    let z = [
                        axes[0].uniform_coordinate(i),
                        axes[1].uniform_coordinate(j),
                        axes[2].uniform_coordinate(k),
                        axes[3].uniform_coordinate(l),
                    ];
                    let v = table.value_at_node(node).unwrap();
                    assert!(v <= f(z));
                    assert!(f(z) - v <= e);
                    node += 1;
                }
            }
        }
    }
}

#[test]
fn policy_between_nodes_follows_the_weighted_vote() {
    // Accelerate only where rel_speed_follower is at its top node.
    let bytes = table_of([3, 3, 3, 3], ValueBits::Eight, |_| 1.0, |z| z[3] > 9.0);
    let table = Table::parse(&bytes).unwrap();
    let near_top = [20.0, 0.0, 20.0, 6.0];
    let near_mid = [20.0, 0.0, 20.0, 4.0];
    assert_eq!(table.policy_at(&near_top).unwrap(), EgoAction::Accelerate);
    assert_eq!(table.policy_at(&near_mid).unwrap(), EgoAction::Brake);
    // Exactly halfway: a tie, resolved by the heaviest corner (the first, which brakes).
    assert_eq!(
        table.policy_at(&[20.0, 0.0, 20.0, 5.0]).unwrap(),
        EgoAction::Brake
    );
}

#[test]
fn states_outside_or_malformed_get_typed_errors() {
    let bytes = small();
    let table = Table::parse(&bytes).unwrap();
    assert_eq!(
        table.value_at(&[0.0, 0.0, 0.0]),
        Err(Error::DimensionMismatch {
            expected: 4,
            found: 3
        })
    );
    assert_eq!(
        table.value_at(&[0.0, f32::NAN, 0.0, 0.0]),
        Err(Error::NonFiniteState { axis: 1 })
    );
    assert_eq!(
        table.value_at(&[0.0, 0.0, f32::INFINITY, 0.0]),
        Err(Error::NonFiniteState { axis: 2 })
    );
    assert_eq!(
        table.value_at(&[0.0, 0.0, 0.0, 10.5]),
        Err(Error::OutOfDomain { axis: 3 })
    );
    assert!(
        table.value_at(&[45.0, 10.0, 45.0, 10.0]).is_ok(),
        "upper corner is in"
    );
    assert!(table.contains(&[45.0, 10.0, 45.0, 10.0]));
    assert!(!table.contains(&[45.0, 10.0, 45.0, f32::NAN]));
    assert!(!table.in_trusted_box(&[45.0, 10.0, 45.0, 10.0]));
    assert!(table.in_trusted_box(&[20.0, 0.0, 20.0, 0.0]));
}

#[test]
fn every_single_bit_flip_is_rejected() {
    let bytes = table_of([2, 2, 3, 2], ValueBits::Eight, multilinear, |z| z[0] > 0.0);
    for byte in 0..bytes.len() {
        for bit in 0..8 {
            let mut corrupt = bytes.clone();
            corrupt[byte] ^= 1 << bit;
            assert!(
                Table::parse(&corrupt).is_err(),
                "flip of bit {bit} in byte {byte} accepted"
            );
        }
    }
}

#[test]
fn truncated_or_extended_buffers_are_rejected() {
    let bytes = small();
    for len in 0..bytes.len() {
        assert!(
            Table::parse(&bytes[..len]).is_err(),
            "prefix of {len} accepted"
        );
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(Table::parse(&longer).is_err());
}

/// A file cut short is reported as truncated, with the length its header declares, not as a
/// checksum mismatch (once the header itself is whole); a flipped byte is still a checksum.
#[test]
fn a_cut_file_is_truncated_not_corrupt() {
    let bytes = small();
    let header_end = 8 + usize::from(u16::from_le_bytes([bytes[6], bytes[7]]));
    for len in [header_end + 4, bytes.len() / 2, bytes.len() - 1] {
        assert_eq!(
            Table::parse(&bytes[..len]).unwrap_err(),
            Error::Truncated {
                needed: bytes.len(),
                found: len
            },
            "cut at {len}"
        );
    }
    let mut flipped = bytes.clone();
    let last = flipped.len() - 10;
    flipped[last] ^= 1;
    assert!(matches!(
        Table::parse(&flipped).unwrap_err(),
        Error::Checksum { .. }
    ));
}

/// A table flashed into a slot of fixed size: the bytes after it are erased flash (`0xFF`), or
/// whatever an earlier, longer table left there.
#[test]
fn a_table_at_the_start_of_a_longer_region_is_found_by_its_declared_length() {
    let bytes = small();
    for fill in [0xFF_u8, 0x00, 0xA5] {
        let mut slot = bytes.clone();
        slot.resize(bytes.len() + 1000, fill);
        assert_eq!(Table::declared_len(&slot), Ok(bytes.len()));
        let table = Table::parse_prefix(&slot).expect("table in a slot");
        let whole = Table::parse(&bytes).expect("table");
        assert_eq!(table.header(), whole.header());
        assert_eq!(
            table.lookup(&[10.0, 1.0, 20.0, 2.0]),
            whole.lookup(&[10.0, 1.0, 20.0, 2.0])
        );
    }
    // Exactly the table's length is a slot too.
    assert!(Table::parse_prefix(&bytes).is_ok());
    // Erased flash, in either polarity, is not a table.
    assert_eq!(
        Table::parse_prefix(&[0xFF; 4096]).unwrap_err(),
        Error::BadMagic
    );
    assert_eq!(
        Table::parse_prefix(&[0; 4096]).unwrap_err(),
        Error::BadMagic
    );
    // A slot cut short of the declared table (a table too big for its slot).
    for len in 0..bytes.len() {
        assert!(
            Table::parse_prefix(&bytes[..len]).is_err(),
            "prefix of {len} accepted"
        );
    }
    assert_eq!(
        Table::parse_prefix(&bytes[..bytes.len() - 1]).unwrap_err(),
        Error::Truncated {
            needed: bytes.len(),
            found: bytes.len() - 1
        }
    );
    // A corrupt table in a slot is still refused by its CRC, and nothing beyond it is read.
    let mut slot = bytes.clone();
    slot.resize(bytes.len() + 64, 0xFF);
    let mid = bytes.len() / 2;
    slot[mid] ^= 0x10;
    assert!(matches!(
        Table::parse_prefix(&slot).unwrap_err(),
        Error::Checksum { .. }
    ));
}

#[test]
fn specific_corruptions_name_their_cause() {
    let bytes = small();
    let mut wrong_magic = bytes.clone();
    wrong_magic[0] = b'X';
    assert_eq!(Table::parse(&wrong_magic).unwrap_err(), Error::BadMagic);
    // A version-1 table (the layout without breakpoints) is refused by its version alone.
    let mut version_one = bytes.clone();
    version_one[4] = 1;
    assert_eq!(
        Table::parse(&version_one).unwrap_err(),
        Error::UnsupportedVersion { found: 1 }
    );
    // A version-2 table (the header without its verification record) likewise.
    let mut version_two = bytes.clone();
    version_two[4] = 2;
    assert_eq!(
        Table::parse(&version_two).unwrap_err(),
        Error::UnsupportedVersion { found: 2 }
    );
    // A version-3 table (no Proven horizon status) likewise.
    let mut version_three = bytes.clone();
    version_three[4] = 3;
    assert_eq!(
        Table::parse(&version_three).unwrap_err(),
        Error::UnsupportedVersion { found: 3 }
    );
    // A version-4 table (no measurement error in its verification record) likewise.
    let mut version_four = bytes.clone();
    version_four[4] = 4;
    assert_eq!(
        Table::parse(&version_four).unwrap_err(),
        Error::UnsupportedVersion { found: 4 }
    );
    // A version-5 table (a split table without its emergency declaration) likewise.
    let mut version_five = bytes.clone();
    version_five[4] = 5;
    assert_eq!(
        Table::parse(&version_five).unwrap_err(),
        Error::UnsupportedVersion { found: 5 }
    );
    // A version-6 table (no lights' deceleration in the declaration) likewise.
    let mut version_six = bytes.clone();
    version_six[4] = 6;
    assert_eq!(
        Table::parse(&version_six).unwrap_err(),
        Error::UnsupportedVersion { found: 6 }
    );
    let mut future = bytes.clone();
    future[4] = 8;
    assert_eq!(
        Table::parse(&future).unwrap_err(),
        Error::UnsupportedVersion { found: 8 }
    );
    let mut payload_flip = bytes.clone();
    let last = payload_flip.len() - 5;
    payload_flip[last] ^= 0x10;
    assert!(matches!(
        Table::parse(&payload_flip).unwrap_err(),
        Error::Checksum { .. }
    ));
}

/// Re-signs a modified body with a valid CRC, so that the checks behind the CRC are reached.
fn resign(mut body: Vec<u8>) -> Vec<u8> {
    let crc = table_format::CRC32.checksum(&body);
    body.extend_from_slice(&crc.to_le_bytes());
    body
}

#[test]
fn a_validly_signed_but_short_payload_is_rejected() {
    let bytes = small();
    let body = bytes[..bytes.len() - 5].to_vec();
    assert!(matches!(
        Table::parse(&resign(body)).unwrap_err(),
        Error::PayloadSize { .. }
    ));
}

#[test]
fn writer_refuses_bad_contents() {
    let axes = axes([2, 2, 2, 2]);
    let trusted: Vec<Bounds> = axes.iter().map(|a| Bounds::new(a.min, a.max)).collect();
    let values = vec![1.0f32; 16];
    let accelerate = vec![false; 16];
    let mut contents = TableContents {
        game: idm_game(),
        min_gap: 0.0,
        horizon: Horizon {
            seconds: 3.0,
            status: HorizonStatus::Fixed,
        },
        axes: &axes,
        breakpoints: &[],
        trusted_box: &trusted,
        interpolation_error: 0.0,
        value_bits: ValueBits::Sixteen,
        values: &values,
        accelerate: &accelerate,
    };
    assert!(encode(&contents).is_ok());
    contents.accelerate = &accelerate[..15];
    assert_eq!(
        encode(&contents).unwrap_err(),
        Error::ContentsSize {
            expected: 16,
            found: 15
        }
    );
    contents.accelerate = &accelerate;
    let mut with_nan = values.clone();
    with_nan[3] = f32::NAN;
    contents.values = &with_nan;
    assert_eq!(
        encode(&contents).unwrap_err(),
        Error::NonFiniteValue { node: 3 }
    );
    let wide: Vec<Bounds> = axes
        .iter()
        .map(|a| Bounds::new(a.min - 1.0, a.max))
        .collect();
    contents.trusted_box = &wide;
    assert_eq!(
        encode(&contents).unwrap_err(),
        Error::InvalidHeader("trusted box")
    );
}

proptest! {
    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        let _ = Table::parse(&bytes);
    }

    #[test]
    fn signed_garbage_after_a_valid_preamble_never_panics(
        tail in proptest::collection::vec(any::<u8>(), 0..300),
        header_len in 0u16..300,
    ) {
        let mut body = b"HJTB".to_vec();
        body.extend_from_slice(&1u16.to_le_bytes());
        body.extend_from_slice(&header_len.to_le_bytes());
        body.extend_from_slice(&tail);
        let signed = resign(body);
        if let Ok(table) = Table::parse(&signed) {
            let z = vec![0.0f32; table.dims()];
            let _ = table.lookup(&z);
        };
    }

    #[test]
    fn lookups_never_panic_and_stay_within_node_range(
        z in proptest::array::uniform4(-20.0f32..60.0),
    ) {
        let bytes = small();
        let table = Table::parse(&bytes).unwrap();
        match table.lookup(&z) {
            Ok(l) => {
                prop_assert!(table.contains(&z));
                let q = table.header().quantization;
                prop_assert!(l.value >= q.offset - 1e-3);
                prop_assert!(l.value <= q.offset + q.scale * 65535.0 + 1e-3);
            }
            Err(Error::OutOfDomain { .. }) => prop_assert!(!table.contains(&z)),
            Err(e) => prop_assert!(false, "unexpected {e:?}"),
        }
    }
}

/// A 3-D table on listed (uneven) breakpoints, without policy bits, of the multilinear function
/// `f`: the reader must reproduce `f` between nodes (multilinear interpolation is exact for it)
/// to within the quantization step.
fn listed_table(f: impl Fn(f32, f32, f32) -> f32, bits: ValueBits) -> (Vec<u8>, [Vec<f32>; 3]) {
    let gap: Vec<f32> = vec![-1.0, 0.0, 0.5, 1.0, 1.25, 1.5, 2.0, 4.0, 10.0, 40.0, 150.0];
    let speed: Vec<f32> = vec![0.0, 0.05, 0.1, 0.3, 1.0, 3.0, 8.0, 35.0];
    let axes = [
        Axis {
            name: "gap_follower",
            unit: "m",
            min: -1.0,
            max: 150.0,
            points: gap.len() as u32,
            spacing: table_format::Spacing::Listed,
        },
        Axis {
            name: "follower_speed",
            unit: "m/s",
            min: 0.0,
            max: 35.0,
            points: 36,
            spacing: table_format::Spacing::Uniform,
        },
        Axis {
            name: "ego_speed",
            unit: "m/s",
            min: 0.0,
            max: 35.0,
            points: speed.len() as u32,
            spacing: table_format::Spacing::Listed,
        },
    ];
    let uniform: Vec<f32> = (0..36).map(|i| i as f32).collect();
    let mut values = Vec::new();
    for &x in &gap {
        for &v in &uniform {
            for &w in &speed {
                values.push(f(x, v, w));
            }
        }
    }
    let bytes = encode(&TableContents {
        game: Game::ThreeCarSplit {
            ego: Bounds::new(-3.5, 2.0),
            leader: Bounds::new(-6.0, 2.0),
            follower: table_format::FollowerModel::Idm {
                clip: Bounds::new(-6.0, 2.0),
                idm: table_format::IdmParameters::HIGHWAY,
                time_gap: Bounds::new(1.0, 2.0),
            },
            max_speed: 35.0,
            emergency: table_format::EmergencyDeclaration::DEFAULT,
        },
        min_gap: 0.0,
        horizon: Horizon {
            seconds: 1.0,
            status: HorizonStatus::Fixed,
        },
        axes: &axes,
        breakpoints: &[&gap, &speed],
        trusted_box: &[
            Bounds::new(-1.0, 150.0),
            Bounds::new(0.0, 35.0),
            Bounds::new(0.0, 35.0),
        ],
        interpolation_error: 0.0,
        value_bits: bits,
        values: &values,
        accelerate: &[],
    });
    (bytes.unwrap(), [gap, uniform, speed])
}

#[test]
fn listed_axes_interpolate_exactly_between_uneven_breakpoints() {
    let f = |x: f32, v: f32, w: f32| 0.5 + 0.01 * x - 0.02 * v + 0.03 * w + 0.001 * x * v * w;
    let (bytes, [gap, _, speed]) = listed_table(f, ValueBits::Sixteen);
    let table = Table::parse(&bytes).unwrap();
    let step = table.header().quantization.scale;
    // Nodes, cell midpoints and arbitrary points, with cells of very different widths.
    let mut points = vec![(-1.0, 0.0, 0.0), (150.0, 35.0, 35.0), (1.3, 0.2, 0.07)];
    for (i, &x) in gap.iter().enumerate().skip(1) {
        for (j, &w) in speed.iter().enumerate().skip(1) {
            points.push((x, 17.5, w));
            points.push((0.5 * (x + gap[i - 1]), 3.3, 0.5 * (w + speed[j - 1])));
            points.push((
                0.9 * x + 0.1 * gap[i - 1],
                34.9,
                0.2 * w + 0.8 * speed[j - 1],
            ));
        }
    }
    for (x, v, w) in points {
        let got = table.value_at(&[x, v, w]).unwrap();
        let want = f(x, v, w);
        assert!(
            got <= want + 1e-4 && got >= want - step - 1e-3 * (1.0 + want.abs()),
            "value at ({x}, {v}, {w}): {got}, exact {want}"
        );
    }
    assert_eq!(table.policy_at(&[1.0, 1.0, 1.0]), Err(Error::NoPolicy));
    assert_eq!(table.action_at_node(0), None);
    assert_eq!(
        table.value_at(&[150.5, 1.0, 1.0]),
        Err(Error::OutOfDomain { axis: 0 })
    );
}

#[test]
fn bad_breakpoints_are_refused_by_writer_and_reader() {
    let f = |x: f32, _: f32, w: f32| x + w;
    let (bytes, _) = listed_table(f, ValueBits::Eight);
    Table::parse(&bytes).unwrap();
    // The breakpoint block starts right after the header; its first f32 is the gap axis' min.
    let header_len = u16::from_le_bytes([bytes[6], bytes[7]]) as usize;
    let block = 8 + header_len;
    let body = &bytes[..bytes.len() - 4];
    // Two breakpoints out of order, and a first breakpoint that is not the axis' min.
    for (at, value) in [(block + 8, 1.5f32), (block, -0.5f32)] {
        let mut broken = body.to_vec();
        broken[at..at + 4].copy_from_slice(&value.to_le_bytes());
        assert_eq!(
            Table::parse(&resign(broken)).unwrap_err(),
            Error::InvalidHeader("axis breakpoints")
        );
    }
    // A NaN breakpoint.
    let mut broken = body.to_vec();
    broken[block + 12..block + 16].copy_from_slice(&f32::NAN.to_le_bytes());
    assert!(Table::parse(&resign(broken)).is_err());
}

#[test]
fn node_indices_past_the_end_are_none_not_an_overflow() {
    // 16-bit values: the byte offset of a node is twice its index, which overflows for huge
    // indices (a panic in debug builds, the wrong node in release before the fix).
    let bytes = small();
    let t = Table::parse(&bytes).unwrap();
    let n = t.node_count();
    assert!(t.value_at_node(n - 1).is_some());
    for node in [n, usize::MAX / 2 + 1, usize::MAX - 1, usize::MAX] {
        assert_eq!(t.value_at_node(node), None, "{node}");
        assert_eq!(t.action_at_node(node), None, "{node}");
    }
}

#[test]
fn a_verification_record_changes_the_header_only() {
    let plain = small();
    let record = table_format::Verification {
        verifier: 1,
        rear_margin: 0.25,
        certified_cells: 1000,
        proven_cells: 998,
        shortest_period: 0.02,
        longest_period: 0.3,
        measurement_error: table_format::MeasurementError::default(),
    };
    let recorded = table_format::with_verification(&plain, record).expect("re-encodes");
    let (a, b) = (
        Table::parse(&plain).expect("parses"),
        Table::parse(&recorded).expect("parses"),
    );
    assert_eq!(a.header().verification, None);
    assert_eq!(b.header().verification, Some(record));
    assert!(!record.is_complete());
    // Every node, and so every lookup, is the same; the file grew by the record's bytes.
    for n in 0..a.node_count() {
        assert_eq!(a.value_at_node(n), b.value_at_node(n));
        assert_eq!(a.action_at_node(n), b.action_at_node(n));
    }
    assert_eq!(recorded.len(), plain.len() + 17 + 6 * 4);
    // A record the header cannot hold is refused.
    let bad = table_format::Verification {
        proven_cells: 1001,
        ..record
    };
    assert!(table_format::with_verification(&plain, bad).is_err());
    let bad = table_format::Verification {
        measurement_error: table_format::MeasurementError {
            range_rate: f32::NAN,
            ..record.measurement_error
        },
        ..record
    };
    assert!(table_format::with_verification(&plain, bad).is_err());
}

/// The emergency declaration is a split table's, declared anew without touching a value, and
/// a declaration that is not one is refused (by `Header::validate`, which the reader runs too).
#[test]
fn an_emergency_declaration_changes_the_header_only() {
    use table_format::authority::Braking;
    use table_format::EmergencyDeclaration;
    let (plain, _) = listed_table(|x, v, w| x - 0.1 * v + 0.05 * w, ValueBits::Sixteen);
    let default = match Table::parse(&plain).expect("parses").header().game {
        Game::ThreeCarSplit { emergency, .. } => emergency,
        g => panic!("not a split table: {g:?}"),
    };
    assert_eq!(default, EmergencyDeclaration::DEFAULT);
    let wet = EmergencyDeclaration {
        braking: Braking {
            level: 5.0,
            jerk: f32::INFINITY,
        },
        follower_reaction_time: 2.0,
        lights_deceleration: 0.7,
        lights_command: -1.0,
    };
    let declared = table_format::with_emergency(&plain, wet).expect("re-encodes");
    let (a, b) = (
        Table::parse(&plain).expect("parses"),
        Table::parse(&declared).expect("parses"),
    );
    match b.header().game {
        Game::ThreeCarSplit { emergency, .. } => assert_eq!(emergency, wet),
        g => panic!("not a split table: {g:?}"),
    }
    assert_eq!(declared.len(), plain.len());
    for n in 0..a.node_count() {
        assert_eq!(a.value_at_node(n), b.value_at_node(n));
    }
    // What is not a declaration: no braking, no build-up, a reaction that is none or beyond
    // the bound, a lights' deceleration below zero, lights commanded short of it.
    let bad = [
        EmergencyDeclaration {
            braking: Braking {
                level: 0.0,
                ..wet.braking
            },
            ..wet
        },
        EmergencyDeclaration {
            braking: Braking {
                level: f32::NAN,
                ..wet.braking
            },
            ..wet
        },
        EmergencyDeclaration {
            braking: Braking {
                jerk: 0.0,
                ..wet.braking
            },
            ..wet
        },
        EmergencyDeclaration {
            follower_reaction_time: -0.1,
            ..wet
        },
        EmergencyDeclaration {
            follower_reaction_time: table_format::MAX_REACTION_TIME + 0.01,
            ..wet
        },
        EmergencyDeclaration {
            lights_deceleration: -0.1,
            ..wet
        },
        EmergencyDeclaration {
            lights_deceleration: f32::NAN,
            ..wet
        },
        EmergencyDeclaration {
            lights_command: -0.7,
            ..wet
        },
        EmergencyDeclaration {
            lights_command: 0.0,
            ..wet
        },
        EmergencyDeclaration {
            lights_command: f32::NEG_INFINITY,
            ..wet
        },
    ];
    for d in bad {
        assert_eq!(
            table_format::with_emergency(&plain, d).unwrap_err(),
            Error::InvalidHeader("game parameters"),
            "{d:?}"
        );
    }
    // Only a split table declares one.
    assert!(table_format::with_emergency(&small(), wet).is_err());
}

/// A rough function of the nodes: its minimum over a box is at interior breakpoints as often as
/// at the box's ends, so a box minimum that skipped either would be caught.
fn rough(x: f32, v: f32, w: f32) -> f32 {
    let h = (x * 12.9898 + v * 78.233 + w * 37.719).sin() * 43_758.547;
    h - h.floor()
}

proptest! {
    /// `least_over_box` is never above the value anywhere in the box (sampled densely, the
    /// box's corners and the breakpoints inside included by chance only), and a dense sample
    /// comes within the interpolant's variation over one sample spacing of it.
    #[test]
    fn the_box_minimum_is_sound_and_attained(
        x in -1.0f32..140.0, dx in 0.0f32..6.0,
        v in 0.0f32..30.0, dv in 0.0f32..4.5,
        w in 0.0f32..30.0, dw in 0.0f32..2.0,
    ) {
        let (bytes, _) = listed_table(rough, ValueBits::Sixteen);
        let table = Table::parse(&bytes).unwrap();
        let (lo, hi) = ([x, v, w], [x + dx, v + dv, w + dw]);
        let least = match table.least_over_box(&lo, &hi) {
            Ok(l) => l,
            Err(Error::BoxTooWide { .. }) => return Ok(()),
            Err(e) => panic!("{e}"),
        };
        let n = 24;
        let mut dense = f32::INFINITY;
        for i in 0..=n {
            for j in 0..=n {
                for k in 0..=n {
                    let p = [
                        x + dx * i as f32 / n as f32,
                        v + dv * j as f32 / n as f32,
                        w + dw * k as f32 / n as f32,
                    ];
                    let value = table.value_at(&p).unwrap();
                    prop_assert!(least <= value + 1e-5, "{least} above {value} at {p:?}");
                    dense = dense.min(value);
                }
            }
        }
        // Node values are in [0, 1); over a sample spacing the interpolant moves at most by the
        // steepest cell's slope times the spacing: generous, but it fails for a minimum taken
        // over the wrong cells.
        prop_assert!(dense - least < 0.5, "dense {dense} against {least}");
    }
}

proptest! {
    /// `least_over_box` is the least of the interpolant at every combination of each axis'
    /// candidates (the box's ends and the breakpoints strictly inside), each looked up alone
    /// with `value_at`: the box's upper cell found by the breakpoint scan is the one a lookup
    /// finds, also where the box ends exactly on a breakpoint or at the grid's top (drawn here
    /// a third of the time each).
    #[test]
    fn the_box_minimum_is_the_least_over_its_candidates(
        x in -1.0f32..150.0, dx in 0.0f32..6.0, sx in 0u8..3,
        v in 0.0f32..35.0, dv in 0.0f32..4.5,
        w in 0.0f32..35.0, dw in 0.0f32..2.0, sw in 0u8..3,
    ) {
        let (bytes, [gaps, _, speeds]) = listed_table(rough, ValueBits::Sixteen);
        let table = Table::parse(&bytes).unwrap();
        // The upper end: as drawn, snapped to the first breakpoint at or above it, or the top.
        let snap = |lo: f32, d: f32, how: u8, nodes: &[f32]| -> f32 {
            let top = *nodes.last().unwrap();
            match how {
                0 => (lo + d).min(top),
                1 => nodes.iter().copied().find(|&b| b >= lo + d).unwrap_or(top),
                _ => top,
            }
        };
        let hi = [snap(x, dx, sx, &gaps), (v + dv).min(35.0), snap(w, dw, sw, &speeds)];
        let lo = [x, v, w];
        let least = match table.least_over_box(&lo, &hi) {
            Ok(l) => l,
            Err(Error::BoxTooWide { .. }) => return Ok(()),
            Err(e) => panic!("{e}"),
        };
        let candidates = |axis: usize| -> Vec<f32> {
            let mut c = vec![lo[axis]];
            let mut k = 0;
            while let Some(b) = table.breakpoint(axis, k) {
                if b > lo[axis] && b < hi[axis] {
                    c.push(b);
                }
                k += 1;
            }
            c.push(hi[axis]);
            c
        };
        let (cx, cv, cw) = (candidates(0), candidates(1), candidates(2));
        let mut reference = f32::INFINITY;
        for &a in &cx {
            for &b in &cv {
                for &c in &cw {
                    reference = reference.min(table.value_at(&[a, b, c]).unwrap());
                }
            }
        }
        prop_assert!(
            (least - reference).abs() <= 1e-6,
            "{least} against {reference} over {lo:?}..{hi:?}"
        );
    }
}

#[test]
fn the_box_minimum_finds_an_interior_breakpoint_and_refuses_what_it_cannot_bound() {
    // A valley at the gap breakpoint 1.25 m, between box ends at 1.1 and 1.4.
    let f = |x: f32, _: f32, _: f32| (x - 1.25).abs();
    let (bytes, _) = listed_table(f, ValueBits::Sixteen);
    let table = Table::parse(&bytes).unwrap();
    let least = table
        .least_over_box(&[1.1, 3.0, 3.0], &[1.4, 3.5, 3.2])
        .unwrap();
    assert!(least.abs() < 1e-3, "{least}");
    // A point box is one lookup.
    let point = table.least_over_box(&[1.1, 3.0, 3.0], &[1.1, 3.0, 3.0]);
    assert_eq!(point, table.value_at(&[1.1, 3.0, 3.0]));
    // Six uniform breakpoints inside the follower-speed range are taken, seven are too
    // wide ([`BOX_INTERIOR`]), and so are eight.
    assert!(table
        .least_over_box(&[1.0, 0.5, 1.0], &[1.0, 6.5, 1.0])
        .is_ok());
    assert_eq!(
        table.least_over_box(&[1.0, 0.5, 1.0], &[1.0, 7.5, 1.0]),
        Err(Error::BoxTooWide { axis: 1 })
    );
    assert_eq!(
        table.least_over_box(&[1.0, 0.5, 1.0], &[1.0, 8.5, 1.0]),
        Err(Error::BoxTooWide { axis: 1 })
    );
    assert_eq!(
        table.least_over_box(&[1.0, 2.0, 1.0], &[1.0, 1.0, 1.0]),
        Err(Error::OutOfDomain { axis: 1 })
    );
    assert_eq!(
        table.least_over_box(&[1.0, 2.0, f32::NAN], &[1.0, 2.0, 1.0]),
        Err(Error::NonFiniteState { axis: 2 })
    );
}
