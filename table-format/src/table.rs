//! The zero-copy reader: checks a buffer once, then answers value and policy lookups.
//!
//! `parse` does every check up front (magic, version, sizes, CRC, header sanity), so that the
//! lookups afterwards only have to check the state they are given. No function here allocates,
//! and none panics: every slice access is a checked `get`.

use crate::header::{Header, PolicyEncoding, Spacing, MAX_DIMS};
use crate::{Error, CRC32, CRC_LEN, FORMAT_VERSION, MAGIC, PREAMBLE_LEN};

/// Breakpoints strictly inside a box that [`Table::least_over_box`] takes per axis, at most.
/// With the firmware's default sensor bounds a rear box holds at most three of the deployed
/// table's gap breakpoints (0.1 m + 1.5% of the range against 0.25-3 m spacing) and four of its
/// speed breakpoints (0.5 m/s apart): `8^3 = 512` points at most, each one pass over a cell's
/// eight corners.
pub const BOX_INTERIOR: usize = 6;

/// One axis's candidates for [`Table::least_over_box`]: (cell, position in the cell), the
/// box's ends and the breakpoints between them.
type Candidates = heapless::Vec<(u32, f32), { BOX_INTERIOR + 2 }>;

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
    nodes: usize,
    dims: usize,
    geometry: [AxisGeometry<'a>; MAX_DIMS],
}

/// Per axis, what a lookup needs, unpacked from the header once at parse time.
#[derive(Debug, Clone, Copy, Default)]
struct AxisGeometry<'a> {
    /// The breakpoints of a listed axis (little-endian `f32`, checked at parse time); empty
    /// for a uniform axis.
    breakpoints: &'a [u8],
    min: f32,
    max: f32,
    inv_spacing: f32,
    /// `points - 1`, as a float.
    last: f32,
    /// The index of the last cell, `points - 2`.
    last_cell: u32,
    stride: usize,
    trusted: (f32, f32),
}

fn le_u16(bytes: &[u8], at: usize) -> Option<u16> {
    let b = bytes.get(at..at + 2)?;
    Some(u16::from_le_bytes([*b.first()?, *b.get(1)?]))
}

fn le_f32(bytes: &[u8], at: usize) -> Option<f32> {
    le_u32(bytes, at).map(f32::from_bits)
}

fn le_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at + 4)?;
    let mut a = [0u8; 4];
    a.copy_from_slice(b);
    Some(u32::from_le_bytes(a))
}

