/*
 * board.h - what the node firmware needs of a board, and nothing more.
 *
 * Porting the firmware to another RV32 board is writing one file that implements these
 * functions (firmware/board/qemu_virt.c is the first). Everything above this line, the loader,
 * the flash directory and the protocol, is the same on every board.
 *
 * Three things: a byte stream to the host (the link), the flash the modules live in, and a
 * clock, and a way to sleep until one of the first and last has something. None of them may
 * block the node for long: the UART is polled, and a flash operation returns when the chip says
 * it is done.
 *
 * Flash geometry. The node lays its flash out in 256-byte blocks, as the Python node does (the
 * same directory bytes, docs/node.md), and programs one block at a time. Real NOR flash erases
 * in larger sectors (QEMU virt's CFI flash: 256 KiB), so the board says how large its erase
 * sector is and the layer above (loader/flash_layout.c) never erases a sector that holds anything
 * it must keep. A board whose flash erases single blocks reports a sector of 256 bytes.
 */
#ifndef BOARD_H
#define BOARD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define BOARD_BLOCK_SIZE 256u

/* Set the board up (UART, flash in read mode); called once, first thing in main. */
void board_init(void);

/* A short name for the board, shown in the node's PONG and banner. */
const char *board_name(void);

/* The next byte the host sent, if one is waiting: true and *byte set, or false at once. */
bool board_uart_read(uint8_t *byte);

/* Send `length` bytes to the host (waits only for the UART's transmit register). */
void board_uart_write(const uint8_t *bytes, size_t length);

/* Microseconds since the board started; never goes back. */
uint64_t board_time_us(void);

/* Wait without running the CPU until board_time_us() reaches `until_us` or a byte from the
 * host arrives, whichever comes first (at once when either already has); it may return
 * earlier. An idle node then draws no host CPU on an emulator and little power on a board.
 * Whatever the board enables to wake up must not reach module code as a trap (trap.h). */
void board_idle(uint64_t until_us);

/* Where the flash is mapped (the address modules run from), its size and its erase sector. */
uint32_t board_flash_base(void);
/* Where the firmware reads the flash as memory (it writes it only through the functions
 * below): board_flash_base() itself on a board that maps it, as every RV32 board does; the
 * host's test board keeps it in an array. */
void *board_flash_memory(void);
uint32_t board_flash_size(void);
uint32_t board_flash_sector_size(void);

/* Copy `length` bytes at `offset` from the flash's start into `destination`. */
void board_flash_read(uint32_t offset, void *destination, size_t length);

/* Erase the sector that starts at `offset` (a multiple of the sector size) to 0xFF; false when
 * the chip reports an error. */
bool board_flash_erase_sector(uint32_t offset);

/* Program `length` bytes (1..256, a whole number of 4-byte words) at `offset` (word aligned,
 * inside one block). Every word must be erased (0xFFFFFFFF) before: NOR flash only clears bits,
 * and QEMU's model replaces a word programmed twice, so the board refuses (false) rather than
 * hide a bug of the layer above. False too when the chip reports an error. */
bool board_flash_program(uint32_t offset, const void *source, size_t length);

/* Whether code programmed over flash that held code the CPU ran runs as programmed once
 * board_flash_program returned (which makes the CPU see it: fence.i, or an instruction cache
 * invalidated). False on QEMU virt: its CFI flash model writes the chip's memory without
 * dropping QEMU's translations of the code that ran there, so the old code would run on. The
 * loader then gives a module's sectors out again only after a restart. */
bool board_code_reusable(void);

/* The RAM the kernel gives module code (docs/firmware.md, "Memory map"): SRAM for instance
 * areas, the task window a running instance works in, and the stack module code runs on. Each
 * is a power of two in size and aligned to its size: the trap file guards each with one NAPOT
 * PMP region. */
struct board_region {
    uint32_t base, size;
    void *memory; /* where the firmware reaches it: `base` itself on an RV32 board */
};
void board_module_memory(struct board_region *sram, struct board_region *window,
                         struct board_region *stack);

/* The watchdog of module code: the machine timer interrupt `after_us` from now (it traps only
 * while module code runs in user mode: the firmware keeps mstatus.MIE clear), and its cancel. */
void board_alarm_in(uint32_t after_us);
void board_alarm_cancel(void);

/* False when the one who started the board asked for its modules to be left off when they are
 * installed (`firmware-sim qemu --no-start`), for a host to start them. */
bool board_start_modules(void);

#endif /* BOARD_H */
