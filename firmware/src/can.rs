//! A CAN driver for the radar tracks, the ego speed and the acceleration request, generic over
//! the `embedded-can` non-blocking traits.
//!
//! # Frame layout (standard 11-bit identifiers, little-endian fields)
//! | id | name | bytes |
//! |---|---|---|
//! | `0x120` | front track (leader) | 0-1 gap `u16` 0.01 m (`0xFFFF`: no vehicle), 2-3 relative speed `i16` 0.01 m/s (`v_leader - v_ego`), 4 flags (bit 0: valid), 5 age `u8` ms, 6 counter, 7 CRC |
//! | `0x121` | rear track (follower) | as `0x120`, relative speed `v_ego - v_follower` |
//! | `0x130` | ego speed | 0-1 speed `u16` 0.01 m/s, 2 flags (bit 0: valid), 3 age `u8` ms, 4 counter, 5 CRC |
//! | `0x131` | actuator state ([`crate::Inputs::ego_acceleration`]) | 0-1 acceleration `i16` 0.001 m/s^2 (the largest of the powertrain's realised acceleration and its requests in force and in flight), 2 flags (bit 0: valid), 3 age `u8` ms, 4 counter, 5 CRC |
//! | `0x140` | driver request ([`crate::controller::DriverRequest`]) | 0 request (1 engage/SET, 2 cancel, 3 resume, 4 set speed, 5 time gap), 1-2 value `u16` (set speed 0.01 m/s; time-gap setting), 3 counter, 4 CRC; one request per frame, delivered one per period in order (up to 4 queued) |
//! | `0x200` | acceleration request (sent) | 0-1 acceleration `i16` 0.001 m/s^2, 2 mode (bits 0-6: 0 nominal, 1 override, 2 minimum risk, 3 uncertified, 4 standby: not for the actuator; bit 7: an emergency, [`crate::Command::emergency`]: the actuator is to deliver it as an automatic emergency braking, beyond the comfort band or faster than ISO 15622's jerk limit), 3 status ([`status_byte`]: certified, takeover request, the tracks' states), 4 counter, 5 CRC |
//! | `0x210` | driver's display (sent, [`crate::DriverDisplay`]: [`crate::Controller::driver`]) | 0 flags (bit 0: engaged, bit 1: a resume waits for the move-off), 1-2 set speed `u16` 0.01 m/s, 3 time-gap setting, 4 why the latest driver request was refused ([`refusal_code`]: 0 taken or none yet, 1 set speed out of range, 2 no such time gap, 3 not certified, 4 certificate unknown, 5 needs emergency braking), 5 refusals since start (`u8`, wrapping: a new refusal changes it even with the same reason), 6 counter, 7 CRC; after every acceleration request |
//!
//! # End-to-end protection (after AUTOSAR E2E profile 1)
//! - **CRC**: CRC-8 SAE J1850 (polynomial 0x1D, initial value 0xFF, final XOR 0xFF, the
//!   `crc` crate's `CRC_8_SAE_J1850`) over the identifier (two bytes, little-endian) and every
//!   payload byte before the CRC. A frame whose CRC does not match is *corrupted*.
//! - **Counter**: each sender increments its rolling counter by one per frame, wrapping at
//!   255. Per identifier the receiver expects the next one: the same counter again is a
//!   *repeated* frame; a jump of 2 to [`MAX_COUNTER_JUMP`] means frames were *lost* (counted,
//!   the frame is used); a larger jump is *out of sequence* (the frame is not used, the
//!   receiver resynchronises on it).
//! - **Age**: the sender states how old its measurement is when it sends it (ms, up to
//!   255); the measurement's time stamp is the reception time less that age, so the sensor's
//!   latency is seen by the controller's staleness check and its look-ahead.
//!
//! A frame that is malformed (wrong length), corrupted, repeated or out of sequence is counted
//! ([`CanBus::e2e`]) and not used: the measurement it would have refreshed keeps its old time
//! stamp and ages: the controller's look-ahead covers it up to the covered track age, its
//! certified fallback beyond (`controller`'s module docs); an ego speed that ages past its stale
//! limit is a fault (the minimum-risk manoeuvre).

