/*
 * The node CPU's block hook, in C: it counts guest instructions exactly at Unicorn's speed.
 *
 * Unicorn calls a UC_HOOK_BLOCK hook as each translated block starts. Counting there from Python
 * costs a Python call per block (about 0.5 us: 5-6 M instructions/s in a tight loop), and
 * Unicorn's own budget (`count=` of uc_emu_start) adds a hook per instruction and stops block
 * chaining (about 250 M/s). This hook runs inside Unicorn's generated code as a plain C call, so
 * a tight loop counted exactly keeps about 0.6 of Unicorn's speed with no hook at all
 * (benchmarks/scheduler.py).
 *
 * It needs no Unicorn header or library: the engine is opaque here and `stop` is uc_emu_stop,
 * whose address the Python side (firmware_sim/core/block_counter.py) passes in. Stopping from a block
 * hook stops before the block runs (Unicorn checks for a stop request right after the hook), so
 * the count stays exact. The layout of `struct block_counter` is mirrored by a ctypes Structure in
 * firmware_sim/core/block_counter.py: change both together.
 */
#include <stdint.h>

enum block_counter_stop {
    BLOCK_COUNTER_RAN = 0,     /* every block entered was counted */
    BLOCK_COUNTER_REFUSED = 1, /* a block outside the code range, or not 4-byte aligned */
    BLOCK_COUNTER_BUDGET = 2,  /* the next block would have run past the budget */
};

struct block_counter {
    uint64_t count;       /* instructions of the blocks entered since the call began */
    uint64_t budget;      /* the most `count` may reach in this call */
    uint64_t code_start;  /* the call may fetch instructions in [code_start, code_end) */
    uint64_t code_end;
    uint64_t block_start; /* the latest block entered, or the one refused */
    uint64_t block_end;
    void (*stop)(void *engine);
    uint32_t stopped;     /* an enum block_counter_stop */
};

enum { INSTRUCTION_SIZE = 4 }; /* RV32IM without the C extension */

void block_counter_hook(void *engine, uint64_t address, uint32_t size, void *data)
{
    struct block_counter *counter = data;
    uint64_t end = address + size;
    uint64_t instructions = size / INSTRUCTION_SIZE;

    counter->block_start = address;
    counter->block_end = end;
    if (((address | size) % INSTRUCTION_SIZE) != 0 || address < counter->code_start
        || end > counter->code_end) {
        counter->stopped = BLOCK_COUNTER_REFUSED;
        counter->stop(engine);
        return;
    }
    if (counter->count + instructions > counter->budget) {
        counter->stopped = BLOCK_COUNTER_BUDGET;
        counter->stop(engine);
        return;
    }
    counter->count += instructions;
}
