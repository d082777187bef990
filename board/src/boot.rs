//! What the board decides before its first control step: where the table is, and whether the
//! last run ended in a fault of the board's own.
//!
//! # The table's slot
//! The table is flashed on its own into a slot of fixed size (the linker's `TABLE` region,
//! `memory.x`: sectors 6-11 of the STM32F407, 768 KiB at `0x0804_0000`), so that a new table
//! needs no new code and a new build of the code keeps the table. The code finds the table at
//! the slot's start by the length its header declares ([`table_in_slot`]); the controller then
//! checks it whole: CRC, format version, game, the band against the vehicle's envelope, the
//! speed range, and the `solver verify` record (`firmware::Controller::new`). An erased slot, a
//! table too long for the slot or any failed check is a typed [`firmware::Fault`] and the
//! minimum-risk manoeuvre.
//!
//! # A restart after a fault
//! The fault handlers (HardFault, panic) send one minimum-risk frame, leave a marker in RAM that
//! a reset does not clear ([`FaultMarker`]) and reset the core. A stack overflow may leave the
//! core locked up instead, and a hung step stops feeding the watchdog: either way the
//! independent watchdog resets the board. At boot, [`restart_fault`] reads the reset cause and
//! the marker: after a watchdog reset or a marked fault the controller is latched into the
//! minimum-risk manoeuvre until the next power-on ([`firmware::Fault::RestartedAfterFault`]).
//! Software that failed once in a drive is not trusted again in it; the car is brought to a
//! stop. A power-on, brown-out or reset-pin start is a fresh start.

use firmware::Fault;

/// The table's bytes at the start of `slot`: the prefix of the length the table's header
/// declares, or the whole slot when no length can be read (erased flash, another format), so
/// that the controller's own parse names the fault.
pub fn table_in_slot(slot: &[u8]) -> &[u8] {
    firmware::table_format::Table::declared_len(slot)
        .ok()
        .and_then(|len| slot.get(..len))
        .unwrap_or(slot)
}

/// Why the core last started, from the reset controller's flags (the STM32F4's `RCC_CSR`).
/// The flags stay set until software clears them, so the boot clears them (`RMVF`) once it has
/// read them: each boot then sees the resets since the last boot only. Several can be set at
/// once (an internal reset also pulses the reset pin).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ResetFlags {
    /// Power-on or power-down reset (`PORRSTF`).
    pub power_on: bool,
    /// Brown-out reset (`BORRSTF`).
    pub brown_out: bool,
    /// The reset pin (`PINRSTF`): a button, a debug probe, or any of the internal resets,
    /// which also pulse the pin on the STM32F4.
    pub pin: bool,
    /// Software reset (`SFTRSTF`): the fault handlers reset this way, after leaving their
    /// marker.
    pub software: bool,
    /// The independent watchdog (`IWDGRSTF`).
    pub independent_watchdog: bool,
    /// The window watchdog (`WWDGRSTF`).
    pub window_watchdog: bool,
    /// Low-power management reset (`LPWRRSTF`).
    pub low_power: bool,
}

/// The marker a fault handler leaves for the next boot: two words in RAM that no reset clears
/// (cortex-m-rt's `.uninit`), the second the complement of the first, so that power-on
/// garbage passes for a marker with probability about 2^-64.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FaultMarker(pub [u32; 2]);

/// The marker's first word: "HJFT".
pub const FAULT_MARKER_WORD: u32 = 0x484A_4654;

impl FaultMarker {
    /// What a fault handler writes.
    pub const SET: FaultMarker = FaultMarker([FAULT_MARKER_WORD, !FAULT_MARKER_WORD]);
    /// What the boot writes once it has read the marker.
    pub const CLEAR: FaultMarker = FaultMarker([0, 0]);

    /// Whether the words are the set marker.
    pub fn is_set(&self) -> bool {
        *self == FaultMarker::SET
    }
}

/// The acceleration requests' rolling counter, as kept in two words of RAM across a reset: the
/// counter and its complement.
pub fn counter_words(counter: u8) -> [u32; 2] {
    let c = u32::from(counter);
    [c, !c]
}

