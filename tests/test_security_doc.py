"""docs/security.md names a test for each claim: every ``tests/FILE.py::NAME`` it cites is a test
function of that file, so the page cannot keep citing a test that was renamed or removed."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CITED = re.compile(r"`(tests/[\w/]+\.py)::(test_\w+)`")


def test_every_test_the_threat_model_cites_exists():
    page = (ROOT / "docs" / "security.md").read_text(encoding="utf-8")
    cited = CITED.findall(page)
    assert len(cited) > 50
    missing = [
        f"{file}::{name}"
        for file, name in cited
        if not (ROOT / file).is_file()
        or not re.search(rf"^(async )?def {name}\(", (ROOT / file).read_text(), re.MULTILINE)
    ]
    assert missing == []
