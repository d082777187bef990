//! What the firmware's integration tests share.

use firmware::{Config, PlantConfig, SensorBounds};

/// The ideal plant: exact sensors, no actuator dead time or lag (the certificate's own tests;
/// the delays have theirs), so that a test's own integration is the truth.
pub fn ideal() -> Config {
    Config {
        sensors: SensorBounds::EXACT,
        plant: PlantConfig {
            actuator_dead_time_us: 0,
            actuator_lag_us: 0,
            ..Config::default().plant
        },
        ..Config::default()
    }
}

/// The default table with `config`'s emergency declaration (its emergency authority, follower
/// reaction and lights' command): the firmware refuses the default table for a configuration
/// that declares others ([`firmware::Fault::EmergencyDeclarationDiffers`]).
pub fn table_for(config: &Config) -> &'static [u8] {
    firmware::table_format::with_emergency(firmware::DEFAULT_TABLE, config.certificate.emergency)
        .expect("the default table takes any valid declaration")
        .leak()
}
