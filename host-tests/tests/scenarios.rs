//! The drivable ACC's acceptance, as a test: the scenario suite ([`host_tests::scenarios`]) with
//! the default configuration passes every scenario with and without a follower (no collision, no
//! loss of the certificate, ISO 15622's limits in every scenario whose leader brakes no harder than
//! the comfort braking, and each scenario's own criterion: steady following without the override
//! within 1 m of the gap policy or cruising at the set speed above it, the set speed held on
//! grades, a stop from 1 m/s in under 3 s at the standstill gap, set-speed changes without the
//! override). The paper's bang-bang policy is run too: no collision and no loss, but it breaks
//! the jerk limit, which is why it is not the default.

use firmware::{Authorities, CertificateConfig, Config};
use host_tests::scenarios::{run, suite, summary_rows, Scenario, ScenarioResult, SUMMARY_HEADER};
use host_tests::world::Trace;
use table_format::Table;

fn results(config: Config) -> Vec<ScenarioResult> {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    suite()
        .iter()
        .flat_map(|s| [false, true].map(|f| (s, f)))
        .map(|(s, f)| run(&table, firmware::DEFAULT_TABLE, config, s, f, None).unwrap())
        .collect()
}

/// The suite under the default policy, run once for the tests that read it.
fn default_results() -> &'static [ScenarioResult] {
    static RESULTS: std::sync::OnceLock<Vec<ScenarioResult>> = std::sync::OnceLock::new();
    RESULTS.get_or_init(|| results(Config::default()))
}

/// The suite under the paper's bang-bang policy, run once for the tests that read it.
fn bang_bang_results() -> &'static [ScenarioResult] {
    static RESULTS: std::sync::OnceLock<Vec<ScenarioResult>> = std::sync::OnceLock::new();
    RESULTS.get_or_init(|| results(Config::bang_bang()))
}

/// The suite's scenario of that name.
fn scenario_named(name: &str) -> Scenario {
    suite()
        .into_iter()
        .find(|s| s.name == name)
        .unwrap_or_else(|| panic!("no scenario {name:?}"))
}

/// The default configuration with the certificate argued with two authorities.
fn two_authorities() -> Config {
    Config {
        certificate: CertificateConfig {
            authorities: Authorities::Two,
            ..CertificateConfig::default()
        },
        ..Config::default()
    }
}

mod common;
use common::table_with_leader as with_leader;

#[test]
fn the_default_policy_passes_the_suite() {
    let results = default_results();
    assert!(results.len() >= 90, "{}", results.len());
    let failed: Vec<_> = results.iter().filter(|r| !r.passed()).collect();
    assert!(failed.is_empty(), "{failed:#?}");
    // Not vacuous: the comfort checks reach a good share of their limits somewhere, and the
    // override acts in some scenarios.
    let worst = results.iter().map(|r| r.iso.worst()).fold(0.0f32, f32::max);
    assert!(worst > 0.8, "{worst}");
    assert!(results.iter().any(|r| r.override_periods > 0));
    assert!(results.iter().all(|r| r.emergency_periods == 0));
}

#[test]
fn the_bang_bang_policy_is_safe_but_jerks() {
    let results = bang_bang_results();
    assert!(results.iter().all(|r| !r.collided && !r.certificate_lost));
    assert!(results.iter().any(|r| r.comfort_scope && r.iso.jerk > 1.01));
}

/// docs/closed-loop.md's scenario table is what the suite gives now, row by row
/// ([`summary_rows`], which `host-tests scenarios` prints below its runs). The table had gone
/// stale once without anything noticing (the paper's policy's openpilot row: 32 passed and 154
/// emergency periods, where the code gave 30 and 86).
#[test]
fn the_docs_scenario_table_is_the_suites() {
    let all: Vec<ScenarioResult> = [default_results(), bang_bang_results()].concat();
    let rows = summary_rows(&all);
    let doc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/closed-loop.md"
    ))
    .unwrap();
    let at = doc
        .find(SUMMARY_HEADER)
        .expect("the scenario table's header in docs/closed-loop.md");
    let documented: Vec<&str> = doc[at + SUMMARY_HEADER.len()..]
        .lines()
        .skip(1)
        .take_while(|l| l.starts_with('|'))
        .collect();
    assert_eq!(
        documented, rows,
        "docs/closed-loop.md's scenario table is not the suite's: `host-tests scenarios` prints it"
    );
}

