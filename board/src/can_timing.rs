//! The bxCAN bit timing, derived rather than copied from a calculator.
//!
//! A CAN bit is `1 + ts1 + ts2` time quanta; a quantum is `prescaler` cycles of the
//! peripheral's clock (APB1). The bit rate is `pclk1 / (prescaler * (1 + ts1 + ts2))` and the
//! sample point sits after `1 + ts1` quanta. The STM32F4's `CAN_BTR` holds each field less one:
//! `BRP` in bits 0-9, `TS1` in 16-19, `TS2` in 20-22, `SJW` in 24-25.
//!
//! The board runs APB1 at 42 MHz (168 MHz system clock, APB1 prescaler 4). For 500 kbit/s,
//! the bus of most powertrain and chassis networks: prescaler 6 gives 7 MHz quanta, 14 quanta a
//! bit, `ts1 = 11`, `ts2 = 2`, sample point 12/14 = 85.7 %, inside CiA 301's 85-90 % for this
//! rate; the resynchronisation jump width is 1 quantum.

/// One bit timing of the bxCAN peripheral.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BitTiming {
    /// Peripheral clock cycles per time quantum (1 to 1024).
    pub prescaler: u16,
    /// Quanta before the sample point, after the sync quantum (1 to 16).
    pub ts1: u8,
    /// Quanta after the sample point (1 to 8).
    pub ts2: u8,
    /// Resynchronisation jump width, quanta (1 to 4).
    pub sjw: u8,
}

/// The board's timing: 500 kbit/s from a 42 MHz APB1.
pub const BOARD_500K: BitTiming = BitTiming {
    prescaler: 6,
    ts1: 11,
    ts2: 2,
    sjw: 1,
};

/// The board's APB1 clock, Hz.
pub const BOARD_PCLK1_HZ: u32 = 42_000_000;

impl BitTiming {
    /// Whether every field is in the register's range.
    pub fn is_valid(&self) -> bool {
        (1..=1024).contains(&self.prescaler)
            && (1..=16).contains(&self.ts1)
            && (1..=8).contains(&self.ts2)
            && (1..=4).contains(&self.sjw)
            && self.sjw <= self.ts2
    }

    /// The `CAN_BTR` value (mode bits clear), or `None` for a timing outside the register's
    /// ranges.
    pub fn btr(&self) -> Option<u32> {
        self.is_valid().then(|| {
            u32::from(self.prescaler - 1)
                | (u32::from(self.ts1 - 1) << 16)
                | (u32::from(self.ts2 - 1) << 20)
                | (u32::from(self.sjw - 1) << 24)
        })
    }

    /// Quanta per bit.
    pub fn quanta(&self) -> u32 {
        1 + u32::from(self.ts1) + u32::from(self.ts2)
    }

    /// The bit rate at peripheral clock `pclk1_hz`, bits per second, if it is a whole number.
    pub fn bit_rate(&self, pclk1_hz: u32) -> Option<u32> {
        let cycles = u32::from(self.prescaler) * self.quanta();
        pclk1_hz.is_multiple_of(cycles).then(|| pclk1_hz / cycles)
    }

    /// The sample point, per mille of the bit.
    pub fn sample_point_per_mille(&self) -> u32 {
        1000 * (1 + u32::from(self.ts1)) / self.quanta()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_board_runs_500_kbit_with_the_sample_point_in_range() {
        assert_eq!(BOARD_500K.bit_rate(BOARD_PCLK1_HZ), Some(500_000));
        let sp = BOARD_500K.sample_point_per_mille();
        assert!((850..=900).contains(&sp), "{sp}");
        assert_eq!(BOARD_500K.btr(), Some(0x001A_0005));
    }

    /// The register value decodes back into the fields, as the reference manual reads it.
    #[test]
    fn the_register_holds_each_field_less_one() {
        let btr = BOARD_500K.btr().unwrap();
        assert_eq!((btr & 0x3FF) + 1, 6);
        assert_eq!(((btr >> 16) & 0xF) + 1, 11);
        assert_eq!(((btr >> 20) & 0x7) + 1, 2);
        assert_eq!(((btr >> 24) & 0x3) + 1, 1);
        let bad = BitTiming {
            ts2: 9,
            ..BOARD_500K
        };
        assert_eq!(bad.btr(), None);
        let zero = BitTiming {
            prescaler: 0,
            ..BOARD_500K
        };
        assert_eq!(zero.btr(), None);
    }
}
