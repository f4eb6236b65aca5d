/*
 * qemu_virt.c - the board file of QEMU's `virt` machine (qemu-system-riscv32 -M virt).
 *
 * The only file that knows the machine: an ns16550a UART at 0x10000000 (QEMU puts it on a pty
 * with -serial pty), the second CFI flash bank at 0x22000000 (-drive if=pflash,unit=1 keeps it in
 * a file) driven with its real Intel command set, and the CLINT's mtime at 10 MHz. A real board
 * replaces this file and nothing else (docs/firmware.md).
 */
#include "board.h"

/* ns16550a registers (byte wide, QEMU maps them one byte apart). */
#define UART_BASE 0x10000000u
#define UART_RBR 0u /* receive buffer (read) */
#define UART_THR 0u /* transmit holding (write) */
#define UART_FCR 2u /* FIFO control */
#define UART_LCR 3u /* line control */
#define UART_LSR 5u /* line status */
#define UART_IER 1u /* interrupt enable */
#define LSR_DATA_READY 0x01u
#define LSR_THR_EMPTY 0x20u
#define IER_RECEIVED 0x01u /* the line is raised while received data waits */
#define UART_DLL 0u /* divisor latch, low byte (while LCR_DIVISOR_LATCH) */
#define UART_DLM 1u /* divisor latch, high byte */
#define LCR_DIVISOR_LATCH 0x80u
/* FIFOs on and cleared, the receive interrupt at 14 bytes (or 4 characters' time after the
 * last byte, when fewer wait). QEMU takes from the socket behind the UART only what fits
 * below the trigger: at 1 byte, it took one byte per turn of its main loop, about 45 us of
 * host CPU each; a 600-byte request cost QEMU 28 ms of CPU, at 14 bytes 6 ms. */
#define FCR_FIFOS_CLEARED_TRIGGER_14 0xC7u

/* PLIC: the UART is source 10; context 0 is hart 0 in machine mode. */
#define PLIC_BASE 0x0C000000u
#define PLIC_UART_SOURCE 10u
#define PLIC_PRIORITY(source) (PLIC_BASE + 4u * (source))
#define PLIC_ENABLE 0x0C002000u
#define PLIC_THRESHOLD 0x0C200000u
#define PLIC_CLAIM 0x0C200004u
#define MIE_MEIE 0x800u

/* CFI flash, bank 1 (unit=1): 32 MiB of 256 KiB sectors, 32-bit bus (two x16 chips). */
#define FLASH_BASE 0x22000000u
#define FLASH_SIZE (32u * 1024u * 1024u)
#define FLASH_SECTOR (256u * 1024u)
#define CFI_READ_ARRAY 0x00FF00FFu
#define CFI_CLEAR_STATUS 0x00500050u
#define CFI_BLOCK_ERASE 0x00200020u
#define CFI_ERASE_CONFIRM 0x00D000D0u
#define CFI_WORD_PROGRAM 0x00400040u
#define CFI_STATUS_READY 0x80u
#define CFI_STATUS_ERRORS 0x3Au /* erase, program, voltage and lock errors */
#define CFI_POLLS 1000000u      /* a bound: a chip that never gets ready is an error, not a hang */

/* CLINT: mtime counts at 10 MHz on virt. */
#define CLINT_MTIME_LOW 0x0200BFF8u
#define CLINT_MTIME_HIGH 0x0200BFFCu
#define MTIME_PER_US 10u /* divide_by_ten below relies on it */
#define CLINT_MTIMECMP_LOW 0x02004000u /* hart 0 */
#define CLINT_MTIMECMP_HIGH 0x02004004u
#define MIE_MTIE 0x80u

/* What `firmware-sim qemu --no-start` writes at __boot_options (QEMU's generic loader, before
 * the hart starts); RAM is zero otherwise. */
#define BOOT_NO_START 0x4E4F5354u /* "NOST" */

extern char __module_sram[], __module_sram_size[]; /* the module regions, link.ld */
extern char __task_window[], __task_window_size[];
extern char __module_stack[], __module_stack_size[];
extern volatile uint32_t __boot_options[];

static volatile uint8_t *uart(uint32_t reg)
{
    return (volatile uint8_t *)(UART_BASE + reg);
}

static volatile uint32_t *flash_word(uint32_t offset)
{
    return (volatile uint32_t *)(FLASH_BASE + offset);
}

