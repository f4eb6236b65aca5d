/*
 * node_harness.c - the host harness with the kernel and the control requests linked in: the
 * node's whole request path (control.c, setting.c, ports.c, watch.c, the kernel) under
 * AddressSanitizer and UndefinedBehaviorSanitizer, fed hostile requests by
 * tests/firmware/test_control_fuzz.py.
 *
 * Module code cannot run on the host, so at each boot the harness registers one module made of
 * C fakes (firmware/kernel/tests/fake_module.h), as the kernel's own host tests do: `gain`,
 * y = k * x, the Python node's gain's ports. Its image sits in the last module sector of the
 * flash, which the node's allocator gives out last: the harness installs nothing else there.
 * Between messages the harness does what the board's loop does: due jobs run and a watch pushes
 * its REPORTs (the clock moves only by the STX T directive).
 */
#include "../board/board.h"
#include "../control/watch.h"
#include "../kernel/abi.h"
#include "../kernel/guest_memory.h"
#include "../kernel/kernel.h"
#include "../kernel/module_call.h"
#include "../kernel/tests/fake_module.h"
#include "../loader/flash_layout.h"
#include "../main/runtime.h"
#include "../rv32/trap.h"
#include "harness.h"

#include <stdio.h>
#include <stdlib.h>

enum { X, Y, K };
static const struct fake_port GAIN_PORTS[] = {
    {"x", DIRECTION_IN, KIND_SCALAR, 4, 1, 1},
    {"y", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1},
    {"k", DIRECTION_CONST, KIND_SCALAR, 4, 1, 1},
};
#define BIT(method) (1u << (method))

static uint32_t gain_base; /* where the fake gain's image is linked: the last module sector */

/* module_call's trap handler for an ecall, as the board's: a refused service ends the call. */
static int32_t ecall(uint32_t number, uint32_t a0, uint32_t a1, uint32_t a2, uint32_t a3)
{
    const int32_t result = kernel_service(number, a0, a1, a2, a3);
    if (kernel_service_faulted()) {
        module_call_abort();
    }
    return result;
}

static uint32_t port_address(uint32_t context, uint32_t port)
{
    return guest_read32(context + 4 + 4 * port);
}

static int32_t gain_init(uint32_t argument)
{
    (void)argument;
    return ecall(SERVICE_REGISTER, gain_base + FAKE_DESCRIPTOR, 0, 0, 0);
}

static int32_t gain_on(uint32_t context)
{
    return guest_read32(port_address(context, K)) == 0 ? STATUS_ERR_INVALID : 0;
}

static int32_t gain_cycle(uint32_t context)
{
    const uint32_t k = guest_read32(port_address(context, K));
    guest_write32(port_address(context, Y), k * guest_read32(port_address(context, X)));
    return 0;
}

/* The fake gain's image, programmed once into the erased flash (a restart finds it there). */
static void program_gain(void)
{
    static uint8_t image[FAKE_IMAGE_SIZE];
    const uint32_t offset = (flash_module_sectors() - 1) * flash_sector_size();
    gain_base = board_flash_base() + offset;
    fake_module_image(image, gain_base, "gain", 0, GAIN_PORTS, 3,
                      BIT(METHOD_ON) | BIT(METHOD_CYCLE));
    for (uint32_t at = 0; at < sizeof image; at += FLASH_BLOCK) {
        if (!board_flash_program(offset + at, image + at, FLASH_BLOCK)) {
            return; /* programmed at an earlier boot */
        }
    }
}

/* Module code is C here: nothing to guard (trap.c is the QEMU board's). */
void trap_init(void) {}

void harness_start(void)
{
    uint32_t slot;
    runtime_init();
    program_gain();
    module_call_forget_fakes();
    module_call_fake(gain_base, gain_init);
    module_call_fake(fake_module_method(gain_base, METHOD_ON), gain_on);
    module_call_fake(fake_module_method(gain_base, METHOD_CYCLE), gain_cycle);
    if (kernel_register_module(gain_base, FAKE_IMAGE_SIZE, gain_base, true, &slot) != 0 ||
        kernel_admit(slot, 100000u) != 0) {
        fprintf(stderr, "node harness: the fake gain was refused\n");
        exit(2);
    }
}

void harness_step(void (*send)(const char *bytes, size_t length))
{
    runtime_step();
    watch_push(send);
}
