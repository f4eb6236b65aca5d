"""Parse and emit a 1 MiB image with hexmigrate, intelhex and bincopy in one run.

Prints throughput (MiB of image per second) and our speed as a ratio to each library. The input
is the same canonical text for all three (16 data bytes per record, 04 records every 64 KiB), so
every parser does the same work. Each figure is the best of several repetitions.

    python benchmarks/hex_codec.py [--size BYTES] [--repeat N]
"""

from __future__ import annotations

import argparse
import io
import random
import time
from collections.abc import Callable

import bincopy
from intelhex import IntelHex

from hexmigrate.records import HexContent, Segment, decode, encode

BASE = 0x0001_0000


def best_time(action: Callable[[], object], repeat: int) -> float:
    """Fastest of `repeat` runs, in seconds: the least disturbed by the rest of the machine."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return min(times)


def intelhex_parse(text: str) -> IntelHex:
    return IntelHex(io.StringIO(text))


def intelhex_emit(parsed: IntelHex) -> str:
    out = io.StringIO()
    parsed.write_hex_file(out, write_start_addr=False)
    return out.getvalue()


def bincopy_parse(text: str) -> bincopy.BinFile:
    parsed = bincopy.BinFile()
    parsed.add_ihex(text)
    return parsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1 << 20, help="image bytes (default 1 MiB)")
    parser.add_argument("--repeat", type=int, default=5, help="repetitions, best is kept")
    args = parser.parse_args()

    data = random.Random(1).randbytes(args.size)
    content = HexContent((Segment(BASE, data),))
    text = encode(content)
    assert decode(text) == content
    assert intelhex_parse(text).tobinstr() == data
    assert bincopy_parse(text).as_binary() == data

    ours_ih, ours_bc = IntelHex(io.StringIO(text)), bincopy_parse(text)
    parse = {
        "hexmigrate": best_time(lambda: decode(text), args.repeat),
        "intelhex": best_time(lambda: intelhex_parse(text), args.repeat),
        "bincopy": best_time(lambda: bincopy_parse(text), args.repeat),
    }
    emit = {
        "hexmigrate": best_time(lambda: encode(content), args.repeat),
        "intelhex": best_time(lambda: intelhex_emit(ours_ih), args.repeat),
        "bincopy": best_time(lambda: ours_bc.as_ihex(), args.repeat),
    }
    mib = args.size / (1 << 20)
    print(f"image {args.size} bytes, hex text {len(text)} characters, best of {args.repeat}")
    print(f"{'':12}{'parse MiB/s':>12}{'ours x':>9}{'emit MiB/s':>12}{'ours x':>9}")
    for name in parse:
        print(
            f"{name:12}{mib / parse[name]:12.1f}{parse[name] / parse['hexmigrate']:9.2f}"
            f"{mib / emit[name]:12.1f}{emit[name] / emit['hexmigrate']:9.2f}"
        )
    print(
        f"parse: {parse['intelhex'] / parse['hexmigrate']:.1f}x intelhex (goal >= 5), "
        f"{parse['bincopy'] / parse['hexmigrate']:.1f}x bincopy (goal > 1)"
    )


if __name__ == "__main__":
    main()
