//! The controller's clock: microseconds since boot as a `u64`, from a free-running 32-bit
//! hardware counter at 1 MHz (TIM2 on the STM32F4), which wraps every 71.6 minutes.
//!
//! The extension adds the counter's forward distance since the last reading, modulo 2^32, to a
//! 64-bit total. That is exact as long as two readings are less than 2^32 us (71.6 min) apart;
//! the control loop reads the clock every 20 ms, and the watchdog resets the board long before
//! a loop could stall that long. So the clock never goes backwards and never jumps, and what
//! the controller's clock-jump check sees is the loop's own timing.

/// A free-running 32-bit counter ticking once per microsecond.
pub trait MicrosCounter {
    /// The counter's current value.
    fn ticks(&mut self) -> u32;
}

/// A [`firmware::Clock`] over a 32-bit microsecond counter.
#[derive(Debug)]
pub struct WideClock<C> {
    counter: C,
    last: u32,
    total_us: u64,
}

impl<C: MicrosCounter> WideClock<C> {
    /// A clock reading 0 at the counter's current value.
    pub fn new(mut counter: C) -> Self {
        let last = counter.ticks();
        WideClock {
            counter,
            last,
            total_us: 0,
        }
    }

    /// The counter, given back.
    pub fn release(self) -> C {
        self.counter
    }
}

impl<C: MicrosCounter> firmware::Clock for WideClock<C> {
    fn now_us(&mut self) -> u64 {
        let now = self.counter.ticks();
        let elapsed = now.wrapping_sub(self.last);
        self.last = now;
        self.total_us = self.total_us.saturating_add(u64::from(elapsed));
        self.total_us
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::Clock;

    /// A counter that returns the values it is given, in order.
    struct Script<'a>(core::slice::Iter<'a, u32>);

    impl MicrosCounter for Script<'_> {
        fn ticks(&mut self) -> u32 {
            *self
                .0
                .next()
                .expect("the script has a value for every reading")
        }
    }

    #[test]
    fn counts_from_zero_and_across_the_counters_wrap() {
        let readings = [
            u32::MAX - 30_000,
            u32::MAX - 10_000,
            9_999, // wrapped: 20,000 us after the last reading
            29_999,
            29_999, // no time passed
        ];
        let mut clock = WideClock::new(Script(readings.iter()));
        assert_eq!(clock.now_us(), 20_000);
        assert_eq!(clock.now_us(), 40_000);
        assert_eq!(clock.now_us(), 60_000);
        assert_eq!(clock.now_us(), 60_000);
    }

    /// A counter that advances by `step` between readings.
    struct Stepping {
        ticks: u32,
        step: u32,
    }

    impl MicrosCounter for Stepping {
        fn ticks(&mut self) -> u32 {
            let now = self.ticks;
            self.ticks = self.ticks.wrapping_add(self.step);
            now
        }
    }

    #[test]
    fn runs_past_many_wraps_without_drift() {
        // 20 ms a reading for 20 wraps of the counter (about a day).
        let step = 20_000u32;
        let n = 20 * (u64::from(u32::MAX) + 1) / u64::from(step);
        let mut clock = WideClock::new(Stepping {
            ticks: 12_345,
            step,
        });
        let mut last = 0;
        for _ in 0..n {
            let now = clock.now_us();
            assert_eq!(now - last, u64::from(step));
            last = now;
        }
        assert_eq!(last, n * u64::from(step));
    }
}
