//! The board-independent part of the STM32F407 binary, run on QEMU's `netduinoplus2` (an
//! STM32F405: the same core, flash and RAM map). QEMU does not model the F4's clock tree, CAN,
//! or watchdog, so this binary keeps everything else the board does and replaces those three:
//! - the board's `memory.x`: code in sectors 0-5, the table in its own slot at `0x0804_0000`,
//!   loaded apart from the code (`-device loader,file=...,addr=0x08040000`), the stack at the
//!   bottom of RAM;
//! - the boot: the table found in its slot by its declared length and checked whole; the fault
//!   marker in `.uninit`, read and cleared;
//! - the period: `firmware::run_period_on_bus` over the firmware's CAN driver, with its
//!   end-to-end checks, on a loopback bus that a plant model feeds with encoded frames and
//!   reads the acceleration requests from;
//! - the fault path: a HardFault (an undefined instruction) ends in the last frame, the marker,
//!   and a reset; the next boot latches the minimum-risk manoeuvre; then a stack overflow does
//!   the same.
//!
//! Logs go out as defmt frames over semihosting (decode with `defmt-print -e ELF`); the exit
//! status is 0 when every check held. Without a table in the slot it checks the fallback
//! instead: the table refused with a typed fault and every command the minimum-risk manoeuvre.
#![no_std]
#![no_main]
// The entry point, the exception handler, the linker's table symbols, the words in RAM that
// survive a reset, and the deliberate faults are this check's unsafe code.
#![allow(unsafe_code)]

use core::cell::Cell;
use core::hint::black_box;
use core::panic::PanicInfo;
use core::ptr::{addr_of, addr_of_mut};

use board_stm32f4::boot::{self, ResetFlags};
use board_stm32f4::clock::{MicrosCounter, WideClock};
use board_stm32f4::last_resort;
use board_stm32f4::target::{self, KeptWords};
use board_stm32f4::PERIOD_US;
use cortex_m_rt::entry;
use cortex_m_semihosting::debug;
use defmt_semihosting as _;
use embedded_can::{Frame as _, Id, StandardId};
use firmware::can::{
    decode_driver_display, encode_ego_speed, encode_track, CanBus, ACCEL_REQUEST_ID,
    DRIVER_DISPLAY_ID, EGO_SPEED_ID, FRONT_TRACK_ID, REAR_TRACK_ID,
};
use firmware::{Config, Controller, Fault, Mode, Track};
use heapless::Deque;

/// Which fault this check has caused so far (survives the resets): a word and its complement.
#[link_section = ".uninit.HJACC_CHECK_STAGE"]
static mut STAGE: KeptWords = KeptWords::new();

/// The request counter the run after the next fault must start at: a word and its complement.
#[link_section = ".uninit.HJACC_EXPECTED_COUNTER"]
static mut EXPECTED_COUNTER: KeptWords = KeptWords::new();

/// Records that the run after the fault about to happen must go on one past the kept counter
/// (the fault handler's last frame takes the kept one).
fn expect_counter_after_fault() {
    let next = u32::from(target::kept_request_counter().wrapping_add(1));
    write_words(addr_of_mut!(EXPECTED_COUNTER), [next, !next]);
}

/// The stack pointer at the last HardFault (survives the reset): a word and its complement.
#[link_section = ".uninit.HJACC_FAULT_SP"]
static mut FAULT_SP: KeptWords = KeptWords::new();

fn read_words(words: *const KeptWords) -> [u32; 2] {
    // SAFETY: single core, no interrupts in use; a fault handler never returns.
    unsafe { target::read(words) }
}

fn write_words(words: *mut KeptWords, value: [u32; 2]) {
    // SAFETY: as in `read_words`.
    unsafe { target::write(words, value) }
}

fn stage() -> u32 {
    let [s, check] = read_words(addr_of!(STAGE));
    if check == !s && s <= 2 {
        s
    } else {
        0
    }
}

fn set_stage(s: u32) {
    write_words(addr_of_mut!(STAGE), [s, !s]);
}

/// The check's result: exit status 0 or 1.
fn finish(ok: bool) -> ! {
    set_stage(0);
    if ok {
        defmt::info!("netduino-check: PASS");
        debug::exit(debug::EXIT_SUCCESS);
    } else {
        defmt::error!("netduino-check: FAIL");
        debug::exit(debug::EXIT_FAILURE);
    }
    loop {
        cortex_m::asm::nop();
    }
}

