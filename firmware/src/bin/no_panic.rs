//! The proof that no panic is reachable from the controller: this binary parses the default
//! table and runs `Controller::step` on inputs the optimiser cannot see through, and its panic
//! handler calls a function that exists nowhere. If any panic path survived in the code it
//! links, the link would fail with an undefined symbol; CI builds it.
#![no_std]
#![no_main]
// The bare-metal entry point and the undefined extern are the unsafe parts.
#![allow(unsafe_code)]

use core::hint::black_box;
use core::panic::PanicInfo;

use cortex_m_rt::entry;
use firmware::{Config, Controller, Inputs, Measurement, Track, DEFAULT_TABLE};

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
            now_us: black_box(now_us),
        };
        black_box(controller.step(&inputs));
        for event in controller.events() {
            black_box(event);
        }
    }
}
