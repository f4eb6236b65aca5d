/*
 * capacities.h - the sizes of the node's tables that a build may choose: the firmware has no
 * heap, so each is fixed when it compiles and takes its RAM for good. The defaults are the
 * Python node's (the conformance suite's node, `make firmware`); a board with less RAM gives
 * its own values in a header the build puts before every source (`-include`,
 * FIRMWARE_CAPACITIES in firmware/firmware.mk), as capacities_32k.h does, and keeps the
 * defaults of those it does not give. Each says what running out means; the RAM each takes is
 * in docs/firmware.md (Size). The other sizes are the protocol's or the flash layout's, the same
 * on every node, and stay where they are used.
 */
#ifndef FIRMWARE_CAPACITIES_H
#define FIRMWARE_CAPACITIES_H

/* Characters of a PBO's last failure kept (PS's last_failure), the fault text included: a
 * longer one is cut there. Once in each PBO, and on the stack of a method call. */
#ifndef FAILURE_TEXT
#define FAILURE_TEXT 256u
#endif

/* Bytes of module log lines kept, for all PBOs together (kernel/module_log.h): the oldest lines
 * are dropped first, so a smaller log reaches less far back. */
#ifndef MODULE_LOG_BYTES
#define MODULE_LOG_BYTES 1536u
#endif

/* Transfers open at once; BEGIN refuses one more, saying "N transfers are open". 664 bytes
 * each: a 256-byte block buffer and its relocation words. */
#ifndef MAX_TRANSFERS
#define MAX_TRANSFERS 4u
#endif

/* COMMITs whose answers are remembered: a COMMIT sent again comes right after its lost ACK,
 * before its sender's next transfer, so 16 leave room for several hosts sending at once (the
 * Python node keeps 64; 28 bytes each). */
#ifndef REMEMBERED_COMMITS
#define REMEMBERED_COMMITS 16u
#endif

/* Bytes of the answers to changing control requests kept to be given again
 * (protocol/answer_memory.h); an answer longer than a quarter of them is not kept, and a host
 * that lost it and asks again has the request done again. */
#ifndef ANSWER_MEMORY_BYTES
#define ANSWER_MEMORY_BYTES 1024u
#endif

/* Ports one WATCH reports (READ takes up to 32, control.py's MAX_PORTS, whatever this is);
 * a WATCH of more is refused, saying "expected at most N ports, got more". 30 bytes each. */
#ifndef WATCH_PORTS_MAX
#define WATCH_PORTS_MAX 32u
#endif

#endif /* FIRMWARE_CAPACITIES_H */
