"""What `hexmigrate inspect` shows about a module file, as data and as text.

The report is built once as a plain dict (the `--json` output) and the text form is rendered from
that dict, so the two can never disagree.
"""

from __future__ import annotations

import zlib
from collections import Counter
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from hexmigrate import descriptor as abi
from hexmigrate.image import FLASH_BLOCK_SIZE, ModuleImage, find_descriptor
from hexmigrate.records import RecordType, decode_record
from hexmigrate.signing.verify import examine

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PublicKey


def build_report(
    image: ModuleImage, text: str, path: str, keys: Sequence[PublicKey] = ()
) -> dict[str, Any]:
    """Everything `inspect` prints, as JSON-ready data; `keys` check the signature."""
    found = find_descriptor(image)
    return {
        "file": path,
        "name": image.name,
        "name_from": "descriptor" if found is not None and found[1].name else "file",
        "link_base": image.link_base,
        "size": image.size,
        "init": image.init,
        "crc32": zlib.crc32(image.relocate(image.link_base)),
        "flash_block_size": FLASH_BLOCK_SIZE,
        "flash_blocks": image.flash_blocks(),
        "records": _record_counts(text),
        "descriptor": _descriptor_report(found),
        "relocations": [_relocation(image, found, location) for location in image.relocations],
        "signature": _signature_report(image, keys),
    }


def _signature_report(image: ModuleImage, keys: Sequence[PublicKey]) -> dict[str, Any] | None:
    """Version, signer and what holds, for a signed image (None for an unsigned one).
    `signature_holds` is None when no key given has the module's key hash."""
    verdict = examine(image, keys)
    if verdict is None:
        return None
    return {
        "version": str(verdict.version),
        "name": verdict.area.name,
        "key_type": verdict.area.signature_type,
        "key_hash": verdict.key_hash,
        "hash_holds": verdict.hash_holds,
        "name_holds": verdict.name_holds,
        "signature_holds": verdict.signature_holds,
    }


def _record_counts(text: str) -> dict[str, int]:
    """How many records of each type the file holds (every line was already checked)."""
    counts = Counter(decode_record(line.strip()).type for line in text.splitlines() if line.strip())
    return {f"{kind.value:02X}": counts[kind] for kind in RecordType if counts[kind]}


def _descriptor_report(found: tuple[int, abi.Descriptor] | None) -> dict[str, Any] | None:
    if found is None:
        return None
    address, descriptor = found
    return {
        "address": address,
        "name": descriptor.name,
        "abi_version": descriptor.abi_version,
        "state_size": descriptor.state_size,
        "ports": [{**vars(port), "size_bytes": port.size_bytes} for port in descriptor.ports],
        "methods": descriptor.methods,
    }


def _relocation(
    image: ModuleImage, found: tuple[int, abi.Descriptor] | None, location: int
) -> dict[str, Any]:
    target = image.word_at(location)
    slot = None
    if found is not None:
        method = abi.method_slot(location - found[0])
        slot = f"descriptor.{method}" if method else None
    return {
        "location": location,
        "target": target,
        "slot": slot,
        "function": image.symbols.get(target) or (slot and slot.removeprefix("descriptor.")),
    }


_NAME_FROM = {
    "descriptor": "the name in its descriptor",
    "file": "no descriptor: the file's name",
}


def render_text(report: dict[str, Any]) -> str:
    """The report as the aligned text a person reads in a terminal."""
    lines = [
        f"module {report['name']}  ({report['file']}; {_NAME_FROM[report['name_from']]})",
        f"  link base   0x{report['link_base']:08X}",
        f"  size        {report['size']} bytes "
        f"(0x{report['link_base']:08X}..0x{report['link_base'] + report['size'] - 1:08X}), "
        f"CRC-32 0x{report['crc32']:08X}",
        f"  init        0x{report['init']:08X}",
        "  records     "
        + ", ".join(f"{count} x {kind}" for kind, count in report["records"].items())
        + " (all checksums valid)",
    ]
    blocks = report["flash_blocks"]
    lines.append(
        f"  flash       {len(blocks)} block(s) of {report['flash_block_size']} bytes at the link "
        "base: " + ", ".join(f"0x{b:08X}" for b in blocks)
    )
    lines += _descriptor_lines(report["descriptor"])
    lines.append(_signature_line(report["signature"]))
    lines.append(f"  relocations {len(report['relocations'])} (record 07)")
    lines.append(f"    {'location':<12}{'target':<12}{'slot':<22}function")
    lines += [
        f"    0x{r['location']:08X}  0x{r['target']:08X}  {r['slot'] or '-':<22}"
        f"{r['function'] or '?'}"
        for r in report["relocations"]
    ]
    return "\n".join(lines)


def _signature_line(signature: dict[str, Any] | None) -> str:
    if signature is None:
        return "  signature   none (unsigned: no 09 records)"
    holds = {True: "holds", False: "does NOT hold", None: "not checked (no --key with this hash)"}
    return (
        f"  signature   version {signature['version']}, {signature['key_type']} key "
        f"{signature['key_hash']}; hash {'holds' if signature['hash_holds'] else 'does NOT hold'}"
        f"{'' if signature['name_holds'] else ', signed as ' + repr(signature['name'])}, "
        f"signature {holds[signature['signature_holds']]}"
    )


def _descriptor_lines(descriptor: dict[str, Any] | None) -> list[str]:
    if descriptor is None:
        return ["  descriptor  none found (no PBO1 magic)"]
    lines = [
        f"  descriptor  at 0x{descriptor['address']:08X}: {descriptor['name']!r}, "
        f"ABI {descriptor['abi_version']}, state {descriptor['state_size']} bytes",
    ]
    lines += [
        f"    port {p['name']:<12} {p['direction']:<8} {p['type']:<6} "
        f"{p['size_bytes']} bytes ({p['rows']}x{p['columns']} of {p['element_size']}-byte elements)"
        for p in descriptor["ports"]
    ]
    return lines
