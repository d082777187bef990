//! A CAN driver for the radar tracks, the ego speed and the acceleration request, generic over
//! the `embedded-can` non-blocking traits.
//!
//! # Frame layout (standard 11-bit identifiers, little-endian fields)
//! | id | name | bytes |
//! |---|---|---|
//! | `0x120` | front track (leader) | 0-1 gap `u16` 0.01 m (`0xFFFF`: no vehicle), 2-3 relative speed `i16` 0.01 m/s (`v_leader - v_ego`), 4 flags (bit 0: valid), 5 rolling counter |
//! | `0x121` | rear track (follower) | as `0x120`, relative speed `v_ego - v_follower` |
//! | `0x130` | ego speed | 0-1 speed `u16` 0.01 m/s, 2 flags (bit 0: valid), 3 rolling counter |
//! | `0x200` | acceleration request (sent) | 0-1 acceleration `i16` 0.001 m/s^2, 2 mode (0 nominal, 1 override, 2 minimum risk, 3 uncertified), 3 rolling counter |
//!
//! A received frame is time-stamped with the clock value of the `read` that drained it; a frame
//! with a wrong length is counted and ignored, so the old measurement ages until it is stale.

use embedded_can::{Frame, Id, StandardId};

use crate::controller::{Command, Mode};
use crate::inputs::{Actuator, Inputs, Measurement, Sensors, Track};
use crate::math;

/// Identifier of the front (leader) track.
pub const FRONT_TRACK_ID: u16 = 0x120;
/// Identifier of the rear (follower) track.
pub const REAR_TRACK_ID: u16 = 0x121;
/// Identifier of the ego speed.
pub const EGO_SPEED_ID: u16 = 0x130;
/// Identifier of the acceleration request.
pub const ACCEL_REQUEST_ID: u16 = 0x200;

/// Frames drained per `read`, at most (bounds the time a flooded bus can take).
pub const MAX_FRAMES_PER_READ: usize = 32;

/// Errors of the CAN driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error<E> {
    /// The bus driver failed.
    Bus(E),
    /// The transmit mailbox is full.
    TransmitBusy,
    /// A frame could not be built (never with the identifiers above).
    FrameConstruction,
}

/// The driver: decodes received frames into [`Inputs`] and encodes commands.
pub struct CanBus<C> {
    can: C,
    inputs: Inputs,
    counter: u8,
    malformed: u32,
}

fn never(now_us: u64) -> Inputs {
    let track = Measurement {
        value: Track {
            gap: f32::NAN,
            rel_speed: f32::NAN,
        },
        timestamp_us: now_us,
        valid: false,
    };
    Inputs {
        leader: track,
        follower: track,
        ego_speed: Measurement {
            value: f32::NAN,
            timestamp_us: now_us,
            valid: false,
        },
        now_us,
    }
}

fn u16_at(data: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes([*data.get(at)?, *data.get(at + 1)?]))
}

/// Decodes a track frame's payload.
pub fn decode_track(data: &[u8]) -> Option<(Track, bool)> {
    if data.len() != 6 {
        return None;
    }
    let gap_raw = u16_at(data, 0)?;
    let rel_raw = u16_at(data, 2)? as i16;
    let valid = data.get(4)? & 1 == 1;
    let gap = if gap_raw == u16::MAX {
        f32::INFINITY
    } else {
        f32::from(gap_raw) * 0.01
    };
    Some((
        Track {
            gap,
            rel_speed: f32::from(rel_raw) * 0.01,
        },
        valid,
    ))
}

/// Encodes a track (for simulations and tests of the other end).
pub fn encode_track(track: &Track, valid: bool, counter: u8) -> [u8; 6] {
    let gap = if track.gap.is_infinite() && track.gap > 0.0 {
        u16::MAX
    } else {
        quantize_u16(track.gap * 100.0).min(u16::MAX - 1)
    };
    let rel = quantize_i16(track.rel_speed * 100.0);
    let [g0, g1] = gap.to_le_bytes();
    let [r0, r1] = rel.to_le_bytes();
    [g0, g1, r0, r1, u8::from(valid), counter]
}

/// Decodes an ego-speed frame's payload.
pub fn decode_ego_speed(data: &[u8]) -> Option<(f32, bool)> {
    if data.len() != 4 {
        return None;
    }
    Some((f32::from(u16_at(data, 0)?) * 0.01, data.get(2)? & 1 == 1))
}