/// A CAN frame on the loopback bus.
#[derive(Clone, Copy)]
struct Frame {
    id: StandardId,
    len: usize,
    data: [u8; 8],
}

impl embedded_can::Frame for Frame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        let Id::Standard(id) = id.into() else {
            return None;
        };
        let mut bytes = [0; 8];
        bytes.get_mut(..data.len())?.copy_from_slice(data);
        Some(Frame {
            id,
            len: data.len(),
            data: bytes,
        })
    }
    fn new_remote(_: impl Into<Id>, _: usize) -> Option<Self> {
        None
    }
    fn is_extended(&self) -> bool {
        false
    }
    fn is_remote_frame(&self) -> bool {
        false
    }
    fn id(&self) -> Id {
        Id::Standard(self.id)
    }
    fn dlc(&self) -> usize {
        self.len
    }
    fn data(&self) -> &[u8] {
        self.data.get(..self.len).unwrap_or(&[])
    }
}

/// A bus whose receive queue the plant fills and whose transmissions the plant reads.
#[derive(Default)]
struct Loopback {
    rx: Deque<Frame, 8>,
    tx: Deque<Frame, 8>,
}

#[derive(Debug, Clone, Copy, defmt::Format)]
struct Never;

impl embedded_can::Error for Never {
    fn kind(&self) -> embedded_can::ErrorKind {
        embedded_can::ErrorKind::Other
    }
}

impl embedded_can::nb::Can for Loopback {
    type Frame = Frame;
    type Error = Never;
    fn transmit(&mut self, frame: &Frame) -> nb::Result<Option<Frame>, Never> {
        self.tx
            .push_back(*frame)
            .map(|()| None)
            .map_err(|_| nb::Error::WouldBlock)
    }
    fn receive(&mut self) -> nb::Result<Frame, Never> {
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

/// Simulated time for the board's clock: the plant sets the counter one period per step.
struct SimCounter<'a>(&'a Cell<u32>);

impl MicrosCounter for SimCounter<'_> {
    fn ticks(&mut self) -> u32 {
        self.0.get()
    }
}

struct Dog(u32);

impl firmware::Watchdog for Dog {
    fn feed(&mut self) {
        self.0 += 1;
    }
}

/// One car on the lane: position of the front bumper and speed.
#[derive(Clone, Copy)]
struct Car {
    x: f32,
    v: f32,
}

impl Car {
    fn advance(&mut self, a: f32, h: f32) {
        let a = if self.v <= 0.0 && a < 0.0 { 0.0 } else { a };
        let t = if a < 0.0 { (-self.v / a).min(h) } else { h };
        self.x += self.v * t + 0.5 * a * t * t;
        self.v = (self.v + a * t).max(0.0);
    }
}

/// What a run of the loop did.
struct Run {
    nominal: u32,
    minimum_risk: u32,
    /// The fault of the first minimum-risk step.
    first_fault: Option<Fault>,
    /// Minimum-risk steps with the first one's fault.
    same_fault: u32,
    smallest_gap: f32,
    last_ego_speed: f32,
    /// Frames the CAN driver's end-to-end checks refused.
    e2e_faults: u32,
    /// The rolling counter of the first acceleration request sent.
    first_counter: Option<u8>,
    /// Display frames that decoded to an engaged ACC with nothing refused.
    displays: u32,
}

