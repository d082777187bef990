//! The CAN driver against a mock bus: decoding, staleness through missing frames, malformed
//! frames, and the request frame.

use std::collections::VecDeque;

use embedded_can::{Frame, Id, StandardId};
use firmware::can::{self, CanBus};
use firmware::{
    run_period, Actuator, Clock, Config, Controller, Fault, Mode, Sensors, Track, Watchdog,
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

fn healthy_frames() -> Vec<MockFrame> {
    vec![
        frame(
            can::FRONT_TRACK_ID,
            &can::encode_track(
                &Track {
                    gap: 60.0,
                    rel_speed: 0.0,
                },
                true,
                1,
            ),
        ),
        frame(
            can::REAR_TRACK_ID,
            &can::encode_track(
                &Track {
                    gap: 40.0,
                    rel_speed: -0.5,
                },
                true,
                1,
            ),
        ),
        frame(can::EGO_SPEED_ID, &[0xC4, 0x09, 1, 1]), // 25.00 m/s
    ]
}

#[test]
fn frames_decode_into_inputs() {
    let mut bus = CanBus::new(MockBus::default());
    bus = push_all(&mut bus, healthy_frames());
    let inputs = bus.read(1_000).unwrap();
    assert!((inputs.leader.value.gap - 60.0).abs() < 0.01);
    assert!((inputs.follower.value.rel_speed + 0.5).abs() < 0.01);
    assert!((inputs.ego_speed.value - 25.0).abs() < 0.01);
    assert!(inputs.leader.valid && inputs.follower.valid && inputs.ego_speed.valid);
    assert_eq!(inputs.leader.timestamp_us, 1_000);
}

#[test]
fn encoding_round_trips_and_saturates() {
    for (gap, rel) in [(0.0f32, -12.34f32), (123.45, 7.5), (655.0, 0.0)] {
        let (t, valid) = can::decode_track(&can::encode_track(
            &Track {
                gap,
                rel_speed: rel,
            },
            true,
            0,
        ))
        .unwrap();
        assert!(valid);
        assert!((t.gap - gap).abs() < 0.006 && (t.rel_speed - rel).abs() < 0.006);
    }
    let (t, _) = can::decode_track(&can::encode_track(
        &Track {
            gap: f32::INFINITY,
            rel_speed: f32::NAN,
        },
        true,
        0,
    ))
    .unwrap();
    assert!(t.gap.is_infinite());
    assert_eq!(t.rel_speed, 0.0);
    assert!(can::decode_track(&[0; 5]).is_none());
    assert!(can::decode_ego_speed(&[0; 8]).is_none());
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

    // No new frames for 200 ms: everything goes stale and the minimum-risk manoeuvre follows.
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
    assert_eq!(cmd.fault, Some(Fault::LeaderStale));
    assert_eq!(dog.0, 1);
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
