/*
 * loader.c - the streaming module loader (loader.h).
 */
#include "loader.h"

#include "../lib/crc.h"

/* The signature area of the one transfer that may hold one at a time: signed modules are sent
 * one after another. */
static struct signature_area signature;
static const struct load_session *signature_owner;

/* The reservation's name as the Python node gives it: 'transfer:0000002A'. */
static void add_owner(struct text *why, const struct load_session *session)
{
    char name[20];
    struct text owner;
    text_start(&owner, name, sizeof name);
    text_add(&owner, "transfer:");
    text_add_hex(&owner, session->tid, 8);
    text_add_repr(why, name, owner.length);
}

static uint32_t session_offset(const struct load_session *session)
{
    return session->extent.first * flash_sector_size();
}

uint32_t loader_load_base(const struct load_session *session)
{
    return flash_base() + session_offset(session);
}

uint32_t loader_received(const struct load_session *session)
{
    return session->programmed_blocks * FLASH_BLOCK + session->buffered;
}

uint32_t loader_programmed(const struct load_session *session)
{
    return session->programmed_blocks * FLASH_BLOCK;
}

static void no_room(const struct load_session *session, uint32_t blocks, struct text *why)
{
    text_format(why, "expected %U free consecutive flash block(s) for ", (uint64_t)blocks);
    add_owner(why, session);
    text_format(why, ", the largest free run is %U",
                (uint64_t)flash_largest_run() * (flash_sector_size() / FLASH_BLOCK));
    uint32_t retired = flash_retired_sectors();
    if (retired) {
        text_format(why, "; %U more held modules that ran, which this board programs again only "
                    "after a restart", (uint64_t)retired * (flash_sector_size() / FLASH_BLOCK));
    }
}

/* The sectors at flash address `address`, which must start a free module sector. */
static bool reserve_at(struct load_session *session, uint32_t address, uint32_t sectors,
                       struct text *why)
{
    uint32_t offset = address - flash_base();
    if (address < flash_base() || offset >= flash_size() || offset % flash_sector_size()) {
        text_format(why, "expected a load address at a flash sector boundary (a multiple of %U "
                    "from %a), got %a", (uint64_t)flash_sector_size(), (uint32_t)flash_base(),
                    (uint32_t)address);
        return false;
    }
    if (!flash_place(flash_sector_of(offset), sectors, &session->extent)) {
        text_add(why, "expected free flash for ");
        add_owner(why, session);
        text_format(why, " at %a, but it is taken or past the module area", (uint32_t)address);
        return false;
    }
    return true;
}

bool loader_begin(struct load_session *session, uint32_t tid, bool sized, uint32_t size, bool at,
                  uint32_t address, struct text *why)
{
    *session = (struct load_session){0};
    session->tid = tid;
    uint32_t blocks = sized ? size / FLASH_BLOCK + (size % FLASH_BLOCK != 0) : SIZELESS_BLOCKS;
    session->block_limit = blocks ? blocks : 1;
    uint32_t sectors = flash_sectors_for(session->block_limit * FLASH_BLOCK);
    if (at) {
        if (!reserve_at(session, address, sectors, why)) {
            return false;
        }
    } else if (!flash_allocate(sized ? sectors : 0, sectors, &session->extent)) {
        no_room(session, session->block_limit, why);
        return false;
    }
    session->open = true;
    return true;
}

void loader_rewind(struct load_session *session)
{
    session->next_address -= session->buffered;
    session->buffered = 0;
}

bool loader_has_relocation(const struct load_session *session, uint32_t location)
{
    for (uint16_t i = 0; i < session->relocation_count; i++) {
        if (session->relocations[i] == location) {
            return true;
        }
    }
    return false;
}

bool loader_reset_pointers(struct load_session *session, struct text *why)
{
    if (session->programmed_blocks) {
        text_add(why, "the pointer records cannot change once a block is programmed");
        return false;
    }
    session->relocation_count = 0;
    session->has_init = false;
    return true;
}

bool loader_feed_relocation(struct load_session *session, uint32_t location, struct text *why)
{
    if (location % 4) {
        text_format(why, "line 0: expected a 4-byte aligned pointer word, got %a (the node fixes "
                    "whole words; `hexmigrate verify` refuses this file too)", (uint32_t)location);
        return false;
    }
    uint64_t offset = (uint64_t)location - session->link_base;
    if (session->has_link_base && location >= session->link_base &&
        offset < loader_programmed(session)) {
        text_format(why, "line 0: the pointer word at %a arrived after its flash block was "
                    "programmed; a module file must give its 07 records before the data "
                    "(canonical form, as `hexmigrate pack` writes it)", (uint32_t)location);
        return false;
    }
    if (session->relocation_count >= LOADER_MAX_RELOCATIONS) {
        text_add(why, "expected at most 64 pointer locations, got 65");
        return false;
    }
    session->applied &= ~(1ull << session->relocation_count);
    session->relocations[session->relocation_count++] = location;
    return true;
}