/// Runs `steps` periods of the loop: the leader cruises at 25 m/s, then at 2 s brakes at
/// 4 m/s^2 to a stop and stands; no follower.
fn drive(controller: &mut Controller<'_>, steps: u32) -> Run {
    let h = PERIOD_US as f32 * 1e-6;
    let mut leader = Car { x: 80.0, v: 25.0 };
    let mut ego = Car { x: 20.0, v: 25.0 };
    let mut ego_a = 0.0f32;
    // The request sequence goes on from the last run's, as on the board.
    let mut bus = CanBus::with_next_counter(Loopback::default(), target::kept_request_counter());
    let ticks = Cell::new(0u32);
    let mut clock = WideClock::new(SimCounter(&ticks));
    let mut dog = Dog(0);
    let mut run = Run {
        nominal: 0,
        minimum_risk: 0,
        first_fault: None,
        first_counter: None,
        same_fault: 0,
        smallest_gap: f32::INFINITY,
        last_ego_speed: ego.v,
        e2e_faults: 0,
        displays: 0,
    };
    let mut seq = 0u8;
    for k in 0..steps {
        // The sensors' frames of this period, 5 ms old when sent.
        let gap = leader.x - ego.x;
        run.smallest_gap = run.smallest_gap.min(gap);
        let front = Track {
            gap,
            rel_speed: leader.v - ego.v,
        };
        let none = Track {
            gap: f32::INFINITY,
            rel_speed: 0.0,
        };
        let raw = bus.bus_mut();
        let frames = [
            (
                FRONT_TRACK_ID,
                &encode_track(FRONT_TRACK_ID, &front, true, 5, seq)[..],
            ),
            (
                REAR_TRACK_ID,
                &encode_track(REAR_TRACK_ID, &none, true, 5, seq)[..],
            ),
            (EGO_SPEED_ID, &encode_ego_speed(ego.v, true, 5, seq)[..]),
        ];
        for (id, data) in frames {
            if let Some(f) = StandardId::new(id).and_then(|id| Frame::new(id, data)) {
                let _ = raw.rx.push_back(f);
            }
        }
        seq = seq.wrapping_add(1);
        ticks.set(k.wrapping_mul(PERIOD_US));
        let sent = firmware::run_period_on_bus(controller, &mut bus, &mut clock, &mut dog);
        let Ok(command) = sent else {
            defmt::error!("step {=u32}: request not sent", k);
            finish(false);
        };
        match command.mode {
            Mode::Nominal => run.nominal += 1,
            Mode::MinimumRisk => {
                run.minimum_risk += 1;
                if run.first_fault.is_none() {
                    run.first_fault = command.fault;
                }
                if command.fault == run.first_fault {
                    run.same_fault += 1;
                }
            }
            _ => {}
        }
        // Kept for the run after a reset, as the board keeps it.
        target::keep_request_counter(bus.next_counter());
        // The actuator reads the request off the bus, the display its frame.
        while let Some(f) = bus.bus_mut().tx.pop_front() {
            match f.id.as_raw() {
                ACCEL_REQUEST_ID => {
                    let [a0, a1, _, _, counter, ..] = f.data;
                    ego_a = f32::from(i16::from_le_bytes([a0, a1])) * 1e-3;
                    run.first_counter = run.first_counter.or(Some(counter));
                }
                DRIVER_DISPLAY_ID
                    if decode_driver_display(f.data.get(..f.len).unwrap_or(&[]))
                        .is_ok_and(|(d, _)| d.engaged && d.refused.is_none()) =>
                {
                    run.displays += 1;
                }
                _ => {}
            }
        }
        let t = k as f32 * h;
        let leader_a = if t >= 2.0 { -4.0 } else { 0.0 };
        leader.advance(leader_a, h);
        ego.advance(ego_a, h);
    }
    let e2e = bus.e2e();
    run.e2e_faults = e2e.corrupted + e2e.repeated + e2e.out_of_sequence + e2e.malformed;
    run.last_ego_speed = ego.v;
    run
}

#[inline(never)]
fn overflow(depth: u32) -> u32 {
    let frame = black_box([depth; 64]);
    if black_box(depth) == u32::MAX {
        return 0;
    }
    overflow(depth + 1).wrapping_add(frame[black_box(3)])
}

