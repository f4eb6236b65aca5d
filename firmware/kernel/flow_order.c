/* flow_order.c - each PBO's rank in the ties of a release (pbort/flow_order.py): after every
 * PBO that feeds one of its inputs; among the PBOs free to go, the one registered first; in a
 * loop, where none of its PBOs is free, the loop's PBO registered first. A chain registered
 * against its flow, or a filter ReFrESH inserts into a running pipeline, then costs no period
 * of latency per link. */
#include "kernel_internal.h"

/* Whether every PBO that feeds `pbo` (itself aside) has its rank already. */
static bool free_to_go(const struct pbo *pbo, const bool *ranked)
{
    for (uint32_t port = 0; port < ABI_MAX_PORTS; port++) {
        uint32_t out;
        const struct pbo *source = pbo_source(pbo, port, &out);
        if (source != 0 && source != pbo && !ranked[kernel_slot_of(source)]) {
            return false;
        }
    }
    return true;
}

/* The admitted PBO without a rank registered first: among those free to go when `free`. */
static struct pbo *first_left(const bool *ranked, bool free)
{
    struct pbo *first = 0;
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        struct pbo *pbo = &kernel.pbos[i];
        if (!kernel_admitted(pbo) || ranked[i] || (free && !free_to_go(pbo, ranked))) {
            continue;
        }
        if (first == 0 || pbo->serial < first->serial) {
            first = pbo;
        }
    }
    return first;
}

void kernel_reorder(void)
{
    bool ranked[KERNEL_MAX_PBOS] = {false};
    for (uint8_t rank = 0; rank < KERNEL_MAX_PBOS; rank++) {
        struct pbo *next = first_left(ranked, true);
        if (next == 0) {
            next = first_left(ranked, false);
        }
        if (next == 0) {
            return;
        }
        next->flow = rank;
        ranked[kernel_slot_of(next)] = true;
    }
}
