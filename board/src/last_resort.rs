//! The last frame: what a HardFault or panic handler sends before it resets the core.
//!
//! A fault handler cannot trust the drivers (the fault may be in them) nor much of the stack, so
//! it writes one acceleration request straight into a bxCAN transmit mailbox: the minimum-risk
//! deceleration, mode "minimum risk", with the rolling counter the CAN driver would have used
//! next and the frame's CRC, so the actuator's end-to-end check accepts it. Everything it needs
//! is computed here, on plain values, and tested on the host; the handler only stores four
//! words. After the reset the controller is latched in the same manoeuvre
//! ([`crate::boot::restart_fault`]).

use firmware::can::{encode_command, ACCEL_REQUEST_ID};
use firmware::{Command, Mode};

/// The four words of a bxCAN transmit mailbox, in the order the handler writes them (the
/// identifier register last: its `TXRQ` bit starts the transmission).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MailboxWords {
    /// `CAN_TDTxR`: the data length code.
    pub tdtr: u32,
    /// `CAN_TDLxR`: data bytes 0-3, byte 0 in the low byte.
    pub tdlr: u32,
    /// `CAN_TDHxR`: data bytes 4-7.
    pub tdhr: u32,
    /// `CAN_TIxR`: the standard identifier in bits 21-31, `TXRQ` (bit 0) set.
    pub tir: u32,
}

/// The mailbox words of a standard data frame with identifier `id` (11 bits) and up to eight
/// data bytes (the rest are dropped).
pub fn mailbox_words(id: u16, data: &[u8]) -> MailboxWords {
    let mut bytes = [0u8; 8];
    let len = data.len().min(8);
    for (b, d) in bytes.iter_mut().zip(data) {
        *b = *d;
    }
    let [b0, b1, b2, b3, b4, b5, b6, b7] = bytes;
    MailboxWords {
        tdtr: u32::try_from(len).unwrap_or(8),
        tdlr: u32::from_le_bytes([b0, b1, b2, b3]),
        tdhr: u32::from_le_bytes([b4, b5, b6, b7]),
        tir: (u32::from(id & 0x7FF) << 21) | 1,
    }
}

/// The minimum-risk request at `deceleration` m/s^2 (positive), as the controller would send it.
pub fn minimum_risk_command(deceleration: f32) -> Command {
    let mut command = Command::bare(
        -deceleration,
        Mode::MinimumRisk,
        Some(firmware::Fault::RestartedAfterFault),
    );
    command.takeover = true;
    command
}

/// The last frame's mailbox words: the minimum-risk request at `deceleration`, carrying
/// `counter`.
pub fn minimum_risk_frame(deceleration: f32, counter: u8) -> MailboxWords {
    let payload = encode_command(&minimum_risk_command(deceleration), counter);
    mailbox_words(ACCEL_REQUEST_ID, &payload)
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::can::frame_crc;

    #[test]
    fn the_last_frame_is_a_valid_minimum_risk_request() {
        let w = minimum_risk_frame(2.0, 41);
        assert_eq!(w.tir >> 21, u32::from(ACCEL_REQUEST_ID));
        assert_eq!(
            w.tir & 0b111,
            1,
            "standard id, data frame, transmit requested"
        );
        assert_eq!(w.tdtr, 6);
        let bytes = [w.tdlr.to_le_bytes(), w.tdhr.to_le_bytes()].concat();
        // -2 m/s^2 in 0.001 m/s^2, mode 2 (minimum risk), the status (not certified, takeover
        // requested, both tracks missing), the counter, then the CRC.
        assert_eq!(i16::from_le_bytes([bytes[0], bytes[1]]), -2000);
        assert_eq!(bytes[2], 2);
        assert_eq!(bytes[3], 0b1001_0010);
        assert_eq!(bytes[4], 41);
        assert_eq!(bytes[5], frame_crc(ACCEL_REQUEST_ID, &bytes[..5]));
        assert_eq!(&bytes[6..], &[0, 0]);
    }

    #[test]
    fn the_words_hold_the_frame_as_the_reference_manual_lays_it_out() {
        let w = mailbox_words(0x7FF, &[1, 2, 3, 4, 5, 6, 7, 8, 9]);
        assert_eq!(w.tir, 0xFFE0_0001);
        assert_eq!(w.tdtr, 8);
        assert_eq!(w.tdlr, 0x0403_0201);
        assert_eq!(w.tdhr, 0x0807_0605);
        assert_eq!(mailbox_words(0x120, &[]).tdtr, 0);
    }
}