/// The ego's speed near the domain's top, with two authorities, behind leaders at 6 and at
/// 9.8 m/s^2: closing on a leader at 30 m/s at the law's top speed, the ego speed's error
/// (switching corners) moves the worst corner's speed headroom by twice the error from one
/// measurement to the next. No emergency: the headroom is argued along the speed's own ramp
/// at the comfort band's jerk (the firmware's controller docs: the ego's speed), not the
/// braking in force's (the emergency authority's 12 m/s^3: 5 emergency periods a run). No
/// override: the law's set speed is held below the top by three of the speed's errors and a
/// room for the rise (the firmware's `SET_SPEED_ROOM`).
#[test]
fn the_speed_near_the_domains_top_is_no_emergency_with_two_authorities() {
    let config = two_authorities();
    for leader_braking in [6.0, 9.8] {
        let bytes = with_leader(leader_braking);
        let table = Table::parse(bytes).unwrap();
        let steady = scenario_named("steady following at 30 m/s");
        for follower in [false, true] {
            let mut trace = Trace::new();
            let r = run(&table, bytes, config, &steady, follower, Some(&mut trace)).unwrap();
            assert_eq!(r.emergency_periods, 0, "{leader_braking}: {r:#?}");
            assert!(
                !r.collided && !r.certificate_lost,
                "{leader_braking}: {r:#?}"
            );
            // The run passes its own check too: no override at all, the law's set speed held
            // below the top by three of the speed's errors (the firmware's `SET_SPEED_ROOM`).
            assert!(r.passed(), "{leader_braking}: {r:#?}");
            // Not vacuous: the ego comes within 1 m/s of the top (its set speed is the
            // domain's), less than twice the ego speed's error box (0.55 m/s wide there).
            let fastest = trace.iter().map(|p| p.speeds[1]).fold(0.0f32, f32::max);
            assert!(fastest > 34.0, "{leader_braking}: {fastest}");
        }
    }
}

/// Steady following behind a leader at the domain's top (34 m/s), with two authorities: the
/// run starts at the band's gap, and the law's set speed (34.08 m/s, three of the ego speed's
/// errors and a room below the domain's 35) closes on the leader at a few centimetres a
/// second. The car cruises at its set speed, as an ACC does behind a leader at least as fast,
/// and the check takes that as following (`Check::SteadyFollowing`). Not vacuous: the gap stays
/// above 100 m, every sample of the check's last 20 s is cruising, and the ego is within
/// 0.5 m/s of the law's set speed.
#[test]
fn a_leader_at_the_domains_top_is_followed_by_cruising_at_the_set_speed() {
    let config = two_authorities();
    for leader_braking in [6.0, 9.8] {
        let bytes = with_leader(leader_braking);
        let table = Table::parse(bytes).unwrap();
        let steady = scenario_named("steady following at 34 m/s");
        let probe = firmware::Controller::new(
            bytes,
            Config {
                law: firmware::LawConfig {
                    set_speed: steady.set_speed,
                    ..config.law
                },
                ..config
            },
        );
        let set = probe.law_set_speed();
        assert!((34.0..34.2).contains(&set), "{set}");
        for follower in [false, true] {
            let mut trace = Trace::new();
            let r = run(&table, bytes, config, &steady, follower, Some(&mut trace)).unwrap();
            assert!(r.passed(), "{leader_braking}: {r:#?}");
            // 20 s at 50 Hz, all cruising.
            assert_eq!(r.check_figures[2], 1000.0, "{leader_braking}: {r:#?}");
            let last = trace.last().unwrap();
            // Still about the band's 116 m, where the gap policy with the emergency authority
            // is under 70 m (docs/closed-loop.md's gap table).
            let gap = last.gap_leader;
            assert!(gap > 100.0, "{gap}");
            assert!((last.speeds[1] - set).abs() < 0.5, "{}", last.speeds[1]);
        }
    }
}

