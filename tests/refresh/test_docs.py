"""The Python example in docs/refresh.md runs as written and prints the paper's decision."""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path

ROOT = Path(__file__).parents[2]


def test_the_documented_example_runs():
    text = (ROOT / "docs" / "refresh.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 1
    out = io.StringIO()
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(blocks[0], "docs/refresh.md", "exec"), {})
    finally:
        os.chdir(cwd)
    first = out.getvalue().splitlines()[0]
    assert first == "CamReader {CamReader, Dehazer, SSD, TrajGen, HexMan}"