/// Decodes and validates the header from exactly its announced bytes.
fn decode_header(header_bytes: &[u8]) -> Result<Header<'_>, Error> {
    let (header, rest): (Header<'_>, &[u8]) =
        postcard::take_from_bytes(header_bytes).map_err(|_| Error::HeaderDecode)?;
    if !rest.is_empty() {
        return Err(Error::InvalidHeader(
            "header length does not match its encoding",
        ));
    }
    header.validate()?;
    Ok(header)
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
    /// CRC-32 trailer matches (when it does not, and the header declares a longer table than
    /// the buffer, the error is [`Error::Truncated`]: a cut file, not a corrupt one); the header
    /// decodes, uses all its announced bytes and passes [`Header::validate`]; the payload has
    /// exactly the size the grid calls for.
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
            // A file cut short fails its CRC too; say what happened when the (not yet trusted)
            // header declares more bytes than there are.
            if let Ok(needed) = Self::declared_len(bytes) {
                if needed > bytes.len() {
                    return Err(Error::Truncated {
                        needed,
                        found: bytes.len(),
                    });
                }
            }
            return Err(Error::Checksum { stored, computed });
        }
        let header_bytes = bytes
            .get(PREAMBLE_LEN..header_end)
            .ok_or(Error::HeaderDecode)?;
        let header = decode_header(header_bytes)?;
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
        let size_error = Error::PayloadSize {
            expected: expected + CRC_LEN,
            found: payload.len() + CRC_LEN,
        };
        let (mut breakpoints, payload) = payload
            .split_at_checked(header.breakpoint_len())
            .ok_or(size_error)?;
        let (values, policy) = payload.split_at_checked(value_len).ok_or(size_error)?;
        let dims = header.axes.len();
        let mut geometry = [AxisGeometry::default(); MAX_DIMS];
        let mut stride = 1usize;
        for k in (0..dims).rev() {
            let (Some(slot), Some(axis), Some(trusted)) = (
                geometry.get_mut(k),
                header.axes.get(k),
                header.trusted_box.get(k),
            ) else {
                return Err(Error::HeaderDecode);
            };
            *slot = AxisGeometry {
                breakpoints: &[],
                min: axis.min,
                max: axis.max,
                inv_spacing: 1.0 / axis.uniform_spacing(),
                last: axis.points.saturating_sub(1) as f32,
                last_cell: axis.points.saturating_sub(2),
                stride,
                trusted: (trusted.min, trusted.max),
            };
            stride = stride.saturating_mul(axis.points as usize);
        }
        // The breakpoint block holds the listed axes in axis order.
        for (slot, axis) in geometry.iter_mut().zip(header.axes.iter()) {
            if axis.spacing == Spacing::Listed {
                let (list, rest) = breakpoints
                    .split_at_checked(axis.breakpoint_bytes())
                    .ok_or(size_error)?;
                check_breakpoints(list, axis.min, axis.max)?;
                slot.breakpoints = list;
                breakpoints = rest;
            }
        }
        Ok(Table {
            header,
            values,
            policy,
            nodes: n,
            dims,
            geometry,
        })
    }

    /// Checks the table at the start of `region`, a buffer that may be longer than the table
    /// (a flash slot of fixed size, erased beyond the table), and returns a reader over the
    /// table's bytes alone.
    ///
    /// The table's length is found from its preamble and header alone: `8 + H` plus the
    /// payload the header's grid calls for, plus the CRC (see the crate's README, "File
    /// layout"). Nothing before the CRC check is trusted beyond that arithmetic, which is
    /// overflow-checked; then [`Table::parse`] checks the prefix of that length, CRC first. An
    /// erased or foreign region is refused as [`Error::BadMagic`], a region shorter than the
    /// declared table as [`Error::Truncated`].
    pub fn parse_prefix(region: &'a [u8]) -> Result<Self, Error> {
        let len = Self::declared_len(region)?;
        let bytes = region.get(..len).ok_or(Error::Truncated {
            needed: len,
            found: region.len(),
        })?;
        Self::parse(bytes)
    }

    /// The length in bytes of the table that starts `region`, as its preamble and header
    /// declare it (not yet checked against the CRC).
    pub fn declared_len(region: &[u8]) -> Result<usize, Error> {
        if region.get(..4) != Some(&MAGIC[..]) {
            return Err(Error::BadMagic);
        }
        let version = le_u16(region, 4).ok_or(Error::Truncated {
            needed: PREAMBLE_LEN,
            found: region.len(),
        })?;
        if version != FORMAT_VERSION {
            return Err(Error::UnsupportedVersion { found: version });
        }
        let header_len = usize::from(le_u16(region, 6).ok_or(Error::Truncated {
            needed: PREAMBLE_LEN,
            found: region.len(),
        })?);
        let header_end = PREAMBLE_LEN + header_len;
        let header_bytes = region
            .get(PREAMBLE_LEN..header_end)
            .ok_or(Error::Truncated {
                needed: header_end,
                found: region.len(),
            })?;
        decode_header(header_bytes)?
            .payload_len()?
            .checked_add(header_end + CRC_LEN)
            .ok_or(Error::InvalidHeader("grid has too many nodes"))
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
        self.nodes
    }

    /// The stored integer at a flat (C-order) node index.
    fn raw_value(&self, node: usize) -> Option<u16> {
        if self.header.quantization.bits == 8 {
            self.values.get(node).map(|&b| u16::from(b))
        } else {
            // (`checked_mul`: a huge index must be "past the last node", not an overflow.)
            node.checked_mul(2).and_then(|at| le_u16(self.values, at))
        }
    }

    /// The dequantized value at a flat (C-order) node index, `None` past the last node.
    pub fn value_at_node(&self, node: usize) -> Option<f32> {
        self.raw_value(node)
            .map(|q| self.header.quantization.dequantize(q))
    }

    /// The policy bit at a flat (C-order) node index, `None` past the last node or in a table
    /// without policy bits.
    pub fn action_at_node(&self, node: usize) -> Option<EgoAction> {
        if node >= self.node_count() || self.header.policy == PolicyEncoding::None {
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
                .zip(self.geometry.iter())
                .all(|(x, g)| g.min <= *x && *x <= g.max)
    }

    /// Whether every coordinate of `state` is finite and inside the trusted box.
    pub fn in_trusted_box(&self, state: &[f32]) -> bool {
        state.len() == self.dims
            && state
                .iter()
                .zip(self.geometry.iter())
                .all(|(x, g)| g.trusted.0 <= *x && *x <= g.trusted.1)
    }

    /// The trusted box's extent on `axis` (`None` past the last axis).
    pub fn trusted_bounds(&self, axis: usize) -> Option<crate::Bounds> {
        self.geometry
            .get(axis)
            .filter(|_| axis < self.dims)
            .map(|g| crate::Bounds::new(g.trusted.0, g.trusted.1))
    }

    /// The coordinate of node `index` on `axis`: the listed breakpoint, or `min + index *
    /// spacing` on a uniform axis (`None` past the last axis or node).
    pub fn breakpoint(&self, axis: usize, index: usize) -> Option<f32> {
        let a = self.header.axes.get(axis).filter(|_| axis < self.dims)?;
        if index >= a.points as usize {
            return None;
        }
        match a.spacing {
            crate::Spacing::Listed => le_f32(self.geometry.get(axis)?.breakpoints, index * 4),
            crate::Spacing::Uniform => Some(a.uniform_coordinate(u32::try_from(index).ok()?)),
        }
    }

    /// The grid's extent on `axis` (`None` past the last axis).
    pub fn axis_bounds(&self, axis: usize) -> Option<crate::Bounds> {
        self.geometry
            .get(axis)
            .filter(|_| axis < self.dims)
            .map(|g| crate::Bounds::new(g.min, g.max))
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
        for (k, ((&x, g), f)) in state
            .iter()
            .zip(self.geometry.iter())
            .zip(cell.frac.iter_mut())
            .enumerate()
        {
            if !x.is_finite() {
                return Err(Error::NonFiniteState { axis: k });
            }
            if x < g.min || x > g.max {
                return Err(Error::OutOfDomain { axis: k });
            }
            let (i, t) = locate(g, x);
            *f = t;
            cell.base += i as usize * g.stride;
        }
        Ok(cell)
    }

    /// The table's least interpolated value over the box `[lo, hi]` (both corners in the grid,
    /// `lo <= hi` on every axis), exactly, up to `f32` rounding of the interpolation.
    ///
    /// Why it is exact: the value is multilinear on each cell. The grid's breakpoints cut the
    /// box into sub-boxes that each lie in one cell, where the value is linear in each
    /// coordinate separately, so its least value on a sub-box is at one of that sub-box's
    /// corners. Every such corner has, on each axis, an end of the box or a breakpoint strictly
    /// inside it, so the least value over those candidate points is the least over the box.
    /// Each candidate is located once per axis (no search per point), and each point costs one
    /// pass over its cell's `2^dims` corners.
    ///
    /// [`Error::BoxTooWide`] when an axis holds more than [`BOX_INTERIOR`] breakpoints strictly
    /// inside the box (the cost is bounded: at most `(BOX_INTERIOR + 2)^dims` points);
    /// [`Error::OutOfDomain`] or [`Error::NonFiniteState`] for a corner outside the grid or not
    /// finite, or `lo > hi`.
    pub fn least_over_box(&self, lo: &[f32], hi: &[f32]) -> Result<f32, Error> {
        self.least_over_box_summing(lo, hi, Self::corner_sum_read_where_weighed)
    }

    /// [`Table::least_over_box`], each candidate point's interpolation summed by `sum_at`.
    #[inline(always)]
    fn least_over_box_summing(
        &self,
        lo: &[f32],
        hi: &[f32],
        sum_at: impl Fn(&Self, &Cell) -> f32,
    ) -> Result<f32, Error> {
        if lo.len() != self.dims || hi.len() != self.dims {
            return Err(Error::DimensionMismatch {
                expected: self.dims,
                found: lo.len().min(hi.len()),
            });
        }
        // Per axis: the candidates' cell index and position in the cell. (`heapless::Vec`
        // leaves its storage unwritten until pushed: a zeroed array of them cost the default
        // configuration's step about 390 instructions of `memclr` on the Cortex-M4F.)
        let mut cells: [Candidates; MAX_DIMS] = Default::default();
        for (k, (((&l, &h), g), out)) in lo
            .iter()
            .zip(hi.iter())
            .zip(self.geometry.iter())
            .zip(cells.iter_mut())
            .enumerate()
        {
            if !(l.is_finite() && h.is_finite()) {
                return Err(Error::NonFiniteState { axis: k });
            }
            if l < g.min || h > g.max || l > h {
                return Err(Error::OutOfDomain { axis: k });
            }
            self.axis_candidates(k, g, l, h, out)?;
        }
        // Every combination of the axes' candidates (an odometer over the axes).
        let mut digit = [0usize; MAX_DIMS];
        let mut least = f32::INFINITY;
        loop {
            let mut cell = Cell {
                base: 0,
                frac: [0.0; MAX_DIMS],
            };
            for (((&d, axis), g), f) in digit
                .iter()
                .zip(cells.iter())
                .zip(self.geometry.iter())
                .zip(cell.frac.iter_mut())
                .take(self.dims)
            {
                let (i, t) = axis.get(d).copied().unwrap_or((0, 0.0));
                cell.base += i as usize * g.stride;
                *f = t;
            }
            let sum = sum_at(self, &cell);
            if sum < least {
                least = sum;
            }
            // Next combination: the first axis that is not at its last candidate moves on.
            let mut carried = true;
            for (d, axis) in digit.iter_mut().zip(cells.iter()).take(self.dims) {
                *d += 1;
                if *d < axis.len() {
                    carried = false;
                    break;
                }
                *d = 0;
            }
            if carried {
                break;
            }
        }
        let q = &self.header.quantization;
        Ok(q.offset + q.scale * least)
    }

    /// The interpolation's sum at `cell` (in stored units), reading only the corners it
    /// weighs. A point on a breakpoint weighs one of its cell's two nodes along that axis at
    /// exactly 0 (`t` or `1 - t` is 0), and a corner of weight 0 adds exactly +0 to this sum
    /// of non-negative terms: leaving it out gives the same sum, bit for bit, as reading every
    /// corner (`the_box_minimum_reads_only_the_weighed_corners_and_sums_the_same_bits`). Most
    /// of a box's candidate points have a coordinate on a breakpoint.
    #[inline(always)]
    fn corner_sum_read_where_weighed(&self, cell: &Cell) -> f32 {
        let mut sum = 0.0f32;
        self.for_each_corner(cell, |node, w| {
            if w != 0.0 {
                sum += w * self.stored(node);
            }
        });
        sum
    }

    /// The candidates of one axis for [`Table::least_over_box`], pushed onto `out` (empty):
    /// `lo`, the breakpoints strictly inside `(lo, hi)`, and `hi` (one candidate when
    /// `lo == hi`), each as (cell, position).
    fn axis_candidates(
        &self,
        axis: usize,
        g: &AxisGeometry<'_>,
        lo: f32,
        hi: f32,
        out: &mut Candidates,
    ) -> Result<(), Error> {
        let too_wide = |_| Error::BoxTooWide { axis };
        let (first_cell, first_t) = locate(g, lo);
        out.push((first_cell, first_t)).map_err(too_wide)?;
        if hi <= lo {
            return Ok(());
        }
        // The breakpoints after `lo`'s cell's lower node, while strictly below `hi`.
        let mut index = first_cell as usize + 1;
        while let Some(b) = self.breakpoint(axis, index) {
            if b >= hi {
                break;
            }
            if b > lo {
                // (The capacity, `BOX_INTERIOR + 2`, refuses the box past `BOX_INTERIOR`
                // breakpoints: here, or at `hi`.)
                // A breakpoint inside the grid's last cell range is the lower node of its cell.
                let cell = u32::try_from(index).unwrap_or(u32::MAX).min(g.last_cell);
                let t = if cell as usize == index { 0.0 } else { 1.0 };
                out.push((cell, t)).map_err(too_wide)?;
            }
            index += 1;
        }
        // `hi`'s cell. On a listed axis the scan has just passed it, so the binary search is
        // not run again (about 210 instructions an axis on the Cortex-M4F): the cell below the
        // first breakpoint at or above `hi` (`index - 1`, the last cell at the grid's top),
        // with `locate_listed`'s own arithmetic for the position. Where `hi` is that breakpoint
        // the position is exactly 1 (`x / x`), the same node as the binary search's cell
        // above at 0. A uniform axis' `locate` is a multiplication.
        let upper = if g.breakpoints.is_empty() {
            locate(g, hi)
        } else {
            let cell = u32::try_from(index - 1)
                .unwrap_or(u32::MAX)
                .min(g.last_cell);
            (cell, listed_position(g.breakpoints, cell, hi))
        };
        out.push(upper).map_err(too_wide)
    }

    /// Visits the `2^dims` corners of a cell in corner order (corner `c` is offset by
    /// `(c >> k) & 1` nodes along axis `k`) with their multilinear weights. The axes are split
    /// into a low half (the first `ceil(dims / 2)`) and a high half; each half's at most eight
    /// partial weights and offsets are built by doubling, and every corner then costs one
    /// product and one sum. Nothing is indexed that can fail.
    #[inline(always)]
    fn for_each_corner(&self, cell: &Cell, mut visit: impl FnMut(usize, f32)) {
        let low_axes = self.dims.div_ceil(2);
        let half = |axes: core::ops::Range<usize>| {
            let mut weight = [0f32; 8];
            let mut offset = [0usize; 8];
            weight[0] = 1.0;
            let mut len = 1usize;
            for k in axes {
                let (Some(g), Some(&t)) = (self.geometry.get(k), cell.frac.get(k)) else {
                    continue;
                };
                let (Some((w_lo, w_hi)), Some((o_lo, o_hi))) = (
                    weight.split_at_mut_checked(len),
                    offset.split_at_mut_checked(len),
                ) else {
                    break;
                };
                for (((wl, wh), ol), oh) in w_lo
                    .iter_mut()
                    .zip(w_hi.iter_mut())
                    .zip(o_lo.iter())
                    .zip(o_hi.iter_mut())
                {
                    *wh = *wl * t;
                    *wl *= 1.0 - t;
                    *oh = *ol + g.stride;
                }
                len *= 2;
            }
            (weight, offset, len.min(8))
        };
        let (wa, oa, na) = half(0..low_axes);
        let (wb, ob, nb) = half(low_axes..self.dims);
        for (&w_high, &o_high) in wb.iter().zip(ob.iter()).take(nb) {
            for (&w_low, &o_low) in wa.iter().zip(oa.iter()).take(na) {
                visit(cell.base + o_low + o_high, w_low * w_high);
            }
        }
    }

    /// The stored integer of a node, as a float (0 past the end).
    #[inline(always)]
    fn stored(&self, node: usize) -> f32 {
        if self.header.quantization.bits == 8 {
            f32::from(self.values.get(node).copied().unwrap_or(0))
        } else {
            match self.values.get(2 * node..2 * node + 2) {
                Some(&[lo, hi]) => f32::from(u16::from_le_bytes([lo, hi])),
                _ => 0.0,
            }
        }
    }

    /// The policy bit of a node (false past the end).
    #[inline(always)]
    fn bit(&self, node: usize) -> bool {
        self.policy
            .get(node >> 3)
            .is_some_and(|byte| byte >> (node & 7) & 1 == 1)
    }

    /// The multilinear interpolation of the dequantized values at `state`.
    pub fn value_at(&self, state: &[f32]) -> Result<f32, Error> {
        let cell = self.cell(state)?;
        let mut sum = 0.0f32;
        self.for_each_corner(&cell, |node, w| sum += w * self.stored(node));
        let q = &self.header.quantization;
        Ok(q.offset + q.scale * sum)
    }

    /// The ego's bang-bang input at `state` ([`crate::PolicyEncoding::SignBitWeightedVote`]).
    pub fn policy_at(&self, state: &[f32]) -> Result<EgoAction, Error> {
        Ok(self.lookup(state)?.action)
    }

    /// Value and action at `state` from one cell search ([`Error::NoPolicy`] for a table
    /// without policy bits).
    pub fn lookup(&self, state: &[f32]) -> Result<Lookup, Error> {
        if self.header.policy == PolicyEncoding::None {
            return Err(Error::NoPolicy);
        }
        let cell = self.cell(state)?;
        let mut sum = 0.0f32;
        let mut vote = 0.0f32;
        // The first corner of largest weight, for an exact tie of the vote.
        let mut heaviest = (-1.0f32, false);
        self.for_each_corner(&cell, |node, w| {
            sum += w * self.stored(node);
            let bit = self.bit(node);
            vote += if bit { w } else { -w };
            if w > heaviest.0 {
                heaviest = (w, bit);
            }
        });
        let accelerate = if vote != 0.0 { vote > 0.0 } else { heaviest.1 };
        let q = &self.header.quantization;
        Ok(Lookup {
            value: q.offset + q.scale * sum,
            action: if accelerate {
                EgoAction::Accelerate
            } else {
                EgoAction::Brake
            },
        })
    }
}

