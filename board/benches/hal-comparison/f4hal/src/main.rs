//! Measurement probe: the board's peripheral set on stm32f4xx-hal (168 MHz from an 8 MHz HSE,
//! CAN1 on PB8/PB9 at 500 kbit/s, the independent watchdog, a 50 Hz tick, one output pin).
#![no_std]
#![no_main]
use bxcan::filter::Mask32;
use bxcan::{Fifo, Frame, StandardId};
use cortex_m_rt::entry;
use defmt_rtt as _;
use stm32f4xx_hal::{pac, prelude::*, rcc::Config, watchdog::IndependentWatchdog};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! { loop {} }

#[entry]
fn main() -> ! {
    let dp = pac::Peripherals::take().unwrap();
    let mut rcc = dp.RCC.freeze(Config::hse(8.MHz()).sysclk(168.MHz()).pclk1(42.MHz()).pclk2(84.MHz()));
    let gpiod = dp.GPIOD.split(&mut rcc);
    let mut lamp = gpiod.pd12.into_push_pull_output();
    let gpiob = dp.GPIOB.split(&mut rcc);
    let can = dp.CAN1.can((gpiob.pb9, gpiob.pb8), &mut rcc);
    let mut can = bxcan::Can::builder(can).set_bit_timing(0x001A_0005).leave_disabled();
    can.modify_filters().enable_bank(0, Fifo::Fifo0, Mask32::accept_all());
    let _ = nb::block!(can.enable_non_blocking());
    let mut wdg = IndependentWatchdog::new(dp.IWDG);
    wdg.start(100.millis());
    let mut tick = dp.TIM3.counter_hz(&mut rcc);
    tick.start(50.Hz()).unwrap();
    let mut n: u8 = 0;
    loop {
        nb::block!(tick.wait()).unwrap();
        while let Ok(frame) = can.receive() { defmt::info!("rx {}", frame.dlc()); }
        let frame = Frame::new_data(StandardId::new(0x200).unwrap(), [n, 0, 0, 0, 0]);
        let _ = can.transmit(&frame);
        n = n.wrapping_add(1);
        lamp.toggle();
        wdg.feed();
    }
}
