//! hjacc on an STM32F407 (an STM32F4DISCOVERY, or any F407/F405 board with an 8 MHz crystal and
//! a CAN transceiver on PB8/PB9).
//!
//! Boot, in order:
//! 1. The reset cause and the fault marker are read, then cleared ([`boot::restart_fault`]).
//! 2. Clocks: 168 MHz from the 8 MHz crystal (HSE), APB1 42 MHz (the CAN's clock), APB2
//!    84 MHz.
//! 3. The table is read in place from its own flash slot and checked whole
//!    (`firmware::Controller::new`: one CRC over the table and the header's checks, bounded);
//!    after a fault restart the controller is latched in the minimum-risk manoeuvre.
//! 4. The independent watchdog starts (100 ms, five periods): from here on a hang resets the
//!    board. It starts after the table check, so that the check's length cannot trip it.
//! 5. TIM2 runs free at 1 MHz over its 32 bits (the controller's clock); TIM3 paces the loop
//!    at 50 Hz.
//! 6. CAN1 on PB8 (RX) / PB9 (TX) at 500 kbit/s; filters pass the tracks (0x120, 0x121), the
//!    ego speed and the actuator's state (0x130, 0x131) and the driver's requests (0x140). The peripheral joins the bus without blocking: until it has, no frame
//!    arrives and the controller is in the minimum-risk manoeuvre, as with a silent bus. The
//!    takeover request goes on PD14.
//!
//! Then, every 20 ms: read the CAN frames, step the controller, send the acceleration request,
//! feed the watchdog, send the driver's display frame (0x210; `firmware::run_period_on_bus`), show the takeover request on PD14 (the
//! Discovery's red LED). A step that overran its period is counted and logged.
//!
//! The HardFault and panic handlers send one minimum-risk request straight from a CAN mailbox,
//! leave the fault marker and reset; a stack overflow (the stack sits at the bottom of RAM,
//! `memory.x`) faults into the HardFault handler, or locks the core up, which the watchdog
//! resets. Either way the next boot latches the minimum-risk manoeuvre.
#![no_std]
#![no_main]
// The exception handlers and the mailbox writes of the last frame are this binary's unsafe
// code (the slot and the marker are in `board_stm32f4::target`); the controller has none.
#![allow(unsafe_code)]

use core::panic::PanicInfo;

use board_stm32f4::boot::{self, ResetFlags};
use board_stm32f4::can_timing::BOARD_500K;
use board_stm32f4::clock::{MicrosCounter, WideClock};
use board_stm32f4::last_resort;
use board_stm32f4::takeover::TakeoverRequest;
use board_stm32f4::target;
use board_stm32f4::{PERIOD_US, WATCHDOG_TIMEOUT_MS};
use bxcan::filter::Mask32;
use bxcan::{Fifo, StandardId};
use cortex_m_rt::entry;
use defmt_rtt as _;
use firmware::can::{CanBus, DRIVER_REQUEST_ID, EGO_SPEED_ID, FRONT_TRACK_ID};
use firmware::Config;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{Config as ClockConfig, Enable, Reset};
use stm32f4xx_hal::watchdog::IndependentWatchdog;

/// TIM2 at 1 MHz, free-running over all 32 bits.
struct Tim2(pac::TIM2);

impl MicrosCounter for Tim2 {
    fn ticks(&mut self) -> u32 {
        self.0.cnt().read().bits()
    }
}

/// The independent watchdog behind the firmware's trait.
struct Iwdg(IndependentWatchdog);

impl firmware::Watchdog for Iwdg {
    fn feed(&mut self) {
        self.0.feed();
    }
}

