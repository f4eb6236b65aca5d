/*
 * trap.c - module code in user mode (trap.h).
 *
 * Module code runs in user mode, as on the Python node (docs/memory-map.md), so the hart itself
 * enforces the guest's permissions: four NAPOT PMP regions give user mode flash r-x, SRAM r--,
 * the task window rw- and the module stack rw-; everything else (the firmware's RAM, the UART,
 * the flash's command registers) faults. The firmware runs in machine mode, which unlocked PMP
 * regions do not bind, with mstatus.MIE clear: the watchdog's timer interrupt reaches the hart
 * only while user mode runs.
 *
 * A call goes in with guest_enter (start.S) on the module stack and a return address no region
 * lets user mode execute, so the module's own `ret` traps with a fetch fault at exactly that
 * address: the call's end, with a0 its status. Any other trap is an ecall to answer, or a fault
 * that ends the call (kernel_fault, then module_call_abort back into the kernel).
 */
#include "trap.h"

#include "../board/board.h"
#include "../kernel/guest_memory.h"
#include "../kernel/kernel.h"
#include "../kernel/module_call.h"
#include "../kernel/text.h"

/* Where a returning module jumps: no PMP region covers it, so the fetch traps. */
#define GUEST_RETURN 0xFFFFFFFCu
#define FAULT_TEXT 160

/* mcause: exceptions, and the one interrupt module code takes (the watchdog's timer). */
enum cause {
    CAUSE_FETCH_MISALIGNED = 0, CAUSE_FETCH_FAULT = 1, CAUSE_ILLEGAL = 2,
    CAUSE_LOAD_MISALIGNED = 4, CAUSE_LOAD_FAULT = 5, CAUSE_STORE_MISALIGNED = 6,
    CAUSE_STORE_FAULT = 7, CAUSE_USER_ECALL = 8
};
#define CAUSE_TIMER 0x80000007u
enum { REG_A0 = 10, REG_A1, REG_A2, REG_A3, REG_A7 = 17 };

/* PMP configuration bits: readable, writable, executable, NAPOT matching. */
#define PMP_R 0x01u
#define PMP_W 0x02u
#define PMP_X 0x04u
#define PMP_NAPOT 0x18u

_Noreturn void guest_enter(uint32_t entry, uint32_t argument, uint32_t stack_top,
                           uint32_t return_address);

static module_jump_point returned_to; /* run_in_user_mode, as the module returns */
static volatile int32_t returned;      /* volatile: read after the jump back */
static uint32_t stack_top;
static uint32_t ticks; /* the watchdog's ticks in the running call */

