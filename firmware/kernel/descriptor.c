/* descriptor.c - decode and check a module's descriptor (see descriptor.h). */
#include "descriptor.h"

#include "area.h"
#include "guest_memory.h"

static bool is_letter(char c)
{
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_';
}

static bool is_digit(char c)
{
    return c >= '0' && c <= '9';
}

/* A C identifier, as hexmigrate's IDENTIFIER: printed by every tool and parsed in requests
 * ("PBO.port"), so no escape sequence, space, dot or '=' may hide in one. */
static bool is_identifier(const char *name)
{
    if (!is_letter(name[0])) {
        return false;
    }
    for (uint32_t i = 1; name[i] != '\0'; i++) {
        if (!is_letter(name[i]) && !is_digit(name[i])) {
            return false;
        }
    }
    return true;
}

/* The field's bytes up to the first NUL (all of them when none), as hexmigrate reads it. */
static void read_name(uint32_t address, uint32_t field, char *name)
{
    uint32_t i = 0;
    while (i < field && guest_read8(address + i) != 0) {
        name[i] = (char)guest_read8(address + i);
        i++;
    }
    name[i] = '\0';
}

/* A refused name as Python's ascii() shows it after hexmigrate decoded it as ASCII with
 * replacement: the same text on both nodes. */
static void add_name_literal(struct text *why, const char *name)
{
    static const char hex[] = "0123456789abcdef";
    const bool double_quotes = text_find(name, '\'') != text_length(name, UINT32_MAX) &&
                               text_find(name, '"') == text_length(name, UINT32_MAX);
    const char *quote = double_quotes ? "\"" : "'";

    text_add(why, quote);
    for (uint32_t i = 0; name[i] != '\0'; i++) {
        const unsigned char c = (unsigned char)name[i];
        const char escaped[4] = {'\\', 'x', hex[c >> 4], hex[c & 0xFu]};
        if (c >= 0x80) {
            text_add(why, "\\ufffd"); /* one replacement character per non-ASCII byte */
        } else if (c == '\t' || c == '\n' || c == '\r') {
            text_add(why, c == '\t' ? "\\t" : c == '\n' ? "\\n" : "\\r");
        } else if (c == '\\' || (c == (unsigned char)quote[0])) {
            text_format(why, "\\%s", c == '\\' ? "\\" : quote);
        } else if (c < 0x20 || c == 0x7F) {
            text_add_bytes(why, escaped, 4);
        } else {
            text_add_bytes(why, (const char *)&c, 1);
        }
    }
    text_add(why, quote);
}

static int32_t refuse_identifier(struct text *why, const char *name)
{
    text_add(why, ": expected a C identifier (letters, digits, _), got ");
    add_name_literal(why, name);
    return STATUS_ERR_INVALID;
}

/* Writes why no buffer can hold `port` (hexmigrate's _shape_problem); false when one can.
 * `element_size` is the descriptor's 16-bit field: the port keeps it in 8 bits once valid. */
static bool add_shape_problem(struct text *why, const struct port_spec *port,
                              uint32_t element_size)
{
    const char *expected;

    if (element_size != 1 && element_size != 2 && element_size != 4) {
        text_format(why, "expected an element size in (1, 2, 4), got %u", element_size);
        return true;
    }
    if (port->rows < 1 || port->columns < 1) {
        expected = "at least 1 row and 1 column";
    } else if (port->kind == KIND_SCALAR && (port->rows != 1 || port->columns != 1)) {
        expected = "a scalar of 1x1";
    } else if (port->kind == KIND_VECTOR && port->rows != 1) {
        expected = "a vector of 1xN (one row)";
    } else {
        return false;
    }
    text_format(why, "expected %s, got %ux%u", expected, (uint32_t)port->rows,
                (uint32_t)port->columns);
    return true;
}

static int32_t decode_port(uint32_t address, uint32_t index, struct port_spec *port,
                           struct text *why)
{
    const uint32_t at = address + ABI_OFFSET_PORTS + index * ABI_PORT_SIZE;
    const uint32_t element_size = guest_read16(at + ABI_PORT_OFFSET_ELEMENT_SIZE);
    char problem_buffer[64];
    struct text problem;

    read_name(at, ABI_PORT_NAME_LEN, port->name);
    port->direction = guest_read8(at + ABI_PORT_OFFSET_DIRECTION);
    port->kind = guest_read8(at + ABI_PORT_OFFSET_TYPE);
    port->element_size = (uint8_t)element_size; /* refused below unless 1, 2 or 4 */
    port->rows = guest_read16(at + ABI_PORT_OFFSET_ROWS);
    port->columns = guest_read16(at + ABI_PORT_OFFSET_COLUMNS);
    if (port->direction >= DIRECTION_COUNT || port->kind >= KIND_COUNT) {
        text_format(why, "port %u: expected direction < 4 and type < 3, got %u and %u", index,
                    (uint32_t)port->direction, (uint32_t)port->kind);
        return STATUS_ERR_INVALID;
    }
    if (!is_identifier(port->name)) {
        text_format(why, "port %u's name", index);
        return refuse_identifier(why, port->name);
    }
    text_start(&problem, problem_buffer, sizeof problem_buffer);
    if (add_shape_problem(&problem, port, element_size)) {
        text_format(why, "port %u (%q): %s", index, port->name, problem_buffer);
        return STATUS_ERR_INVALID;
    }
    return STATUS_OK;
}

