/*
 * host_board.c - a board for the host: the firmware's loader and receiver, unchanged, on a flash
 * in a RAM array, so they can run under AddressSanitizer and UndefinedBehaviorSanitizer and be
 * fed hostile input by the hypothesis tests (tests/firmware/test_host_fuzz.py), and with the
 * kernel and the control requests in the node harness (tests/firmware/test_control_fuzz.py).
 *
 * The flash behaves as the QEMU board's does where it matters to the code above it: 256 KiB
 * erase sectors would make each erase of the fuzz slow, so its sectors are 4 KiB, and it keeps
 * the rules (sector erase to 0xFF, programming refused on words not erased).
 */
#include "../board/board.h"
#include "host_board.h"

#include <stdio.h>
#include <string.h>

#define HOST_FLASH_BASE 0x22000000u
#define HOST_FLASH_SIZE (1024u * 1024u)
#define HOST_SECTOR (4u * 1024u)

static uint8_t flash[HOST_FLASH_SIZE];
static uint64_t clock_us;
static uint32_t cut_after; /* 0: no cut planned */
static int power_off;

void board_init(void)
{
    static int erased;
    if (!erased) {
        memset(flash, 0xFF, sizeof flash);
        erased = 1;
    }
}

const char *board_name(void) { return "host"; }

bool board_uart_read(uint8_t *byte)
{
    int c = getchar(); /* blocks: on the host the stream's end is the end of the run */
    if (c == EOF) {
        return false;
    }
    *byte = (uint8_t)c;
    return true;
}

void board_uart_write(const uint8_t *bytes, size_t length)
{
    fwrite(bytes, 1, length, stdout);
    fflush(stdout);
}

uint64_t board_time_us(void) { return clock_us; }
void host_board_advance(uint64_t microseconds) { clock_us += microseconds; }

uint32_t board_flash_base(void) { return HOST_FLASH_BASE; }
void *board_flash_memory(void) { return flash; }
uint32_t board_flash_size(void) { return HOST_FLASH_SIZE; }
uint32_t board_flash_sector_size(void) { return HOST_SECTOR; }

/* No code runs here: every sector may be programmed again. */
bool board_code_reusable(void) { return true; }

/* Modules that arrive start, as on a board started without --no-start. */
bool board_start_modules(void) { return true; }

/* The QEMU board's module regions (firmware/rv32/link.ld) at its addresses, in arrays: the
 * kernel of the node harness keeps its PBOs' areas there (module code is C on the host). */
void board_module_memory(struct board_region *sram, struct board_region *window,
                         struct board_region *stack)
{
    static uint8_t sram_memory[128u << 10], window_memory[64u << 10], stack_memory[8u << 10];
    *sram = (struct board_region){0x80040000u, sizeof sram_memory, sram_memory};
    *window = (struct board_region){0x80060000u, sizeof window_memory, window_memory};
    *stack = (struct board_region){0x80070000u, sizeof stack_memory, stack_memory};
}

void board_flash_read(uint32_t offset, void *destination, size_t length)
{
    if (offset > HOST_FLASH_SIZE || length > HOST_FLASH_SIZE - offset) {
        fprintf(stderr, "host board: flash read of %zu bytes at 0x%08X outside the flash\n",
                length, offset);
        __builtin_trap();
    }
    memcpy(destination, flash + offset, length);
}

void host_board_cut_power_after(uint32_t count) { cut_after = count; }

int host_board_cut_pending(void) { return cut_after != 0; }

void host_board_restore_power(void)
{
    power_off = 0;
    cut_after = 0;
}

/* Count one flash operation: 0 when it runs, 1 when it is the one cut, -1 when off. */
static int power_state(void)
{
    if (power_off) {
        return -1;
    }
    if (cut_after && --cut_after == 0) {
        power_off = 1;
        return 1;
    }
    return 0;
}

bool board_flash_erase_sector(uint32_t offset)
{
    if (offset % HOST_SECTOR || offset >= HOST_FLASH_SIZE) {
        return false;
    }
    int state = power_state();
    if (state < 0) {
        return false;
    }
    memset(flash + offset, 0xFF, state ? HOST_SECTOR / 2 : HOST_SECTOR);
    return state == 0;
}

bool board_flash_program(uint32_t offset, const void *source, size_t length)
{
    if (offset % 4 || length % 4 || length == 0 || length > BOARD_BLOCK_SIZE ||
        offset / BOARD_BLOCK_SIZE != (offset + length - 1) / BOARD_BLOCK_SIZE ||
        offset + length > HOST_FLASH_SIZE) {
        return false;
    }
    for (size_t i = 0; i < length; i++) {
        if (flash[offset + i] != 0xFF) {
            return false; /* a word programmed twice: the layer above has a bug */
        }
    }
    int state = power_state();
    if (state < 0) {
        return false;
    }
    memcpy(flash + offset, source, state ? length / 8 * 4 : length);
    return state == 0;
}

void host_board_load(const char *path)
{
    FILE *file = fopen(path, "rb");
    if (file) {
        size_t got = fread(flash, 1, sizeof flash, file);
        (void)got;
        fclose(file);
    }
}

void host_board_save(const char *path)
{
    FILE *file = fopen(path, "wb");
    if (file) {
        fwrite(flash, 1, sizeof flash, file);
        fclose(file);
    }
}
