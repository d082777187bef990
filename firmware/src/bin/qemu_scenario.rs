//! A closed-loop scenario on the emulated Cortex-M4F (`qemu-system-arm -machine mps2-an386`):
//! three cars on a lane for 60 s of simulated time, the ego driven by the firmware's
//! `Controller` on the default table at 50 Hz, a small plant model integrated exactly between
//! samples. The leader stops to standstill twice, once braking as hard as the table's model
//! allows, and goes again; the follower drives by the table's IDM. The measurements carry the
//! default configuration's declared error at the box's worst corner for the front (gaps long,
//! range rates opening, the ego slow), so every step evaluates the error box (the rear's least
//! value over it on every new follower track); for 1.3 s the leader track is flagged invalid,
//! longer than the covered age (1 s), so the track ages and is then lost. So every path of the
//! control step runs: nominal, override (braking at the certificate's level), the aging track
//! and the certified fallback; then a car cuts in 12 m ahead, 5 m/s slower, and brakes at
//! 6 m/s^2 for 1 s, so that the emergency answer runs too (below the band, the follower's
//! check included), and the release after it. The instruction counter's worst case covers them all.
//! Prints a summary over semihosting and exits with status 0 when no gap closed, each of the three
//! modes ran, the minimum-risk manoeuvre ran exactly when the track was past its covered age, the
//! certificate's margin never fell below `-CERTIFICATE_TOLERANCE` before the cut-in, and the cut-in
//! was braked below the band; 1 otherwise.
//!
//! It also measures the stack one control step uses (the stack below the caller is painted
//! before the first step and scanned after the last), and brackets every step with two marker
//! functions whose addresses the CI's instruction counter looks for.
#![no_std]
#![no_main]
// The bare-metal entry point, the markers' unmangled names and the stack painting are the only
// unsafe code in the project; the controller itself has none.
#![allow(unsafe_code)]

#[path = "qemu/markers.rs"]
mod markers;

use core::hint::black_box;
use core::panic::PanicInfo;

use markers::{hjacc_step_begin, hjacc_step_end};

use cortex_m_rt::entry;
use cortex_m_semihosting::debug;
#[cfg(not(feature = "qemu-defmt"))]
use cortex_m_semihosting::hprintln;
#[cfg(feature = "qemu-defmt")]
use defmt_semihosting as _;

#[cfg(all(feature = "defmt", not(feature = "qemu-defmt")))]
compile_error!(
    "the QEMU binaries log defmt with the `qemu-defmt` feature (it adds the semihosting logger)"
);

/// A line of the summary: text over semihosting, or a defmt frame when the defmt log shares
/// the channel (text would corrupt its frames).
macro_rules! report {
    ($($arg:tt)*) => {{
        #[cfg(feature = "qemu-defmt")]
        defmt::println!($($arg)*);
        #[cfg(not(feature = "qemu-defmt"))]
        hprintln!($($arg)*);
    }};
}
use firmware::controller::ISO_15622_LIMITS;
use firmware::{
    Config, Controller, DriverError, DriverRequest, Inputs, Measurement, Mode, Track,
    CERTIFICATE_TOLERANCE, DEFAULT_TABLE,
};

/// Tells the instruction counter that the step just counted was an emergency (the cut-in
/// phase: the answer in the band, or the emergency authority below it).
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_emergency() {
    black_box(0x5eed_0050u32);
}

/// Tells the instruction counter that the step just counted ran the nominal law.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_nominal() {
    black_box(0x5eed_0010u32);
}

/// Tells the instruction counter that the step just counted overrode the nominal law.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_override() {
    black_box(0x5eed_0011u32);
}

/// Tells the instruction counter that the step just counted was the minimum-risk manoeuvre.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_minimum_risk() {
    black_box(0x5eed_0012u32);
}

/// Tells the instruction counter that the step just counted ran uncertified.
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_uncertified() {
    black_box(0x5eed_0013u32);
}