/// Encodes an acceleration request's payload.
pub fn encode_command(command: &Command, counter: u8) -> [u8; 4] {
    let [a0, a1] = quantize_i16(command.acceleration * 1000.0).to_le_bytes();
    let mode = match command.mode {
        Mode::Nominal => 0,
        Mode::Override => 1,
        Mode::MinimumRisk => 2,
        Mode::Uncertified => 3,
    };
    [a0, a1, mode, counter]
}

/// Rounds to the nearest `i16`, saturating; NaN becomes 0. The cast happens on a finite value
/// inside the range only.
fn quantize_i16(x: f32) -> i16 {
    if !math::is_finite(x) {
        return if x > 0.0 {
            i16::MAX
        } else if x < 0.0 {
            i16::MIN
        } else {
            0
        };
    }
    let r = math::clamp(x + if x >= 0.0 { 0.5 } else { -0.5 }, -32768.0, 32767.0);
    #[allow(clippy::cast_possible_truncation)]
    let q = r as i16;
    q
}

/// Rounds to the nearest `u16`, saturating; NaN and negatives become 0.
fn quantize_u16(x: f32) -> u16 {
    if !math::is_finite(x) {
        return if x > 0.0 { u16::MAX } else { 0 };
    }
    let r = math::clamp(x + 0.5, 0.0, 65535.0);
    #[allow(clippy::cast_possible_truncation)]
    let q = r as u16;
    q
}

impl<C: embedded_can::nb::Can> CanBus<C> {
    /// A driver on `can`. Until the first frames arrive every measurement is invalid.
    pub fn new(can: C) -> Self {
        CanBus {
            can,
            inputs: never(0),
            counter: 0,
            malformed: 0,
        }
    }

    /// Frames ignored for a wrong length so far.
    pub fn malformed_frames(&self) -> u32 {
        self.malformed
    }

    /// Gives the bus back.
    pub fn release(self) -> C {
        self.can
    }

    /// Drains up to [`MAX_FRAMES_PER_READ`] received frames into the inputs.
    pub fn poll(&mut self, now_us: u64) -> Result<(), Error<C::Error>> {
        for _ in 0..MAX_FRAMES_PER_READ {
            let frame = match self.can.receive() {
                Ok(f) => f,
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(e)) => return Err(Error::Bus(e)),
            };
            let Id::Standard(id) = frame.id() else {
                continue;
            };
            let data = frame.data();
            match id.as_raw() {
                FRONT_TRACK_ID | REAR_TRACK_ID => match decode_track(data) {
                    Some((track, valid)) => {
                        let m = Measurement {
                            value: track,
                            timestamp_us: now_us,
                            valid,
                        };
                        if id.as_raw() == FRONT_TRACK_ID {
                            self.inputs.leader = m;
                        } else {
                            self.inputs.follower = m;
                        }
                    }
                    None => self.malformed = self.malformed.saturating_add(1),
                },
                EGO_SPEED_ID => match decode_ego_speed(data) {
                    Some((speed, valid)) => {
                        self.inputs.ego_speed = Measurement {
                            value: speed,
                            timestamp_us: now_us,
                            valid,
                        }
                    }
                    None => self.malformed = self.malformed.saturating_add(1),
                },
                _ => {}
            }
        }
        Ok(())
    }
}

impl<C: embedded_can::nb::Can> Sensors for CanBus<C> {
    type Error = Error<C::Error>;

    fn read(&mut self, now_us: u64) -> Result<Inputs, Self::Error> {
        self.poll(now_us)?;
        let mut inputs = self.inputs;
        inputs.now_us = now_us;
        Ok(inputs)
    }
}

impl<C: embedded_can::nb::Can> Actuator for CanBus<C> {
    type Error = Error<C::Error>;

    fn request(&mut self, command: &Command) -> Result<(), Self::Error> {
        let payload = encode_command(command, self.counter);
        self.counter = self.counter.wrapping_add(1);
        let id = StandardId::new(ACCEL_REQUEST_ID).ok_or(Error::FrameConstruction)?;
        let frame = C::Frame::new(id, &payload).ok_or(Error::FrameConstruction)?;
        match self.can.transmit(&frame) {
            Ok(_) => Ok(()),
            Err(nb::Error::WouldBlock) => Err(Error::TransmitBusy),
            Err(nb::Error::Other(e)) => Err(Error::Bus(e)),
        }
    }
}