use embedded_can::{Frame, Id, StandardId};

use crate::controller::{Command, Mode};
use crate::driver::{DriverError, DriverRequest, DriverState};
use crate::hardware::{Actuator, DriverDisplay, Sensors};
use crate::inputs::{Inputs, Measurement, Track};
use crate::math;
use crate::sensing::TrackState;

/// Identifier of the front (leader) track.
pub const FRONT_TRACK_ID: u16 = 0x120;
/// Identifier of the rear (follower) track.
pub const REAR_TRACK_ID: u16 = 0x121;
/// Identifier of the ego speed.
pub const EGO_SPEED_ID: u16 = 0x130;
/// Identifier of the actuator's state.
pub const ACTUATOR_STATE_ID: u16 = 0x131;
/// Identifier of a driver request.
pub const DRIVER_REQUEST_ID: u16 = 0x140;
/// Identifier of the acceleration request.
pub const ACCEL_REQUEST_ID: u16 = 0x200;
/// Identifier of the driver's display frame.
pub const DRIVER_DISPLAY_ID: u16 = 0x210;

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
    /// The rolling counter of the next display frame.
    display_counter: u8,
    /// Display frames the bus did not take.
    unshown: u32,
    counts: E2eCounts,
    /// The last counter accepted per identifier: front, rear, ego speed, actuator state,
    /// driver request.
    last_counters: [Option<u8>; 5],
    /// Driver requests received and not yet delivered (one per period, oldest first).
    driver: heapless::Deque<DriverRequest, 4>,
}

fn u16_at(data: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes([*data.get(at)?, *data.get(at + 1)?]))
}

/// What a received frame carries.
enum Payload {
    Track(Track),
    Scalar(f32),
    Driver(DriverRequest),
}

/// The largest counter jump that still counts as frames lost, not out of sequence.
pub const MAX_COUNTER_JUMP: u8 = 3;

const CRC8: crc::Crc<u8> = crc::Crc::<u8>::new(&crc::CRC_8_SAE_J1850);

/// The CRC of a frame with identifier `id` over `bytes` (every payload byte before the CRC).
pub fn frame_crc(id: u16, bytes: &[u8]) -> u8 {
    let mut digest = CRC8.digest();
    digest.update(&id.to_le_bytes());
    digest.update(bytes);
    digest.finalize()
}

/// Why a received payload was not decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// Not the frame's length.
    Length,
    /// The CRC does not match.
    Checksum,
}

/// A decoded sensor frame: the value, the sender's validity flag, the measurement's age when
/// sent (ms) and the rolling counter.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Received<T> {
    /// The value.
    pub value: T,
    /// The sender's validity flag.
    pub valid: bool,
    /// How old the measurement was when it was sent, ms.
    pub age_ms: u8,
    /// The rolling counter.
    pub counter: u8,
}

/// Checks length and CRC; returns the bytes before the CRC.
fn checked(id: u16, data: &[u8], len: usize) -> Result<&[u8], FrameError> {
    if data.len() != len {
        return Err(FrameError::Length);
    }
    let (body, crc) = data.split_at(len - 1);
    if crc.first() != Some(&frame_crc(id, body)) {
        return Err(FrameError::Checksum);
    }
    Ok(body)
}

/// Decodes a track frame's payload (`id`: [`FRONT_TRACK_ID`] or [`REAR_TRACK_ID`]).
pub fn decode_track(id: u16, data: &[u8]) -> Result<Received<Track>, FrameError> {
    let body = checked(id, data, 8)?;
    let field = |at| body.get(at).copied().ok_or(FrameError::Length);
    let gap_raw = u16_at(body, 0).ok_or(FrameError::Length)?;
    let rel_raw = i16::from_le_bytes([field(2)?, field(3)?]);
    let gap = if gap_raw == u16::MAX {
        f32::INFINITY
    } else {
        f32::from(gap_raw) * 0.01
    };
    Ok(Received {
        value: Track {
            gap,
            rel_speed: f32::from(rel_raw) * 0.01,
        },
        valid: field(4)? & 1 == 1,
        age_ms: field(5)?,
        counter: field(6)?,
    })
}

