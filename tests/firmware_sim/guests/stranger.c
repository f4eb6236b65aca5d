/*
 * stranger: a module whose descriptor claims ABI version 99, which no node speaks. Its init
 * subroutine calls REGISTER, the node refuses, and the node must stay exactly as it was.
 */
#include "pbo_module.h"

static int32_t stranger_cycle(struct pbo_context *ctx)
{
    (void)ctx;
    return PBO_OK;
}

static const struct pbo_descriptor stranger_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = 99,
    .name = "stranger",
    .cycle = stranger_cycle,
};

PBO_MODULE(stranger_descriptor)