/// Tells the instruction counter that the step just counted was in standby (the sweep of
/// engagements after the run).
#[no_mangle]
#[inline(never)]
pub extern "C" fn hjacc_mode_standby() {
    black_box(0x5eed_0014u32);
}

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {}
}

const PAINT: u32 = 0xDEAD_BEEF;
const PAINT_WORDS: usize = 2048; // 8 KiB, up to the caller's stack pointer

/// One vehicle: position of its front bumper (m) and speed (m/s).
#[derive(Clone, Copy)]
struct Car {
    x: f32,
    v: f32,
}

impl Car {
    /// Exact motion under constant acceleration `a` for `h` seconds, stopping at zero speed.
    fn advance(&mut self, a: f32, h: f32) {
        let a = if self.v <= 0.0 && a < 0.0 { 0.0 } else { a };
        let t_stop = if a < 0.0 { -self.v / a } else { h };
        let t = if t_stop < h { t_stop } else { h };
        self.x += self.v * t + 0.5 * a * t * t;
        self.v += a * t;
        if self.v < 0.0 {
            self.v = 0.0;
        }
    }
}

/// Lowest value over `[0, h]` of `g + dv t + da t^2 / 2` (a gap between two samples).
fn lowest_gap(g: f32, dv: f32, da: f32, h: f32) -> f32 {
    let end = g + dv * h + 0.5 * da * h * h;
    let mut low = if end < g { end } else { g };
    if da > 0.0 {
        let t = -dv / da;
        if t > 0.0 && t < h {
            let inner = g + dv * t + 0.5 * da * t * t;
            if inner < low {
                low = inner;
            }
        }
    }
    low
}

/// The leader's acceleration programme: cruise, a hard stop at the model's limit (6 m/s^2),
/// stand, pull away to 20 m/s, cruise, a gentle stop (2 m/s^2), stand, pull away.
fn leader_acceleration(t: f32, v: f32) -> f32 {
    let a = if t < 5.0 {
        0.0
    } else if t < 14.0 {
        -6.0
    } else if t < 26.0 {
        1.5
    } else if t < 32.0 {
        0.0
    } else if t < 46.0 {
        -2.0
    } else {
        1.0
    };
    // Speeds stay in [0, 25] m/s (the plant stops a braking car at zero).
    if v >= 25.0 && a > 0.0 {
        0.0
    } else if t >= 14.0 && t < 26.0 && v >= 20.0 {
        0.0
    } else {
        a
    }
}

/// The follower: the table's IDM (a = 1, b = 1.5, v0 = 33.3 m/s, s0 = 2 m) with a time gap of
/// 1.5 s, clipped to the table's bounds [-6, 2].
fn follower_acceleration(follower: Car, ego: Car) -> f32 {
    let gap = ego.x - follower.x;
    let v = follower.v;
    let two_sqrt_ab = 2.449_489_8; // 2 sqrt(1.0 * 1.5)
    let dynamic = v * 1.5 + v * (v - ego.v) / two_sqrt_ab;
    let desired = 2.0 + if dynamic > 0.0 { dynamic } else { 0.0 };
    let r = v / 33.3;
    let free = r * r * r * r;
    let interaction = if gap > 0.1 {
        (desired / gap) * (desired / gap)
    } else {
        100.0
    };
    let a = 1.0 - free - interaction;
    if a < -6.0 {
        -6.0
    } else if a > 2.0 {
        2.0
    } else {
        a
    }
}

/// The fault window: the leader track is flagged invalid, s.
const FAULT: (u32, u32) = (2_500, 2_565);

/// From this period on, a car cuts in 12 m ahead, 5 m/s slower than the ego, and brakes at
/// the leader model's 6 m/s^2 for 1 s, then keeps its speed: the emergency answer runs, and
/// then the release the follower must allow (outside the model: the margin and gap checks end
/// here).
const CUT_IN: u32 = 3_000;

