//! Measurement probe: the board's peripheral set on embassy-stm32 (168 MHz from an 8 MHz HSE,
//! CAN1 on PB8/PB9 at 500 kbit/s, the independent watchdog, a 50 Hz tick, one output pin).
#![no_std]
#![no_main]
use embassy_executor::Spawner;
use embassy_stm32::can::{Can, Frame, Rx0InterruptHandler, Rx1InterruptHandler, SceInterruptHandler, TxInterruptHandler};
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::peripherals::CAN1;
use embassy_stm32::time::Hertz;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, Config};
use embassy_time::{Duration, Ticker};
use defmt_rtt as _;

bind_interrupts!(struct Irqs {
    CAN1_RX0 => Rx0InterruptHandler<CAN1>;
    CAN1_RX1 => Rx1InterruptHandler<CAN1>;
    CAN1_SCE => SceInterruptHandler<CAN1>;
    CAN1_TX => TxInterruptHandler<CAN1>;
});

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! { loop {} }

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let mut config = Config::default();
    {
        use embassy_stm32::rcc::*;
        config.rcc.hse = Some(Hse { freq: Hertz(8_000_000), mode: HseMode::Oscillator });
        config.rcc.pll_src = PllSource::HSE;
        config.rcc.pll = Some(Pll { prediv: PllPreDiv::DIV8, mul: PllMul::MUL336, divp: Some(PllPDiv::DIV2), divq: Some(PllQDiv::DIV7), divr: None });
        config.rcc.sys = Sysclk::PLL1_P;
        config.rcc.ahb_pre = AHBPrescaler::DIV1;
        config.rcc.apb1_pre = APBPrescaler::DIV4;
        config.rcc.apb2_pre = APBPrescaler::DIV2;
    }
    let p = embassy_stm32::init(config);
    let mut lamp = Output::new(p.PD12, Level::Low, Speed::Low);
    let mut can = Can::new(p.CAN1, p.PB8, p.PB9, Irqs);
    can.modify_filters().enable_bank(0, embassy_stm32::can::Fifo::Fifo0, embassy_stm32::can::filter::Mask32::accept_all());
    can.set_bitrate(500_000);
    can.enable().await;
    let mut wdg = IndependentWatchdog::new(p.IWDG, 100_000);
    wdg.unleash();
    let mut ticker = Ticker::every(Duration::from_millis(20));
    let mut n: u8 = 0;
    loop {
        ticker.next().await;
        while let Ok(env) = can.try_read() { defmt::info!("rx {}", env.frame.header().len()); }
        let frame = Frame::new_standard(0x200, &[n, 0, 0, 0, 0]).unwrap();
        let _ = can.try_write(&frame);
        n = n.wrapping_add(1);
        lamp.toggle();
        wdg.pet();
    }
}
