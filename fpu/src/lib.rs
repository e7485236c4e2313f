//! The square root hollowpath computes with.
//!
//! libm 0.2's `sqrtf` is a software routine on 32-bit Arm (its hardware paths cover x86,
//! aarch64 and wasm only), where the Cortex-M4F's FPU has `VSQRT.F32`. Measured under QEMU, the
//! software routine was 28 % of the offset spiral's instructions on three_holes (2 075 M with
//! it, 1 497 M with the instruction), 16 % of the look-ahead's (35 093 and 29 479 a move) and
//! 2 % of four_holes' plan (1 101 M and 1 076 M).
//! [`sqrtf`] is that instruction on a hard-float 32-bit Arm target and `libm::sqrtf`
//! everywhere else.
//!
//! **Same bits on every target.** IEEE 754 requires the square root correctly rounded; the
//! Cortex-M4F's FPU computes it so in its default round-to-nearest mode with denormals kept
//! (FPSCR as reset and as cortex-m-rt leaves it), and libm's `sqrtf` is correctly rounded too.
//! So the host and the controller compute bit-identical plans. The check runs where the
//! instruction does: the QEMU bench firmware compares this function with `libm::sqrtf` on two
//! million inputs before anything else, and `host-sim/tests/mcu.rs` requires that line and
//! compares the firmware's plan and layer digests with the host's. (On the host this
//! function is `libm::sqrtf`, so a host test would compare libm with itself.)
//!
//! This is the one `unsafe` block the planner's arithmetic depends on, kept out of the core
//! crate (which has none). It goes when libm ships the same instruction
//! (rust-lang/compiler-builtins#1300, merged, not released in libm 0.2.16).
#![no_std]

/// The square root of `x`, correctly rounded (NaN below zero).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
pub fn sqrtf(x: f32) -> f32 {
    let y: u32;
    // SAFETY: VSQRT.F32 reads one FPU register and writes one; it touches no memory and no
    // stack, and of the FPSCR only its cumulative exception flags (nothing reads them). A
    // hard-float target (`eabihf`) has the FPU, enabled by cortex-m-rt before `main`. The
    // operands pass through core registers: rustc refuses FPU register operands on
    // thumbv7em-none-eabihf (it does not count the target's FPU as `vfp2`), so `s0` is saved
    // in a core register and restored, and nothing else is touched.
    unsafe {
        core::arch::asm!(
            "vmov {save}, s0",
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {y}, s0",
            "vmov s0, {save}",
            x = in(reg) x.to_bits(),
            y = lateout(reg) y,
            save = out(reg) _,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    f32::from_bits(y)
}

/// The square root of `x`, correctly rounded (NaN below zero).
#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline(always)]
pub fn sqrtf(x: f32) -> f32 {
    libm::sqrtf(x)
}