#[entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else {
        // Taken once, here: unreachable, but never a panic.
        fault_exit();
    };

    // The free stack is painted, so that its high-water mark can be logged.
    target::paint_stack();

    // 1. Why we started, and whether the last run ended in a fault.
    let csr = dp.RCC.csr().read();
    let flags = ResetFlags {
        // PADRSTF and WDGRSTF are the reference manual's PINRSTF and IWDGRSTF.
        power_on: csr.porrstf().bit_is_set(),
        brown_out: csr.borrstf().bit_is_set(),
        pin: csr.padrstf().bit_is_set(),
        software: csr.sftrstf().bit_is_set(),
        independent_watchdog: csr.wdgrstf().bit_is_set(),
        window_watchdog: csr.wwdgrstf().bit_is_set(),
        low_power: csr.lpwrrstf().bit_is_set(),
    };
    dp.RCC.csr().modify(|_, w| w.rmvf().set_bit());
    let restart = boot::restart_fault(flags, target::take_fault_marker());

    // 2. Clocks.
    let mut rcc = dp.RCC.freeze(
        ClockConfig::hse(8.MHz())
            .sysclk(168.MHz())
            .pclk1(42.MHz())
            .pclk2(84.MHz()),
    );

    // 3. The table, and the controller: one CRC over the table and its checks, bounded, done
    //    before the watchdog starts so that its length cannot trip it.
    let slot = target::table_slot();
    let table = boot::table_in_slot(slot);
    let Some(controller) = target::controller(table, Config::default()) else {
        // Made once, here: unreachable, but never a panic.
        fault_exit();
    };
    defmt::info!(
        "hjacc: table slot {=usize:#x}, {=usize} of {=usize} bytes, accepted {=bool}",
        slot.as_ptr() as usize,
        table.len(),
        slot.len(),
        controller.table().is_some()
    );
    if let Some(fault) = restart {
        defmt::warn!(
            "restarted after a fault (watchdog {=bool}): minimum-risk manoeuvre until power-on",
            flags.independent_watchdog || flags.window_watchdog
        );
        controller.latch_minimum_risk(fault);
    }

    // 4. The watchdog, before anything that could hang.
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.stop_on_debug(&dp.DBGMCU, true);
    watchdog.start(WATCHDOG_TIMEOUT_MS.millis());

    // 5. The clock (TIM2: 84 MHz timer clock / 84) and the pacing timer.
    pac::TIM2::enable(&mut rcc);
    pac::TIM2::reset(&mut rcc);
    let tim2 = dp.TIM2;
    tim2.psc().write(|w| w.psc().set(83));
    tim2.arr().write(|w| w.arr().set(u32::MAX));
    tim2.egr().write(|w| w.ug().set_bit());
    tim2.cr1().modify(|_, w| w.cen().set_bit());
    let mut clock = WideClock::new(Tim2(tim2));
    let mut pace = dp.TIM3.counter_hz(&mut rcc);
    if pace.start((1_000_000 / PERIOD_US).Hz()).is_err() {
        defmt::error!("the pacing timer did not start");
        fault_exit();
    }

    // 6. CAN1, and the takeover request.
    let gpiob = dp.GPIOB.split(&mut rcc);
    let can = dp.CAN1.can((gpiob.pb9, gpiob.pb8), &mut rcc);
    let Some(btr) = BOARD_500K.btr() else {
        fault_exit();
    };
    let builder = bxcan::Can::builder(can).set_bit_timing(btr);
    // Automatic bus-off management (ABOM): after a bus-off the controller rejoins by itself
    // once it has seen 128 x 11 recessive bits, instead of staying off until software asks.
    // SAFETY: CAN1 is in initialisation mode (the builder's), where MCR is written; nothing
    // else touches the peripheral here.
    unsafe { (*pac::CAN1::ptr()).mcr().modify(|_, w| w.abom().set_bit()) };
    let mut can = builder.leave_disabled();
    {
        let mut filters = can.modify_filters();
        if let (Some(tracks), Some(pair), Some(ego), Some(driver), Some(exact)) = (
            StandardId::new(FRONT_TRACK_ID),
            StandardId::new(0x7FE),
            StandardId::new(EGO_SPEED_ID),
            StandardId::new(DRIVER_REQUEST_ID),
            StandardId::new(0x7FF),
        ) {
            // 0x120 and 0x121 differ in the last bit only, as 0x130 and 0x131 (the ego speed
            // and the actuator's state) do.
            filters.enable_bank(0, Fifo::Fifo0, Mask32::frames_with_std_id(tracks, pair));
            filters.enable_bank(1, Fifo::Fifo0, Mask32::frames_with_std_id(ego, pair));
            filters.enable_bank(2, Fifo::Fifo0, Mask32::frames_with_std_id(driver, exact));
        }
    }
    // The request sequence goes on from the last run's (0 after a power-on).
    let mut bus = CanBus::with_next_counter(can, target::kept_request_counter());
    let gpiod = dp.GPIOD.split(&mut rcc);
    let mut takeover = TakeoverRequest::new(gpiod.pd14.into_push_pull_output());

    let mut dog = Iwdg(watchdog);
    let mut overruns: u32 = 0;
    let mut periods: u32 = 0;
    loop {
        periods = periods.wrapping_add(1);
        if periods.is_multiple_of(500) {
            defmt::info!(
                "{=u32} periods, stack high-water mark {=usize} of 16384 bytes, {=u32} overruns",
                periods,
                target::stack_high_water(),
                overruns
            );
        }
        // The period's start: TIM3's update. Already there means the last step overran.
        if pace.wait().is_ok() {
            overruns = overruns.saturating_add(1);
            defmt::warn!("control step overran its period ({=u32} so far)", overruns);
        } else {
            while pace.wait().is_err() {
                cortex_m::asm::nop();
            }
        }
        // Joins the bus once it has seen it idle; a no-op afterwards.
        let _ = bus.bus_mut().enable_non_blocking();
        let sent = firmware::run_period_on_bus(controller, &mut bus, &mut clock, &mut dog);
        target::keep_request_counter(bus.next_counter());
        if let Err(e) = sent {
            let why = match e {
                firmware::can::Error::Bus(_) => "receive overrun",
                firmware::can::Error::TransmitBusy => "transmit mailboxes full",
                _ => "frame construction",
            };
            defmt::warn!("acceleration request not sent: {=str}", why);
        }
        // Shown whether or not the request went out: the driver sees the controller's state.
        if takeover
            .show(controller.mode(), controller.takeover_requested())
            .is_err()
        {
            defmt::warn!("takeover request not shown");
        }
    }
}

