//! The drivable ACC's acceptance, as a test: the scenario suite ([`host_tests::scenarios`]) with
//! the default configuration passes every scenario with and without a follower (no collision, no
//! loss of the certificate, ISO 15622's limits in every scenario whose leader brakes no harder than
//! the comfort braking, and each scenario's own criterion: steady following without the override
//! within 1 m of the gap policy, the set speed held on grades, a stop from 1 m/s in under 3 s at
//! the standstill gap, set-speed changes without the override). The paper's bang-bang policy is run
//! too: no collision and no loss, but it breaks the jerk limit, which is why it is not the default.

use firmware::Config;
use host_tests::scenarios::{run, suite, ScenarioResult};
use table_format::Table;

fn results(config: Config) -> Vec<ScenarioResult> {
    let table = Table::parse(firmware::DEFAULT_TABLE).unwrap();
    suite()
        .iter()
        .flat_map(|s| [false, true].map(|f| (s, f)))
        .map(|(s, f)| run(&table, firmware::DEFAULT_TABLE, config, s, f, None).unwrap())
        .collect()
}

#[test]
fn the_default_policy_passes_the_suite() {
    let results = results(Config::default());
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
    let results = results(Config::bang_bang());
    assert!(results.iter().all(|r| !r.collided && !r.certificate_lost));
    assert!(results.iter().any(|r| r.comfort_scope && r.iso.jerk > 1.01));
}