/// Encodes a track (for simulations and tests of the other end).
pub fn encode_track(id: u16, track: &Track, valid: bool, age_ms: u8, counter: u8) -> [u8; 8] {
    let gap = if track.gap.is_infinite() && track.gap > 0.0 {
        u16::MAX
    } else {
        quantize_u16(track.gap * 100.0).min(u16::MAX - 1)
    };
    let rel = quantize_i16(track.rel_speed * 100.0);
    let [g0, g1] = gap.to_le_bytes();
    let [r0, r1] = rel.to_le_bytes();
    let body = [g0, g1, r0, r1, u8::from(valid), age_ms, counter];
    let crc = frame_crc(id, &body);
    [g0, g1, r0, r1, u8::from(valid), age_ms, counter, crc]
}

/// Decodes an ego-speed frame's payload.
pub fn decode_ego_speed(data: &[u8]) -> Result<Received<f32>, FrameError> {
    let body = checked(EGO_SPEED_ID, data, 6)?;
    let field = |at| body.get(at).copied().ok_or(FrameError::Length);
    Ok(Received {
        value: f32::from(u16_at(body, 0).ok_or(FrameError::Length)?) * 0.01,
        valid: field(2)? & 1 == 1,
        age_ms: field(3)?,
        counter: field(4)?,
    })
}

/// Encodes an ego speed (for simulations and tests of the other end).
pub fn encode_ego_speed(speed: f32, valid: bool, age_ms: u8, counter: u8) -> [u8; 6] {
    let [s0, s1] = quantize_u16(speed * 100.0).to_le_bytes();
    let body = [s0, s1, u8::from(valid), age_ms, counter];
    [
        s0,
        s1,
        u8::from(valid),
        age_ms,
        counter,
        frame_crc(EGO_SPEED_ID, &body),
    ]
}

/// Decodes an actuator-state frame's payload.
pub fn decode_actuator_state(data: &[u8]) -> Result<Received<f32>, FrameError> {
    let body = checked(ACTUATOR_STATE_ID, data, 6)?;
    let field = |at| body.get(at).copied().ok_or(FrameError::Length);
    Ok(Received {
        value: f32::from(i16::from_le_bytes([field(0)?, field(1)?])) * 0.001,
        valid: field(2)? & 1 == 1,
        age_ms: field(3)?,
        counter: field(4)?,
    })
}

/// Encodes an actuator state (for simulations and tests of the other end).
pub fn encode_actuator_state(acceleration: f32, valid: bool, age_ms: u8, counter: u8) -> [u8; 6] {
    let [a0, a1] = quantize_i16(acceleration * 1000.0).to_le_bytes();
    let body = [a0, a1, u8::from(valid), age_ms, counter];
    [
        a0,
        a1,
        u8::from(valid),
        age_ms,
        counter,
        frame_crc(ACTUATOR_STATE_ID, &body),
    ]
}

/// Decodes a driver-request frame's payload: the request and the counter. An unknown request
/// code is a malformed frame ([`FrameError::Length`]'s count).
pub fn decode_driver_request(data: &[u8]) -> Result<(DriverRequest, u8), FrameError> {
    let body = checked(DRIVER_REQUEST_ID, data, 5)?;
    let field = |at| body.get(at).copied().ok_or(FrameError::Length);
    let value = u16_at(body, 1).ok_or(FrameError::Length)?;
    let request = match field(0)? {
        1 => DriverRequest::Engage,
        2 => DriverRequest::Cancel,
        3 => DriverRequest::Resume,
        4 => DriverRequest::SetSpeed(f32::from(value) * 0.01),
        5 => DriverRequest::TimeGap(u8::try_from(value).unwrap_or(u8::MAX)),
        _ => return Err(FrameError::Length),
    };
    Ok((request, field(3)?))
}

