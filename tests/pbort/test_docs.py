"""The native PBO example in docs/pbort.md runs as written."""

from __future__ import annotations

import logging
import re
from pathlib import Path

import pytest

from pbort import Kernel, NativeModule, State
from pbort.errors import MethodFailedError

DOC = Path(__file__).parents[2] / "docs" / "pbort.md"


def example_source() -> str:
    """The Python block of the section 'Writing a native PBO'."""
    section = DOC.read_text(encoding="utf-8").split("## Writing a native PBO", 1)[1]
    match = re.search(r"```python\n(.*?)```", section, re.DOTALL)
    assert match, "docs/pbort.md: no python block under 'Writing a native PBO'"
    return match.group(1)


def test_the_documented_example_runs_and_its_assertions_hold(
    caplog: pytest.LogCaptureFixture,
) -> None:
    namespace: dict[str, object] = {"__name__": "pbort_doc_example"}
    exec(compile(example_source(), str(DOC), "exec"), namespace)
    kernel = namespace["kernel"]
    assert kernel.closed  # the with-block closed it
    assert namespace["estimate"].failure is None

    # the Gain of the example refuses to start without k, and says why in the log
    with Kernel() as other, caplog.at_level(logging.INFO, logger="pbort.module"):
        other.add(NativeModule(namespace["Gain"]))
        other.spawn("gain")
        with pytest.raises(MethodFailedError, match="on returned -1; now ERROR"):
            other.on("gain")
        assert other.state("gain") is State.ERROR
        assert "gain: k is not configured" in caplog.text
