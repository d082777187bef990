//! The zero-copy reader: checks a buffer once, then answers value and policy lookups.
//!
//! `parse` does every check up front (magic, version, sizes, CRC, header sanity), so that the
//! lookups afterwards only have to check the state they are given. No function here allocates,
//! and none panics: every slice access is a checked `get`.

use crate::header::{Header, MAX_DIMS};
use crate::{Error, CRC32, CRC_LEN, FORMAT_VERSION, MAGIC, PREAMBLE_LEN};

/// The ego's bang-bang input, as stored in the policy bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EgoAction {
    /// Command the game's maximum ego acceleration.
    Accelerate,
    /// Command the game's minimum ego acceleration (the hardest braking the game allows).
    Brake,
}

/// The answer of one table lookup.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Lookup {
    /// The multilinearly interpolated, dequantized value.
    pub value: f32,
    /// The ego's bang-bang input by the weighted vote of the cell's policy bits.
    pub action: EgoAction,
}

/// A parsed safety table borrowing its bytes.
#[derive(Debug, Clone)]
pub struct Table<'a> {
    header: Header<'a>,
    values: &'a [u8],
    policy: &'a [u8],
    dims: usize,
    strides: [usize; MAX_DIMS],
    inv_spacing: [f32; MAX_DIMS],
}

fn le_u16(bytes: &[u8], at: usize) -> Option<u16> {
    let b = bytes.get(at..at + 2)?;
    Some(u16::from_le_bytes([*b.first()?, *b.get(1)?]))
}

fn le_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at + 4)?;
    let mut a = [0u8; 4];
    a.copy_from_slice(b);
    Some(u32::from_le_bytes(a))
}

/// The grid cell of a state: per axis the lower node index and the position in the cell.
struct Cell {
    base: usize,
    frac: [f32; MAX_DIMS],
}

impl<'a> Table<'a> {
    /// Checks `bytes` and returns a reader over them.
    ///
    /// The checks, in order: the preamble is there and starts with [`MAGIC`]; the version is
    /// [`FORMAT_VERSION`]; the buffer holds the header length it announces and a trailer; the
    /// CRC-32 trailer matches; the header decodes, uses all its announced bytes and passes
    /// [`Header::validate`]; the payload has exactly the size the grid calls for.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, Error> {
        let minimum = PREAMBLE_LEN + CRC_LEN;
        if bytes.len() < minimum {
            return Err(Error::Truncated {
                needed: minimum,
                found: bytes.len(),
            });
        }
        if bytes.get(..4) != Some(&MAGIC[..]) {
            return Err(Error::BadMagic);
        }
        let version = le_u16(bytes, 4).ok_or(Error::BadMagic)?;
        if version != FORMAT_VERSION {
            return Err(Error::UnsupportedVersion { found: version });
        }
        let header_len = usize::from(le_u16(bytes, 6).ok_or(Error::BadMagic)?);
        let header_end = PREAMBLE_LEN + header_len;
        if bytes.len() < header_end + CRC_LEN {
            return Err(Error::Truncated {
                needed: header_end + CRC_LEN,
                found: bytes.len(),
            });
        }
        let body_len = bytes.len() - CRC_LEN;
        let stored = le_u32(bytes, body_len).ok_or(Error::HeaderDecode)?;
        let computed = CRC32.checksum(bytes.get(..body_len).ok_or(Error::HeaderDecode)?);
        if stored != computed {
            return Err(Error::Checksum { stored, computed });
        }
        let header_bytes = bytes
            .get(PREAMBLE_LEN..header_end)
            .ok_or(Error::HeaderDecode)?;
        let (header, rest): (Header<'a>, &[u8]) =
            postcard::take_from_bytes(header_bytes).map_err(|_| Error::HeaderDecode)?;
        if !rest.is_empty() {
            return Err(Error::InvalidHeader(
                "header length does not match its encoding",
            ));
        }
        header.validate()?;
        let payload = bytes.get(header_end..body_len).ok_or(Error::HeaderDecode)?;
        let expected = header.payload_len()?;
        if payload.len() != expected {
            return Err(Error::PayloadSize {
                expected: expected + CRC_LEN,
                found: payload.len() + CRC_LEN,
            });
        }
        let n = header.node_count()?;
        let value_len = n * header.quantization.bytes_per_value();
        let (values, policy) = payload.split_at(value_len);
        let dims = header.axes.len();
        let mut strides = [0usize; MAX_DIMS];
        let mut inv_spacing = [0f32; MAX_DIMS];
        let mut stride = 1usize;
        for k in (0..dims).rev() {
            let axis = header.axes.get(k).ok_or(Error::HeaderDecode)?;
            if let (Some(s), Some(inv)) = (strides.get_mut(k), inv_spacing.get_mut(k)) {
                *s = stride;
                *inv = 1.0 / axis.spacing();
            }
            stride *= axis.points as usize;
        }
        Ok(Table {
            header,
            values,
            policy,
            dims,
            strides,
            inv_spacing,
        })
    }