static volatile uint32_t *plic(uint32_t address)
{
    return (volatile uint32_t *)address;
}

void board_init(void)
{
    /* The fastest rate (divisor 1), for the shortest timeout of a FIFO holding fewer bytes than
     * its trigger: at QEMU's reset rate it added 1.2 ms to a PING after a pause (2.3 ms). */
    *uart(UART_LCR) = LCR_DIVISOR_LATCH;
    *uart(UART_DLL) = 1;
    *uart(UART_DLM) = 0;
    *uart(UART_LCR) = 0x03; /* 8N1 */
    *uart(UART_FCR) = FCR_FIFOS_CLEARED_TRIGGER_14;
    *plic(PLIC_PRIORITY(PLIC_UART_SOURCE)) = 1;
    *plic(PLIC_ENABLE) = 1u << PLIC_UART_SOURCE;
    *plic(PLIC_THRESHOLD) = 0;
    *flash_word(0) = CFI_READ_ARRAY;
}

const char *board_name(void)
{
    return "qemu-virt";
}

bool board_uart_read(uint8_t *byte)
{
    if (!(*uart(UART_LSR) & LSR_DATA_READY)) {
        return false;
    }
    *byte = *uart(UART_RBR);
    return true;
}

void board_uart_write(const uint8_t *bytes, size_t length)
{
    for (size_t i = 0; i < length; i++) {
        while (!(*uart(UART_LSR) & LSR_THR_EMPTY)) {
        }
        *uart(UART_THR) = bytes[i];
    }
}

/* n / 10 by shifts and adds (Hacker's Delight, divu10): no 64-bit division from libgcc. */
static uint64_t divide_by_ten(uint64_t n)
{
    uint64_t q = (n >> 1) + (n >> 2);
    q += q >> 4;
    q += q >> 8;
    q += q >> 16;
    q += q >> 32;
    q >>= 3;
    uint64_t r = n - q * 10;
    return q + ((r + 6) >> 4);
}

/* The CLINT's 64-bit counter: high, low, high again, so a carry between the halves is seen
 * and the read retried. */
static uint64_t mtime(void)
{
    volatile uint32_t *low = (volatile uint32_t *)CLINT_MTIME_LOW;
    volatile uint32_t *high = (volatile uint32_t *)CLINT_MTIME_HIGH;
    uint32_t before, after, value;
    do {
        before = *high;
        value = *low;
        after = *high;
    } while (before != after);
    return ((uint64_t)after << 32) | value;
}

uint64_t board_time_us(void)
{
    return divide_by_ten(mtime());
}

uint32_t board_flash_base(void)
{
    return FLASH_BASE;
}

void *board_flash_memory(void)
{
    return (void *)(uintptr_t)FLASH_BASE;
}

uint32_t board_flash_size(void)
{
    return FLASH_SIZE;
}

uint32_t board_flash_sector_size(void)
{
    return FLASH_SECTOR;
}

void board_flash_read(uint32_t offset, void *destination, size_t length)
{
    const volatile uint8_t *source = (const volatile uint8_t *)(FLASH_BASE + offset);
    uint8_t *out = destination;
    for (size_t i = 0; i < length; i++) {
        out[i] = source[i];
    }
}

/* Wait for the chip's ready bit; true when it finished without an error bit. The chip is then
 * put back into read-array mode, whatever happened, so the flash reads as memory again. */
static bool cfi_wait(uint32_t offset)
{
    uint32_t status = 0;
    for (uint32_t polls = 0; polls < CFI_POLLS; polls++) {
        status = *flash_word(offset);
        if (status & CFI_STATUS_READY) {
            break;
        }
    }
    bool ok = (status & CFI_STATUS_READY) && !(status & CFI_STATUS_ERRORS);
    if (!ok) {
        *flash_word(offset) = CFI_CLEAR_STATUS;
    }
    *flash_word(offset) = CFI_READ_ARRAY;
    return ok;
}

bool board_flash_erase_sector(uint32_t offset)
{
    if (offset % FLASH_SECTOR || offset >= FLASH_SIZE) {
        return false;
    }
    *flash_word(offset) = CFI_BLOCK_ERASE;
    *flash_word(offset) = CFI_ERASE_CONFIRM;
    return cfi_wait(offset);
}