#define CSR_READ(name)                                                                        \
    ({                                                                                        \
        uint32_t value_;                                                                      \
        __asm__ volatile("csrr %0, " #name : "=r"(value_));                                   \
        value_;                                                                               \
    })

static uint32_t napot(const struct guest_region *region)
{
    return (region->base + region->size / 2u - 1u) >> 2;
}

static int32_t run_in_user_mode(uint32_t entry, uint32_t argument)
{
    if (module_call_save(returned_to) != 0) {
        return returned; /* the module returned: trap_from_module jumped back here */
    }
    ticks = 0;
    board_alarm_in(WATCHDOG_TICK_US);
    guest_enter(entry, argument, stack_top, GUEST_RETURN);
}

void trap_init(void)
{
    const struct guest_region *stack = guest_memory_region(REGION_STACK);
    uint32_t config = (PMP_NAPOT | PMP_R | PMP_X) | (PMP_NAPOT | PMP_R) << 8 |
                      (PMP_NAPOT | PMP_R | PMP_W) << 16 | (PMP_NAPOT | PMP_R | PMP_W) << 24;

    __asm__ volatile("csrw pmpaddr0, %0" : : "r"(napot(guest_memory_region(REGION_FLASH))));
    __asm__ volatile("csrw pmpaddr1, %0" : : "r"(napot(guest_memory_region(REGION_SRAM))));
    __asm__ volatile("csrw pmpaddr2, %0" : : "r"(napot(guest_memory_region(REGION_WINDOW))));
    __asm__ volatile("csrw pmpaddr3, %0" : : "r"(napot(stack)));
    __asm__ volatile("csrw pmpcfg0, %0" : : "r"(config));
    stack_top = stack->base + stack->size;
    board_alarm_cancel();
    module_call_use(run_in_user_mode);
}

/* "SRAM, guest r--" or "unmapped memory": where an address lies, as the Python node says it. */
static void add_where(struct text *text, uint32_t address)
{
    const struct guest_region *region = guest_region_at(address, 1);
    if (region == 0) {
        text_add(text, "unmapped memory");
        return;
    }
    text_format(text, "%s, guest ", region->name);
    text_add_char(text, region->guest & GUEST_READ ? 'r' : '-');
    text_add_char(text, region->guest & GUEST_WRITE ? 'w' : '-');
    text_add_char(text, region->guest & GUEST_EXECUTE ? 'x' : '-');
}

/* The bytes a load or store at `pc` moves (funct3's low two bits), 4 when it cannot be read. */
static uint32_t access_size(uint32_t pc)
{
    if (guest_region_at(pc, 4) == 0) {
        return 4;
    }
    return 1u << ((guest_read32(pc) >> 12) & 3u);
}

static void memory_fault(struct text *text, bool write, uint32_t address, uint32_t pc)
{
    text_format(text, "memory fault: %U%s", (uint64_t)(access_size(pc)),
                write ? "-byte write at " : "-byte read at ");
    text_add_address(text, address);
    text_add(text, " (");
    add_where(text, address);
    text_add(text, ") by the instruction at ");
    text_add_address(text, pc);
}

/* What ended the call, in the Python node's words where it has the same fault. */
static void describe_fault(struct text *text, uint32_t cause, uint32_t pc, uint32_t value)
{
    switch (cause) {
    case CAUSE_TIMER:
        text_format(text, "watchdog: time budget of %U us exhausted at ", (uint64_t)WATCHDOG_US);
        text_add_address(text, pc);
        return;
    case CAUSE_FETCH_FAULT:
        text_add(text, "memory fault: instruction fetch at ");
        text_add_address(text, value);
        text_add(text, " (");
        add_where(text, value);
        text_add(text, ")");
        return;
    case CAUSE_FETCH_MISALIGNED:
        text_add(text, "instruction fetch at ");
        text_add_address(text, value);
        text_add(text, ": expected 4-byte aligned RV32IM instructions, got a misaligned "
                         "address or a compressed instruction");
        return;
    case CAUSE_ILLEGAL:
        text_add(text, "illegal instruction ");
        text_add_address(text, value);
        text_add(text, " at ");
        text_add_address(text, pc);
        return;
    case CAUSE_LOAD_FAULT:
    case CAUSE_STORE_FAULT:
        memory_fault(text, cause == CAUSE_STORE_FAULT, value, pc);
        return;
    default: /* misaligned loads and stores: QEMU does them; kept for another hart */
        text_format(text, "exception (cause %U), pc ", (uint64_t)cause);
        text_add_address(text, pc);
    }
}

/* The call is over: no watchdog for the kernel, and back to where the kernel called it. */
static _Noreturn void end_call(bool faulted, int32_t status)
{
    board_alarm_cancel();
    if (faulted) {
        module_call_abort();
    }
    returned = status;
    module_call_jump(returned_to);
}

void trap_from_module(uint32_t *frame)
{
    const uint32_t cause = CSR_READ(mcause);
    const uint32_t pc = CSR_READ(mepc);
    const uint32_t value = CSR_READ(mtval);
    char buffer[FAULT_TEXT];
    struct text text;

    if (cause == CAUSE_USER_ECALL) {
        frame[REG_A0] = (uint32_t)kernel_service(frame[REG_A7], frame[REG_A0], frame[REG_A1],
                                                 frame[REG_A2], frame[REG_A3]);
        if (!kernel_service_faulted()) {
            __asm__ volatile("csrw mepc, %0" : : "r"(pc + 4u));
            return; /* the module goes on after its ecall */
        }
        end_call(true, 0); /* the service said why */
    }
    if (cause == CAUSE_FETCH_FAULT && pc == GUEST_RETURN) {
        end_call(false, (int32_t)frame[REG_A0]);
    }
    if (cause == CAUSE_TIMER && ++ticks < WATCHDOG_TICKS) {
        board_alarm_in(WATCHDOG_TICK_US);
        return; /* a tick of the budget: the module goes on where it was interrupted */
    }
    text_start(&text, buffer, sizeof buffer);
    describe_fault(&text, cause, pc, value);
    kernel_fault(buffer);
    end_call(true, 0);
}