    /// The header.
    pub fn header(&self) -> &Header<'a> {
        &self.header
    }

    /// The number of state axes.
    pub fn dims(&self) -> usize {
        self.dims
    }

    /// The number of grid nodes.
    pub fn node_count(&self) -> usize {
        self.policy_len_nodes()
    }

    fn policy_len_nodes(&self) -> usize {
        self.values.len() / self.header.quantization.bytes_per_value()
    }

    /// The stored integer at a flat (C-order) node index.
    fn raw_value(&self, node: usize) -> Option<u16> {
        if self.header.quantization.bits == 8 {
            self.values.get(node).map(|&b| u16::from(b))
        } else {
            le_u16(self.values, node * 2)
        }
    }

    /// The dequantized value at a flat (C-order) node index, `None` past the last node.
    pub fn value_at_node(&self, node: usize) -> Option<f32> {
        self.raw_value(node)
            .map(|q| self.header.quantization.dequantize(q))
    }

    /// The policy bit at a flat (C-order) node index, `None` past the last node.
    pub fn action_at_node(&self, node: usize) -> Option<EgoAction> {
        if node >= self.node_count() {
            return None;
        }
        let byte = self.policy.get(node / 8)?;
        Some(if byte >> (node % 8) & 1 == 1 {
            EgoAction::Accelerate
        } else {
            EgoAction::Brake
        })
    }

    /// Whether every coordinate of `state` is finite and inside the grid.
    pub fn contains(&self, state: &[f32]) -> bool {
        state.len() == self.dims
            && state
                .iter()
                .zip(self.header.axes.iter())
                .all(|(x, a)| a.min <= *x && *x <= a.max)
    }

    /// Whether every coordinate of `state` is finite and inside the trusted box.
    pub fn in_trusted_box(&self, state: &[f32]) -> bool {
        state.len() == self.dims
            && state
                .iter()
                .zip(self.header.trusted_box.iter())
                .all(|(x, b)| b.contains(*x))
    }

    /// Locates `state` in the grid. The cast of each scaled coordinate to an index happens only
    /// after it is known to be finite and within `[0, points - 1]`.
    fn cell(&self, state: &[f32]) -> Result<Cell, Error> {
        if state.len() != self.dims {
            return Err(Error::DimensionMismatch {
                expected: self.dims,
                found: state.len(),
            });
        }
        let mut cell = Cell {
            base: 0,
            frac: [0.0; MAX_DIMS],
        };
        for (k, (&x, axis)) in state.iter().zip(self.header.axes.iter()).enumerate() {
            if !x.is_finite() {
                return Err(Error::NonFiniteState { axis: k });
            }
            if x < axis.min || x > axis.max {
                return Err(Error::OutOfDomain { axis: k });
            }
            let inv = self.inv_spacing.get(k).copied().unwrap_or(0.0);
            let last = axis.points - 1;
            let s = ((x - axis.min) * inv).clamp(0.0, last as f32);
            // `s` is finite and in [0, last]: truncation is floor and fits in u32.
            let i = (s as u32).min(last - 1);
            let t = s - i as f32;
            if let Some(f) = cell.frac.get_mut(k) {
                *f = t;
            }
            cell.base += i as usize * self.strides.get(k).copied().unwrap_or(0);
        }
        Ok(cell)
    }

    /// Visits the `2^dims` corners of a cell with their multilinear weights.
    fn for_each_corner(&self, cell: &Cell, mut visit: impl FnMut(usize, f32)) {
        for corner in 0u32..(1 << self.dims) {
            let mut weight = 1.0f32;
            let mut node = cell.base;
            for k in 0..self.dims {
                let t = cell.frac.get(k).copied().unwrap_or(0.0);
                if corner >> k & 1 == 1 {
                    weight *= t;
                    node += self.strides.get(k).copied().unwrap_or(0);
                } else {
                    weight *= 1.0 - t;
                }
            }
            visit(node, weight);
        }
    }

    /// The multilinear interpolation of the dequantized values at `state`.
    pub fn value_at(&self, state: &[f32]) -> Result<f32, Error> {
        Ok(self.lookup(state)?.value)
    }

    /// The ego's bang-bang input at `state` ([`crate::PolicyEncoding::SignBitWeightedVote`]).
    pub fn policy_at(&self, state: &[f32]) -> Result<EgoAction, Error> {
        Ok(self.lookup(state)?.action)
    }

    /// Value and action at `state` from one cell search.
    pub fn lookup(&self, state: &[f32]) -> Result<Lookup, Error> {
        let cell = self.cell(state)?;
        let mut q_sum = 0.0f32;
        let mut vote = 0.0f32;
        let mut heaviest = (-1.0f32, EgoAction::Brake);
        self.for_each_corner(&cell, |node, weight| {
            q_sum += weight * f32::from(self.raw_value(node).unwrap_or(0));
            let action = self.action_at_node(node).unwrap_or(EgoAction::Brake);
            vote += match action {
                EgoAction::Accelerate => weight,
                EgoAction::Brake => -weight,
            };
            if weight > heaviest.0 {
                heaviest = (weight, action);
            }
        });
        let q = &self.header.quantization;
        let action = if vote > 0.0 {
            EgoAction::Accelerate
        } else if vote < 0.0 {
            EgoAction::Brake
        } else {
            heaviest.1
        };
        Ok(Lookup {
            value: q.offset + q.scale * q_sum,
            action,
        })
    }
}
