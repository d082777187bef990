//! The CAN driver against a mock bus: decoding, the sender's age in the time stamp, the
//! end-to-end checks (CRC, rolling counter), staleness through missing frames, malformed frames,
//! the request frame and the driver's display frame.

use std::collections::VecDeque;

use embedded_can::{Frame, Id, StandardId};
use firmware::can::{self, CanBus};
use firmware::{
    run_period, Actuator, Clock, Config, Controller, Fault, Inputs, Mode, Sensors, Track, Watchdog,
    DEFAULT_TABLE,
};

#[derive(Debug, Clone, PartialEq)]
struct MockFrame {
    id: Id,
    data: Vec<u8>,
}

impl Frame for MockFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        (data.len() <= 8).then(|| MockFrame {
            id: id.into(),
            data: data.to_vec(),
        })
    }
    fn new_remote(_: impl Into<Id>, _: usize) -> Option<Self> {
        None
    }
    fn is_extended(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }
    fn is_remote_frame(&self) -> bool {
        false
    }
    fn id(&self) -> Id {
        self.id
    }
    fn dlc(&self) -> usize {
        self.data.len()
    }
    fn data(&self) -> &[u8] {
        &self.data
    }
}

#[derive(Default)]
struct MockBus {
    rx: VecDeque<MockFrame>,
    tx: Vec<MockFrame>,
    fail: bool,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct BusError;

impl embedded_can::Error for BusError {
    fn kind(&self) -> embedded_can::ErrorKind {
        embedded_can::ErrorKind::Other
    }
}

impl embedded_can::nb::Can for MockBus {
    type Frame = MockFrame;
    type Error = BusError;
    fn transmit(&mut self, frame: &MockFrame) -> nb::Result<Option<MockFrame>, BusError> {
        self.tx.push(frame.clone());
        Ok(None)
    }
    fn receive(&mut self) -> nb::Result<MockFrame, BusError> {
        if self.fail {
            return Err(nb::Error::Other(BusError));
        }
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

fn frame(id: u16, data: &[u8]) -> MockFrame {
    MockFrame::new(StandardId::new(id).unwrap(), data).unwrap()
}

fn push_all(bus: &mut CanBus<MockBus>, frames: Vec<MockFrame>) -> CanBus<MockBus> {
    let mut raw = std::mem::replace(bus, CanBus::new(MockBus::default())).release();
    raw.rx.extend(frames);
    CanBus::new(raw)
}

fn front(gap: f32, age_ms: u8, counter: u8) -> MockFrame {
    let track = Track {
        gap,
        rel_speed: 0.0,
    };
    frame(
        can::FRONT_TRACK_ID,
        &can::encode_track(can::FRONT_TRACK_ID, &track, true, age_ms, counter),
    )
}

fn healthy_frames() -> Vec<MockFrame> {
    healthy_frames_counted(1)
}

fn healthy_frames_counted(counter: u8) -> Vec<MockFrame> {
    vec![
        front(100.0, 0, counter),
        frame(
            can::REAR_TRACK_ID,
            &can::encode_track(
                can::REAR_TRACK_ID,
                &Track {
                    gap: 40.0,
                    rel_speed: -0.5,
                },
                true,
                0,
                counter,
            ),
        ),
        frame(
            can::EGO_SPEED_ID,
            &can::encode_ego_speed(25.0, true, 0, counter),
        ),
        frame(
            can::ACTUATOR_STATE_ID,
            &can::encode_actuator_state(0.0, true, 0, counter),
        ),
    ]
}

#[test]
fn frames_decode_into_inputs() {
    let mut bus = CanBus::new(MockBus::default());
    bus = push_all(&mut bus, healthy_frames());
    let inputs = bus.read(1_000).unwrap();
    assert!((inputs.leader.value.gap - 100.0).abs() < 0.01);
    assert!((inputs.follower.value.rel_speed + 0.5).abs() < 0.01);
    assert!((inputs.ego_speed.value - 25.0).abs() < 0.01);
    assert!(inputs.leader.valid && inputs.follower.valid && inputs.ego_speed.valid);
    assert_eq!(inputs.leader.timestamp_us, 1_000);
}

#[test]
fn encoding_round_trips_and_saturates() {
    let id = can::FRONT_TRACK_ID;
    for (gap, rel) in [(0.0f32, -12.34f32), (123.45, 7.5), (655.0, 0.0)] {
        let track = Track {
            gap,
            rel_speed: rel,
        };
        let r = can::decode_track(id, &can::encode_track(id, &track, true, 7, 9)).unwrap();
        assert!(r.valid && r.age_ms == 7 && r.counter == 9);
        assert!((r.value.gap - gap).abs() < 0.006 && (r.value.rel_speed - rel).abs() < 0.006);
    }
    let wild = Track {
        gap: f32::INFINITY,
        rel_speed: f32::NAN,
    };
    let r = can::decode_track(id, &can::encode_track(id, &wild, true, 0, 0)).unwrap();
    assert!(r.value.gap.is_infinite());
    assert_eq!(r.value.rel_speed, 0.0);
    assert_eq!(can::decode_track(id, &[0; 5]), Err(can::FrameError::Length));
    assert_eq!(can::decode_ego_speed(&[0; 8]), Err(can::FrameError::Length));
    let speed = can::decode_ego_speed(&can::encode_ego_speed(25.0, true, 3, 4)).unwrap();
    assert!((speed.value - 25.0).abs() < 0.006 && speed.age_ms == 3 && speed.counter == 4);
}

#[test]
fn every_single_bit_flip_and_a_wrong_identifier_fail_the_crc() {
    let id = can::FRONT_TRACK_ID;
    let good = can::encode_track(
        id,
        &Track {
            gap: 42.0,
            rel_speed: -1.0,
        },
        true,
        20,
        17,
    );
    for byte in 0..good.len() {
        for bit in 0..8 {
            let mut bad = good;
            bad[byte] ^= 1 << bit;
            assert_eq!(
                can::decode_track(id, &bad),
                Err(can::FrameError::Checksum),
                "byte {byte} bit {bit}"
            );
        }
    }
    // The rear track's frame on the front identifier (data identifier in the CRC).
    assert_eq!(
        can::decode_track(can::REAR_TRACK_ID, &good),
        Err(can::FrameError::Checksum)
    );
    // The request frame's CRC, as the receiver will check it.
    let mut cmd = firmware::Command::bare(-1.25, Mode::Override, None);
    cmd.margin = Some(0.3);
    cmd.takeover = true;
    cmd.leader = firmware::TrackState::New;
    cmd.follower = firmware::TrackState::Aging;
    let sent = can::encode_command(&cmd, 5);
    assert_eq!(sent[5], can::frame_crc(can::ACCEL_REQUEST_ID, &sent[..5]));
    // Certified, takeover, leader new (3), follower aging (1).
    assert_eq!(sent[3], 0b0010_1111);
    assert_eq!(sent[4], 5);
    // Override (1), no emergency; an emergency braking below the band sets the mode's bit 7.
    assert_eq!(sent[2], 1);
    cmd.acceleration = -7.5;
    cmd.emergency = true;
    let sent = can::encode_command(&cmd, 6);
    assert_eq!(sent[2], 0x81);
    assert_eq!(i16::from_le_bytes([sent[0], sent[1]]), -7_500);
    assert_eq!(sent[5], can::frame_crc(can::ACCEL_REQUEST_ID, &sent[..5]));
}

#[test]
fn the_senders_age_dates_the_measurement() {
    let mut bus = CanBus::new(MockBus::default());
    bus = push_all(&mut bus, vec![front(60.0, 80, 1)]);
    let inputs = bus.read(1_000_000).unwrap();
    assert_eq!(inputs.leader.timestamp_us, 1_000_000 - 80_000);
}

#[test]
fn repeated_lost_corrupted_and_out_of_sequence_frames_are_counted_and_not_used() {
    let mut bus = CanBus::new(MockBus::default());
    let mut corrupted = front(10.0, 0, 2);
    corrupted.data[0] ^= 0x10;
    bus = push_all(
        &mut bus,
        vec![
            front(60.0, 0, 1),  // accepted
            front(10.0, 0, 1),  // repeated: not used
            corrupted,          // corrupted: not used
            front(59.0, 0, 3),  // one frame lost (2): used
            front(10.0, 0, 40), // out of sequence: not used, resynchronised on 40
            front(58.0, 0, 41), // in sequence again: used
        ],
    );
    let inputs = bus.read(5_000).unwrap();
    let e2e = bus.e2e();
    assert_eq!(
        e2e,
        can::E2eCounts {
            malformed: 0,
            corrupted: 1,
            repeated: 1,
            lost: 1,
            out_of_sequence: 1,
        }
    );
    assert!((inputs.leader.value.gap - 58.0).abs() < 0.01, "{inputs:?}");
    // Only repeats from here on (`push_all` starts a fresh driver: the first of the 20 frames is
    // accepted, the 19 others repeat it): the track is not refreshed, and it ages.
    let mut bus = push_all(&mut bus, vec![front(58.0, 0, 41); 20]);
    let first = bus.read(5_020).unwrap().leader.timestamp_us;
    let mut last = None;
    for k in 1..=10u64 {
        last = Some(bus.read(5_000 + k * 20_000).unwrap());
    }
    assert_eq!(bus.e2e().repeated, 19);
    assert_eq!(last.unwrap().leader.timestamp_us, first);
}

struct TestClock(u64);
impl Clock for TestClock {
    fn now_us(&mut self) -> u64 {
        self.0
    }
}
#[derive(Default)]
struct Dog(u32);
impl Watchdog for Dog {
    fn feed(&mut self) {
        self.0 += 1;
    }
}

#[test]
fn a_period_over_can_and_then_silence() {
    let mut controller = Controller::new(DEFAULT_TABLE, Config::default());
    let mut bus = CanBus::new(MockBus::default());
    bus = push_all(&mut bus, healthy_frames());
    let mut dog = Dog::default();
    // The bus is both the sensor source and the actuator: borrow it twice through a cell-free
    // split by running the two halves in sequence.
    let inputs = bus.read(20_000).unwrap();
    let cmd = controller.step(&inputs);
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    bus.request(&cmd).unwrap();
    let raw = bus.release();
    assert_eq!(raw.tx.len(), 1);
    let sent = &raw.tx[0];
    assert_eq!(
        sent.id,
        Id::Standard(StandardId::new(can::ACCEL_REQUEST_ID).unwrap())
    );
    assert_eq!(sent.data, can::encode_command(&cmd, 0).to_vec());

    // No new frames for 200 ms: the ego's speed is past its stale limit (100 ms) and the
    // minimum-risk manoeuvre follows (the radar tracks would be covered for a second).
    let mut bus = CanBus::new(raw);
    let mut clock = TestClock(20_000);
    let mut silent = CanBus::new(MockBus::default());
    std::mem::swap(&mut bus, &mut silent);
    let mut sensors = silent;
    sensors = push_all(&mut sensors, healthy_frames());
    sensors.read(20_000).unwrap();
    clock.0 = 220_000;
    let mut actuator = CanBus::new(MockBus::default());
    let cmd = run_period(
        &mut controller,
        &mut sensors,
        &mut actuator,
        &mut clock,
        &mut dog,
    )
    .unwrap();
    assert_eq!(cmd.mode, Mode::MinimumRisk);
    assert_eq!(cmd.fault, Some(Fault::EgoSpeedStale));
    assert!(cmd.takeover);
    assert_eq!(dog.0, 1);
}

/// A driver restarted with the next counter goes on with the sequence, across the wrap.
#[test]
fn a_restarted_driver_goes_on_with_the_request_sequence() {
    let mut bus = CanBus::with_next_counter(MockBus::default(), 255);
    let command = Controller::new(DEFAULT_TABLE, Config::default()).step(&Inputs::invalid(0));
    bus.request(&command).unwrap();
    bus.request(&command).unwrap();
    assert_eq!(bus.next_counter(), 1);
    let raw = bus.release();
    assert_eq!(raw.tx[0].data, can::encode_command(&command, 255).to_vec());
    assert_eq!(raw.tx[1].data, can::encode_command(&command, 0).to_vec());
}

/// One bus delivers the inputs and takes the command, as on the board.
#[test]
fn one_bus_runs_the_whole_period() {
    let mut controller = Controller::new(DEFAULT_TABLE, Config::default());
    let mut bus = CanBus::new(MockBus::default());
    bus = push_all(&mut bus, healthy_frames());
    let mut dog = Dog::default();
    let cmd =
        firmware::run_period_on_bus(&mut controller, &mut bus, &mut TestClock(20_000), &mut dog)
            .unwrap();
    assert_eq!(cmd.mode, Mode::Nominal, "{cmd:?}");
    assert_eq!(dog.0, 1);
    assert_eq!(bus.next_counter(), 1);
    let raw = bus.release();
    // The acceleration request, then the driver's display.
    assert_eq!(raw.tx.len(), 2);
    assert_eq!(raw.tx[0].data, can::encode_command(&cmd, 0).to_vec());
    assert_eq!(
        raw.tx[1].id,
        Id::Standard(StandardId::new(can::DRIVER_DISPLAY_ID).unwrap())
    );
    assert_eq!(
        raw.tx[1].data,
        can::encode_driver_display(&controller.driver(), 0).to_vec()
    );
    // A failing bus: the manoeuvre, and the watchdog still fed.
    let mut failing = CanBus::new(MockBus {
        fail: true,
        ..MockBus::default()
    });
    let sent = firmware::run_period_on_bus(
        &mut controller,
        &mut failing,
        &mut TestClock(40_000),
        &mut dog,
    );
    // (The mock's receive fails; its transmit still works.)
    assert_eq!(sent.unwrap().mode, Mode::MinimumRisk);
    assert_eq!(dog.0, 2);
}

#[test]
fn malformed_frames_are_counted_and_a_bus_error_means_minimum_risk() {
    let mut bus = CanBus::new(MockBus::default());
    bus = push_all(&mut bus, vec![frame(can::FRONT_TRACK_ID, &[1, 2, 3])]);
    let inputs = bus.read(5).unwrap();
    assert_eq!(bus.malformed_frames(), 1);
    assert!(!inputs.leader.valid);

    let mut failing = CanBus::new(MockBus {
        fail: true,
        ..MockBus::default()
    });
    assert!(matches!(failing.read(5), Err(can::Error::Bus(BusError))));
    let mut controller = Controller::new(DEFAULT_TABLE, Config::default());
    let mut actuator = CanBus::new(MockBus::default());
    let mut dog = Dog::default();
    let cmd = run_period(
        &mut controller,
        &mut failing,
        &mut actuator,
        &mut TestClock(9),
        &mut dog,
    )
    .unwrap();
    assert_eq!(cmd.mode, Mode::MinimumRisk);
    assert_eq!(
        actuator.release().tx.len(),
        1,
        "the manoeuvre is still requested"
    );
}

/// The driver-interface frames: the actuator's state (0x131) reaches the inputs with its age, and
/// the driver's requests (0x140) are delivered one per period, in order; a request code that does
/// not exist is a malformed frame, counted and not used.
#[test]
fn the_actuator_state_and_the_drivers_requests_arrive() {
    use firmware::DriverRequest;
    let state =
        can::decode_actuator_state(&can::encode_actuator_state(-1.234, true, 7, 3)).unwrap();
    assert!((state.value + 1.234).abs() < 1e-3 && state.valid && state.age_ms == 7);
    for request in [
        DriverRequest::Engage,
        DriverRequest::Cancel,
        DriverRequest::Resume,
        DriverRequest::SetSpeed(27.5),
        DriverRequest::TimeGap(2),
    ] {
        let (back, counter) =
            can::decode_driver_request(&can::encode_driver_request(&request, 9)).unwrap();
        assert_eq!((back, counter), (request, 9));
    }
    let mut bogus = can::encode_driver_request(&DriverRequest::Cancel, 3);
    bogus[0] = 9;
    bogus[4] = can::frame_crc(can::DRIVER_REQUEST_ID, &bogus[..4]);
    let mut bus = CanBus::new(MockBus::default());
    let mut frames = healthy_frames();
    frames.push(frame(
        can::ACTUATOR_STATE_ID,
        &can::encode_actuator_state(0.75, true, 20, 2),
    ));
    frames.push(frame(
        can::DRIVER_REQUEST_ID,
        &can::encode_driver_request(&DriverRequest::SetSpeed(22.0), 1),
    ));
    frames.push(frame(
        can::DRIVER_REQUEST_ID,
        &can::encode_driver_request(&DriverRequest::TimeGap(1), 2),
    ));
    frames.push(frame(can::DRIVER_REQUEST_ID, &bogus));
    bus = push_all(&mut bus, frames);
    let first = bus.read(100_000).unwrap();
    assert!((first.ego_acceleration.value - 0.75).abs() < 1e-3);
    assert_eq!(first.ego_acceleration.timestamp_us, 80_000);
    assert_eq!(first.driver, Some(DriverRequest::SetSpeed(22.0)));
    assert_eq!(
        bus.read(120_000).unwrap().driver,
        Some(DriverRequest::TimeGap(1))
    );
    assert_eq!(bus.read(140_000).unwrap().driver, None);
    assert_eq!(bus.e2e().malformed, 1);
}

/// The display frame carries the driver's state and why the latest request was refused, so
/// that a refused engagement reaches the driver: every field round-trips, the refusal's code is
/// the one documented for it, and a later accepted request clears the reason but not the
/// count.
#[test]
fn a_refused_engagement_reaches_the_drivers_display() {
    use firmware::{DriverError, DriverRequest};
    let mut controller = Controller::new(DEFAULT_TABLE, Config::default());
    assert_eq!(controller.request(DriverRequest::Cancel), Ok(()));
    // No standby period since the cancel: nothing certifies an engagement yet.
    assert_eq!(
        controller.request(DriverRequest::Engage),
        Err(DriverError::CertificateUnknown)
    );
    let mut bus = CanBus::new(MockBus::default());
    bus = push_all(&mut bus, healthy_frames());
    let mut dog = Dog::default();
    firmware::run_period_on_bus(&mut controller, &mut bus, &mut TestClock(20_000), &mut dog)
        .unwrap();
    let raw = bus.release();
    let shown = raw
        .tx
        .iter()
        .find(|f| f.id == Id::Standard(StandardId::new(can::DRIVER_DISPLAY_ID).unwrap()))
        .expect("a display frame");
    assert_eq!(shown.data[4], 4, "certificate unknown is code 4");
    let (state, counter) = can::decode_driver_display(&shown.data).unwrap();
    assert_eq!(counter, 0);
    assert!(!state.engaged);
    assert_eq!(state.refused, Some(DriverError::CertificateUnknown));
    assert_eq!(state.refusals, 1);
    assert_eq!(state, controller.driver());

    // A request taken clears the reason; the count stays.
    assert_eq!(controller.request(DriverRequest::TimeGap(0)), Ok(()));
    let taken = controller.driver();
    assert_eq!((taken.refused, taken.refusals), (None, 1));
    // Every reason and both flags round-trip, the set speed to 0.01 m/s.
    for (refused, code) in [
        (None, 0),
        (Some(DriverError::SetSpeedOutOfRange), 1),
        (Some(DriverError::NoSuchTimeGap), 2),
        (Some(DriverError::NotCertified), 3),
        (Some(DriverError::CertificateUnknown), 4),
        (Some(DriverError::NeedsEmergencyBraking), 5),
    ] {
        let state = firmware::DriverState {
            engaged: true,
            resume_requested: true,
            set_speed: 27.5,
            time_gap_setting: 3,
            refused,
            refusals: 255,
        };
        let bytes = can::encode_driver_display(&state, 7);
        assert_eq!(bytes[4], code);
        assert_eq!(can::refusal_code(refused), code);
        let (back, counter) = can::decode_driver_display(&bytes).unwrap();
        assert_eq!((back, counter), (state, 7));
    }
    // An unknown reason or flag is malformed; a flipped bit fails the CRC.
    let state = controller.driver();
    let mut bogus = can::encode_driver_display(&state, 1);
    bogus[4] = 6;
    bogus[7] = can::frame_crc(can::DRIVER_DISPLAY_ID, &bogus[..7]);
    assert_eq!(
        can::decode_driver_display(&bogus),
        Err(can::FrameError::Length)
    );
    let mut flipped = can::encode_driver_display(&state, 1);
    flipped[1] ^= 1;
    assert_eq!(
        can::decode_driver_display(&flipped),
        Err(can::FrameError::Checksum)
    );
}

/// A display frame the bus does not take is counted, and the period's command still stands.
#[test]
fn a_display_the_bus_does_not_take_is_counted() {
    use firmware::DriverDisplay;
    struct Full(MockBus);
    impl embedded_can::nb::Can for Full {
        type Frame = MockFrame;
        type Error = BusError;
        fn transmit(&mut self, frame: &MockFrame) -> nb::Result<Option<MockFrame>, BusError> {
            if frame.id == Id::Standard(StandardId::new(can::DRIVER_DISPLAY_ID).unwrap()) {
                return Err(nb::Error::WouldBlock);
            }
            self.0.transmit(frame)
        }
        fn receive(&mut self) -> nb::Result<MockFrame, BusError> {
            self.0.receive()
        }
    }
    let mut controller = Controller::new(DEFAULT_TABLE, Config::default());
    let mut raw = MockBus::default();
    raw.rx.extend(healthy_frames());
    let mut bus = CanBus::new(Full(raw));
    let mut dog = Dog::default();
    let cmd =
        firmware::run_period_on_bus(&mut controller, &mut bus, &mut TestClock(20_000), &mut dog)
            .unwrap();
    assert_eq!(cmd.mode, Mode::Nominal);
    assert_eq!(bus.unshown(), 1);
    assert!(matches!(
        bus.show(&controller.driver()),
        Err(can::Error::TransmitBusy)
    ));
    assert_eq!(bus.unshown(), 2);
    assert_eq!(bus.release().0.tx.len(), 1);
}
