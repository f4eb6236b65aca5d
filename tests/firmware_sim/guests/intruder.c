/*
 * intruder: a test module that behaves (y = x + 1) for three cycles and then tries, as its
 * configuration constant `mode` says, to change the CPU for every module after it or to leave
 * the code it was given. The node must stop that call with a fault naming the module and keep
 * every other PBO running.
 *
 * mode 1: Sv32 paging (satp) for its loads and stores (mstatus.MPRV, MPP = S)
 * mode 2: a locked PMP entry that denies all memory, to M-mode too
 * mode 3: ebreak      mode 4: wfi      mode 5: mret      mode 6: sret
 * mode 7: fence.i (harmless: the cycle succeeds)
 * mode 8: call the address in the constant `target` (another module's code, the kernel page)
 * mode 9: write a distinct value into every register but ra, sp and a0, and return
 */
#include "pbo_module.h"

enum { PORT_X, PORT_Y, PORT_MODE, PORT_TARGET, PORT_COUNT };

struct intruder_state {
    int32_t cycles;
};

/* Writes a distinct value into every register but ra, sp and a0, and returns PBO_OK: the
 * callee-saved ones too, as no well-behaved module would. */
__asm__(".section .text.taint\n"
        "taint:\n"
        "li gp, 0x7A100003\nli tp, 0x7A100004\nli t0, 0x7A100005\nli t1, 0x7A100006\n"
        "li t2, 0x7A100007\nli s0, 0x7A100008\nli s1, 0x7A100009\nli a1, 0x7A100011\n"
        "li a2, 0x7A100012\nli a3, 0x7A100013\nli a4, 0x7A100014\nli a5, 0x7A100015\n"
        "li a6, 0x7A100016\nli a7, 0x7A100017\nli s2, 0x7A100018\nli s3, 0x7A100019\n"
        "li s4, 0x7A100020\nli s5, 0x7A100021\nli s6, 0x7A100022\nli s7, 0x7A100023\n"
        "li s8, 0x7A100024\nli s9, 0x7A100025\nli s10, 0x7A100026\nli s11, 0x7A100027\n"
        "li t3, 0x7A100028\nli t4, 0x7A100029\nli t5, 0x7A100030\nli t6, 0x7A100031\n"
        "li a0, 0\nret\n");

int32_t taint(void);

static int32_t misbehave(int32_t mode, uint32_t target, struct pbo_context *ctx)
{
    switch (mode) {
    case 1: /* csrw satp, t0 (Sv32, root table at 0); csrs mstatus, t1 (MPRV, MPP = S) */
        __asm__ volatile("li t0, 0x80000000\n.word 0x18029073\n"
                         "li t1, 0x20800\n.word 0x30032073" ::: "t0", "t1");
        break;
    case 2: /* csrw pmpaddr0, t0 (all memory); csrw pmpcfg0, t0 (locked, NAPOT, no access) */
        __asm__ volatile("li t0, -1\n.word 0x3B029073\nli t0, 0x98\n.word 0x3A029073" ::: "t0");
        break;
    case 3:
        __asm__ volatile("ebreak");
        break;
    case 4:
        __asm__ volatile("wfi");
        break;
    case 5:
        __asm__ volatile("mret");
        break;
    case 6:
        __asm__ volatile("sret");
        break;
    case 7:
        __asm__ volatile(".word 0x0000100f" ::: "memory"); /* fence.i */
        break;
    case 8:
        return ((int32_t(*)(struct pbo_context *))(uintptr_t)target)(ctx);
    case 9:
        return taint();
    default:
        break;
    }
    return PBO_OK;
}

static int32_t intruder_cycle(struct pbo_context *ctx)
{
    struct intruder_state *s = ctx->state;
    const int32_t mode = *(const int32_t *)ctx->ports[PORT_MODE];

    s->cycles++;
    *(int32_t *)ctx->ports[PORT_Y] = *(const int32_t *)ctx->ports[PORT_X] + 1;
    if (s->cycles > 3) {
        return misbehave(mode, *(const uint32_t *)ctx->ports[PORT_TARGET], ctx);
    }
    return PBO_OK;
}

/* Cleared, it behaves for three more cycles. */
static int32_t intruder_clear(struct pbo_context *ctx)
{
    struct intruder_state *s = ctx->state;
    s->cycles = 0;
    return PBO_OK;
}

static const struct pbo_descriptor intruder_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "intruder",
    .state_size = sizeof(struct intruder_state),
    .ports = {
        [PORT_X] = {"x", PBO_PORT_IN, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_Y] = {"y", PBO_PORT_OUT, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_MODE] = {"mode", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_TARGET] = {"target", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
    },
    .cycle = intruder_cycle,
    .clear = intruder_clear,
};

PBO_MODULE(intruder_descriptor)
