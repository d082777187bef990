//! `verify` against cases whose answer is known in closed form, against sampled trajectories,
//! and on the firmware's table.

use solver::verify::{
    travel, verify, verify_cell, verify_suspects_first, Budget, Interval, RearModel, RearTable,
    Reason, Settings, StateBox, Stopped, Verdict,
};

/// A follower that always brakes at 6 m/s^2 (its clip is the single point -6) behind an ego
/// that never brakes (its band is [0, 2]); speeds in [0, 4] m/s.
fn braking_follower() -> RearModel {
    RearModel {
        ego_min: 0.0,
        ego_max: 2.0,
        follower: table_format::FollowerModel::Idm {
            clip: table_format::Bounds::new(-6.0, -6.0),
            idm: table_format::IdmParameters::HIGHWAY,
            time_gap: table_format::Bounds::new(1.0, 2.0),
        },
        max_speed: 4.0,
        min_gap: 0.0,
    }
}

const K: f64 = 0.3;
const PERIOD: f64 = 0.1;

/// `W = gap - K` on gaps 0, 0.25, ..., 10 m and speeds 0, 1, ..., 4 m/s: multilinear, so the
/// table is exact. Certified: `gap > K` (no error bound, no margin).
fn linear_table() -> RearTable {
    linear_table_with_gap_step(0.25)
}

/// [`linear_table`] with gaps `0, step, 2 step, ..., 10` m.
fn linear_table_with_gap_step(step: f64) -> RearTable {
    let n = (10.0 / step).round() as i32;
    let gaps: Vec<f64> = (0..=n).map(|i| step * f64::from(i)).collect();
    let speeds: Vec<f64> = (0..=4).map(f64::from).collect();
    let mut values = Vec::new();
    for &g in &gaps {
        for _ in &speeds {
            for _ in &speeds {
                values.push(g - K);
            }
        }
    }
    RearTable::new(
        braking_follower(),
        [gaps, speeds.clone(), speeds],
        values,
        0.0,
    )
    .expect("a valid table")
}

/// The checker on one period, searching every sub-box of an unproven cell (so that the
/// reason reported is the worst one's, as these tests expect).
fn settings(depth: u32) -> Settings {
    Settings {
        periods: vec![PERIOD],
        rear_margin: 0.0,
        max_depth: depth,
        exhaustive: true,
        ..Settings::default()
    }
}

/// The exact verdict of cell `(i, j, k)` of [`linear_table`]: the gap changes over the period by
/// `ego distance - follower distance`, least at the ego's lowest speed (no acceleration) and the
/// follower's highest (braking at 6). A cell wholly above the plane `gap = K` keeps its
/// certificate iff its lowest gap stays above `K`; a cell the plane cuts keeps it iff that
/// least change is positive (states arbitrarily close to the plane).
fn expected(i: usize, j: usize, k: usize) -> &'static str {
    let (g_lo, g_hi) = (0.25 * i as f64, 0.25 * (i + 1) as f64);
    let (vf_hi, ve_lo) = ((j + 1) as f64, k as f64);
    let change = ve_lo * PERIOD - travel(vf_hi, -6.0, PERIOD, 4.0).0;
    if g_hi <= K {
        "not certified"
    } else if g_lo >= K {
        if g_lo + change > K {
            "proven"
        } else {
            "unproven"
        }
    } else if change > 0.0 {
        "proven"
    } else {
        "unproven"
    }
}

fn name(v: &Verdict) -> &'static str {
    match v {
        Verdict::NotCertified => "not certified",
        Verdict::Proven | Verdict::ProvenAtStandstill => "proven",
        Verdict::Unproven { .. } => "unproven",
        Verdict::Unchecked => "unchecked",
    }
}

