//! The byte layout of an hjacc safety table, shared by the host solver and the firmware.
//!
//! A safety table is the compiled form of a Hamilton-Jacobi-Isaacs value function `V` on a
//! Cartesian grid: a quantized value at every node and one bit per node for the ego's bang-bang
//! input. The solver writes it once; the firmware reads it on every control period. This crate is
//! the contract between the two, so it is small, `no_std`, allocation-free on the read side, and
//! it never panics on any input: a table arrives as untrusted bytes (flashed separately, perhaps
//! from another build) and the firmware must be able to refuse it with a typed reason.
//!
//! # Why this layout
//! - **A postcard header** carries everything a consumer needs without out-of-band knowledge: the
//!   game and its parameters, the horizon, the grid, the trusted box, the quantization and the
//!   error bound that quantization and interpolation add. postcard is compact, `no_std`, and lets
//!   the reader borrow the axis names from the buffer (zero copy).
//! - **A fixed-layout little-endian payload** (values in C order, then packed policy bits) so that
//!   a lookup is a few multiplications and loads, and so that any language reads it with one
//!   `frombuffer` call. The layout is written down byte by byte in this crate's `README.md`.
//! - **A CRC-32 trailer** over everything before it: every single-bit error, every burst up to
//!   32 bits, and truncation are detected before a single value is trusted.
//!
//! # Reading
//! ```
//! # fn demo(bytes: &[u8]) -> Result<(), table_format::Error> {
//! let table = table_format::Table::parse(bytes)?;
//! let state = [20.0, -1.0, 15.0, 0.5]; // gap_leader, rel_speed_leader, gap_follower, rel_speed_follower
//! let lookup = table.lookup(&state)?;
//! if lookup.value > table.header().error_bound.total() {
//!     // certified safe at this state; lookup.action is the ego's bang-bang input
//! }
//! # Ok(()) }
//! ```
//!
//! # Features
//! - `std`: the writer ([`encode`]), used by the solver.
//! - `defmt`: `defmt::Format` for the public types.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![warn(missing_docs)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing,
        clippy::unreachable
    )
)]

pub mod authority;
#[cfg(test)]
mod brute;
mod error;
pub mod front;
mod header;
pub mod idm;
pub mod math;
pub mod rear;
pub mod sensing;
mod table;
#[cfg(feature = "std")]
mod writer;

pub use error::Error;
pub use header::{
    Axis, Bounds, EmergencyDeclaration, ErrorBound, FollowerModel, FollowerSpeed, Game, GameKind,
    Header, Horizon, HorizonStatus, IdmParameters, PolicyEncoding, Quantization, Spacing,
    Verification, MAX_DIMS, MAX_REACTION_TIME, R13H_LIGHTS_DECELERATION,
};
pub use sensing::{MeasurementError, SensorBounds};
pub use table::{EgoAction, Lookup, Table, BOX_INTERIOR};
#[cfg(feature = "std")]
pub use writer::{
    encode, with_emergency, with_leader, with_verification, TableContents, ValueBits,
};

/// How far below its level a split table's rear value may read at a control period between
/// the periods `solver verify` proves it over, m: the rear half's stated tolerance at every
/// sample. `solver verify` from [`REAR_SAMPLE_VERIFIER`] on proves a box only if, at every
/// multiple of its shortest period inside the proving period, the value over every state the
/// box can reach stays above `level - REAR_SAMPLE_TOLERANCE`; the firmware refuses a split
/// table whose record is older.
pub const REAR_SAMPLE_TOLERANCE: f32 = 0.1;

/// The first version of `solver verify` ([`Verification::verifier`]) that proves
/// [`REAR_SAMPLE_TOLERANCE`] at every sample.
pub const REAR_SAMPLE_VERIFIER: u16 = 2;

/// The four bytes every table starts with: `HJTB` (Hamilton-Jacobi TaBle).
pub const MAGIC: [u8; 4] = *b"HJTB";

/// The layout version this crate reads and writes. Bumped on any change a reader of the previous
/// version would misread.
pub const FORMAT_VERSION: u16 = 7;

/// Bytes before the header: magic (4), format version (2), header length (2).
pub const PREAMBLE_LEN: usize = 8;

/// Bytes of the CRC-32 trailer.
pub const CRC_LEN: usize = 4;

/// The CRC used for the trailer: CRC-32/ISO-HDLC, the one of zlib, PNG and Ethernet
/// (`zlib.crc32` in Python, `crc32fast` in Rust).
pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// The largest number of grid nodes a table may hold (2^26: 64 Mi nodes, 128 MiB of 16-bit
/// values). It keeps every size computation far from overflow on 32-bit targets.
pub const MAX_NODES: usize = 1 << 26;
