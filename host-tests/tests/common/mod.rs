//! Helpers the integration tests share.

use table_format::Bounds;

/// The deployed table with its leader braking at most at `leader_braking`, m/s^2 (its top
/// acceleration 2 m/s^2, as deployed).
pub fn table_with_leader(leader_braking: f32) -> &'static [u8] {
    table_format::with_leader(
        firmware::DEFAULT_TABLE,
        Bounds {
            min: -leader_braking,
            max: 2.0,
        },
    )
    .unwrap()
    .leak()
}
