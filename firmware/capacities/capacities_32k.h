/*
 * capacities_32k.h - the node's capacities on an MCU with 32 KiB of SRAM (a GD32VF103CB, say:
 * RV32IMAC, 128 KiB of flash): the firmware's RAM besides module areas within 16 KiB, which
 * leaves the other half to the modules' SRAM, task window and stack. `make firmware-32k` builds
 * the QEMU board with them (build/firmware/32k/node.elf), where tests/firmware/test_capacities.py
 * runs a module and meets each smaller limit. What each capacity means: capacities.h.
 */
#define FAILURE_TEXT 160u        /* a fault's text and the module's words, cut past that */
#define MODULE_LOG_BYTES 768u    /* about 12 lines of 60 characters */
#define MAX_TRANSFERS 2u         /* a host sends one module at a time */
#define REMEMBERED_COMMITS 8u
#define ANSWER_MEMORY_BYTES 512u /* 5 ACKs at least; no answer line of more than 122 bytes */
#define WATCH_PORTS_MAX 16u
