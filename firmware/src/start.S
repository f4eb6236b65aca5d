/*
 * start.S - from reset to main: a stack, a zeroed .bss, and a trap that stops rather than runs
 * on from an unknown state.
 *
 * QEMU's loader starts the hart at the ELF's entry with nothing set up. Only hart 0 runs (virt
 * starts one hart unless -smp says otherwise; any other parks). A trap (an illegal instruction,
 * a misaligned access in the firmware itself) is a firmware bug: the hart parks in wfi, and the
 * host's requests go unanswered, which its timeouts report.
 */
    .section .text.start, "ax"
    .globl _start
_start:
    csrr    t0, mhartid
    bnez    t0, park
    la      t0, trap
    csrw    mtvec, t0
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

    .align 4
trap:
    j       park
