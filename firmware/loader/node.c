/*
 * node.c - the node's modules (node.h), kept in the order the Python node keeps them (its dict
 * of modules: a replaced module leaves, the new one comes last), so directory records match.
 */
#include "node.h"

#include "../board/board.h"
#include "descriptor.h"
#include "modules.h"

static struct {
    uint32_t count;
    struct installed_module modules[DIRECTORY_MAX_ENTRIES];
    uint32_t kept_count;
    struct kept_version kept[DIRECTORY_MAX_KEPT];
} node;


uint32_t node_module_count(void)
{
    return node.count;
}

const struct installed_module *node_module(uint32_t index)
{
    return index < node.count ? &node.modules[index] : 0;
}

static int find_module(const char *name)
{
    for (uint32_t i = 0; i < node.count; i++) {
        if (text_equal(node.modules[i].entry.name, name)) {
            return (int)i;
        }
    }
    return -1;
}

static void forget_module(uint32_t index)
{
    for (uint32_t i = index; i + 1 < node.count; i++) {
        node.modules[i] = node.modules[i + 1];
    }
    node.count--;
}

/* Keep `version` as the highest of `name` (a signed module that leaves the flash). */
static void keep_version(const char *name, uint32_t version)
{
    if (!version) {
        return;
    }
    for (uint32_t i = 0; i < node.kept_count; i++) {
        if (text_equal(node.kept[i].name, name)) {
            node.kept[i].version = version;
            return;
        }
    }
    if (node.kept_count < DIRECTORY_MAX_KEPT) {
        text_copy(node.kept[node.kept_count].name, name, sizeof node.kept[0].name);
        node.kept[node.kept_count++].version = version;
    }
}

static void drop_kept(const char *name)
{
    for (uint32_t i = 0; i < node.kept_count; i++) {
        if (text_equal(node.kept[i].name, name)) {
            for (uint32_t j = i; j + 1 < node.kept_count; j++) {
                node.kept[j] = node.kept[j + 1];
            }
            node.kept_count--;
            return;
        }
    }
}

/* The record of the modules but `skip` (plus `extra`, if any) and the kept versions. */
static void make_record(struct directory_record *record, const char *skip,
                        const struct directory_entry *extra)
{
    record->sequence = directory_next_sequence();
    record->entry_count = 0;
    for (uint32_t i = 0; i < node.count; i++) {
        if (!skip || !text_equal(node.modules[i].entry.name, skip)) {
            record->entries[record->entry_count++] = node.modules[i].entry;
        }
    }
    if (extra && record->entry_count < DIRECTORY_MAX_ENTRIES + 1) {
        record->entries[record->entry_count++] = *extra;
    }
    record->kept_count = 0;
    for (uint32_t i = 0; i < node.kept_count; i++) {
        if (!extra || !text_equal(node.kept[i].name, extra->name)) {
            record->kept[record->kept_count++] = node.kept[i];
        }
    }
}

/* A line for the console (noinline: its buffer is not on the stack while boot reads the
 * directory). */
__attribute__((noinline)) static void say(void (*report)(const char *), const char *what,
                                          const char *name, const char *reason)
{
    char line[240];
    struct text text;
    text_start(&text, line, sizeof line);
    text_format(&text, "%s%r: %s", what, name, (uint32_t)(text_length(name, DIRECTORY_NAME_LEN)),
                reason);
    report(line);
}

/* Take back one entry of the directory: its sectors, its intact image, its name. */
static bool restore(const struct directory_entry *entry, struct text *why)
{
    uint32_t offset = entry->load_address - flash_base();
    if (entry->load_address < flash_base() || offset >= flash_size() ||
        offset % flash_sector_size() || entry->size == 0) {
        text_format(why, "expected a load address at a flash sector boundary and a size > 0, got "
                    "%a", (uint32_t)entry->load_address);
        return false;
    }
    struct installed_module module = {*entry, {0, 0}};
    if (!flash_place(flash_sector_of(offset), flash_sectors_for(entry->size), &module.extent)) {
        text_add(why, "its flash overlaps another module's or the directory's");
        return false;
    }
    uint32_t crc = flash_crc32(offset, entry->size);
    bool named = crc == entry->crc32 &&
                 descriptor_find_name(offset, entry->size, entry->link_base, module.entry.name,
                                      why);
    const char *refusal = named ? node_module_installed(module.entry.name, entry->load_address,
                                                        entry->size, entry->init_address)
                                : 0;
    if (!named || refusal) {
        text_add(why, crc != entry->crc32 ? "the image's CRC-32 is not the directory's" : "");
        text_add(why, refusal ? refusal : "");
        if (refusal) { /* its init ran */
            flash_retire(&module.extent);
        } else {
            flash_release(&module.extent);
        }
        return false;
    }
    node.modules[node.count++] = module;
    return true;
}

