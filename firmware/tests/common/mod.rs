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
