//! The writer: quantizes a value function conservatively and lays it out as table bytes.
//!
//! Quantization lives here, next to the reader that undoes it, so that the two cannot disagree
//! about rounding: a stored integer `q` stands for `offset + scale * q` computed in `f32`, exactly
//! as the reader computes it, and `q` is the largest integer whose value does not exceed the
//! solver's value.

use crate::header::{
    Axis, Bounds, EmergencyDeclaration, ErrorBound, Game, Header, Horizon, PolicyEncoding,
    Quantization, Spacing, Verification, MAX_DIMS,
};
use crate::{Error, CRC32, FORMAT_VERSION, MAGIC};

/// The width of a stored value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueBits {
    /// One byte a node: coarse, a quarter of the size of `f32`.
    Eight,
    /// Two bytes a node.
    Sixteen,
}

impl ValueBits {
    fn bits(self) -> u8 {
        match self {
            ValueBits::Eight => 8,
            ValueBits::Sixteen => 16,
        }
    }

    fn max_q(self) -> u16 {
        match self {
            ValueBits::Eight => u16::from(u8::MAX),
            ValueBits::Sixteen => u16::MAX,
        }
    }
}

/// Everything a table is made of, before quantization.
#[derive(Debug, Clone)]
pub struct TableContents<'a> {
    /// The game and its parameters.
    pub game: Game,
    /// `l(z) = min(gaps) - min_gap`.
    pub min_gap: f32,
    /// Horizon and convergence.
    pub horizon: Horizon,
    /// The grid, in state order. An axis whose `spacing` is [`Spacing::Listed`] takes its
    /// breakpoints from `breakpoints`.
    pub axes: &'a [Axis<'a>],
    /// Per listed axis, in axis order, its breakpoints (strictly increasing, from `min` to
    /// `max`, `points` of them); nothing for uniform axes.
    pub breakpoints: &'a [&'a [f32]],
    /// The trusted box, one interval per axis.
    pub trusted_box: &'a [Bounds],
    /// The bound on the interpolation error (see [`ErrorBound::interpolation`]).
    pub interpolation_error: f32,
    /// The width of stored values.
    pub value_bits: ValueBits,
    /// The value at every node, C order (last axis fastest).
    pub values: &'a [f32],
    /// The policy bit at every node, C order: `true` where the ego should accelerate. Empty for
    /// a table without policy bits ([`PolicyEncoding::None`]).
    pub accelerate: &'a [bool],
}