#[test]
fn a_hand_made_table_is_proven_exactly_where_it_is_invariant() {
    let table = linear_table();
    let level = 0.0;
    let mut tally = [0usize; 3];
    for i in 0..40 {
        for j in 0..4 {
            for k in 0..4 {
                let v = verify_cell(&table, &table.cell(i, j, k), level, &settings(12));
                assert_eq!(name(&v), expected(i, j, k), "cell ({i}, {j}, {k}): {v:?}");
                tally[match name(&v) {
                    "not certified" => 0,
                    "proven" => 1,
                    _ => 2,
                }] += 1;
            }
        }
    }
    // Every kind occurs, so the comparison above means something.
    assert!(tally.iter().all(|&n| n > 0), "{tally:?}");
}

/// Stopping a cell's search at its first unproven sub-box (the default) gives every cell the
/// verdict the exhaustive search gives.
#[test]
fn the_first_unproven_sub_box_decides_the_verdict() {
    let table = linear_table();
    let fast = Settings {
        exhaustive: false,
        ..settings(12)
    };
    let mut unproven = 0;
    for i in 0..40 {
        for j in 0..4 {
            for k in 0..4 {
                let cell = table.cell(i, j, k);
                let a = verify_cell(&table, &cell, 0.0, &settings(12));
                let b = verify_cell(&table, &cell, 0.0, &fast);
                assert_eq!(name(&a), name(&b), "cell ({i}, {j}, {k})");
                unproven += usize::from(name(&a) == "unproven");
            }
        }
    }
    assert!(unproven > 0);
}

/// A budget stops the check between chunks of cells: the cells not reached are unchecked,
/// counted as certified and unproven, and the table's record is incomplete.
#[test]
fn a_budget_stops_the_check_and_leaves_the_record_incomplete() {
    let table = linear_table();
    let full = verify(&table, 0, &settings(12));
    assert!(full.proven < full.certified && full.stopped.is_none() && full.unchecked == 0);
    let after_one = verify(
        &table,
        0,
        &Settings {
            budget: Budget {
                seconds: None,
                unproven_cells: Some(1),
            },
            ..settings(12)
        },
    );
    // The table is one chunk: the first unproven cell is found in it, and nothing is left.
    assert_eq!(after_one.unchecked, 0);
    let none = verify(
        &table,
        0,
        &Settings {
            budget: Budget {
                seconds: Some(0.0),
                unproven_cells: None,
            },
            ..settings(12)
        },
    );
    assert_eq!(none.stopped, Some(Stopped::Time));
    assert_eq!(none.unchecked, none.cells);
    assert_eq!((none.certified, none.proven), (none.cells, 0));
    assert!(!none.record().is_complete());
    assert!(none
        .verdicts
        .iter()
        .all(|v| matches!(v, Verdict::Unchecked)));
}

/// The suspects go first: the verdicts are the same, and a budget of one unproven cell is
/// spent on a suspect that fails, before any other cell is checked.
#[test]
fn suspected_cells_are_checked_first() {
    let table = linear_table();
    let full = verify(&table, 0, &settings(12));
    let [_, nj, nk] = table.cells();
    let flat = |c: &solver::verify::UnprovenCell| (c.index[0] * nj + c.index[1]) * nk + c.index[2];
    let last = flat(full.unproven.last().expect("an unproven cell"));
    let all = verify_suspects_first(&table, 0, &settings(12), &[last], &mut |_, _| {});
    assert_eq!(all.verdicts, full.verdicts);
    let fast = verify_suspects_first(
        &table,
        0,
        &Settings {
            budget: Budget {
                seconds: None,
                unproven_cells: Some(1),
            },
            ..settings(12)
        },
        &[last],
        &mut |_, _| {},
    );
    assert_eq!(fast.stopped, Some(Stopped::UnprovenCells));
    assert_eq!(fast.unchecked, fast.cells - 1);
    assert_eq!(fast.unproven.len(), 1);
    assert_eq!(flat(&fast.unproven[0]), last);
}

