"""The campaign engine on a toy application: the same seed draws the same runs, a crashing run
is recorded with its traceback and the campaign goes on, an interrupted campaign resumes from
its records (a torn last line cut off), a folder holding another campaign is refused, and the
summary, plots and page say what the records hold."""

from __future__ import annotations

import argparse
import errno
import json
import os
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib import image

from campaign import store
from campaign.cli import CampaignSpec, add_campaign_arguments, finish, run_campaign
from campaign.errors import CampaignError, CampaignFolderError
from campaign.plan import plan
from campaign.plots import PLOTS
from campaign.record import crashed, reproducible
from campaign.summary import distribution, rounded, summarize
from tests.campaign import toy
from tests.disk import disk_of

TOY = CampaignSpec("toy", ("a", "b"), toy.draw, toy.run, Path("unused"))


def options(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_campaign_arguments(parser, TOY)
    return parser.parse_args(["--workers", "2", *argv])


def records(out: Path) -> list[dict]:
    lines = (out / store.RECORDS).read_text().splitlines()
    return sorted((json.loads(line) for line in lines), key=lambda r: r["index"])


def test_the_same_seed_draws_the_same_runs_and_a_longer_campaign_extends_a_shorter():
    def draw(rng):
        return toy.draw(rng, ["a", "b"], None)

    assert plan(20, 5, draw) == plan(20, 5, draw)
    assert plan(20, 5, draw)[:10] == plan(10, 5, draw)
    assert plan(20, 5, draw) != plan(20, 6, draw)


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A toy campaign of 12 runs on a local Dask cluster of two workers."""
    out = tmp_path_factory.mktemp("toy")
    run_campaign(options("--runs", "12", "--seed", "3", "--out", str(out)), TOY)
    return out


def test_a_crashing_run_is_recorded_with_its_traceback_and_the_others_finish(finished):
    found = records(finished)
    assert [r["index"] for r in found] == list(range(12))
    crashed = [r for r in found if r["status"] == "crashed"]
    assert crashed and len(crashed) < 12
    for record in crashed:
        assert record["draw"]["crash"]
        assert "Traceback" in record["error"] and toy.CRASH in record["error"]
    for record in found:
        assert record["status"] == ("crashed" if record["draw"]["crash"] else "ok")
        assert record["timing"]["run_seconds"] >= 0


def floats(value) -> list[float]:
    """Every float in a JSON value."""
    if isinstance(value, float):
        return [value]
    if isinstance(value, dict):
        value = list(value.values())
    return [found for item in value for found in floats(item)] if isinstance(value, list) else []


def test_the_summary_plots_and_page_say_what_the_records_hold(finished):
    found = records(finished)
    ok = [r for r in found if r["status"] == "ok"]
    summary = json.loads((finished / "summary.json").read_text())
    assert summary == json.loads(json.dumps(rounded(summarize(found))))
    # six significant digits, not 0.20399999999999485 (the crashes' error texts are text)
    assert [n for n in floats(summary) if float(f"{n:.6g}") != n] == []
    assert summary["false_detections"]["of"] == len(ok)
    assert summary["finished"] == len(ok) and len(summary["crashed"]) == 12 - len(ok)
    assert summary["detection"]["rate"] == 1.0
    assert summary["detection"]["latency"]["median"] == pytest.approx(0.5)
    assert summary["recovery"]["time"]["max"] == pytest.approx(0.7)
    assert summary["location"]["accuracy"]["base-choice"]["all"] == 1.0
    assert summary["cost"]["bytes"] == 100 * len(ok)
    for name in ("detection_latency.png", "recovery_time.png", "location_accuracy.png"):
        pixels = image.imread(finished / name)
        assert np.std(pixels) > 0.01, name  # not a blank canvas
    page = (finished / "index.html").read_text()
    for name in ("detection_latency.png", "recovery_time.png", "location_accuracy.png"):
        assert f"src='{name}'" in page
    assert toy.CRASH in page and "<table>" in page and "only faulty modules named" in page
    parameters = page[page.index("<h2>Parameters</h2>") : page.index("<h2>Runs</h2>")]
    assert "null" not in parameters and "&quot;" not in parameters  # as a reader wants them
    # A row per run, in order, saying what was drawn and what ReFrESH made of it.
    every = page[page.index("<h2>Every run</h2>") :]
    rows = re.findall(r"<tr><td>(\d+)</td><td>([^<]*)</td><td>([^<]*)</td>", every)
    assert [int(index) for index, _, _ in rows] == list(range(12))
    for record, (_, status, fault) in zip(found, rows, strict=True):
        assert fault == record["draw"]["fault_type"]
        assert status == "ok" or status == f"crashed: ValueError: {toy.CRASH}"


def test_an_interrupted_campaign_resumes_where_it_stopped(finished, tmp_path):
    whole = (finished / store.RECORDS).read_bytes().splitlines(keepends=True)
    (tmp_path / store.MANIFEST).write_bytes((finished / store.MANIFEST).read_bytes())
    # Five runs finished, a sixth was being written when the campaign was killed.
    (tmp_path / store.RECORDS).write_bytes(b"".join(whole[:5]) + whole[5][:17])
    run_campaign(options("--resume", "--out", str(tmp_path)), TOY)
    resumed = records(tmp_path)
    assert [reproducible(r) for r in resumed] == [reproducible(r) for r in records(finished)]
    assert len((tmp_path / store.RECORDS).read_text().splitlines()) == 12


def test_a_record_the_disk_refuses_is_an_error_naming_the_file_and_is_taken_back(
    finished, tmp_path, monkeypatch
):
    whole = (finished / store.RECORDS).read_bytes().splitlines(keepends=True)
    with store.Records(tmp_path) as sink:
        for line in whole[:3]:
            sink.add(json.loads(line))

        def full(_descriptor: int) -> None:  # the disk took the bytes, not their sync
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        monkeypatch.setattr(os, "fsync", full)
        refused = rf"{tmp_path / store.RECORDS}: cannot write run 3's record: No space left"
        with pytest.raises(CampaignError, match=refused):
            sink.add(json.loads(whole[3]))
    assert (tmp_path / store.RECORDS).read_bytes() == b"".join(whole[:3])  # no torn line


def test_a_manifest_the_disk_refuses_is_named_and_leaves_the_folder_free(tmp_path):
    parameters = {"runs": 12, "seed": 3}
    with disk_of(10), pytest.raises(OSError) as refusal:
        store.start(tmp_path, parameters, resume=False)
    assert refusal.value.filename == str(tmp_path / store.MANIFEST)
    assert list(tmp_path.iterdir()) == []
    assert store.start(tmp_path, parameters, resume=False) == {}  # no cut manifest holds it


def test_a_plot_the_disk_refuses_is_named_and_no_file_is_left_cut(finished, tmp_path):
    summary = (finished / "summary.json").read_bytes()
    with disk_of(len(summary) + 100), pytest.raises(OSError) as refusal:  # a plot is 20 kB
        finish(tmp_path, store.read_manifest(finished), records(finished))
    assert Path(refusal.value.filename).parent == tmp_path
    assert Path(refusal.value.filename).name in PLOTS
    assert [path.name for path in tmp_path.iterdir()] == ["summary.json"]
    assert (tmp_path / "summary.json").read_bytes() == summary


def test_a_folder_holding_a_campaign_is_refused_unless_resumed(finished, tmp_path):
    with pytest.raises(CampaignFolderError, match="--resume to finish it"):
        run_campaign(options("--runs", "12", "--out", str(finished)), TOY)
    with pytest.raises(CampaignFolderError, match="expected a campaign to resume"):
        run_campaign(options("--resume", "--out", str(tmp_path)), TOY)
    with pytest.raises(CampaignFolderError, match=r"seed: expected 4 .*, got 3"):
        run_campaign(options("--resume", "--seed", "4", "--out", str(finished)), TOY)


def test_a_record_line_that_is_not_a_record_is_named_by_its_line(finished, tmp_path):
    records_of_finished = (finished / store.RECORDS).read_text().splitlines()
    path = tmp_path / store.RECORDS
    path.write_text(f"{records_of_finished[0]}\nnot json\n{records_of_finished[1]}\n")
    with pytest.raises(CampaignFolderError, match=r"runs.jsonl:2: expected a run's record"):
        store.read_records(path)
    path.write_text('["a list"]\n')
    with pytest.raises(CampaignFolderError, match=r"runs.jsonl:1: the record: expected a run"):
        store.read_records(path)
    good = json.loads(records_of_finished[0])
    for key, value, where in [
        ("status", "fine", "['status']"),
        ("index", -1, "['index']"),
        ("decisions", [{"located": "Cam"}], "['decisions'][0]"),
        ("timing", {}, "['timing']"),
        ("draw", {**good["draw"], "fault_type": "fog", "fault_at": None}, "['draw']['fault_at']"),
    ]:
        path.write_text(json.dumps({**good, key: value}) + "\n")
        with pytest.raises(CampaignFolderError, match=re.escape(f"runs.jsonl:1: {where}: ")):
            store.read_records(path)


def test_a_bad_option_is_a_usage_error(capsys):
    bad = [["--runs", "0"], ["--runs", "nan"], ["--scenarios", "a,zz"], ["--seed", "-1"]]
    bad += [["--scheduler", a] for a in ("garbage", "tls://127.0.0.1:9", "tcp://127.0.0.1", "")]
    for argv in bad:
        with pytest.raises(SystemExit) as exited:
            options(*argv)
        assert exited.value.code == 2
    said = capsys.readouterr().err
    assert "expected scenario names among a,b, got 'a,zz'" in said
    assert "--scheduler: expected tcp://HOST:PORT, got 'garbage'" in said


def test_distribution_of_nothing_and_of_values():
    assert distribution([])["median"] is None
    spread = distribution([3.0, 1.0, 2.0, 10.0])
    assert (spread["min"], spread["median"], spread["p90"], spread["max"]) == (1.0, 2.5, 10.0, 10.0)


@pytest.mark.parametrize(
    ("key", "value"),
    [("runs", "many"), ("runs", -3), ("seed", 1.5), ("scenarios", ["zz"]), ("location", "guess")],
)
def test_a_hostile_campaign_file_is_refused_on_resume_naming_the_key(tmp_path, key, value):
    parameters = {"application": "toy", "runs": 2, "seed": 1, "scenarios": ["a"], "location": None}
    (tmp_path / store.MANIFEST).write_text(json.dumps({**parameters, key: value}))
    with pytest.raises(CampaignFolderError, match=rf"campaign.json: {key}: expected what --{key}"):
        run_campaign(options("--resume", "--out", str(tmp_path)), TOY)
    assert not (tmp_path / store.RECORDS).exists()


def test_a_run_whose_worker_dies_is_recorded_as_crashed_and_the_others_finish(tmp_path):
    dying = CampaignSpec("toy", ("a", "b"), toy.draw, toy.die, Path("unused"))
    run_campaign(options("--runs", "4", "--seed", "3", "--out", str(tmp_path)), dying)
    found = records(tmp_path)
    assert [r["status"] for r in found] == ["ok", "crashed", "ok", "ok"]
    assert found[1]["error"].startswith("the run's worker failed: ")


def test_a_crashed_run_with_a_blank_error_is_summarized():
    draw = {"fault_type": "fog", "fault_at": 1.0, "truth": ["Cam"]}
    blank = crashed({"index": 0, "seed": 1, "draw": draw}, "  \n", 0.5)
    assert summarize([blank])["crashed"] == [{"index": 0, "error": ""}]


def test_a_folder_that_cannot_be_one_is_refused_before_any_run(tmp_path, capsys):
    taken = tmp_path / "taken"
    taken.write_text("a file\n")
    for out, said in ((taken, "(a file)"), (taken / "below", "Not a directory")):
        with pytest.raises(SystemExit):
            options("--runs", "2", "--out", str(out))
        err = capsys.readouterr().err
        assert "argument --out: " in err and said in err
    later = tmp_path / "later"  # a folder when the options were read, a file when the run begins
    read = options("--runs", "2", "--out", str(later))
    later.write_text("a file\n")
    with pytest.raises(
        CampaignFolderError, match=r"expected a folder for the campaign, got a file$"
    ):
        run_campaign(read, TOY)
    assert taken.read_text() == later.read_text() == "a file\n"


def test_naming_only_faulty_modules_is_told_apart_from_naming_exactly_the_faults():
    def answer(*named: str) -> dict:
        return {"located": list(named), "tried": 2, "generated": 4}

    record = toy.run({"draw": {"crash": False, "fault_at": 1.0}})
    record["timing"]["run_seconds"] = 0.1
    record["decisions"][0]["comparison"] = {
        "exact": answer("Cam", "Servo"),
        "one-of-two": answer("Servo"),
        "wrong-too": answer("Servo", "Matcher"),
        "nothing": answer(),
    }
    drawn = {"scenario": "a", "fault_type": "two", "fault_at": 1.0, "truth": ["Servo", "Cam"]}
    location = summarize([{"index": 0, "status": "ok", "draw": drawn, **record}])["location"]
    exact = {name: rates["all"] for name, rates in location["accuracy"].items()}
    assert exact == {
        "decided": 0.0,
        "exact": 1.0,
        "one-of-two": 0.0,
        "wrong-too": 0.0,
        "nothing": 0.0,
    }
    assert location["blameless"] == {
        "decided": 1.0,  # the toy's decision names Cam alone
        "exact": 1.0,
        "one-of-two": 1.0,
        "wrong-too": 0.0,
        "nothing": 0.0,
    }


def test_the_local_workers_log_into_the_campaign_s_folder_not_on_the_terminal(tmp_path, capfd):
    """A worker ending with its campaign can log a heartbeat that met its scheduler closing: a
    traceback on the user's terminal that says nothing about the runs."""
    import logging

    from campaign.engine import client

    log = tmp_path / "workers.log"

    def complain() -> None:
        logging.getLogger("distributed.worker").error("Failed to communicate with scheduler")
        logging.getLogger("tornado.application").error("Exception in callback")
        print("a library's own line", file=sys.stderr, flush=True)

    with client(1, None, log) as dask:
        dask.run(complain)
    written = log.read_text()
    assert "distributed.worker - ERROR - Failed to communicate with scheduler" in written
    assert "Exception in callback" in written and "a library's own line" in written
    out, err = capfd.readouterr()
    assert "Failed to communicate" not in out + err and "Exception in callback" not in err
