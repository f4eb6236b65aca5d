"""The repository explains itself: no file cites a document that lives outside it (the design
notes a checkout may have beside it are not part of what a user gets)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUTSIDE = re.compile(r"ARCHITECTURE\.md|TOOLCHAIN_NOTES\.md|STYLE\.md|\.\./shared/")


def citations_outside(root: Path) -> list[str]:
    """``FILE:LINE: text`` for each line of a tracked file that cites a document outside."""
    tracked = subprocess.run(
        ["git", "ls-files"], cwd=root, capture_output=True, text=True, check=True
    ).stdout.split()
    found = []
    for name in tracked:
        path = root / name
        if path == Path(__file__).resolve() or not path.is_file():
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        found += [
            f"{name}:{number}: {line.strip()}"
            for number, line in enumerate(text.splitlines(), 1)
            if OUTSIDE.search(line)
        ]
    return found


def test_no_file_cites_a_document_outside_the_repository():
    assert citations_outside(ROOT) == []
