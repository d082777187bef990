//! The proof that no panic is reachable from the control path: this binary parses the default
//! table, runs `firmware::run_period` (sensors, `Controller::step`, actuator, watchdog) and the
//! CAN frame codecs on inputs the optimiser cannot see through, and its panic handler calls a
//! function that exists nowhere. If any panic path survived in the code it links, the link
//! would fail with an undefined symbol; CI builds it.
#![no_std]
#![no_main]
// The bare-metal entry point and the undefined extern are the unsafe parts.
#![allow(unsafe_code)]

use core::hint::black_box;
use core::panic::PanicInfo;

use cortex_m_rt::entry;

// The proof covers the control path without a logger. defmt's loggers (defmt-rtt,
// defmt-semihosting) panic by design when they are entered reentrantly, so with one linked in
// the proof fails, rightly: on the board such a panic ends in the panic handler's last frame
// and the latched minimum-risk manoeuvre instead.
#[cfg(feature = "defmt")]
compile_error!("the no-panic proof is built without defmt: a defmt logger can panic (reentrancy)");
use firmware::can::{
    decode_actuator_state, decode_driver_request, decode_ego_speed, decode_track, encode_command,
};
use firmware::{
    run_period, Actuator, Clock, Command, Config, Controller, Inputs, Measurement, Sensors, Track,
    Watchdog, DEFAULT_TABLE,
};

/// Sensors whose every reading the optimiser must treat as unknown.
struct Opaque;

impl Sensors for Opaque {
    type Error = ();
    fn read(&mut self, now_us: u64) -> Result<Inputs, ()> {
        if black_box(false) {
            return Err(());
        }
        let frame: [u8; 8] = black_box([0; 8]);
        let leader = decode_track(black_box(0x120), black_box(&frame[..])).map_err(|_| ())?;
        let follower = decode_track(black_box(0x121), black_box(&frame[..])).map_err(|_| ())?;
        let speed: [u8; 6] = black_box([0; 6]);
        let ego = decode_ego_speed(black_box(&speed[..])).map_err(|_| ())?;
        let state = decode_actuator_state(black_box(&speed[..])).map_err(|_| ())?;
        let request: [u8; 5] = black_box([0; 5]);
        let driver = decode_driver_request(black_box(&request[..]))
            .ok()
            .map(|(d, _)| d);
        let (leader, leader_valid) = (leader.value, leader.valid);
        let (follower, follower_valid) = (follower.value, follower.valid);
        let (ego, ego_valid) = (ego.value, ego.valid);
        let stamp = black_box(now_us);
        Ok(Inputs {
            leader: Measurement {
                value: leader,
                timestamp_us: stamp,
                valid: leader_valid,
            },
            follower: Measurement {
                value: follower,
                timestamp_us: black_box(stamp),
                valid: follower_valid,
            },
            ego_speed: Measurement {
                value: ego,
                timestamp_us: black_box(stamp),
                valid: ego_valid,
            },
            ego_acceleration: Measurement {
                value: state.value,
                timestamp_us: black_box(stamp),
                valid: state.valid,
            },
            driver,
            now_us: black_box(now_us),
        })
    }
}

impl Actuator for Opaque {
    type Error = ();
    fn request(&mut self, command: &Command) -> Result<(), ()> {
        black_box(encode_command(command, black_box(0)));
        Ok(())
    }
}

impl Clock for Opaque {
    fn now_us(&mut self) -> u64 {
        black_box(0)
    }
}

impl Watchdog for Opaque {
    fn feed(&mut self) {
        black_box(());
    }
}

extern "C" {
    /// Deliberately undefined: referencing it from a reachable panic breaks the link.
    fn hjacc_a_panic_is_reachable() -> !;
}

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    unsafe { hjacc_a_panic_is_reachable() }
}

#[entry]
fn main() -> ! {
    let table = black_box(DEFAULT_TABLE);
    let mut controller = Controller::new(table, black_box(Config::default()));
    let mut now_us = 0u64;
    loop {
        now_us += 20_000;
        let track = Track {
            gap: black_box(30.0),
            rel_speed: black_box(-1.0),
        };
        let inputs = Inputs {
            leader: Measurement {
                value: track,
                timestamp_us: black_box(now_us),
                valid: black_box(true),
            },
            follower: Measurement {
                value: black_box(track),
                timestamp_us: black_box(now_us),
                valid: black_box(true),
            },
            ego_speed: Measurement {
                value: black_box(25.0),
                timestamp_us: black_box(now_us),
                valid: black_box(true),
            },
            ego_acceleration: Measurement {
                value: black_box(0.5),
                timestamp_us: black_box(now_us),
                valid: black_box(true),
            },
            driver: black_box(None),
            now_us: black_box(now_us),
        };
        black_box(controller.step(&inputs));
        let (mut sensors, mut actuator, mut clock, mut watchdog) = (Opaque, Opaque, Opaque, Opaque);
        let _ = black_box(run_period(
            &mut controller,
            &mut sensors,
            &mut actuator,
            &mut clock,
            &mut watchdog,
        ));
        for event in controller.events() {
            black_box(event);
        }
    }
}