/// Encodes a driver request (for simulations and tests of the other end).
pub fn encode_driver_request(request: &DriverRequest, counter: u8) -> [u8; 5] {
    let (code, value) = match *request {
        DriverRequest::Engage => (1, 0),
        DriverRequest::Cancel => (2, 0),
        DriverRequest::Resume => (3, 0),
        DriverRequest::SetSpeed(v) => (4, quantize_u16(v * 100.0)),
        DriverRequest::TimeGap(k) => (5, u16::from(k)),
    };
    let [v0, v1] = value.to_le_bytes();
    let body = [code, v0, v1, counter];
    [code, v0, v1, counter, frame_crc(DRIVER_REQUEST_ID, &body)]
}

/// Encodes an acceleration request's payload: the acceleration, the mode (its bit 7 set for an
/// emergency, [`Command::emergency`]), the status byte ([`status_byte`]), the counter and the
/// CRC.
pub fn encode_command(command: &Command, counter: u8) -> [u8; 6] {
    let [a0, a1] = quantize_i16(command.acceleration * 1000.0).to_le_bytes();
    let mode = match command.mode {
        Mode::Nominal => 0,
        Mode::Override => 1,
        Mode::MinimumRisk => 2,
        Mode::Uncertified => 3,
        Mode::Standby => 4,
    } | u8::from(command.emergency) << 7;
    let status = status_byte(command);
    let body = [a0, a1, mode, status, counter];
    [
        a0,
        a1,
        mode,
        status,
        counter,
        frame_crc(ACCEL_REQUEST_ID, &body),
    ]
}

/// The display's code for why the latest driver request was refused (frame `0x210`, byte 4):
/// 0 taken (or none yet), then one per [`DriverError`].
pub fn refusal_code(refused: Option<DriverError>) -> u8 {
    match refused {
        None => 0,
        Some(DriverError::SetSpeedOutOfRange) => 1,
        Some(DriverError::NoSuchTimeGap) => 2,
        Some(DriverError::NotCertified) => 3,
        Some(DriverError::CertificateUnknown) => 4,
        Some(DriverError::NeedsEmergencyBraking) => 5,
    }
}

/// Encodes the driver's display frame: the driver's state ([`DriverState`]), the counter and
/// the CRC.
pub fn encode_driver_display(driver: &DriverState, counter: u8) -> [u8; 8] {
    let flags = u8::from(driver.engaged) | u8::from(driver.resume_requested) << 1;
    let [v0, v1] = quantize_u16(driver.set_speed * 100.0).to_le_bytes();
    let body = [
        flags,
        v0,
        v1,
        driver.time_gap_setting,
        refusal_code(driver.refused),
        driver.refusals,
        counter,
    ];
    let [b0, b1, b2, b3, b4, b5, b6] = body;
    [
        b0,
        b1,
        b2,
        b3,
        b4,
        b5,
        b6,
        frame_crc(DRIVER_DISPLAY_ID, &body),
    ]
}

/// Decodes a driver's display frame (the display's end, and tests): the driver's state, the
/// set speed to 0.01 m/s, and the counter. An unknown refusal code or unknown flags are a
/// malformed frame ([`FrameError::Length`]'s count).
pub fn decode_driver_display(data: &[u8]) -> Result<(DriverState, u8), FrameError> {
    let body = checked(DRIVER_DISPLAY_ID, data, 8)?;
    let field = |at| body.get(at).copied().ok_or(FrameError::Length);
    let flags = field(0)?;
    if flags > 0b11 {
        return Err(FrameError::Length);
    }
    let refused = match field(4)? {
        0 => None,
        1 => Some(DriverError::SetSpeedOutOfRange),
        2 => Some(DriverError::NoSuchTimeGap),
        3 => Some(DriverError::NotCertified),
        4 => Some(DriverError::CertificateUnknown),
        5 => Some(DriverError::NeedsEmergencyBraking),
        _ => return Err(FrameError::Length),
    };
    let state = DriverState {
        engaged: flags & 1 != 0,
        resume_requested: flags & 2 != 0,
        set_speed: f32::from(u16_at(body, 1).ok_or(FrameError::Length)?) * 0.01,
        time_gap_setting: field(3)?,
        refused,
        refusals: field(5)?,
    };
    Ok((state, field(6)?))
}