/// Checks a listed axis' breakpoints: finite, strictly increasing, from `min` to `max`.
fn check_breakpoints(list: &[u8], min: f32, max: f32) -> Result<(), Error> {
    let bad = Error::InvalidHeader("axis breakpoints");
    let count = list.len() / 4;
    let first = le_f32(list, 0).ok_or(bad)?;
    let last = le_f32(list, (count.saturating_sub(1)) * 4).ok_or(bad)?;
    if first != min || last != max {
        return Err(bad);
    }
    let mut previous = f32::NEG_INFINITY;
    for k in 0..count {
        let x = le_f32(list, 4 * k).ok_or(bad)?;
        if !(x.is_finite() && x > previous) {
            return Err(bad);
        }
        previous = x;
    }
    Ok(())
}

/// The cell of `x` (finite, within `[min, max]`) on one axis and the position in it:
/// `i` in `[0, last_cell]` and `t` in `[0, 1]`. The cast of a uniform axis' scaled coordinate to
/// an index happens only after it is clamped into `[0, last]`.
#[inline(always)]
fn locate(g: &AxisGeometry<'_>, x: f32) -> (u32, f32) {
    if g.breakpoints.is_empty() {
        // `s` is finite and in [0, last] up to rounding: clamp, then truncation is floor and
        // fits in u32. (Not `f32::clamp`: it asserts its bounds are ordered, a panic path.)
        let s = (x - g.min) * g.inv_spacing;
        let s = if s > 0.0 { s } else { 0.0 };
        let s = if s < g.last { s } else { g.last };
        let i = (s as u32).min(g.last_cell);
        (i, s - i as f32)
    } else {
        locate_listed(g.breakpoints, g.last_cell, x)
    }
}

