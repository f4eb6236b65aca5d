# The node firmware's build (docs/firmware.md), included by the top Makefile.
#
#   make firmware        build/firmware/node.elf for QEMU virt (RV32IM, no libc), with the
#                        Python node's capacities (firmware/capacities/capacities.h)
#   make firmware-32k    build/firmware/32k/node.elf: the same board with the capacities of an
#                        MCU with 32 KiB of SRAM (firmware/capacities/capacities_32k.h)
#   make firmware-host   build/firmware/host/receiver_harness: the same loader and receiver for
#                        the host, with a RAM flash, under ASan and UBSan (tests/firmware);
#                        and build/firmware/host/node_harness: the same with the kernel and the
#                        control requests in, a fake module registered (test_control_fuzz.py)
#
# A board is one file: FIRMWARE_BOARD selects it. The sizes of the node's tables are the
# defaults of firmware/capacities/capacities.h, or those of FIRMWARE_CAPACITIES, a header put
# before every source. The folders are the firmware's parts
# (docs/firmware.md): rv32/ the hart (reset, the trap vector, module code in user mode), main/
# the node put together (boot, the polling loop, the kernel on this firmware), loader/ modules
# into flash and the directory, protocol/ the transfer protocol's two modes, control/ the
# control requests on the kernel, kernel/ the PBO/RT kernel, lib/ CRCs and memcpy, capacities/
# the sizes of the node's tables. The kernel
# implements the seam of firmware/loader/modules.h (node_modules.c); firmware/control/control.c
# answers the control requests on it.