/// Quantizes `contents` and returns the table's bytes (preamble, header, payload, CRC-32).
pub fn encode(contents: &TableContents<'_>) -> Result<Vec<u8>, Error> {
    let mut axes = heapless::Vec::<Axis<'_>, MAX_DIMS>::new();
    for axis in contents.axes {
        axes.push(*axis)
            .map_err(|_| Error::InvalidHeader("too many axes"))?;
    }
    let mut trusted_box = heapless::Vec::<Bounds, MAX_DIMS>::new();
    for b in contents.trusted_box {
        trusted_box
            .push(*b)
            .map_err(|_| Error::InvalidHeader("trusted box dimensions"))?;
    }
    let mut header = Header {
        game: contents.game,
        min_gap: contents.min_gap,
        horizon: contents.horizon,
        axes,
        trusted_box,
        quantization: Quantization {
            bits: contents.value_bits.bits(),
            scale: 1.0,
            offset: 0.0,
        },
        error_bound: ErrorBound {
            quantization: 0.0,
            interpolation: contents.interpolation_error,
        },
        policy: if contents.accelerate.is_empty() {
            PolicyEncoding::None
        } else {
            PolicyEncoding::SignBitWeightedVote
        },
        verification: None,
    };
    header.validate()?;
    let n = header.node_count()?;
    let policy_len = if contents.accelerate.is_empty() {
        n
    } else {
        contents.accelerate.len()
    };
    for len in [contents.values.len(), policy_len] {
        if len != n {
            return Err(Error::ContentsSize {
                expected: n,
                found: len,
            });
        }
    }
    if let Some(node) = contents.values.iter().position(|v| !v.is_finite()) {
        return Err(Error::NonFiniteValue { node });
    }

    let (quantization, q, quantization_error) = quantize(contents.values, contents.value_bits);
    header.quantization = quantization;
    header.error_bound.quantization = quantization_error;
    header.validate()?;

    let mut out = preamble_and_header(&header, n * 2 + n / 8 + 8)?;
    let listed: Vec<&Axis<'_>> = header
        .axes
        .iter()
        .filter(|a| a.spacing == Spacing::Listed)
        .collect();
    if listed.len() != contents.breakpoints.len() {
        return Err(Error::InvalidHeader("one breakpoint list per listed axis"));
    }
    for (axis, list) in listed.iter().zip(contents.breakpoints) {
        let ok = list.len() == axis.points as usize
            && list.first() == Some(&axis.min)
            && list.last() == Some(&axis.max)
            && list.iter().all(|x| x.is_finite())
            && list.iter().zip(list.iter().skip(1)).all(|(a, b)| a < b);
        if !ok {
            return Err(Error::InvalidHeader("axis breakpoints"));
        }
        for x in *list {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    match contents.value_bits {
        ValueBits::Eight => out.extend(q.iter().map(|&v| v as u8)),
        ValueBits::Sixteen => {
            for v in &q {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    // Node k is bit k % 8 (least significant first) of byte k / 8.
    out.extend(contents.accelerate.chunks(8).map(|chunk| {
        chunk
            .iter()
            .enumerate()
            .fold(0u8, |byte, (bit, &a)| byte | (u8::from(a) << bit))
    }));
    let crc = CRC32.checksum(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    Ok(out)
}

/// The preamble and the encoded header, in a buffer with room for `payload` more bytes.
fn preamble_and_header(header: &Header<'_>, payload: usize) -> Result<Vec<u8>, Error> {
    let header_bytes =
        postcard::to_stdvec(header).map_err(|_| Error::InvalidHeader("header encoding"))?;
    let header_len = u16::try_from(header_bytes.len())
        .map_err(|_| Error::InvalidHeader("header longer than 65535 bytes"))?;
    let mut out = Vec::with_capacity(crate::PREAMBLE_LEN + header_bytes.len() + payload);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&header_len.to_le_bytes());
    out.extend_from_slice(&header_bytes);
    Ok(out)
}

/// The table `bytes` with `verification` in its header: the payload is copied byte for byte
/// (nothing is quantized again), the header length and the CRC are written anew.
pub fn with_verification(bytes: &[u8], verification: Verification) -> Result<Vec<u8>, Error> {
    rewrite_header(bytes, |header| {
        header.verification = Some(verification);
        Ok(())
    })
}

/// The split three-car table `bytes` with its leader's acceleration bounds declared as
/// `leader`: the rear table's values are the rear game's, which the leader does not enter
/// (the split), so the payload and the verification record are copied as they are. For
/// running the deployed rear table against another leader (a harder one: 9.8 m/s^2). Refused
/// for any other game.
pub fn with_leader(bytes: &[u8], leader: Bounds) -> Result<Vec<u8>, Error> {
    rewrite_header(bytes, |header| match &mut header.game {
        Game::ThreeCarSplit { leader: l, .. } => {
            *l = leader;
            Ok(())
        }
        _ => Err(Error::InvalidHeader("not a split three-car table")),
    })
}

/// The split three-car table `bytes` with `emergency` declared: like the leader, the
/// emergency authority, the follower's reaction and the lights' command do not enter the rear
/// table's values, so the payload and the verification record are copied as they are. For
/// running the deployed rear table on another vehicle, or against another follower. Refused
/// for any other game, and for a declaration that is not one.
pub fn with_emergency(bytes: &[u8], emergency: EmergencyDeclaration) -> Result<Vec<u8>, Error> {
    rewrite_header(bytes, |header| match &mut header.game {
        Game::ThreeCarSplit { emergency: e, .. } => {
            *e = emergency;
            Ok(())
        }
        _ => Err(Error::InvalidHeader("not a split three-car table")),
    })
}

/// The table `bytes` with its header changed by `change`: the payload copied byte for byte,
/// the header length and the CRC written anew.
fn rewrite_header(
    bytes: &[u8],
    change: impl FnOnce(&mut Header) -> Result<(), Error>,
) -> Result<Vec<u8>, Error> {
    let table = crate::Table::parse(bytes)?;
    let mut header = table.header().clone();
    change(&mut header)?;
    header.validate()?;
    // `parse` has checked the preamble, the header length and the trailer.
    let malformed = Error::InvalidHeader("header length");
    let old_header_len = match bytes.get(6..8) {
        Some(&[lo, hi]) => usize::from(u16::from_le_bytes([lo, hi])),
        _ => return Err(malformed),
    };
    let payload = bytes
        .get(crate::PREAMBLE_LEN + old_header_len..bytes.len().saturating_sub(crate::CRC_LEN))
        .ok_or(malformed)?;
    let mut out = preamble_and_header(&header, payload.len() + crate::CRC_LEN)?;
    out.extend_from_slice(payload);
    let crc = CRC32.checksum(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    Ok(out)
}

/// Chooses `offset = min(values)` and the scale that spans the range with the available steps,
/// then rounds every value down. Returns the quantization, the integers and the largest
/// rounding error. All arithmetic that decides `q` is the reader's `f32` arithmetic.
fn quantize(values: &[f32], bits: ValueBits) -> (Quantization, Vec<u16>, f32) {
    let lo = values.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = values.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let (lo, hi) = if values.is_empty() {
        (0.0, 0.0)
    } else {
        (lo, hi)
    };
    let max_q = bits.max_q();
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    let scale = span / f32::from(max_q);
    let quantization = Quantization {
        bits: bits.bits(),
        scale,
        offset: lo,
    };
    let mut worst = 0.0f32;
    let q = values
        .iter()
        .map(|&v| {
            let guess = ((v - lo) / scale).floor().clamp(0.0, f32::from(max_q)) as u16;
            // Float rounding can put the guess one step off either way: settle on the largest
            // q whose dequantized value does not exceed v.
            let mut q = guess;
            while q > 0 && quantization.dequantize(q) > v {
                q -= 1;
            }
            while q < max_q && quantization.dequantize(q + 1) <= v {
                q += 1;
            }
            worst = worst.max(v - quantization.dequantize(q));
            q
        })
        .collect();
    (quantization, q, worst)
}