/* The directory's kept versions into the node's table, and its entries into `entries`: the
 * 608-byte record is on the stack only while it is read, never while a module's init runs
 * (noinline). How many entries; 0 when no record holds. */
__attribute__((noinline)) static uint32_t load_directory(void (*report)(const char *line),
                                                         struct directory_entry *entries)
{
    struct directory_record record;
    if (!directory_load(&record, report)) {
        return 0;
    }
    for (uint32_t i = 0; i < record.kept_count; i++) {
        node.kept[node.kept_count++] = record.kept[i];
    }
    for (uint32_t i = 0; i < record.entry_count; i++) {
        entries[i] = record.entries[i];
    }
    return record.entry_count;
}

void node_boot(void (*report)(const char *line))
{
    struct directory_entry entries[DIRECTORY_MAX_ENTRIES + 1]; /* as a record holds them */
    node.count = 0;
    node.kept_count = 0;
    uint32_t count = load_directory(report, entries);
    for (uint32_t i = 0; i < count; i++) {
        char reason[160];
        struct text why;
        text_start(&why, reason, sizeof reason);
        if (find_module(entries[i].name) >= 0) {
            text_add(&why, "a module of that name came earlier in the directory");
        }
        if (why.length || !restore(&entries[i], &why)) {
            say(report, "boot: skipped module ", entries[i].name, reason);
            keep_version(entries[i].name, entries[i].version);
        }
    }
}

static struct directory_entry entry_of(const struct loaded_image *image, const char *name)
{
    struct directory_entry entry = {{0}, image->load_base, image->size, image->link_base,
                                    image->init + (image->load_base - image->link_base),
                                    image->relocations, image->crc32,
                                    directory_next_sequence(), 0};
    text_copy(entry.name, name, sizeof entry.name);
    return entry;
}

/* The directory write of a commit failed: the kernel goes back to the old module, if any. */
static void undo_registration(const char *name, int old)
{
    if (old < 0) {
        node_module_removed(name);
        return;
    }
    const struct directory_entry *entry = &node.modules[old].entry;
    node_module_installed(entry->name, entry->load_address, entry->size, entry->init_address);
}

/* Write the directory record of the modules but `skip` (plus `extra`, if any): its 608 bytes
 * are on the stack only while it is written, never while a module's code runs (noinline). */
__attribute__((noinline)) static bool write_record(const char *skip,
                                                   const struct directory_entry *extra,
                                                   struct text *why)
{
    struct directory_record record;
    make_record(&record, skip, extra);
    return directory_write(&record, why);
}

bool node_commit(const struct loaded_image *image, char *name, uint32_t *address,
                 struct text *why)
{
    uint32_t offset = image->load_base - flash_base();
    if (!descriptor_find_name(offset, image->size, image->link_base, name, why)) {
        loader_discard(image);
        return false;
    }
    struct directory_entry entry = entry_of(image, name);
    const char *refusal =
        node_module_installed(name, image->load_base, image->size, entry.init_address);
    if (refusal) { /* its init ran */
        text_add(why, refusal);
        loader_erase_extent(&image->extent);
        return false;
    }
    int old = find_module(name);
    if (!write_record(name, &entry, why)) {
        undo_registration(name, old);
        loader_erase_extent(&image->extent);
        return false;
    }
    drop_kept(name);
    if (old >= 0) {
        struct extent retired = node.modules[old].extent;
        forget_module((uint32_t)old);
        loader_erase_extent(&retired);
    }
    node.modules[node.count++] = (struct installed_module){entry, image->extent};
    *address = image->load_base;
    return true;
}

bool node_remove(const char *name, struct text *why)
{
    int index = find_module(name);
    if (index < 0) {
        return false;
    }
    struct installed_module module = node.modules[index];
    keep_version(name, module.entry.version);
    if (!write_record(name, 0, why)) {
        return false;
    }
    forget_module((uint32_t)index);
    node_module_removed(module.entry.name);
    loader_erase_extent(&module.extent);
    return true;
}

void node_describe(struct text *line)
{
    uint32_t blocks_per_sector = flash_sector_size() / FLASH_BLOCK;
    text_format(line, "node: %U module(s), %U of %U flash blocks free, %U bytes of SRAM free, %s "
                "firmware", (uint64_t)node.count,
                (uint64_t)flash_free_sectors() * blocks_per_sector, (uint64_t)flash_block_count(),
                (uint64_t)node_sram_free(), board_name());
}
