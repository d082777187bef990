//! The one error type of this crate: why a buffer is not a table, or why a lookup has no answer.

use core::fmt;

/// Why a buffer was refused as a table, why a state has no value, or why a table could not be
/// written. Every variant is a value the caller can act on; nothing here panics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error {
    /// The buffer ends before the part named by `needed` bytes could be read.
    Truncated {
        /// How many bytes the layout needs at least.
        needed: usize,
        /// How many bytes the buffer has.
        found: usize,
    },
    /// The buffer does not start with [`crate::MAGIC`]: it is not a table at all.
    BadMagic,
    /// The table was written in a layout version this reader does not know.
    UnsupportedVersion {
        /// The version found in the buffer.
        found: u16,
    },
    /// The CRC-32 trailer does not match the bytes before it: the table is corrupt.
    Checksum {
        /// The CRC stored in the trailer.
        stored: u32,
        /// The CRC computed over the buffer.
        computed: u32,
    },
    /// The postcard header could not be decoded.
    HeaderDecode,
    /// The header decoded but describes something impossible; the text names the field.
    InvalidHeader(&'static str),
    /// The buffer's length does not match what the header says the payload holds.
    PayloadSize {
        /// Bytes the header's grid and quantization call for (payload and trailer).
        expected: usize,
        /// Bytes the buffer has after the header.
        found: usize,
    },
    /// A state has a different number of coordinates than the table has axes.
    DimensionMismatch {
        /// The table's number of axes.
        expected: usize,
        /// The state's number of coordinates.
        found: usize,
    },
    /// A state coordinate is NaN or infinite.
    NonFiniteState {
        /// The axis (in state order) of the offending coordinate.
        axis: usize,
    },
    /// A state coordinate lies outside the grid; the table has no value there.
    OutOfDomain {
        /// The axis (in state order) of the offending coordinate.
        axis: usize,
    },
    /// The writer was given a value that is NaN or infinite.
    NonFiniteValue {
        /// The flat (C-order) node index of the value.
        node: usize,
    },
    /// The writer was given a number of values or policy bits that does not match the grid.
    ContentsSize {
        /// The number of grid nodes.
        expected: usize,
        /// The number of entries given.
        found: usize,
    },
    /// A policy lookup on a table that stores no policy bits.
    NoPolicy,
    /// A box given to [`crate::Table::least_over_box`] holds more than
    /// [`crate::BOX_INTERIOR`] breakpoints on this axis; its least value is not computed.
    BoxTooWide {
        /// The axis (in state order).
        axis: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Truncated { needed, found } => {
                write!(
                    f,
                    "table truncated: needs at least {needed} bytes, has {found}"
                )
            }
            Error::BadMagic => f.write_str("not a safety table (bad magic bytes)"),
            Error::UnsupportedVersion { found } => write!(
                f,
                "table format version {found} is not supported (this reader knows {})",
                crate::FORMAT_VERSION
            ),
            Error::Checksum { stored, computed } => write!(
                f,
                "table corrupt: CRC-32 stored {stored:#010x}, computed {computed:#010x}"
            ),
            Error::HeaderDecode => f.write_str("table header could not be decoded"),
            Error::InvalidHeader(what) => write!(f, "invalid table header: {what}"),
            Error::PayloadSize { expected, found } => write!(
                f,
                "table payload has {found} bytes, the header calls for {expected}"
            ),
            Error::DimensionMismatch { expected, found } => write!(
                f,
                "state has {found} coordinates, the table has {expected} axes"
            ),
            Error::NonFiniteState { axis } => write!(f, "state coordinate {axis} is not finite"),
            Error::OutOfDomain { axis } => {
                write!(f, "state coordinate {axis} is outside the table's grid")
            }
            Error::NonFiniteValue { node } => write!(f, "value at node {node} is not finite"),
            Error::ContentsSize { expected, found } => write!(
                f,
                "table contents have {found} entries, the grid has {expected} nodes"
            ),
            Error::NoPolicy => f.write_str("the table stores no policy bits"),
            Error::BoxTooWide { axis } => write!(
                f,
                "the box holds more than {} breakpoints on axis {axis}",
                crate::BOX_INTERIOR
            ),
        }
    }
}

impl core::error::Error for Error {}