/// The request's status byte, which says which case of the argument holds: bit 0 the state is
/// certified (a positive margin: in a minimum-risk manoeuvre, the certified fallback), bit 1
/// the driver's takeover request, bits 2-4 the leader track's state and bits 5-7 the
/// follower's (0 fresh, 1 aging, 2 lost, 3 new vehicle, 4 missing).
pub fn status_byte(command: &Command) -> u8 {
    let track = |t: TrackState| -> u8 {
        match t {
            TrackState::Fresh => 0,
            TrackState::Aging => 1,
            TrackState::Lost => 2,
            TrackState::New => 3,
            TrackState::Missing => 4,
        }
    };
    let certified = command.margin.is_some_and(|m| m > 0.0);
    u8::from(certified)
        | u8::from(command.takeover) << 1
        | track(command.leader) << 2
        | track(command.follower) << 5
}

/// What the end-to-end checks refused or noticed so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct E2eCounts {
    /// Frames of a wrong length.
    pub malformed: u32,
    /// Frames whose CRC did not match.
    pub corrupted: u32,
    /// Frames that repeated the last counter.
    pub repeated: u32,
    /// Frames missing between two accepted ones (counter jumps of 2 to `MAX_COUNTER_JUMP`).
    pub lost: u32,
    /// Frames whose counter jumped further (not used; the receiver resynchronised).
    pub out_of_sequence: u32,
}