bool loader_feed_init(struct load_session *session, uint32_t target, struct text *why)
{
    if (session->has_init) {
        text_add(why, "expected one module initialization pointer (08), got a second one "
                        "(the first is on line 0)");
        return false;
    }
    session->has_init = true;
    session->init = target;
    return true;
}

static bool owns_signature(const struct load_session *session)
{
    return signature_owner == session;
}

bool loader_signature_fits(uint64_t end, struct text *why)
{
    if (end > SIGNATURE_AREA_MAX) {
        text_format(why, "expected a signature area of at most 4096 bytes, got %U", (uint64_t)end);
        return false;
    }
    return true;
}

bool loader_feed_signature(struct load_session *session, uint32_t offset, const uint8_t *data,
                           uint32_t length, struct text *why)
{
    if (signature_owner != 0 && !owns_signature(session)) {
        text_add(why, "expected one signed module at a time, got a signature area while "
                        "another transfer holds the node's: send the modules one by one");
        return false;
    }
    if (!owns_signature(session)) {
        signature_area_clear(&signature);
    }
    if (signature_area_holds(&signature, offset, data, length)) {
        return true; /* the header sent again after a lost acknowledgement */
    }
    if (offset != signature.length) {
        text_format(why, "expected signature bytes for offset %U, got offset %U",
                    (uint64_t)signature.length, (uint64_t)offset);
        return false;
    }
    if (!loader_signature_fits((uint64_t)offset + length, why)) {
        return false;
    }
    signature_owner = session;
    signature_area_append(&signature, data, length);
    return true;
}

/* Add the move to every pointer word inside the block about to be programmed. */
static bool relocate_block(struct load_session *session, uint32_t length, struct text *why)
{
    uint64_t start = (uint64_t)session->link_base + (uint64_t)session->programmed_blocks *
                                                        FLASH_BLOCK;
    uint32_t delta = loader_load_base(session) - session->link_base;
    for (uint16_t i = 0; i < session->relocation_count; i++) {
        uint64_t location = session->relocations[i];
        if (location < start || location - start >= length) {
            continue;
        }
        uint32_t offset = (uint32_t)(location - start);
        if (offset + 4 > length) {
            if (length == FLASH_BLOCK) {
                text_format(why, "line 0: the pointer word at %a straddles a flash block "
                            "boundary; pointer words must be 4-byte aligned", (uint32_t)location);
                return false;
            }
            continue; /* past the end of the image: loader_finish says so */
        }
        uint8_t *word = session->buffer + offset;
        uint32_t value = (uint32_t)word[0] | (uint32_t)word[1] << 8 | (uint32_t)word[2] << 16 |
                         (uint32_t)word[3] << 24;
        value += delta;
        word[0] = (uint8_t)value, word[1] = (uint8_t)(value >> 8);
        word[2] = (uint8_t)(value >> 16), word[3] = (uint8_t)(value >> 24);
        session->applied |= 1ull << i;
    }
    return true;
}

static bool program_buffer(struct load_session *session, struct text *why)
{
    uint32_t index = session->programmed_blocks;
    if (index >= session->block_limit) {
        text_add(why, "module ");
        add_owner(why, session);
        text_format(why, " does not fit: %U block(s) of 256 bytes reserved at %a, more data "
                    "arrived", (uint64_t)session->block_limit,
                    (uint32_t)(loader_load_base(session)));
        return false;
    }
    uint32_t length = session->buffered;
    if (!relocate_block(session, length, why)) {
        return false;
    }
    uint32_t offset = session_offset(session) + index * FLASH_BLOCK;
    bool sector_start = offset % flash_sector_size() == 0;
    if ((sector_start && !flash_make_blank(flash_sector_of(offset))) ||
        !flash_program_block(offset, session->buffer, length)) {
        text_format(why, "the flash refused to erase or program the block at %a",
                    (uint32_t)(flash_base() + offset));
        return false;
    }
    session->crc = crc32_update(session->crc, session->buffer, length);
    session->programmed_blocks++;
    session->buffered = 0;
    return true;
}