/// The suite with two authorities, behind the table's leader (6 m/s^2) and one braking at
/// 9.8 m/s^2: no run brings an emergency period, and none collides or loses the certificate.
/// The engagements that would have jumped, faster than ISO 15622's jerk limit, to the brake
/// lights' command or down the braking ramp within 0.12 s (the Euro NCAP CCRs and CCRm at
/// 30 km/h with an IDM follower 14.5 m behind, 1 period each; at 9.8 also the steady
/// following at 10 m/s and the stop and go at 10 mph, 3 periods each) are refused in standby
/// with their reason, `NeedsEmergencyBraking`; every refusal has a follower, and every run
/// without one engages.
#[test]
fn the_suite_with_two_authorities_engages_only_without_an_emergency() {
    let config = two_authorities();
    for leader_braking in [6.0, 9.8] {
        let bytes = with_leader(leader_braking);
        let table = Table::parse(bytes).unwrap();
        let mut needs_emergency = Vec::new();
        for s in suite() {
            for follower in [false, true] {
                let r = run(&table, bytes, config, &s, follower, None).unwrap();
                assert_eq!(r.emergency_periods, 0, "{leader_braking}: {r:#?}");
                assert!(
                    !r.collided && !r.certificate_lost,
                    "{leader_braking}: {r:#?}"
                );
                assert!(
                    follower || r.engagement_refused.is_none(),
                    "{leader_braking}: {r:#?}"
                );
                if r.engagement_refused.as_deref() == Some("NeedsEmergencyBraking") {
                    needs_emergency.push(s.name.clone());
                }
            }
        }
        for name in [
            "CCRs: stationary target, ego 30 km/h",
            "CCRm: target at 20 km/h, ego 30 km/h",
        ] {
            assert!(
                needs_emergency.iter().any(|n| n == name),
                "{leader_braking}: {needs_emergency:?}"
            );
        }
    }
}

/// With two authorities and an IDM follower, a stop behind a stopped car halts within a metre
/// of the standstill gap where the stop's own braking lights the brakes: the stop is planned
/// harder than the lights' command by a margin (`Controller::stop_deceleration`), so that the
/// lit run the closing follower does not let end brakes as the plan does. Planned at the
/// configured 1.0 m/s^2 these halted 35-48 m short (the lit run held the car at the gentlest
/// command that keeps it, -1.35 m/s^2) and stood there. Two stops of the suite still halt
/// short: their runs are lit at the start, where the follower sits at the rear half's edge
/// (CCRs at 40 km/h and the stop from 10 m/s, 154 m and 23 m).
#[test]
fn a_stop_ahead_of_a_follower_halts_at_the_standstill_gap() {
    let config = two_authorities();
    let stops = [
        "approaching a 0mph car while cruising at 40mph from 150m away",
        "CCRs: stationary target, ego 50 km/h",
        "CCRs: stationary target, ego 60 km/h",
        "CCRs: stationary target, ego 70 km/h",
        "CCRs: stationary target, ego 80 km/h",
    ];
    let suite = suite();
    for leader_braking in [6.0, 9.8] {
        let bytes = with_leader(leader_braking);
        let table = Table::parse(bytes).unwrap();
        for name in stops {
            let s = suite
                .iter()
                .find(|s| s.name == name)
                .expect("the stop is in the suite");
            let r = run(&table, bytes, config, s, true, None).unwrap();
            assert!(r.engagement_refused.is_none(), "{leader_braking}: {r:#?}");
            assert_eq!(r.emergency_periods, 0, "{leader_braking}: {r:#?}");
            let short = r.check_figures[1];
            assert!(
                (0.0..1.0).contains(&short),
                "{leader_braking} {name}: {short} m beyond the standstill gap"
            );
        }
    }
}

/// The suite reports braking and standing the road did not ask for
/// ([`host_tests::world::Needless`]). At the green light the car has been held at a standstill
/// for 10 s when the leader moves off, longer than the automatic resume's 3 s, so it waits
/// for the driver: 13 s standing with the leader more than 40 m ahead and drawing away, where
/// the driver's resume a second after the green light has it moving within a second.
#[test]
fn the_suite_reports_standing_on_a_free_road() {
    use firmware::DriverRequest;
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    let green = suite()
        .into_iter()
        .find(|s| s.name.starts_with("green light"))
        .expect("the green light scenario");
    let r = run(
        &table,
        firmware::DEFAULT_TABLE,
        Config::default(),
        &green,
        false,
        None,
    )
    .unwrap();
    assert!(r.needless.standstill > 10.0, "{:?}", r.needless);
    let mut resumed = green.clone();
    resumed.driver = vec![(11.0, DriverRequest::Resume)];
    let r = run(
        &table,
        firmware::DEFAULT_TABLE,
        Config::default(),
        &resumed,
        false,
        None,
    )
    .unwrap();
    assert!(r.needless.standstill < 1.0, "{:?}", r.needless);
    assert!(r.passed(), "{r:#?}");
}