#[entry]
fn main() -> ! {
    target::paint_stack();
    let marker = target::take_fault_marker();
    // QEMU models no reset flags: the marker alone tells a fault restart.
    let restart = boot::restart_fault(ResetFlags::default(), marker);
    let slot = target::table_slot();
    let table = boot::table_in_slot(slot);
    let Some(controller) = target::controller(table, Config::default()) else {
        // Made once, here: unreachable, but never a panic.
        finish(false);
    };
    defmt::info!(
        "boot: table slot {=usize:#x}, {=usize} of {=usize} bytes, accepted {=bool}, fault restart {=bool}",
        slot.as_ptr() as usize,
        table.len(),
        slot.len(),
        controller.table().is_some(),
        restart.is_some()
    );

    if controller.table().is_none() && restart.is_none() {
        // No table in the slot, or a bad one: the fallback, on healthy sensors.
        let run = drive(controller, 250);
        let refused = matches!(run.first_fault, Some(Fault::Table(_)));
        if let Some(fault) = run.first_fault {
            defmt::info!(
                "table refused: {=u32} of 250 steps minimum-risk with {}, {=u32} nominal",
                run.same_fault,
                fault,
                run.nominal
            );
        }
        finish(refused && run.same_fault == 250 && run.nominal == 0);
    }

    match (restart, stage()) {
        (None, _) => {
            let run = drive(controller, 1500);
            defmt::info!(
                "closed loop, 30 s: {=u32} nominal, {=u32} minimum-risk steps, smallest gap {=f32} m, ego at {=f32} m/s at the end, {=u32} end-to-end faults, {=u32} display frames",
                run.nominal,
                run.minimum_risk,
                run.smallest_gap,
                run.last_ego_speed,
                run.e2e_faults,
                run.displays
            );
            // Everything on the stack so far: main's frame, the loop's (the
            // CAN driver, the plant) and the deepest control step.
            let stack = target::stack_high_water();
            defmt::info!(
                "stack high-water mark after the closed loop: {=usize} of 16384 bytes",
                stack
            );
            if !(stack < 16384
                && run.nominal > 0
                && run.minimum_risk == 0
                && run.smallest_gap > 2.0
                && run.last_ego_speed < 0.1
                && run.e2e_faults == 0
                && run.displays == 1500)
            {
                finish(false);
            }
            defmt::info!("causing a HardFault (undefined instruction)");
            expect_counter_after_fault();
            set_stage(1);
            cortex_m::asm::udf()
        }
        (Some(fault), s) => {
            let [sp, check] = read_words(addr_of!(FAULT_SP));
            let below_ram = check == !sp && sp < 0x2000_0000;
            defmt::info!(
                "the HardFault left the stack pointer at {=u32:#x}{=str}",
                sp,
                if below_ram {
                    ": below RAM, a stack overflow"
                } else {
                    ""
                }
            );
            // The first fault is on a sound stack, the second an overflow.
            if below_ram != (s == 2) {
                finish(false);
            }
            controller.latch_minimum_risk(fault);
            let resumed = target::kept_request_counter();
            let run = drive(controller, 250);
            // The sequence goes on: the last frame took the counter the loop had kept, and the
            // first request after the reset carries the next one.
            let [expected, check] = read_words(addr_of!(EXPECTED_COUNTER));
            let goes_on = check == !expected
                && u32::from(resumed) == expected
                && run.first_counter == Some(resumed);
            defmt::info!(
                "the request sequence goes on after the reset at counter {=u8} (expected {=u32}): {=bool}",
                resumed,
                expected,
                goes_on
            );
            if !goes_on {
                finish(false);
            }
            let latched = if run.first_fault == Some(fault) {
                run.same_fault
            } else {
                0
            };
            defmt::info!(
                "after fault {=u32}: {=u32} of 250 steps minimum-risk (RestartedAfterFault), {=u32} nominal",
                s,
                latched,
                run.nominal
            );
            if latched != 250 {
                finish(false);
            }
            if s == 1 {
                defmt::info!("causing a stack overflow");
                expect_counter_after_fault();
                set_stage(2);
                black_box(overflow(black_box(0)));
                finish(false);
            }
            finish(s == 2);
        }
    }
}

/// The board's fault path, less the CAN mailbox QEMU does not model: the marker, the last
/// frame's words (computed as the board does), and a reset.
fn fault_exit() -> ! {
    let counter = target::kept_request_counter();
    let words =
        last_resort::minimum_risk_frame(Config::default().fallback.mrm_deceleration, counter);
    target::keep_request_counter(counter.wrapping_add(1));
    black_box(words);
    target::set_fault_marker();
    cortex_m::peripheral::SCB::sys_reset()
}

board_stm32f4::hard_fault_on_fresh_stack!(hard_fault);

extern "C" fn hard_fault(stack_pointer: u32) -> ! {
    write_words(addr_of_mut!(FAULT_SP), [stack_pointer, !stack_pointer]);
    fault_exit()
}

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    fault_exit()
}
