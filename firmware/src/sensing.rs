//! What the certificate assumes of the sensors, and what the controller makes of a track's age.
//!
//! The bounds themselves ([`SensorBounds`]: the measurement error and the radar's timing) are
//! declared once, in [`table_format::sensing`], which the solver reads too: its check of a table
//! under measurement error uses the same error box, and a verified table records the error it
//! was checked for. This module adds the firmware's reading of a track's age ([`TrackState`]).

pub use table_format::sensing::{
    MeasurementError, SensorBounds, MAX_EGO_AGE, MAX_RANGE_ERROR, MAX_RELATIVE_ERROR,
    MAX_SPEED_ERROR, MAX_TRACK_AGE_US,
};

/// The state of a track measured `age_us` ago under `bounds`: fresh within the sensor's
/// latency and one cycle, aging within the covered age, lost beyond it.
pub fn track_state(bounds: &SensorBounds, age_us: u64) -> TrackState {
    if bounds.is_on_time(age_us) {
        TrackState::Fresh
    } else if bounds.is_covered(age_us) {
        TrackState::Aging
    } else {
        TrackState::Lost
    }
}

/// What the controller makes of a track's age and continuity, reported with every command
/// (and on CAN) so that the car knows which case of the argument holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TrackState {
    /// Measured within the sensor's latency and one cycle.
    Fresh,
    /// Older than that (detections missed), within the covered age: the nominal law runs,
    /// under a look-ahead that grows with the age.
    Aging,
    /// Older than the covered age: the certified fallback runs on the last good measurement.
    Lost,
    /// This period's measurement is not the same vehicle as the last one (a cut-in: the gap
    /// fell faster than the last track's vehicle can close it). The new track is used at once.
    New,
    /// No plausible measurement has been received yet.
    Missing,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_track_ages_then_is_lost() {
        let s = SensorBounds::default();
        assert_eq!(track_state(&s, 130_000), TrackState::Fresh);
        assert_eq!(track_state(&s, 130_001), TrackState::Aging);
        assert_eq!(track_state(&s, 1_000_000), TrackState::Aging);
        assert_eq!(track_state(&s, 1_000_001), TrackState::Lost);
    }
}