/// The counter kept in `words`, or `None` when they hold none (after a power-on, RAM holds
/// garbage; the sequence then starts at 0).
pub fn counter_from_words(words: [u32; 2]) -> Option<u8> {
    let [c, check] = words;
    if check == !c {
        u8::try_from(c).ok()
    } else {
        None
    }
}

/// The fault to latch at boot, if the last run ended in one: a watchdog reset, or a reset
/// after a fault handler left its marker. A power-on or brown-out reset discards the marker
/// (RAM did not hold).
pub fn restart_fault(flags: ResetFlags, marker: FaultMarker) -> Option<Fault> {
    if flags.power_on || flags.brown_out {
        return None;
    }
    (flags.independent_watchdog || flags.window_watchdog || marker.is_set())
        .then_some(Fault::RestartedAfterFault)
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::table_format::{Error, Table};
    use firmware::DEFAULT_TABLE;

    #[test]
    fn the_table_is_found_in_an_erased_slot_and_erased_flash_is_refused() {
        let mut slot = DEFAULT_TABLE.to_vec();
        slot.resize(768 * 1024, 0xFF);
        let table = table_in_slot(&slot);
        assert_eq!(table, DEFAULT_TABLE);
        let erased = vec![0xFF; 768 * 1024];
        assert_eq!(table_in_slot(&erased).len(), erased.len());
        assert_eq!(
            Table::parse(table_in_slot(&erased)).unwrap_err(),
            Error::BadMagic
        );
        // A slot too small for the table it holds the start of.
        let cut = &DEFAULT_TABLE[..DEFAULT_TABLE.len() - 1];
        assert!(matches!(
            Table::parse(table_in_slot(cut)).unwrap_err(),
            Error::Checksum { .. } | Error::Truncated { .. } | Error::PayloadSize { .. }
        ));
    }

    #[test]
    fn the_controller_runs_the_table_from_its_slot() {
        let mut slot = DEFAULT_TABLE.to_vec();
        slot.resize(768 * 1024, 0xFF);
        let controller = firmware::Controller::new(table_in_slot(&slot), Default::default());
        assert!(controller.table().is_some());
        let erased = vec![0xFF; 1024];
        let controller = firmware::Controller::new(table_in_slot(&erased), Default::default());
        assert!(controller.table().is_none());
    }

    #[test]
    fn the_request_counter_survives_a_reset_and_garbage_is_no_counter() {
        for c in [0u8, 1, 200, 255] {
            assert_eq!(counter_from_words(counter_words(c)), Some(c));
        }
        assert_eq!(counter_from_words([7, 7]), None);
        assert_eq!(counter_from_words([256, !256]), None);
        assert_eq!(counter_from_words(FaultMarker::SET.0), None);
    }

    #[test]
    fn only_a_fault_of_the_boards_own_latches() {
        let none = ResetFlags::default();
        assert_eq!(restart_fault(none, FaultMarker::CLEAR), None);
        assert_eq!(
            restart_fault(
                ResetFlags {
                    pin: true,
                    independent_watchdog: true,
                    ..none
                },
                FaultMarker::CLEAR
            ),
            Some(Fault::RestartedAfterFault)
        );
        assert_eq!(
            restart_fault(
                ResetFlags {
                    window_watchdog: true,
                    ..none
                },
                FaultMarker::CLEAR
            ),
            Some(Fault::RestartedAfterFault)
        );
        let software = ResetFlags {
            pin: true,
            software: true,
            ..none
        };
        assert_eq!(
            restart_fault(software, FaultMarker::SET),
            Some(Fault::RestartedAfterFault)
        );
        assert_eq!(restart_fault(software, FaultMarker::CLEAR), None);
        // Half a marker, or garbage, is not one.
        assert_eq!(
            restart_fault(software, FaultMarker([FAULT_MARKER_WORD, 0])),
            None
        );
        // Power-on and brown-out: RAM did not hold, the marker means nothing.
        for flags in [
            ResetFlags {
                power_on: true,
                pin: true,
                ..none
            },
            ResetFlags {
                brown_out: true,
                independent_watchdog: true,
                ..none
            },
        ] {
            assert_eq!(restart_fault(flags, FaultMarker::SET), None);
        }
    }
}
