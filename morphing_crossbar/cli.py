"""``python -m morphing_crossbar pack``: a partial bitstream as an extended Intel HEX module file.

    python -m morphing_crossbar pack N SLOT bypass|through|empty -o FILE.hex [--cfg-w W]

The file is what ``hexmigrate send FILE.hex --to URL`` sends to a node listening with
``firmware-sim listen --fpga N`` (docs/crossbar.md): ``bypass`` takes the slot's functionality
out of its route, ``through`` puts it back (the reset route), ``empty`` leaves the slot taking and
driving nothing. Errors print ``error: ...`` and exit 1; usage errors exit 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from morphing_crossbar.bitstream import pack
from morphing_crossbar.errors import CrossbarError
from morphing_crossbar.fabric import Fabric
from morphing_crossbar.hex_image import to_image
from morphing_crossbar.routing import SlotRoute, bypass_route, empty_route, through_route

ROUTES = ("bypass", "through", "empty")


def route(name: str, fabric: Fabric, slot: int) -> SlotRoute:
    """The named route for `slot`."""
    if name == "bypass":
        return bypass_route()
    if name == "through":
        return through_route(fabric, slot)
    return empty_route()


def cmd_pack(args: argparse.Namespace) -> int:
    """Pack the route as a partial bitstream and write it as an extended HEX module file."""
    fabric = Fabric(args.n, cfg_w=args.cfg_w)
    bitstream = pack(fabric, args.slot, route(args.route, fabric, args.slot))
    image = to_image(fabric, bitstream)
    image.write(args.output)
    print(
        f"{args.output}: {image.name}, {args.route} route for slot {args.slot} of {args.n}, "
        f"{len(image.data)} bytes at 0x{image.link_base:08X}"
    )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m morphing_crossbar", description=__doc__.splitlines()[0]
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    packing = commands.add_parser("pack", help="write a partial bitstream as a HEX module file")
    packing.add_argument("n", type=int, metavar="N", help="slots of the fabric")
    packing.add_argument("slot", type=int, metavar="SLOT", help="the slot to reconfigure")
    packing.add_argument("route", choices=ROUTES, help="the slot's new route")
    packing.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.hex")
    packing.add_argument("--cfg-w", type=int, default=1, help="configuration width (default 1)")
    packing.set_defaults(func=cmd_pack)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (CrossbarError, ValueError, OSError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
