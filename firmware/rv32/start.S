/*
 * start.S - from reset to main (a stack, a zeroed .bss), and the trap vector.
 *
 * QEMU's loader starts the hart at the ELF's entry with nothing set up. Only hart 0 runs (virt
 * starts one hart unless -smp says otherwise; any other parks).
 *
 * Module code runs in user mode (rv32/trap.c, guest_enter below). Every trap it takes (an
 * ecall, a fault, the watchdog's timer) comes here: mscratch then holds the kernel's stack
 * pointer, so the vector swaps it with the module's sp, saves the module's registers in a frame
 * on the kernel's stack and calls trap_from_module(frame). When that returns (an ecall
 * answered) the registers come back from the frame and mret resumes the module; when the call
 * ends instead (the module returned, or faulted) trap.c jumps back into the kernel and never
 * returns here.
 *
 * While the firmware itself runs mscratch is 0, so a trap of the firmware's own (an illegal
 * instruction or a misaligned access in the firmware, a bug) is told apart: the hart parks in
 * wfi, and the host's requests go unanswered, which its timeouts report.
 */
    .equ FRAME, 128                 /* x0..x31, one word each, at 4 * register number */

    .section .text.start, "ax"
    .globl _start
_start:
    csrr    t0, mhartid
    bnez    t0, park
    la      t0, trap
    csrw    mtvec, t0
    csrw    mscratch, zero
    la      sp, __stack_top
    la      t0, __bss_start
    la      t1, __bss_end
zero_bss:
    bgeu    t0, t1, bss_done
    sw      zero, 0(t0)
    addi    t0, t0, 4
    j       zero_bss
bss_done:
    call    main
park:
    wfi
    j       park

    .text
/*
 * guest_enter(entry, argument, stack_top, return_address): run module code in user mode at
 * `entry` with a0 = `argument`, sp = `stack_top` and ra = `return_address`, every other
 * register 0 (as on the Python node: nothing of the kernel's leaks into module code). It does
 * not return: the trap the module's own return causes (a fetch at `return_address`, which no
 * PMP region lets user mode execute) ends the call in trap.c.
 */
    .globl guest_enter
guest_enter:
    csrw    mepc, a0
    li      t0, 0x1800              /* mstatus.MPP: user mode after mret */
    csrc    mstatus, t0
    csrw    mscratch, sp            /* the stack the module's traps run on */
    mv      sp, a2
    mv      ra, a3
    mv      a0, a1
    li      a1, 0
    li      a2, 0
    li      a3, 0
    li      gp, 0
    li      tp, 0
    li      t0, 0
    li      t1, 0
    li      t2, 0
    li      s0, 0
    li      s1, 0
    li      a4, 0
    li      a5, 0
    li      a6, 0
    li      a7, 0
    li      s2, 0
    li      s3, 0
    li      s4, 0
    li      s5, 0
    li      s6, 0
    li      s7, 0
    li      s8, 0
    li      s9, 0
    li      s10, 0
    li      s11, 0
    li      t3, 0
    li      t4, 0
    li      t5, 0
    li      t6, 0
    mret

    .align 4
trap:
    csrrw   sp, mscratch, sp
    beqz    sp, firmware_trap
    addi    sp, sp, -FRAME
    sw      x1, 4(sp)
    sw      x3, 12(sp)
    sw      x4, 16(sp)
    sw      x5, 20(sp)
    sw      x6, 24(sp)
    sw      x7, 28(sp)
    sw      x8, 32(sp)
    sw      x9, 36(sp)
    sw      x10, 40(sp)
    sw      x11, 44(sp)
    sw      x12, 48(sp)
    sw      x13, 52(sp)
    sw      x14, 56(sp)
    sw      x15, 60(sp)
    sw      x16, 64(sp)
    sw      x17, 68(sp)
    sw      x18, 72(sp)
    sw      x19, 76(sp)
    sw      x20, 80(sp)
    sw      x21, 84(sp)
    sw      x22, 88(sp)
    sw      x23, 92(sp)
    sw      x24, 96(sp)
    sw      x25, 100(sp)
    sw      x26, 104(sp)
    sw      x27, 108(sp)
    sw      x28, 112(sp)
    sw      x29, 116(sp)
    sw      x30, 120(sp)
    sw      x31, 124(sp)
    csrr    t0, mscratch            /* the module's sp */
    sw      t0, 8(sp)
    csrw    mscratch, zero          /* the kernel runs: a trap now is the firmware's own */
    mv      a0, sp
    call    trap_from_module
    addi    t0, sp, FRAME           /* the kernel's stack again, for the module's next trap */
    csrw    mscratch, t0
    lw      x1, 4(sp)
    lw      x3, 12(sp)
    lw      x4, 16(sp)
    lw      x5, 20(sp)
    lw      x6, 24(sp)
    lw      x7, 28(sp)
    lw      x8, 32(sp)
    lw      x9, 36(sp)
    lw      x10, 40(sp)
    lw      x11, 44(sp)
    lw      x12, 48(sp)
    lw      x13, 52(sp)
    lw      x14, 56(sp)
    lw      x15, 60(sp)
    lw      x16, 64(sp)
    lw      x17, 68(sp)
    lw      x18, 72(sp)
    lw      x19, 76(sp)
    lw      x20, 80(sp)
    lw      x21, 84(sp)
    lw      x22, 88(sp)
    lw      x23, 92(sp)
    lw      x24, 96(sp)
    lw      x25, 100(sp)
    lw      x26, 104(sp)
    lw      x27, 108(sp)
    lw      x28, 112(sp)
    lw      x29, 116(sp)
    lw      x30, 120(sp)
    lw      x31, 124(sp)
    lw      sp, 8(sp)
    mret

firmware_trap:
    csrrw   sp, mscratch, sp        /* sp back, mscratch 0 again */
    j       park
