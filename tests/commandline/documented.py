"""What a command's parser accepts that its section of docs/cli.md does not mention."""

from __future__ import annotations

import argparse
from pathlib import Path

CLI_DOC = Path(__file__).parents[2] / "docs" / "cli.md"


def undocumented(parser: argparse.ArgumentParser, heading: str) -> list[str]:
    """The sub-commands and options of `parser` (and of its sub-commands) that the section of
    docs/cli.md under `heading` (a ``## `` line) does not name."""
    text = CLI_DOC.read_text(encoding="utf-8")
    start = text.index(f"\n{heading}\n")
    end = text.find("\n## ", start + 1)
    section = text[start : end if end >= 0 else len(text)]
    return [name for name in sorted(_names(parser)) if name not in section]


def _names(parser: argparse.ArgumentParser) -> set[str]:
    names: set[str] = set()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for command, sub in action.choices.items():
                names |= {command} | _names(sub)
        else:
            names |= {o for o in action.option_strings if o.startswith("--") and o != "--help"}
    return names