/* True when every word of the range reads erased. */
static bool words_erased(uint32_t offset, size_t length)
{
    for (size_t i = 0; i < length; i += 4) {
        if (*flash_word(offset + i) != 0xFFFFFFFFu) {
            return false;
        }
    }
    return true;
}

static bool program_word(uint32_t offset, uint32_t value)
{
    if (value == 0xFFFFFFFFu) {
        return true; /* an erased word stays erased: nothing to program */
    }
    *flash_word(offset) = CFI_WORD_PROGRAM;
    *flash_word(offset) = value;
    return cfi_wait(offset);
}

bool board_flash_program(uint32_t offset, const void *source, size_t length)
{
    const uint8_t *bytes = source;
    if (offset % 4 || length % 4 || length == 0 || length > BOARD_BLOCK_SIZE ||
        offset / BOARD_BLOCK_SIZE != (offset + length - 1) / BOARD_BLOCK_SIZE ||
        offset + length > FLASH_SIZE || !words_erased(offset, length)) {
        return false;
    }
    for (size_t i = 0; i < length; i += 4) {
        uint32_t value = (uint32_t)bytes[i] | (uint32_t)bytes[i + 1] << 8 |
                         (uint32_t)bytes[i + 2] << 16 | (uint32_t)bytes[i + 3] << 24;
        if (!program_word(offset + i, value)) {
            return false;
        }
    }
    __asm__ volatile("fence.i" ::: "memory"); /* new code is seen: no-op in QEMU's TCG, below */
    return true;
}

/* QEMU's pflash model (hw/block/pflash_cfi01.c) programs and erases its memory without
 * invalidating the translated blocks of code that ran from it, and fence.i does not flush
 * them: a module programmed where another one ran would run the old one's code. */
bool board_code_reusable(void)
{
    return false;
}

void board_module_memory(struct board_region *sram, struct board_region *window,
                         struct board_region *stack)
{
    *sram = (struct board_region){(uint32_t)__module_sram, (uint32_t)__module_sram_size,
                                  __module_sram};
    *window = (struct board_region){(uint32_t)__task_window, (uint32_t)__task_window_size,
                                    __task_window};
    *stack = (struct board_region){(uint32_t)__module_stack, (uint32_t)__module_stack_size,
                                   __module_stack};
}

static void set_compare(uint64_t when)
{
    /* High word to all ones first: no moment where a half-written compare value is due. */
    volatile uint32_t *low = (volatile uint32_t *)CLINT_MTIMECMP_LOW;
    volatile uint32_t *high = (volatile uint32_t *)CLINT_MTIMECMP_HIGH;
    *high = 0xFFFFFFFFu;
    *low = (uint32_t)when;
    *high = (uint32_t)(when >> 32);
}

/* Take the UART's interrupt from the PLIC if it has one pending, so that the next wait is not
 * ended by the bytes this one woke for. */
static void plic_take(void)
{
    const uint32_t source = *plic(PLIC_CLAIM);
    if (source != 0) {
        *plic(PLIC_CLAIM) = source; /* complete */
    }
}

/* WFI wakes the hart once an interrupt enabled in mie is pending, even with mstatus.MIE clear,
 * so no trap is taken. The UART raises its line only while the hart waits here: module code in
 * user mode would take the external interrupt as a trap, and a line raised at every byte slows
 * QEMU's reception by a third. Bytes already waiting raise it as soon as it is enabled (14 of
 * them, or fewer whose timeout passed; else when it passes). The timer's compare, which the
 * watchdog shares, is put back out of reach before returning. */
void board_idle(uint64_t until_us)
{
    if (board_time_us() >= until_us) {
        return;
    }
    set_compare(until_us * MTIME_PER_US);
    *uart(UART_IER) = IER_RECEIVED;
    __asm__ volatile("csrs mie, %0" : : "r"(MIE_MTIE | MIE_MEIE));
    __asm__ volatile("wfi");
    __asm__ volatile("csrc mie, %0" : : "r"(MIE_MEIE));
    *uart(UART_IER) = 0;
    set_compare(UINT64_MAX);
    plic_take();
}

void board_alarm_in(uint32_t after_us)
{
    set_compare(mtime() + (uint64_t)after_us * MTIME_PER_US);
    __asm__ volatile("csrs mie, %0" : : "r"(MIE_MTIE));
}

void board_alarm_cancel(void)
{
    set_compare(UINT64_MAX);
}

bool board_start_modules(void)
{
    return __boot_options[0] != BOOT_NO_START;
}