#[test]
fn the_cells_the_plane_cuts_with_a_closing_follower_are_tangent() {
    let table = linear_table();
    // Gap cell [0.25, 0.5] (the plane gap = 0.3 cuts it), follower 1-2 m/s, ego 0-1 m/s: the
    // gap closes by up to 0.17 m in the period, which takes states just above the plane below
    // it without a collision.
    match verify_cell(&table, &table.cell(1, 1, 0), 0.0, &settings(12)) {
        Verdict::Unproven { reason, deficit } => {
            assert_eq!(reason, Reason::Tangency);
            assert!(deficit > 0.0);
        }
        v => panic!("expected unproven, got {v:?}"),
    }
}

#[test]
fn raising_one_boundary_node_above_the_level_is_flagged() {
    let mut table = linear_table();
    // Before: the cell [0, 0.25] x [2, 3] x [1, 2] holds no certified state.
    let cell = table.cell(0, 2, 1);
    assert_eq!(
        verify_cell(&table, &cell, 0.0, &settings(12)),
        Verdict::NotCertified
    );
    // Raise its node (0.25, 3, 1) from -0.05 m to +0.5 m: states near it become certified, and
    // the closing follower takes them towards gap 0, where the value is -0.3.
    table.set_node(1, 3, 1, 0.5);
    assert!(matches!(
        verify_cell(&table, &cell, 0.0, &settings(12)),
        Verdict::Unproven { .. }
    ));
}

#[test]
fn a_level_too_low_for_the_period_is_a_collision() {
    // W = gap: certified means gap > level. At level 0 a follower closing at 4 m/s on a gap of
    // 1 cm collides within the period; at a level of 0.5 m no certified state can (the
    // closing distance in 0.1 s is below 0.4 m), and the cell is tangent instead.
    let mut table = linear_table();
    for i in 0..=40 {
        for j in 0..=4 {
            for k in 0..=4 {
                table.set_node(i, j, k, 0.25 * i as f64);
            }
        }
    }
    let low = verify_cell(&table, &table.cell(0, 3, 0), 0.0, &settings(12));
    assert!(
        matches!(
            low,
            Verdict::Unproven {
                reason: Reason::Collision,
                ..
            }
        ),
        "{low:?}"
    );
    let high = verify_cell(&table, &table.cell(2, 3, 0), 0.5, &settings(12));
    assert!(
        matches!(
            high,
            Verdict::Unproven {
                reason: Reason::Tangency,
                ..
            }
        ),
        "{high:?}"
    );
}

/// The IDM model of the deployment, for the sampled checks.
fn deployment_model() -> RearModel {
    RearModel {
        ego_min: -3.5,
        ego_max: 2.0,
        follower: table_format::FollowerModel::Idm {
            clip: table_format::Bounds::new(-6.0, 2.0),
            idm: table_format::IdmParameters::HIGHWAY,
            time_gap: table_format::Bounds::new(1.0, 2.0),
        },
        max_speed: 35.0,
        min_gap: 0.0,
    }
}

/// The follower's clipped IDM acceleration at a point, as the model states it.
fn idm(m: &RearModel, gap: f64, vf: f64, ve: f64, t: f64) -> f64 {
    m.follower
        .acceleration_f64(vf, vf - ve, gap, t)
        .clamp(m.clip_min(), m.clip_max())
}

