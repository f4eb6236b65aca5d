"""A campaign's folder: its parameters, its records as JSON lines, and resuming.

``campaign.json`` holds the parameters that decide the runs (the application, the number of
runs, the seed and the application's own choices); ``runs.jsonl`` one record per finished run,
in the order the runs finished, each line written whole and flushed to disk before the next
(`Records.add`). A campaign interrupted midway (Ctrl-C, a killed process, a lost machine) leaves
every finished run's line and at most one torn line after them: `--resume` drops the torn line
and runs what is missing. A folder that holds another campaign's records is refused rather than
mixed with them.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any

from jsonschema import Draft202012Validator

from campaign.errors import CampaignError, CampaignFolderError
from campaign.record import SCHEMA, Record
from commandline.output import write_whole

_VALIDATOR = Draft202012Validator(SCHEMA)
MANIFEST = "campaign.json"
RECORDS = "runs.jsonl"


def check_folder(out: Path) -> None:
    """Refuse an `out` that cannot hold a campaign, before a cluster starts: a path that is not
    a folder, or whose nearest existing parent is not a folder."""
    existing = out
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if existing.exists() and not existing.is_dir():
        what = "a file" if existing.is_file() else "something other than a folder"
        where = "" if existing == out else f" at {existing}"
        raise CampaignFolderError(f"{out}: expected a folder for the campaign, got {what}{where}")


def start(out: Path, parameters: Mapping[str, Any], resume: bool) -> dict[int, Record]:
    """Make `out` ready for the campaign of `parameters`; the records already there (by index)
    when resuming, none for a new campaign."""
    manifest, records = out / MANIFEST, out / RECORDS
    if resume:
        if not manifest.is_file():
            raise CampaignFolderError(
                f"{out}: expected a campaign to resume ({MANIFEST}), got none: run it without "
                "--resume first"
            )
        _same(manifest, parameters)
        return read_records(records) if records.exists() else {}
    if manifest.exists() or records.exists():
        raise CampaignFolderError(
            f"{out}: expected a folder without a campaign, got one holding {MANIFEST} or "
            f"{RECORDS}: --resume to finish it, or another --out"
        )
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise CampaignFolderError(
            f"{out}: expected a folder the campaign can be written in, got {error.strerror}"
        ) from None
    write_whole(manifest, (json.dumps(dict(parameters), indent=1) + "\n").encode("utf-8"))
    return {}


def read_manifest(out: Path) -> dict[str, Any]:
    """The parameters of the campaign in `out` (empty when there is none)."""
    manifest = out / MANIFEST
    try:
        held = json.loads(manifest.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {}
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise CampaignFolderError(f"{manifest}: expected a campaign's JSON, got {error}") from None
    if not isinstance(held, dict):
        raise CampaignFolderError(f"{manifest}: expected a JSON object, got {held!r:.60}")
    return held


def _same(manifest: Path, parameters: Mapping[str, Any]) -> None:
    held = read_manifest(manifest.parent)
    for key, value in parameters.items():
        if held.get(key) != value:
            got = held.get(key)
            raise CampaignFolderError(
                f"{manifest}: {key}: expected {value!r} (as this command asks), got {got!r}: a "
                "campaign resumes with the parameters it started with"
            )


def read_records(path: Path) -> dict[int, Record]:
    """The records of `path` by index. A torn last line (a run being written when the campaign
    stopped) is cut off the file; any other line that is not a record is an error."""
    data = path.read_bytes()
    whole = data[: data.rfind(b"\n") + 1]
    if len(whole) != len(data):
        with path.open("r+b") as file:
            file.truncate(len(whole))
    records: dict[int, Record] = {}
    for number, line in enumerate(whole.splitlines(), start=1):
        try:
            record = json.loads(line)
        except (UnicodeDecodeError, json.JSONDecodeError) as error:
            raise CampaignFolderError(
                f"{path}:{number}: expected a run's record (JSON), got {error}"
            ) from None
        problem = next(iter(_VALIDATOR.iter_errors(record)), None)
        if problem is not None:
            where = "".join(f"[{p!r}]" for p in problem.absolute_path) or "the record"
            raise CampaignFolderError(
                f"{path}:{number}: {where}: expected a run's record, got {problem.message:.120}"
            )
        records.setdefault(record["index"], record)
    return records


class Records:
    """``runs.jsonl`` open for appending, one whole line per record."""

    def __init__(self, out: Path) -> None:
        self.path = out / RECORDS
        self._file: IO[bytes] = self.path.open("ab")

    def add(self, record: Record) -> None:
        """Append `record` and put it on disk before the next. A disk that refuses it (full, a
        file size limit) is a CampaignError naming the file, the part written taken back: the
        records before stay whole, for --resume once there is room."""
        end = self._file.tell()
        try:
            self._file.write((json.dumps(record, sort_keys=True) + "\n").encode("utf-8"))
            self._file.flush()
            os.fsync(self._file.fileno())
        except OSError as error:
            with contextlib.suppress(OSError):
                self._file.close()  # what it still buffers cannot reach the disk either
            with contextlib.suppress(OSError):
                os.truncate(self.path, end)
            raise CampaignError(
                f"{self.path}: cannot write run {record.get('index')}'s record: "
                f"{error.strerror}; the records before it are kept (--resume once there is room)"
            ) from None

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()

    def __enter__(self) -> Records:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
