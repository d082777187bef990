//! The square root the certificate's closed forms take, in one place for the table's reader and
//! the firmware.
//!
//! Every path is IEEE 754's correctly rounded square root, so the host and the target compute
//! the same bits: on a hard-float Arm core (a Cortex-M4F) it is the FPU's `vsqrt.f32`, one
//! instruction of 14 cycles; elsewhere libm's `sqrtf`, whose software routine is about 50
//! instructions on a core without that path (libm has none for 32-bit Arm). The front's closed
//! form calls it up to twice per segment of its integration, and the control step's worst
//! takes 18.

/// `sqrt(x)`, correctly rounded; NaN below zero.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        vsqrt(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// The FPU's square root, as a function of the hard-float ABI: the argument arrives in `s0` and
/// the result leaves in it. A naked function, because inline assembly's single-precision
/// register class asks for the `vfp2` feature (double precision), which a Cortex-M4F's
/// `thumbv7em-none-eabihf` does not have (`+vfp4d16sp`); `vsqrt.f32` is single precision, and
/// the `.fpu` directive tells the assembler the FPU it runs on (the Cortex-M4F's, a subset of
/// every hard-float Cortex-M's).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[allow(unsafe_code)]
#[unsafe(naked)]
extern "C" fn vsqrt(x: f32) -> f32 {
    // The ABI's registers are the whole contract: `x` in `s0`, the root back in `s0`.
    core::arch::naked_asm!(".fpu fpv4-sp-d16", "vsqrt.f32 s0, s0", "bx lr")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The host's path is libm's, correctly rounded: it agrees with `f64`'s square root
    /// rounded once to `f32` (exact for `f32` inputs: the double rounding is innocuous for a
    /// square root, 2p + 2 <= 53), over a sweep of the finite non-negative floats' bit
    /// patterns (subnormals included), and at the largest float.
    #[test]
    fn the_root_is_correctly_rounded() {
        let mut bits = 0u32;
        while bits < 0x7f80_0000 {
            let x = f32::from_bits(bits);
            let exact = f64::from(x).sqrt() as f32;
            assert_eq!(sqrt(x).to_bits(), exact.to_bits(), "{x:e}");
            bits += 0x1f3d;
        }
        assert!(sqrt(-1.0).is_nan());
        assert_eq!(sqrt(0.0), 0.0);
        assert_eq!(
            sqrt(f32::MAX).to_bits(),
            (f64::from(f32::MAX).sqrt() as f32).to_bits()
        );
    }
}