bool loader_flush(struct load_session *session, struct text *why)
{
    return session->buffered == 0 || program_buffer(session, why);
}

static void discontinuity(const struct load_session *session, uint32_t address,
                          struct text *why)
{
    uint32_t expected = session->next_address;
    if (address > expected) {
        text_format(why, "expected one contiguous run of data (a module fills consecutive flash "
                    "blocks), got a gap at %a..%a", (uint32_t)expected, (uint32_t)(address - 1));
        return;
    }
    text_format(why, "expected data records in ascending address order (at %a), got %a after "
                "line 0", (uint32_t)expected, (uint32_t)address);
}

bool loader_feed_data(struct load_session *session, uint32_t address, const uint8_t *data,
                      uint32_t length, struct text *why)
{
    if (!length) {
        return true;
    }
    if (!session->has_link_base) {
        session->has_link_base = true;
        session->link_base = session->next_address = address;
    }
    if (address != session->next_address) {
        discontinuity(session, address, why);
        return false;
    }
    for (uint32_t position = 0; position < length;) {
        uint32_t room = FLASH_BLOCK - session->buffered;
        uint32_t piece = length - position < room ? length - position : room;
        for (uint32_t i = 0; i < piece; i++) {
            session->buffer[session->buffered + i] = data[position + i];
        }
        session->buffered += piece;
        position += piece;
        if (session->buffered == FLASH_BLOCK && !program_buffer(session, why)) {
            return false;
        }
    }
    session->next_address = address + length;
    return true;
}

static void add_span(struct text *why, uint32_t link_base, uint32_t size)
{
    text_format(why, "%a..%a", (uint32_t)link_base, (uint32_t)(link_base + size - 1));
}

static bool check_pointers(const struct load_session *session, uint32_t size, struct text *why)
{
    for (uint16_t i = 0; i < session->relocation_count; i++) {
        if (!(session->applied >> i & 1u)) {
            text_add(why, "line 0: expected the pointer word at ");
            add_span(why, session->relocations[i], 4);
            text_add(why, " inside the image data (");
            add_span(why, session->link_base, size);
            text_add(why, "), got it outside");
            return false;
        }
    }
    if ((uint64_t)session->init < session->link_base ||
        (uint64_t)session->init >= (uint64_t)session->link_base + size) {
        text_format(why, "line 0: expected the init subroutine at %a inside the image data (",
                    (uint32_t)session->init);
        add_span(why, session->link_base, size);
        text_add(why, "), got it outside");
        return false;
    }
    return true;
}

static bool check_read_back(const struct load_session *session, uint32_t size, struct text *why)
{
    uint32_t written = flash_crc32(session_offset(session), size);
    if (written == session->crc) {
        return true;
    }
    text_add(why, "flash read-back of module ");
    add_owner(why, session);
    text_format(why, " at %a gives CRC-32 %a, expected %a", (uint32_t)(loader_load_base(session)),
                (uint32_t)written, (uint32_t)session->crc);
    return false;
}

bool loader_finish(struct load_session *session, struct loaded_image *image, struct text *why)
{
    if (!session->has_init) {
        text_add(why, "expected a module initialization pointer (record 08), got none: this is "
                        "a plain HEX file, not a module");
        return false;
    }
    if (!session->has_link_base) {
        text_add(why, "expected the module's data, got no data records");
        return false;
    }
    if (!loader_flush(session, why)) {
        return false;
    }
    uint32_t size = session->next_address - session->link_base;
    if (!check_pointers(session, size, why) || !check_read_back(session, size, why)) {
        return false;
    }
    flash_shrink(&session->extent, flash_sectors_for(loader_programmed(session)));
    *image = (struct loaded_image){session->link_base, loader_load_base(session), size,
                                   session->init, session->relocation_count, session->crc,
                                   session->extent};
    if (owns_signature(session)) {
        signature_owner = 0; /* kept until here; checked here once the node trusts keys */
    }
    session->open = false;
    return true;
}

static void erase(const struct extent *extent)
{
    for (uint32_t i = 0; i < extent->count; i++) {
        flash_make_blank(extent->first + i);
    }
}

void loader_erase_extent(const struct extent *extent)
{
    erase(extent);
    flash_retire(extent);
}

void loader_abort(struct load_session *session)
{
    if (!session->open) {
        return;
    }
    session->open = false;
    if (owns_signature(session)) {
        signature_owner = 0;
    }
    loader_erase_extent(&session->extent);
}

void loader_discard(const struct loaded_image *image)
{
    erase(&image->extent);
    flash_release(&image->extent);
}
