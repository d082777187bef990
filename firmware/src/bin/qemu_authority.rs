//! What the two-authority rule costs on the emulated Cortex-M4F (`qemu-system-arm -machine
//! mps2-an386`): `table_format::authority::TwoAuthorities::decide` and
//! `table_format::rear::lights_on_within`, the work a control step would add to argue two braking
//! authorities against a leader braking at up to 9.8 m/s^2 and a follower that reacts after
//! 1.15 s, over 576 states (the ego at 5-33 m/s, the leader 8-120 m ahead and as fast or slower,
//! the follower 3-40 m behind, the ego braking hard, holding or accelerating, its lights off or
//! on for 1 s). Each call is bracketed by the instruction counter's markers and filed under its
//! decision (drive: the law's proposal passed; graded: a braking between the comfort level and
//! it; brake: under the braking in force). Prints how many of each over semihosting and exits with
//! status 0 when every decision was reached at least once; 1 otherwise. The firmware's step does
//! not run this rule yet: the figure says what it would cost.
#![no_std]
#![no_main]
// The bare-metal entry point and the markers' unmangled names are the only unsafe code.
#![allow(unsafe_code)]

#[path = "qemu/markers.rs"]
mod markers;

use core::hint::black_box;
use core::panic::PanicInfo;

use markers::{hjacc_step_begin, hjacc_step_end};

// The critical section semihosting needs (cortex-m's single-core implementation).
use cortex_m as _;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use table_format::authority::{Braking, Decision, State, TwoAuthorities};
use table_format::rear::ReactingFollower;
use table_format::{Game, Table};

use firmware::{Config, DEFAULT_TABLE};

/// Files the call just counted under "drive": the command passed the look-ahead.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_drive() {
    black_box(0x5eed_0020u32);
}

/// Files the call just counted under "graded": a braking between the comfort level and the
/// proposal passed the look-ahead.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_graded() {
    black_box(0x5eed_0021u32);
}

/// Files the call just counted under "brake": nothing passed, a braking under the braking in
/// force.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_brake() {
    black_box(0x5eed_0022u32);
}

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    fail()
}

fn fail() -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {}
}

/// The law's proposal in every state: a gentle acceleration.
const PROPOSAL: f32 = 0.5;

#[entry]
fn main() -> ! {
    // The deployed comfort authority (the table's band, the configured ramp), the table's
    // declared emergency authority and follower reaction, and its follower braking at its
    // clip once it reacts.
    let config = Config::default();
    let Ok(table) = Table::parse(DEFAULT_TABLE) else {
        fail()
    };
    let Game::ThreeCarSplit {
        ego,
        follower,
        emergency: declared,
        ..
    } = table.header().game
    else {
        fail()
    };
    let model = TwoAuthorities {
        leader_braking: 9.8,
        max_speed: 35.0,
        comfort: Braking {
            level: -ego.min,
            jerk: config.certificate.brake_jerk,
        },
        emergency: declared.braking,
        follower: ReactingFollower {
            reaction_time: declared.follower_reaction_time,
            braking: -follower.clip().min,
            jerk: f32::INFINITY,
            ..ReactingFollower::careful_driver(35.0)
        },
        lights_deceleration: declared.lights_deceleration,
        front_margin: config.certificate.front_margin,
        rear_margin: config.certificate.rear_margin,
    };
    let (mut drive, mut graded, mut brake) = (0u32, 0u32, 0u32);
    for v in [5.0f32, 15.0, 25.0, 33.0] {
        for gap_leader in [8.0f32, 25.0, 60.0, 120.0] {
            for leader_speed in [v - 3.0, v] {
                for gap_follower in [3.0f32, 15.0, 40.0] {
                    for a in [-6.0f32, 0.0, 1.5] {
                        for lights in [0.0f32, 1.0] {
                            let s = State {
                                gap_leader,
                                leader_speed,
                                gap_follower,
                                follower_speed: v,
                                ego_speed: v,
                                ego_acceleration: a,
                            };
                            let in_force = model.emergency;
                            let lights = if a < 0.0 { lights } else { 0.0 };
                            hjacc_step_begin();
                            let e = declared.braking;
                            let on = declared.lights_on_within(0.1, 0.3, a, a, a, e.jerk, e.level);
                            let d = model.decide(
                                black_box(&s),
                                in_force,
                                black_box(lights),
                                black_box(PROPOSAL),
                                0.02,
                            );
                            black_box((on, d));
                            hjacc_step_end();
                            match d {
                                Decision::Drive { command, .. } if command >= PROPOSAL => {
                                    drive += 1;
                                    hjacc_mode_drive();
                                }
                                Decision::Drive { .. } => {
                                    graded += 1;
                                    hjacc_mode_graded();
                                }
                                Decision::Brake(_) => {
                                    brake += 1;
                                    hjacc_mode_brake();
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    let ok = drive > 0 && graded > 0 && brake > 0;
    hprintln!(
        "authority: {} decisions: drive {}, graded {}, brake {}",
        drive + graded + brake,
        drive,
        graded,
        brake
    );
    hprintln!("result: {}", if ok { "PASS" } else { "FAIL" });
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {}
}