/// The cell of `x` (within `[min, max]`) on a listed axis and the position in it, by binary
/// search over the breakpoints: `i` in `[0, last_cell]` with `b_i <= x`, and
/// `t = (x - b_i) / (b_{i+1} - b_i)` clamped to `[0, 1]`.
// Out of line: it keeps the uniform axes' path, the common one, short and inlined.
#[inline(never)]
fn locate_listed(list: &[u8], last_cell: u32, x: f32) -> (u32, f32) {
    // Invariant: b_lo <= x (or lo = 0), and the answer is in [lo, hi].
    let (mut lo, mut hi) = (0u32, last_cell);
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if le_f32(list, mid as usize * 4).is_some_and(|b| b <= x) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    (lo, listed_position(list, lo, x))
}

/// The position of `x` in cell `i` of a listed axis: `(x - b_i) / (b_{i+1} - b_i)` clamped to
/// `[0, 1]`.
#[inline(always)]
fn listed_position(list: &[u8], i: u32, x: f32) -> f32 {
    let a = le_f32(list, i as usize * 4).unwrap_or(x);
    let b = le_f32(list, i as usize * 4 + 4).unwrap_or(x);
    let t = if b > a { (x - a) / (b - a) } else { 0.0 };
    let t = if t > 0.0 { t } else { 0.0 };
    if t < 1.0 {
        t
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The deployed table, which the firmware's rear check reads.
    const DEPLOYED: &[u8] = include_bytes!("../../firmware/tables/default.bin");

    proptest! {
        /// Reading only the corners a candidate point weighs gives the box minimum every corner
        /// gives, to the bit, on the deployed table: boxes anywhere in its grid, their ends on
        /// a breakpoint a third of the time on each axis (where the skipped corners are).
        #[test]
        fn the_box_minimum_reads_only_the_weighed_corners_and_sums_the_same_bits(
            start in proptest::array::uniform3(0.0f32..1.0),
            width in proptest::array::uniform3(0.0f32..0.02),
            snap in proptest::array::uniform3(0u8..3),
        ) {
            let table = Table::parse(DEPLOYED).unwrap();
            let mut lo = [0.0f32; 3];
            let mut hi = [0.0f32; 3];
            for k in 0..3 {
                let b = table.axis_bounds(k).unwrap();
                let (min, max) = (b.min, b.max);
                let at = |u: f32| min + (max - min) * u;
                // A breakpoint near `x`: the first at or above it.
                let breakpoint = |x: f32| {
                    (0..).map_while(|i| table.breakpoint(k, i)).find(|&p| p >= x).unwrap_or(max)
                };
                lo[k] = at(start[k]);
                hi[k] = at((start[k] + width[k]).min(1.0));
                match snap[k] {
                    0 => lo[k] = breakpoint(lo[k]).min(hi[k]),
                    1 => hi[k] = breakpoint(hi[k]).max(lo[k]),
                    _ => {}
                }
            }
            let every_corner = |t: &Table<'_>, cell: &Cell| {
                let mut sum = 0.0f32;
                t.for_each_corner(cell, |node, w| sum += w * t.stored(node));
                sum
            };
            let read = table.least_over_box(&lo, &hi);
            let all = table.least_over_box_summing(&lo, &hi, every_corner);
            match (read, all) {
                (Ok(a), Ok(b)) => prop_assert_eq!(a.to_bits(), b.to_bits(), "{:?}..{:?}", lo, hi),
                (a, b) => prop_assert_eq!(a, b),
            }
        }
    }
}