#[test]
fn reach_bounds_contain_sampled_trajectories() {
    // Trajectories from random states of random boxes, with inputs that switch at random
    // instants, integrated finely: every state at the end lies in the end box and every gap
    // on the way above the least gap.
    use rand::{Rng, SeedableRng};
    let m = deployment_model();
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    for _ in 0..400 {
        let g0 = rng.random_range(0.5..40.0);
        let vf0 = rng.random_range(0.0..34.0);
        let ve0 = rng.random_range(0.0..34.0);
        let w = [
            rng.random_range(0.01..1.0),
            rng.random_range(0.01..1.0),
            rng.random_range(0.01..1.0),
        ];
        let b = StateBox {
            gap: Interval {
                lo: g0,
                hi: g0 + w[0],
            },
            follower_speed: Interval {
                lo: vf0,
                hi: (vf0 + w[1]).min(35.0),
            },
            ego_speed: Interval {
                lo: ve0,
                hi: (ve0 + w[2]).min(35.0),
            },
        };
        let period = [0.02, 0.1, 0.3][rng.random_range(0..3)];
        let reach = m.reach(&b, period);
        for _ in 0..20 {
            let mut g = rng.random_range(b.gap.lo..=b.gap.hi);
            let mut vf = rng.random_range(b.follower_speed.lo..=b.follower_speed.hi);
            let mut ve = rng.random_range(b.ego_speed.lo..=b.ego_speed.hi);
            let steps = 400;
            let dt = period / f64::from(steps);
            let (mut ae, mut t) = (m.ego_min, f64::from(m.follower.parameter_range().min));
            for _ in 0..steps {
                if rng.random_bool(0.05) {
                    ae = rng.random_range(m.ego_min..=m.ego_max);
                    t = rng.random_range(
                        f64::from(m.follower.parameter_range().min)
                            ..=f64::from(m.follower.parameter_range().max),
                    );
                }
                let af = idm(&m, g, vf, ve, t);
                let (de, ve1) = travel(ve, ae, dt, m.max_speed);
                let (df, vf1) = travel(vf, af, dt, m.max_speed);
                g += de - df;
                ve = ve1;
                vf = vf1;
                // Integration error of the explicit step: far below these slacks.
                assert!(
                    g >= reach.least_gap - 1e-4,
                    "gap {g} below {}",
                    reach.least_gap
                );
            }
            let e = reach.end;
            for (x, i) in [(g, e.gap), (vf, e.follower_speed), (ve, e.ego_speed)] {
                assert!(
                    x >= i.lo - 1e-4 && x <= i.hi + 1e-4,
                    "{x} outside {i:?} (box {b:?})"
                );
            }
        }
    }
}

#[test]
fn the_least_value_over_a_box_is_at_a_candidate_point() {
    // The exact extremes against a dense sampling of a box spanning several cells.
    let table = linear_table();
    let mut t = table.clone();
    for (n, (i, j, k)) in (0..=40)
        .flat_map(|i| (0..=4).flat_map(move |j| (0..=4).map(move |k| (i, j, k))))
        .enumerate()
    {
        t.set_node(i, j, k, ((n * 7919) % 101) as f64 * 0.01);
    }
    let b = StateBox {
        gap: Interval { lo: 0.1, hi: 0.9 },
        follower_speed: Interval { lo: 0.3, hi: 2.6 },
        ego_speed: Interval { lo: 1.2, hi: 3.9 },
    };
    let e = t.extremes(&b);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for a in 0..=40 {
        for c in 0..=40 {
            for d in 0..=40 {
                let f = |i: Interval, s: i32| i.lo + (i.hi - i.lo) * f64::from(s) / 40.0;
                let w = t.value_at([f(b.gap, a), f(b.follower_speed, c), f(b.ego_speed, d)]);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
    }
    assert!(
        e.lo <= lo + 1e-12 && e.hi >= hi - 1e-12,
        "{e:?} vs sampled [{lo}, {hi}]"
    );
    assert!(
        lo - e.lo < 0.02 && e.hi - hi < 0.02,
        "{e:?} vs sampled [{lo}, {hi}]"
    );
}

#[test]
fn the_firmware_table_is_proven_in_every_certified_cell() {
    let bytes = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/tables/default.bin"
    ))
    .expect("the committed table");
    let table = table_format::Table::parse(&bytes).expect("it parses");
    let rear = RearTable::from_table(&table).expect("a split table");
    // With the default periods and depth, and the standstill lemma: every certified cell.
    let report = verify(
        &rear,
        table_format::CRC32.checksum(&bytes),
        &Settings::default(),
    );
    assert!(report.certified > 500_000, "{}", report.certified);
    assert_eq!(report.proven, report.certified, "{:?}", report.unproven);
    assert!(report.proven_at_standstill > 0);
}

