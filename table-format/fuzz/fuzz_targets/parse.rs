//! Feeds arbitrary bytes to the reader, and looks up states in whatever parses.
//! Run: `cargo +nightly fuzz run parse` from `table-format/`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use table_format::Table;

fuzz_target!(|data: &[u8]| {
    // The first 24 bytes, when present, are a state to look up (up to six axes); the rest is
    // the table.
    let (state_bytes, table_bytes) = data.split_at(data.len().min(24));
    // A flash slot: the table found by its declared length, never past the region's end.
    if let Ok(len) = Table::declared_len(table_bytes) {
        assert!(len <= table_bytes.len() || Table::parse_prefix(table_bytes).is_err());
    }
    if let Ok(table) = Table::parse_prefix(table_bytes) {
        let _ = table.value_at(&[0.0; table_format::MAX_DIMS][..table.dims()]);
    }
    if let Ok(table) = Table::parse(table_bytes) {
        let mut state = [0f32; table_format::MAX_DIMS];
        for (x, b) in state.iter_mut().zip(state_bytes.chunks_exact(4)) {
            *x = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
        let dims = table.dims();
        let _ = table.lookup(&state[..dims]);
        let _ = table.value_at(&state[..dims]);
        let _ = table.contains(&state[..dims]);
    }
});