/* Magic, ABI version, port count, names and shapes: hexmigrate's Descriptor.decode. */
static int32_t decode(uint32_t address, struct module *module, struct text *why)
{
    const uint32_t magic = guest_read32(address + ABI_OFFSET_MAGIC);
    const uint32_t version = guest_read16(address + ABI_OFFSET_ABI_VERSION);
    const uint32_t port_count = guest_read16(address + ABI_OFFSET_PORT_COUNT);

    if (magic != ABI_MAGIC) {
        text_format(why, "expected descriptor magic 0x314F4250, got %a", magic);
        return STATUS_ERR_ABI;
    }
    if (version != ABI_VERSION) {
        text_format(why, "expected ABI version 1, got %u", version);
        return STATUS_ERR_ABI;
    }
    if (port_count > ABI_MAX_PORTS) {
        text_format(why, "expected at most 8 ports, got %u", port_count);
        return STATUS_ERR_INVALID;
    }
    module->port_count = (uint8_t)port_count;
    read_name(address + ABI_OFFSET_NAME, ABI_NAME_LEN, module->name);
    if (!is_identifier(module->name)) {
        text_add(why, "the module's name");
        return refuse_identifier(why, module->name);
    }
    module->state_size = guest_read32(address + ABI_OFFSET_STATE_SIZE);
    for (uint32_t i = 0; i < module->port_count; i++) {
        const int32_t status = decode_port(address, i, &module->ports[i], why);
        if (status != STATUS_OK) {
            return status;
        }
    }
    for (uint32_t i = 0; i < METHOD_COUNT; i++) {
        module->methods[i] = guest_read32(address + ABI_OFFSET_METHODS + 4u * i);
    }
    return STATUS_OK;
}

static bool distinct_ports(const struct module *module)
{
    for (uint32_t i = 0; i < module->port_count; i++) {
        for (uint32_t j = 0; j < i; j++) {
            if (text_equal(module->ports[i].name, module->ports[j].name)) {
                return false;
            }
        }
    }
    return true;
}

static int32_t check_names(const struct module *module, name_taken taken, struct text *why)
{
    if (taken(module->name)) {
        text_format(why, "a module %q is already loaded", module->name);
        return STATUS_ERR_EXISTS;
    }
    if (!distinct_ports(module)) {
        text_format(why, "module %q: expected distinct, non-empty port names, got [",
                    module->name);
        for (uint32_t i = 0; i < module->port_count; i++) {
            text_format(why, i != 0 ? ", %q" : "%q", module->ports[i].name);
        }
        text_add(why, "]");
        return STATUS_ERR_INVALID;
    }
    return STATUS_OK;
}

void descriptor_describe_image(struct text *text, uint32_t base, uint32_t size)
{
    text_format(text, "module image at %a..%a", base, base + size - 1u);
}

static int32_t check_methods(const struct module *module, struct text *why)
{
    for (uint32_t i = 0; i < METHOD_COUNT; i++) {
        const uint32_t entry = module->methods[i];
        const bool inside = entry - module->image_base < module->image_size; /* unsigned */
        if (entry != 0 && (!inside || entry % 4u != 0)) {
            text_format(why, "module %q: expected method %s at a 4-byte aligned address inside "
                             "the ",
                        module->name, method_name((enum method)i));
            descriptor_describe_image(why, module->image_base, module->image_size);
            text_format(why, ", got %a", entry);
            return STATUS_ERR_INVALID;
        }
    }
    return STATUS_OK;
}

static int32_t check_size(struct module *module, uint32_t largest_free, struct text *why)
{
    const uint32_t window = guest_memory_region(REGION_WINDOW)->size;
    const uint32_t room = window < largest_free ? window : largest_free;
    const uint64_t size = area_plan(module, room);

    if (size > room) {
        text_format(why, "module %q: needs a %U-byte area, but the task window holds %u bytes "
                         "and the largest free SRAM block is %u bytes",
                    module->name, size, window, largest_free);
        return STATUS_ERR_NO_MEMORY;
    }
    return STATUS_OK;
}

int32_t descriptor_accept(uint32_t address, struct module *module, name_taken taken,
                          uint32_t largest_free, struct text *why)
{
    int32_t status = decode(address, module, why);

    if (status == STATUS_OK) {
        status = check_names(module, taken, why);
    }
    if (status == STATUS_OK) {
        status = check_methods(module, why);
    }
    if (status == STATUS_OK) {
        status = check_size(module, largest_free, why);
    }
    return status;
}