/// The counter check of one identifier: whether to use a frame with `counter`.
fn sequence(last: &mut Option<u8>, counter: u8, counts: &mut E2eCounts) -> bool {
    let Some(previous) = *last else {
        *last = Some(counter);
        return true;
    };
    let jump = counter.wrapping_sub(previous);
    *last = Some(counter);
    if jump == 0 {
        counts.repeated = counts.repeated.saturating_add(1);
        false
    } else if jump <= MAX_COUNTER_JUMP {
        counts.lost = counts.lost.saturating_add(u32::from(jump - 1));
        true
    } else {
        counts.out_of_sequence = counts.out_of_sequence.saturating_add(1);
        false
    }
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
        Self::with_next_counter(can, 0)
    }

    /// A driver whose first acceleration request carries `counter`: a board that restarts
    /// without a power cycle goes on with the sequence its receiver expects, instead of a jump
    /// back to 0 that an end-to-end check refuses until it resynchronises.
    pub fn with_next_counter(can: C, counter: u8) -> Self {
        CanBus {
            can,
            inputs: Inputs::invalid(0),
            counter,
            display_counter: 0,
            unshown: 0,
            counts: E2eCounts::default(),
            last_counters: [None; 5],
            driver: heapless::Deque::new(),
        }
    }

    /// Frames ignored for a wrong length so far.
    pub fn malformed_frames(&self) -> u32 {
        self.counts.malformed
    }

    /// Display frames ([`DRIVER_DISPLAY_ID`]) the bus did not take so far: the display is
    /// not the control path, so [`crate::run_period_on_bus`] goes on without it.
    pub fn unshown(&self) -> u32 {
        self.unshown
    }

    /// What the end-to-end checks refused or noticed so far.
    pub fn e2e(&self) -> E2eCounts {
        self.counts
    }

    /// Gives the bus back.
    pub fn release(self) -> C {
        self.can
    }

    /// The bus, for what the traits do not cover (a board finishing the peripheral's start-up,
    /// say). Frames taken from it here bypass the end-to-end checks.
    pub fn bus_mut(&mut self) -> &mut C {
        &mut self.can
    }

    /// The rolling counter the next acceleration request will carry: a fault handler that
    /// must send a last frame on its own uses it, so the receiver sees no gap in the sequence.
    pub fn next_counter(&self) -> u8 {
        self.counter
    }

    /// Sends one frame with identifier `id`.
    fn transmit(&mut self, id: u16, payload: &[u8]) -> Result<(), Error<C::Error>> {
        let id = StandardId::new(id).ok_or(Error::FrameConstruction)?;
        let frame = C::Frame::new(id, payload).ok_or(Error::FrameConstruction)?;
        match self.can.transmit(&frame) {
            Ok(_) => Ok(()),
            Err(nb::Error::WouldBlock) => Err(Error::TransmitBusy),
            Err(nb::Error::Other(e)) => Err(Error::Bus(e)),
        }
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
            let raw = id.as_raw();
            let slot = match raw {
                FRONT_TRACK_ID => 0,
                REAR_TRACK_ID => 1,
                EGO_SPEED_ID => 2,
                ACTUATOR_STATE_ID => 3,
                DRIVER_REQUEST_ID => 4,
                _ => continue,
            };
            let decoded = match raw {
                EGO_SPEED_ID => decode_ego_speed(data)
                    .map(|r| (Payload::Scalar(r.value), r.valid, r.age_ms, r.counter)),
                ACTUATOR_STATE_ID => decode_actuator_state(data)
                    .map(|r| (Payload::Scalar(r.value), r.valid, r.age_ms, r.counter)),
                DRIVER_REQUEST_ID => {
                    decode_driver_request(data).map(|(d, c)| (Payload::Driver(d), true, 0, c))
                }
                _ => decode_track(raw, data)
                    .map(|r| (Payload::Track(r.value), r.valid, r.age_ms, r.counter)),
            };
            let (value, valid, age_ms, counter) = match decoded {
                Ok(d) => d,
                Err(FrameError::Length) => {
                    self.counts.malformed = self.counts.malformed.saturating_add(1);
                    continue;
                }
                Err(FrameError::Checksum) => {
                    self.counts.corrupted = self.counts.corrupted.saturating_add(1);
                    continue;
                }
            };
            let Some(last) = self.last_counters.get_mut(slot) else {
                continue;
            };
            if !sequence(last, counter, &mut self.counts) {
                continue;
            }
            let timestamp_us = now_us.saturating_sub(u64::from(age_ms) * 1000);
            let measured = |value: f32| Measurement {
                value,
                timestamp_us,
                valid,
            };
            let track = |value: Track| Measurement {
                value,
                timestamp_us,
                valid,
            };
            match (value, raw) {
                (Payload::Track(t), FRONT_TRACK_ID) => self.inputs.leader = track(t),
                (Payload::Track(t), _) => self.inputs.follower = track(t),
                (Payload::Scalar(v), EGO_SPEED_ID) => self.inputs.ego_speed = measured(v),
                (Payload::Scalar(a), _) => self.inputs.ego_acceleration = measured(a),
                (Payload::Driver(d), _) => {
                    if self.driver.is_full() {
                        self.driver.pop_front();
                    }
                    let _ = self.driver.push_back(d);
                }
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
        inputs.driver = self.driver.pop_front();
        Ok(inputs)
    }
}

impl<C: embedded_can::nb::Can> Actuator for CanBus<C> {
    type Error = Error<C::Error>;

    fn request(&mut self, command: &Command) -> Result<(), Self::Error> {
        let payload = encode_command(command, self.counter);
        self.counter = self.counter.wrapping_add(1);
        self.transmit(ACCEL_REQUEST_ID, &payload)
    }
}

impl<C: embedded_can::nb::Can> DriverDisplay for CanBus<C> {
    type Error = Error<C::Error>;

    fn show(&mut self, driver: &DriverState) -> Result<(), Self::Error> {
        let payload = encode_driver_display(driver, self.display_counter);
        self.display_counter = self.display_counter.wrapping_add(1);
        let sent = self.transmit(DRIVER_DISPLAY_ID, &payload);
        if sent.is_err() {
            self.unshown = self.unshown.saturating_add(1);
        }
        sent
    }
}