/// A table that cannot be proven fails fast: with a budget of one unproven cell, the check
/// stops after the chunk that holds it, names it, and leaves the rest unchecked.
#[test]
fn an_unprovable_table_fails_fast_naming_its_cells() {
    let bytes = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/tables/default.bin"
    ))
    .expect("the committed table");
    let table = table_format::Table::parse(&bytes).expect("it parses");
    let mut rear = RearTable::from_table(&table).expect("a split table");
    // Certify every state at the grid's smallest gaps: a collision is a period away.
    for i in 0..6 {
        for j in 0..rear.axis(1).len() {
            for k in 0..rear.axis(2).len() {
                rear.set_node(i, j, k, 1.0);
            }
        }
    }
    let report = verify(
        &rear,
        0,
        &Settings {
            budget: Budget {
                seconds: None,
                unproven_cells: Some(1),
            },
            ..Settings::default()
        },
    );
    assert_eq!(report.stopped, Some(Stopped::UnprovenCells));
    assert!(!report.unproven.is_empty());
    assert!(report.unchecked > report.cells / 2, "{}", report.unchecked);
    assert!(!report.record().is_complete());
}

#[test]
fn the_standstill_lemma_proves_a_braking_follower_and_not_one_too_fast_to_stop() {
    // The hand-made table on gaps 0.125 m apart: the plane gap = 0.3 cuts the cell
    // [0.25, 0.375] x [0, 1] x [0, 1] with the follower closing, tangent for the period. Below
    // G = 2 / sqrt(7) = 0.756 m the IDM asks for more than 6 m/s^2, so the follower brakes at 6:
    // from a gap of 0.29 m at 1 m/s it covers at most 1/12 m, and the lemma proves the cell
    // (whose gaps are at most G / 2). At 2 m/s it may cover 1/3 m, more than the gap: the cell
    // [0.25, 0.375] x [1, 2] x [0, 1] stays unproven.
    let table = linear_table_with_gap_step(0.125);
    let report = verify(&table, 0, &settings(12));
    let s = report.standstill.expect("the exit face is certified");
    assert!((s.gap - 2.0 / 7f64.sqrt()).abs() < 1e-12, "{s:?}");
    let at = |i: usize, j: usize, k: usize| report.verdicts[(i * 4 + j) * 4 + k];
    assert_eq!(at(2, 0, 0), Verdict::ProvenAtStandstill);
    assert!(
        matches!(at(2, 1, 0), Verdict::Unproven { .. }),
        "{:?}",
        at(2, 1, 0)
    );
    // Without the lemma both are tangent.
    for j in [0, 1] {
        let v = verify_cell(&table, &table.cell(2, j, 0), 0.0, &settings(12));
        assert!(matches!(v, Verdict::Unproven { .. }), "{v:?}");
    }
}

#[test]
fn the_command_writes_its_report_and_fails_cleanly_on_unproven_cells() {
    let out = std::env::temp_dir().join(format!("hjacc-verify-cli-{}", std::process::id()));
    let table = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware/tables/default.bin"
    );
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_solver"))
        .args([
            "--quiet",
            "--out",
            out.to_str().expect("utf-8"),
            "verify",
            table,
            "--depth",
            "3",
        ])
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("the solver runs");
    let stderr = String::from_utf8_lossy(&run.stderr);
    // Unproven cells are a failure, told in one line, with no backtrace.
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("error: ") && stderr.contains("not proven"),
        "{stderr}"
    );
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("verify/default/verify.json")).expect("the report"),
    )
    .expect("JSON");
    assert!(report["certified"].as_u64() > Some(500_000));
    assert!(out.join("verify/default/verdicts-worst.png").exists());
    // The deployed table's own plots: the rear certificate at every ego speed up to
    // the domain's edge, and the front's certified gap.
    for name in [
        "certified-rear-ego-0.png",
        "certified-rear-ego-5.png",
        "certified-rear-ego-15.png",
        "certified-rear-ego-25.png",
        "certified-rear-ego-35.png",
        "front-certified-gap.png",
    ] {
        assert!(out.join("verify/default").join(name).exists(), "{name}");
    }
    // A missing table: one line too.
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_solver"))
        .args([
            "--out",
            out.to_str().expect("utf-8"),
            "verify",
            "/nonexistent/table.bin",
        ])
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("the solver runs");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1));
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    // A cut table, with `--out` after the subcommand: one line that says truncated, once.
    let cut = out.join("cut.bin");
    let bytes = std::fs::read(table).expect("the table");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("written");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_solver"))
        .args([
            "verify",
            cut.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ])
        .output()
        .expect("the solver runs");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert_eq!(stderr.matches("truncated").count(), 1, "{stderr}");
    assert!(!stderr.contains("encoding"), "{stderr}");
    std::fs::remove_dir_all(&out).ok();
}

