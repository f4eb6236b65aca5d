"""Write a Morphing Crossbar's partial bitstream as an extended Intel HEX module file.

Examples:
  python -m morphing_crossbar pack 4 2 bypass -o slot2.hex
  python -m morphing_crossbar pack 8 0 through -o slot0.hex --cfg-w 4
  python -m morphing_crossbar pack 4 0 head -o dehazer.slot0.hex
  python -m morphing_crossbar pack 4 1 tail -o dehazer.slot1.hex

pack N SLOT ROUTE packs the new route of slot SLOT of an N-slot fabric: bypass takes the slot's
functionality out of its route, through puts it back (the reset route), empty leaves the slot
taking and driving nothing. A chain of functionalities along the ring is a head (the slot's
input into its functionality, which feeds the next slot), links (the ring into the
functionality, on to the next) and a tail (the ring into the functionality, out at the slot's
output): head on slot 0 and tail on slot 1 stream input 0 through functionalities 0 and 1 to
output 1. The file is what "hexmigrate send FILE.hex --to URL" sends to a node
started with "firmware-sim listen --fpga N" (docs/crossbar.md). Errors print one line
"error: ..." and exit 1; usage errors exit 2; --debug shows the traceback.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from commandline import add_command, command_parser, run
from commandline.arguments import integer, output_file
from morphing_crossbar.bitstream import pack
from morphing_crossbar.errors import CrossbarError
from morphing_crossbar.fabric import FRAME_BITS, INPUT_SEL, NONE_SEL, RING_SEL, Fabric
from morphing_crossbar.hex_image import to_image
from morphing_crossbar.routing import SlotRoute, bypass_route, empty_route, through_route

ROUTES = ("bypass", "through", "empty", "head", "link", "tail")
MAX_SLOTS = 16
"""The fabric's largest N (a selector field addresses 16 sources)."""


def route(name: str, fabric: Fabric, slot: int) -> SlotRoute:
    """The named route for `slot`."""
    if name == "bypass":
        return bypass_route()
    if name == "through":
        return through_route(fabric, slot)
    if name == "head":
        return SlotRoute(INPUT_SEL, NONE_SEL)
    if name == "link":
        return SlotRoute(RING_SEL, NONE_SEL)
    if name == "tail":
        return SlotRoute(RING_SEL, fabric.self_selector(slot))
    return empty_route()


def cmd_pack(args: argparse.Namespace) -> None:
    """Pack the route as a partial bitstream and write it as an extended HEX module file."""
    fabric = Fabric(args.n, cfg_w=args.cfg_w)
    bitstream = pack(fabric, args.slot, route(args.route, fabric, args.slot))
    image = to_image(fabric, bitstream)
    image.write(args.output)
    print(
        f"{args.output}: {image.name}, {args.route} route for slot {args.slot} of {args.n}, "
        f"{len(image.data)} bytes at 0x{image.link_base:08X}"
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser, subcommands dispatched through `func`."""
    top = command_parser("python -m morphing_crossbar", __doc__)
    commands = top.add_subparsers(required=True, metavar="COMMAND")
    packing = add_command(
        commands, "pack", cmd_pack, "write a partial bitstream as a HEX module file"
    )
    packing.add_argument(
        "n", type=integer(2, MAX_SLOTS), metavar="N", help=f"slots of the fabric, 2 to {MAX_SLOTS}"
    )
    packing.add_argument(
        "slot", type=integer(0, MAX_SLOTS - 1), metavar="SLOT", help="the slot to reconfigure"
    )
    packing.add_argument("route", choices=ROUTES, help="the slot's new route")
    packing.add_argument(
        "-o", "--output", type=output_file, required=True, metavar="FILE.hex", help="the file"
    )
    packing.add_argument(
        "--cfg-w",
        type=integer(1, FRAME_BITS),
        default=1,
        metavar="W",
        help=f"configuration port bits a beat, dividing {FRAME_BITS} (default 1)",
    )
    return top


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; the exit status."""
    return run(build_parser(), CrossbarError, argv)