/// The end of every fault path: one minimum-risk request from a CAN mailbox, the marker, and a
/// reset. Touches no driver and little stack.
fn fault_exit() -> ! {
    send_last_frame();
    target::set_fault_marker();
    cortex_m::peripheral::SCB::sys_reset()
}

/// Writes the minimum-risk request into a free transmit mailbox of CAN1, if the peripheral is
/// running; waits a bounded time for a mailbox to free up.
fn send_last_frame() {
    let counter = target::kept_request_counter();
    let words =
        last_resort::minimum_risk_frame(Config::default().fallback.mrm_deceleration, counter);
    target::keep_request_counter(counter.wrapping_add(1));
    // SAFETY: the handler is the only code running from here to the reset; the registers are
    // CAN1's, written as the reference manual's "transmit" procedure describes.
    let can = unsafe { &*pac::CAN1::ptr() };
    // Abort whatever is pending (an older, possibly gentler command), then take mailbox 0.
    can.tsr()
        .write(|w| w.abrq0().set_bit().abrq1().set_bit().abrq2().set_bit());
    for _ in 0..100_000 {
        if can.tsr().read().tme0().bit_is_set() {
            let mailbox = can.tx(0);
            mailbox.tdtr().write(|w| unsafe { w.bits(words.tdtr) });
            mailbox.tdlr().write(|w| unsafe { w.bits(words.tdlr) });
            mailbox.tdhr().write(|w| unsafe { w.bits(words.tdhr) });
            mailbox.tir().write(|w| unsafe { w.bits(words.tir) });
            break;
        }
    }
    // Let it leave before the reset: a 500 kbit/s frame of 5 bytes takes under 0.25 ms.
    cortex_m::asm::delay(168_000);
}

board_stm32f4::hard_fault_on_fresh_stack!(hard_fault);

extern "C" fn hard_fault(_stack_pointer: u32) -> ! {
    fault_exit()
}

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    fault_exit()
}