/// `W = gap - 1` on [`linear_table`]'s grid, behind an ego that always accelerates at 6 to
/// 8 m/s^2 (its band), ahead of [`braking_follower`]: from a standstill ego and a follower at
/// `v`, the gap first shrinks by `v t - 3 t^2 ...` and then grows, so a long period closes a
/// proof that a short one cannot, over a dip in between.
fn dipping_table() -> RearTable {
    let base = linear_table();
    let axes = [
        base.axis(0).to_vec(),
        base.axis(1).to_vec(),
        base.axis(2).to_vec(),
    ];
    let mut values = Vec::new();
    for &g in &axes[0] {
        for _ in &axes[1] {
            for _ in &axes[2] {
                values.push(g - 1.0);
            }
        }
    }
    let model = RearModel {
        ego_min: 6.0,
        ego_max: 8.0,
        ..braking_follower()
    };
    RearTable::new(model, axes, values, 0.0).expect("a valid table")
}

/// The samples between a proof's periods. From the cell `gap in [1, 1.25]`,
/// follower speed in `[0, 1]`, ego speed in `[0, 1]`, the gap's least change at `t` is
/// `3 t^2 - (t - 3 t^2)` until the follower stops: least at `t = 1/12` s, -4.17 cm. 20 ms is
/// too short to prove the cell, 1 s proves it; the value at the samples in between dips by
/// that much, and `verify` reports it. A follower at up to 4 m/s dips the value by 0.67 m,
/// beyond `REAR_SAMPLE_TOLERANCE`: the long period no longer proves that cell.
#[test]
fn the_samples_between_the_proof_periods_are_bounded() {
    let table = dipping_table();
    let s = Settings {
        periods: vec![0.02, 1.0],
        rear_margin: 0.0,
        max_depth: 9,
        ..Settings::default()
    };
    let slow = table.cell(4, 0, 0);
    assert_eq!(slow.gap, Interval { lo: 1.0, hi: 1.25 });
    assert!(matches!(
        verify_cell(&table, &slow, 0.0, &s),
        Verdict::Proven
    ));
    let only_short = Settings {
        periods: vec![0.02],
        ..s.clone()
    };
    assert!(matches!(
        verify_cell(&table, &slow, 0.0, &only_short),
        Verdict::Unproven { .. }
    ));
    let fast = table.cell(4, 3, 0);
    assert!(matches!(
        verify_cell(&table, &fast, 0.0, &s),
        Verdict::Unproven { .. }
    ));
    // Over the whole table the reported bound is at least the slow cell's dip (the exact least
    // change at a 20 ms sample is -4.16 cm at t = 0.08 s) and, over the boxes that were proven,
    // within the tolerance (faster followers' cells are proven on sub-boxes that dip less).
    let report = verify(&table, 0, &s);
    let tolerance = f64::from(table_format::REAR_SAMPLE_TOLERANCE);
    assert!(
        report.sample_dip >= 0.0416 && report.sample_dip <= tolerance,
        "{}",
        report.sample_dip
    );
}