FIRMWARE_CC ?= riscv64-unknown-elf-gcc
# The objects compile through ccache when it is installed (a clean clone's make test builds the
# firmware twice). Only here: benchmarks/firmware_stack.py compiles with FIRMWARE_CC alone, for
# ccache restores an object from its cache without the -fcallgraph-info file the tool reads.
FIRMWARE_CACHE ?= $(shell command -v ccache)
FIRMWARE_BOARD ?= firmware/board/qemu_virt.c
FIRMWARE_CAPACITIES ?=
FIRMWARE_CAPACITIES_32K := firmware/capacities/capacities_32k.h
FIRMWARE_PARTS := rv32 main loader protocol control kernel lib
FIRMWARE_KERNEL_SOURCES ?= $(wildcard firmware/kernel/*.c)
FIRMWARE_OUT ?= $(BUILD)/firmware
FIRMWARE_ELF := $(FIRMWARE_OUT)/node.elf
FIRMWARE_PART_SOURCES := $(foreach part,$(filter-out kernel,$(FIRMWARE_PARTS)),\
	$(wildcard firmware/$(part)/*.c))
FIRMWARE_SOURCES := $(FIRMWARE_PART_SOURCES) firmware/rv32/start.S $(FIRMWARE_BOARD) \
	$(FIRMWARE_KERNEL_SOURCES)
FIRMWARE_HEADERS := $(foreach part,board capacities $(FIRMWARE_PARTS),\
	$(wildcard firmware/$(part)/*.h))
FIRMWARE_ARCH := -march=rv32imc_zicsr_zifencei -mabi=ilp32 # C for the firmware only: modules stay RV32IM
FIRMWARE_CFLAGS := $(FIRMWARE_ARCH) -nostdlib -ffreestanding -Os -msave-restore -g -std=c11 -Wall -Wextra \
	-Werror -ffunction-sections -fdata-sections -fno-common \
	$(if $(FIRMWARE_CAPACITIES),-include $(FIRMWARE_CAPACITIES))
FIRMWARE_LDFLAGS := -T firmware/rv32/link.ld -Wl,--gc-sections -Wl,--no-warn-rwx-segments \
	-Wl,-Map=$(FIRMWARE_OUT)/node.map

HOST_CC ?= gcc
FIRMWARE_HOST := $(FIRMWARE_OUT)/host/receiver_harness
# The files that join the kernel (control requests, module code in user mode) stay out of the
# host harness, which tests the loader and the receiver with the weak defaults of the seams.
FIRMWARE_ON_KERNEL := $(wildcard firmware/main/*.c firmware/rv32/*.c firmware/control/*.c)
FIRMWARE_HOST_SOURCES := $(wildcard firmware/loader/*.c firmware/protocol/*.c firmware/lib/*.c) \
	firmware/control/control_default.c firmware/kernel/text.c \
	firmware/host/host_board.c firmware/host/receiver_harness.c
FIRMWARE_NODE_HOST := $(FIRMWARE_OUT)/host/node_harness
# The node harness: everything but the QEMU board's main loop and trap handler (module code is C
# fakes on the host), with the kernel.
FIRMWARE_NODE_HOST_SOURCES := $(filter-out firmware/main/main.c firmware/rv32/trap.c,\
	$(FIRMWARE_PART_SOURCES)) $(FIRMWARE_KERNEL_SOURCES) firmware/kernel/tests/fake_module.c \
	firmware/host/host_board.c firmware/host/receiver_harness.c firmware/host/node_harness.c
FIRMWARE_HOST_CFLAGS := -DFIRMWARE_HOST -std=c11 -g -O1 -Wall -Wextra -Werror \
	-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer

.PHONY: firmware firmware-32k firmware-host

firmware: $(FIRMWARE_ELF)
# The other capacities build apart, in a folder of their own.
firmware-32k:
	$(MAKE) --no-print-directory firmware FIRMWARE_OUT=$(BUILD)/firmware/32k \
		FIRMWARE_CAPACITIES=$(FIRMWARE_CAPACITIES_32K)
firmware-host: $(FIRMWARE_HOST) $(FIRMWARE_NODE_HOST)

# One object a source, named after it (build/firmware/obj/firmware/PART/FILE.o), so that the
# link map says which part each byte of the firmware comes from (benchmarks/firmware.py).
FIRMWARE_OBJECTS := $(patsubst %,$(FIRMWARE_OUT)/obj/%.o,$(FIRMWARE_SOURCES))

$(FIRMWARE_OUT)/obj/%.o: % $(FIRMWARE_HEADERS) firmware/firmware.mk
	@mkdir -p $(dir $@)
	$(FIRMWARE_CACHE) $(FIRMWARE_CC) $(FIRMWARE_CFLAGS) -c -o $@ $<

# libgcc of the rv32im/ilp32 multilib: the 64-bit divisions of the clock and of decimal output.
$(FIRMWARE_ELF): $(FIRMWARE_OBJECTS) firmware/rv32/link.ld
	$(FIRMWARE_CC) $(FIRMWARE_CFLAGS) $(FIRMWARE_LDFLAGS) -o $@ $(FIRMWARE_OBJECTS) \
		$$($(FIRMWARE_CC) -march=rv32im -mabi=ilp32 -print-libgcc-file-name)
	riscv64-unknown-elf-size $@

# The host harnesses share their objects (build/firmware/host/obj/firmware/PART/FILE.o): the same
# sources with the same flags.
host_objects = $(patsubst %,$(FIRMWARE_OUT)/host/obj/%.o,$(1))

$(FIRMWARE_OUT)/host/obj/%.o: % $(FIRMWARE_HEADERS) $(wildcard firmware/host/*.h) \
		firmware/kernel/tests/fake_module.h firmware/firmware.mk
	@mkdir -p $(dir $@)
	$(FIRMWARE_CACHE) $(HOST_CC) $(FIRMWARE_HOST_CFLAGS) -c -o $@ $<

$(FIRMWARE_HOST): $(call host_objects,$(FIRMWARE_HOST_SOURCES))
	$(HOST_CC) $(FIRMWARE_HOST_CFLAGS) -o $@ $^

$(FIRMWARE_NODE_HOST): $(call host_objects,$(FIRMWARE_NODE_HOST_SOURCES))
	$(HOST_CC) $(FIRMWARE_HOST_CFLAGS) -o $@ $^