#[entry]
fn main() -> ! {
    let mut config = Config::default();
    // The certificate argued with two authorities, for that mode's figures.
    if cfg!(feature = "qemu-two-authorities") {
        config.certificate.authorities = firmware::Authorities::Two;
    }
    let mut controller = Controller::new(DEFAULT_TABLE, config);
    let h = config.period_us as f32 * 1e-6;
    let s = config.sensors;
    // A range read long by the declared error.
    let long = |g: f32| g + s.error.range + s.error.range_relative * g;
    let steps = CUT_IN + 250; // 60 s, then 5 s after the cut-in
                              // At the gap policy's distance (the certificate's steady gap with the law's room).
    let mut leader = Car { x: 140.0, v: 25.0 };
    let mut last_command = 0.0f32;
    // Since when the ego's brake lights are on (`None`: off).
    let mut lights_on_since_us: Option<u64> = None;
    let mut ego = Car { x: 50.0, v: 25.0 };
    let mut follower = Car { x: 20.0, v: 25.0 };
    let (mut min_margin, mut misplaced_minimum_risk) = (f32::INFINITY, 0u32);
    let (mut nominal, mut overridden, mut minimum_risk) = (0u32, 0u32, 0u32);
    let (mut min_front, mut min_rear) = (f32::INFINITY, f32::INFINITY);
    let mut max_brake = 0.0f32;
    let (mut emergency, mut below_band, mut cut_in_front) = (0u32, 0u32, f32::INFINITY);

    // Paint the stack below us.
    let sp = cortex_m::register::msp::read() as usize;
    // The window ends at the stack pointer itself: nothing of main's frame lies below it (Arm
    // has no red zone), and every byte the control step pushes is counted.
    let bottom = (sp - PAINT_WORDS * 4) & !3;
    for i in 0..PAINT_WORDS {
        unsafe { core::ptr::write_volatile((bottom + 4 * i) as *mut u32, PAINT) };
    }

    for k in 0..steps {
        let now_us = u64::from(k) * u64::from(config.period_us);
        let t = k as f32 * h;
        if k == CUT_IN {
            leader = Car {
                x: ego.x + 12.0,
                v: (ego.v - 5.0).max(0.0),
            };
        }
        let inputs = Inputs {
            leader: Measurement::new(
                Track {
                    gap: long(leader.x - ego.x),
                    rel_speed: leader.v - ego.v + s.error.range_rate,
                },
                now_us,
            ),
            follower: Measurement::new(
                Track {
                    gap: long(ego.x - follower.x),
                    rel_speed: ego.v - follower.v + s.error.range_rate,
                },
                now_us,
            ),
            ego_speed: Measurement::new(
                (ego.v - s.error.ego_speed - s.error.ego_speed_relative * ego.v).max(0.0),
                now_us,
            ),
            // The actuator's state: the last command (this plant has no delay), reported at
            // the low end of its error.
            ego_acceleration: Measurement::new(last_command - s.acceleration_error, now_us),
            driver: None,
            now_us,
        };
        let mut inputs = inputs;
        let in_fault_window = k >= FAULT.0 && k < FAULT.1;
        if in_fault_window {
            inputs.leader.valid = false;
        }
        // The last good leader track (period FAULT.0 - 1) is past the covered age from here on.
        let age_periods = u64::from(config.sensors.max_track_age_us) / u64::from(config.period_us);
        let lost = in_fault_window && u64::from(k - FAULT.0) + 1 > age_periods;
        hjacc_step_begin();
        let command = controller.step(black_box(&inputs));
        hjacc_step_end();
        match command.mode {
            _ if command.emergency => hjacc_mode_emergency(),
            Mode::Nominal => hjacc_mode_nominal(),
            Mode::Override => hjacc_mode_override(),
            Mode::MinimumRisk => hjacc_mode_minimum_risk(),
            Mode::Uncertified | Mode::Standby => hjacc_mode_uncertified(),
        }
        if (command.mode == Mode::MinimumRisk) != lost || (lost && command.margin.is_none()) {
            misplaced_minimum_risk += 1;
        }
        if k >= CUT_IN {
            emergency += u32::from(command.emergency);
            below_band += u32::from(command.acceleration < ISO_15622_LIMITS.0);
        }
        if k < CUT_IN {
            let state = [
                leader.x - ego.x,
                leader.v,
                ego.x - follower.x,
                follower.v,
                ego.v,
            ];
            // The true certificate after the step: the ramp the controller is committed to,
            // through this plant's actuator (none: the command is the acceleration), and its
            // brake lights (on while the acceleration is below the declared lights'
            // deceleration, `-theta`): on for good from when they came on where this command
            // and the committed ramp's next are below it, else from the period the ramp's
            // command falls below it.
            let period_us = u64::from(config.period_us);
            let theta = config.certificate.emergency.lights_deceleration;
            let lights_on_for_good_us =
                controller
                    .committed_braking(now_us)
                    .and_then(|(_, next, braking)| {
                        if next < -theta {
                            Some(if command.acceleration < -theta {
                                lights_on_since_us.unwrap_or(now_us)
                            } else {
                                now_us + period_us
                            })
                        } else {
                            // The ramp's command `k` periods on is `next - j (k - 1) h`.
                            let periods = (next + theta) / (braking.jerk * h);
                            (periods.is_finite() && (0.0..1e6).contains(&periods))
                                .then(|| now_us + (periods as u64 + 2) * period_us)
                        }
                    });
            let margin = controller
                .certificate_with_actuator_and_lights(
                    state,
                    now_us,
                    0,
                    0.0,
                    command.acceleration,
                    lights_on_for_good_us,
                )
                .map_or(f32::NEG_INFINITY, |c| c.margin());
            if margin < min_margin {
                min_margin = margin;
            }
        }
        match command.mode {
            Mode::Nominal => nominal += 1,
            Mode::Override => overridden += 1,
            Mode::MinimumRisk | Mode::Uncertified | Mode::Standby => minimum_risk += 1,
        }
        last_command = command.acceleration;
        // The lights from the next period on: this plant's acceleration is the command.
        lights_on_since_us = (command.acceleration
            < -config.certificate.emergency.lights_deceleration)
            .then(|| lights_on_since_us.unwrap_or(now_us + u64::from(config.period_us)));
        if -command.acceleration > max_brake {
            max_brake = -command.acceleration;
        }
        let a_leader = if k >= CUT_IN + 50 {
            0.0
        } else if k >= CUT_IN {
            -6.0
        } else {
            leader_acceleration(t, leader.v)
        };
        let a_follower = follower_acceleration(follower, ego);
        let a_ego = command.acceleration;
        let front_gap = lowest_gap(leader.x - ego.x, leader.v - ego.v, a_leader - a_ego, h);
        if k < CUT_IN {
            min_front = min_front.min(front_gap);
        } else {
            cut_in_front = cut_in_front.min(front_gap);
        }
        min_rear = min_rear.min(lowest_gap(
            ego.x - follower.x,
            ego.v - follower.v,
            a_ego - a_follower,
            h,
        ));
        leader.advance(a_leader, h);
        ego.advance(a_ego, h);
        follower.advance(a_follower, h);
    }

    // Standby, where the driver drives and each period judges an engagement: the ego at 8.3,
    // 15 and 25 m/s, the leader 100 m ahead and the follower 4-40 m behind at its speed, each
    // state measured for two periods (the same errors as above), then SET asked for: accepted
    // (and cancelled again), refused because the follower leaves no comfortable way to brake
    // (`DriverError::NeedsEmergencyBraking`, with two authorities), or refused otherwise.
    let (mut accepted, mut needs_emergency, mut refused) = (0u32, 0u32, 0u32);
    let _ = controller.request(DriverRequest::Cancel);
    let mut k = steps;
    for speed in [8.3f32, 15.0, 25.0] {
        for gap_follower in (0..13).map(|i| 4.0 + 3.0 * i as f32) {
            for _ in 0..2 {
                let now_us = u64::from(k) * u64::from(config.period_us);
                k += 1;
                let inputs = Inputs {
                    leader: Measurement::new(
                        Track {
                            gap: long(100.0),
                            rel_speed: s.error.range_rate,
                        },
                        now_us,
                    ),
                    follower: Measurement::new(
                        Track {
                            gap: long(gap_follower),
                            rel_speed: s.error.range_rate,
                        },
                        now_us,
                    ),
                    ego_speed: Measurement::new(
                        speed - s.error.ego_speed - s.error.ego_speed_relative * speed,
                        now_us,
                    ),
                    ego_acceleration: Measurement::new(-s.acceleration_error, now_us),
                    driver: None,
                    now_us,
                };
                hjacc_step_begin();
                let command = controller.step(black_box(&inputs));
                hjacc_step_end();
                hjacc_mode_standby();
                black_box(command);
            }
            match controller.request(DriverRequest::Engage) {
                Ok(()) => {
                    accepted += 1;
                    let _ = controller.request(DriverRequest::Cancel);
                }
                Err(DriverError::NeedsEmergencyBraking) => needs_emergency += 1,
                Err(_) => refused += 1,
            }
        }
    }

    let mut used_words = 0;
    for i in 0..PAINT_WORDS {
        if unsafe { core::ptr::read_volatile((bottom + 4 * i) as *const u32) } != PAINT {
            used_words = PAINT_WORDS - i;
            break;
        }
    }
    let stack_bytes = used_words * 4;

    // The FPU's square root (`table_format::math::sqrt`, which the certificate's closed forms
    // take) against libm's software one, which the host runs: the same bits over a sweep of
    // the non-negative floats, subnormals to the largest, and NaN below zero.
    let mut sqrt_checked = 0u32;
    let mut sqrt_differ = 0u32;
    let mut bits = 0u32;
    while bits < 0x7f80_0000 {
        let x = f32::from_bits(bits);
        let root = table_format::math::sqrt(black_box(x));
        sqrt_differ += u32::from(root.to_bits() != libm::sqrtf(x).to_bits());
        sqrt_checked += 1;
        bits += 0xff3d;
    }
    sqrt_differ += u32::from(!table_format::math::sqrt(black_box(-1.0)).is_nan());

    report!(
        "hjacc qemu scenario: {} steps ({} s), nominal {}, override {}, minimum-risk {} (outside the fault window: {})",
        steps,
        steps as f32 * h,
        nominal,
        overridden,
        minimum_risk,
        misplaced_minimum_risk
    );
    report!(
        "smallest certificate margin outside the fault window: {} m",
        min_margin
    );
    report!(
        "min gap front {} m, rear {} m, max braking {} m/s^2, final speeds {} {} {} m/s",
        min_front,
        min_rear,
        max_brake,
        leader.v,
        ego.v,
        follower.v
    );
    report!(
        "cut-in 12 m ahead, 5 m/s slower, braking at 6 m/s^2 for 1 s: {} emergency steps, {} below the band, min gap front {} m",
        emergency,
        below_band,
        cut_in_front
    );
    report!(
        "standby sweep, 39 engagements asked for: {} accepted, {} refused for want of a comfortable way to brake, {} refused otherwise",
        accepted,
        needs_emergency,
        refused
    );
    report!(
        "stack used by the control loop (painted, 8 KiB window): {} bytes",
        stack_bytes
    );
    report!(
        "square root: the FPU's and libm's differ at {} of {} floats",
        sqrt_differ,
        sqrt_checked + 1
    );
    report!(
        "controller state (its command history, event log and table view): {} bytes",
        core::mem::size_of::<Controller<'static>>()
    );
    let ok = min_front > 0.0
        && min_rear > 0.0
        && nominal > 0
        && overridden > 0
        && minimum_risk > 0
        && misplaced_minimum_risk == 0
        && min_margin > -CERTIFICATE_TOLERANCE
        && below_band > 0
        && cut_in_front > 0.0
        && sqrt_differ == 0
        // Both verdicts of an engagement ran (with two authorities, the refusal too).
        && accepted > 0
        && (needs_emergency > 0 || !cfg!(feature = "qemu-two-authorities"));
    report!("result: {}", if ok { "PASS" } else { "FAIL" });
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {}
}
