"""Conformance: node control, the same on every node (`nodes.KINDS`), with the real
``hexmigrate`` over a pty: ps (plain, --json, --verbose), start, stop, clear, set, rate,
connect, disconnect, get, watch and logs, their refusals, and modules that fault.

Both nodes are started with ``--no-start`` (nodes.py): a module sent is created and left OFF,
so every test starts what it runs. Same modules, same commands: the same output, except what
differs by nature (load addresses, times, the power a module measures).
"""

from __future__ import annotations

import json
import re
import time
from dataclasses import replace
from pathlib import Path

import pytest

from hexmigrate.elf import image_from_elf
from hexmigrate.links import open_link
from hexmigrate.links.base import is_text
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import (
    Ack,
    ClearPbo,
    ConnectPorts,
    DescribePbo,
    DisconnectPorts,
    HoldStart,
    Message,
    Nak,
    PerformanceReport,
    PortValues,
    ReadLog,
    ReadPorts,
    SetConstant,
    SetRate,
    StartPbo,
    StopPbo,
    Watch,
    decode,
    encode,
)
from hexmigrate.transfer.receiver import MAX_REFUSAL
from hexmigrate.transfer.sender import Sender
from module_sdk.build import build_module
from tests.conformance.nodes import MODE, MODES
from tests.firmware_sim.host_side import hexmigrate, hexmigrate_refused

PROLOGUE = """
#include "pbo_module.h"
static int32_t ok(struct pbo_context *ctx) { (void)ctx; return PBO_OK; }
"""
DESCRIPTOR = """
static const struct pbo_descriptor descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC, .abi_version = PBO_ABI_VERSION, .port_count = 2, .name = "%s",
    .ports = {{"c", PBO_PORT_CONST, PBO_SCALAR, 4, 1, 1}, {"y", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1}},
    .init = ok, .on = ok, .cycle = cycle, .off = ok, .kill = ok, .error = ok, .clear = ok,
};
PBO_MODULE(descriptor)
"""
CYCLES = {
    # y = c: a source of a constant the host sets, to feed the examples' inputs; through the
    # PORT_READ service onto its stack, so a service's answer (a0) and the stack are used
    "source": "int32_t c = 0; int32_t n = pbo_sys_port_read(ctx, 0, &c, sizeof c);"
    " *(int32_t *)ctx->ports[1] = n == (int32_t)sizeof c ? c : -1; return PBO_OK;",
    # a load from the address c holds (0 unless set): the compiler cannot see it is null
    "nullread": "return *(volatile const int32_t *)(uintptr_t)*(const uint32_t *)ctx->ports[0];",
    # never returns: the node's watchdog (its instruction or time budget) must end it
    "spin": "volatile int forever = 1; (void)ctx; while (forever) {} return PBO_OK;",
    # y = its cycles so far: its output's buffer keeps the last value from cycle to cycle
    "count": "*(int32_t *)ctx->ports[1] += 1; return PBO_OK;",
}
SETTLE = 0.5
"""Seconds for a chain at 100 Hz to carry a constant through (a few periods are enough)."""


def control(url: str, *arguments: object, mode: tuple[str, ...] = MODE) -> str:
    return hexmigrate(*arguments, "--to", url, *mode)


def refused(url: str, *arguments: object) -> str:
    return hexmigrate_refused(*arguments, "--to", url, *MODE).strip()


def send(url: str, path: Path) -> None:
    control(url, "send", path, "--quiet")


@pytest.fixture(scope="module")
def test_modules(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The modules of `CYCLES` as module files, by name."""
    folder = tmp_path_factory.mktemp("control_modules")
    files = {}
    for name, body in CYCLES.items():
        source = folder / f"{name}.c"
        cycle = f"static int32_t cycle(struct pbo_context *ctx) {{ {body} }}\n"
        source.write_text(PROLOGUE + cycle + DESCRIPTOR % name)
        files[name] = folder / f"{name}.hex"
        image_from_elf(build_module(source, folder / name).elf).write(files[name])
    return files


def wait_for_state(url: str, name: str, state: str, timeout: float = 5.0) -> str:
    """``ps`` once PBO `name` is in `state` (a job runs when the node gets to it)."""
    deadline = time.monotonic() + timeout
    while True:
        listing = control(url, "ps")
        if re.search(rf"^{name} +{state} ", listing, re.MULTILINE):
            return listing
        assert time.monotonic() < deadline, f"{name} never reached {state}:\n{listing}"
        time.sleep(0.1)


@pytest.mark.timeout(120)
def test_ps_lists_each_module_off_with_its_rate_and_ports(boot, example_hex):
    url = boot().url
    send(url, example_hex["gain"])
    send(url, example_hex["moving_average"])
    assert control(url, "ps").splitlines() == [
        "gain             OFF             100 Hz  in: x  out: y  const: k",
        "moving_average   OFF             100 Hz  in: x  out: y  const: -",
    ]
    assert json.loads(control(url, "ps", "--json")) == [
        {"name": name, "state": "OFF", "rate": 100.0, "inputs": ["x"], "outputs": ["y"],
         "constants": constants}
        for name, constants in (("gain", ["k"]), ("moving_average", []))
    ]  # fmt: skip
    assert control(url, "ps", "--verbose").splitlines()[1:3] == [
        "    constants: k=0",
        "    wires: -",
    ]


@pytest.mark.timeout(120)
def test_a_node_starts_each_module_that_arrives_or_is_found_at_boot(boot, example_hex):
    board = boot(switch_on=True)
    send(board.url, example_hex["moving_average"])
    send(board.url, example_hex["gain"])  # refuses to start: left OFF for its constant
    states = [["moving_average", "ON"], ["gain", "OFF"]]
    assert [row.split()[:2] for row in control(board.url, "ps").splitlines()] == states
    assert "s  gain: k is not configured\n" in control(board.url, "logs", "gain")
    board.stop()
    board = boot(switch_on=True)  # the modules in flash register and start again
    assert [row.split()[:2] for row in control(board.url, "ps").splitlines()] == states
    control(board.url, "send", example_hex["gain"], "--quiet", "--set", "gain.k=0x10000")
    assert control(board.url, "ps").splitlines()[1].startswith("gain             ON ")
    # held (HOLD) when it arrived: set first, then started once, so it never refused to start
    assert "not configured" not in control(board.url, "logs", "gain")


@pytest.mark.timeout(120)
def test_gain_without_its_constant_refuses_to_start_logs_why_and_is_cleared(boot, example_hex):
    url = boot().url
    send(url, example_hex["gain"])
    assert refused(url, "start", "gain") == (
        "error: the node refused: START refused: PBO 'gain': on returned -1; now ERROR; it "
        "logged: gain: k is not configured / gain: error, output forced to 0"
    )
    verbose = control(url, "ps", "--verbose")
    assert verbose.startswith("gain             ERROR ")
    assert "    last failure: on returned -1" in verbose.splitlines()
    logged = [line.split("s  ", 1)[1] for line in control(url, "logs", "gain").splitlines()]
    assert logged == ["gain: k is not configured", "gain: error, output forced to 0"]
    assert control(url, "clear", "gain").startswith("cleared gain: now OFF on ")
    control(url, "set", "gain.k=0x20000")
    with open_link(url) as link:  # sent again (its answer lost): answered again, not done again
        answers = []
        for _ in range(2):
            link.send(encode(StartPbo(4242, "gain"), True))
            answers.append(link.receive(5.0))
        for tid in range(5000, 5008):  # other requests that change the node, in between
            link.send(encode(HoldStart(tid, f"h{tid}"), True))
            assert isinstance(decode(link.receive(5.0) or b""), Ack)
        link.send(encode(StartPbo(4242, "gain"), True))
        answers.append(link.receive(5.0))
    assert answers == [encode(Ack(4242, 0, "started gain"), True)] * 3
    assert control(url, "ps").startswith("gain             ON ")
    assert refused(url, "start", "gain").endswith("cannot on from state ON; allowed from OFF")


def assert_pushes_in_mode(url: str, text: bool) -> None:
    """A watch asked for in hex mode (`text`) or binary mode is answered and pushed in it (the
    host decodes either, so only the raw messages tell). Its transaction ids are the mode's
    own: the same request again would be a retry, answered and not done again."""
    tid = 70 if text else 80
    with open_link(url) as link:
        link.send(encode(Watch(tid, 50, "gain.y"), text))
        raw = [link.receive(2.0) for _ in range(3)]
        link.send(encode(Watch(tid + 1, 0), text))
    assert all(message and is_text(message) == text for message in raw), raw
    assert isinstance(decode(raw[0]), Ack), raw
    assert all(isinstance(decode(message), PerformanceReport) for message in raw[1:]), raw


@pytest.mark.timeout(120)
def test_a_chain_fed_a_constant_gives_the_same_values(boot, example_hex, test_modules):
    """Read and watched in both transfer modes: a watch pushes in the mode it came in."""
    url = boot().url
    for path in (test_modules["source"], example_hex["gain"], example_hex["moving_average"]):
        send(url, path)
    assert control(url, "set", "source.c=0x30000").startswith("set source.c=196608 on ")
    control(url, "set", "gain.k=0x20000")  # 3.0 * 2.0 in Q16.16
    for wire in ("source.y=gain.x", "gain.y=moving_average.x"):
        assert control(url, "connect", wire).startswith(f"connected {wire} on ")
    assert control(url, "rate", "moving_average=50").startswith("rate moving_average=50 Hz on ")
    for name in ("source", "gain", "moving_average"):
        control(url, "start", name)
    time.sleep(SETTLE)
    assert control(url, "get", "moving_average.y").strip() == "moving_average.y=393216"
    assert "moving_average   ON               50 Hz" in control(url, "ps")
    for mode in MODES:
        mode_option = ("--mode", mode)
        assert control(url, "get", "gain.y", mode=mode_option).strip() == "gain.y=393216"
        watched = control(
            url, "watch", "--seconds", "0.3", "--port", "moving_average.y", mode=mode_option
        )
        reports = [line for line in watched.splitlines() if line.startswith("report #")]
        assert reports, watched
        assert all(
            re.search(r"leftover=[\d.]+  slip=[\d.]+  missed=\d+  ", report) for report in reports
        )
        assert all(report.endswith("moving_average.y=393216") for report in reports), reports
        assert all("gain:F0=0  gain:N0=" in report for report in reports), reports
        assert_pushes_in_mode(url, mode == "hex")
    assert control(url, "stop", "source").startswith("stopped source on ")
    assert control(url, "disconnect", "gain.y=moving_average.x").startswith("disconnected ")
    assert "wires: source.y=gain.x" in control(url, "ps", "--verbose")
    with open_link(url) as link:  # RESET: the manager's, no command of its own
        said = NodeControl(Sender(link, "binary")).reset()
    assert said == "reset: 2 PBO(s) switched off, 1 wire(s) and 0 bridge(s) undone, clock at 0 s"
    assert [row.split()[1] for row in control(url, "ps").splitlines()] == ["OFF"] * 3


@pytest.mark.timeout(120)
def test_a_chain_registered_against_its_flow_carries_a_value_in_the_same_release(
    boot, example_hex, test_modules
):
    """Ties of a release go by the wiring on every node: gain, registered before the count it
    reads, runs after it and shows the count of the same release. Read between two releases
    (nearly always: the jobs of a release run back to back), the two values are equal; when ties
    went by registration, gain showed the count before, always one less."""
    url = boot().url
    for path in (example_hex["gain"], test_modules["count"]):
        send(url, path)
    control(url, "set", "gain.k=0x10000")  # 1.0 in Q16.16
    control(url, "connect", "count.y=gain.x")
    for name in ("gain", "count"):
        control(url, "rate", f"{name}=20")
        control(url, "start", name)
    time.sleep(SETTLE)
    reads = []
    for tid in range(1, 6):
        answer = ask(url, ReadPorts(tid, "count.y gain.y"))
        assert isinstance(answer, PortValues), answer
        reads.append(dict(word.split("=") for word in answer.values.split()))
        time.sleep(0.013)
    assert all(int(r["count.y"]) > 0 for r in reads), reads
    assert sum(r["count.y"] == r["gain.y"] for r in reads) >= 4, reads


def ask(url: str, request: Message) -> Message:
    with open_link(url) as link:
        link.send(encode(request, True))
        return decode(link.receive(5.0) or b"")


@pytest.mark.timeout(120)
def test_port_lists_are_read_and_watched_in_order_and_bad_ones_refused_in_the_same_words(
    boot, example_hex
):
    """READ and WATCH take their ports as the request's words, blanks between as they come; a
    list of more than 32 or a word that is no PBO.port is refused, the first bad word named."""
    url = boot().url
    send(url, example_hex["gain"])
    control(url, "set", "gain.k=7")
    spaced = "  gain.k \t gain.y   gain.k "
    assert ask(url, ReadPorts(5, spaced)) == PortValues(5, "gain.k=7 gain.y=0 gain.k=7")
    with open_link(url) as link:
        link.send(encode(Watch(6, 50, spaced), True))
        answers = [decode(link.receive(2.0) or b"") for _ in range(2)]
        link.send(encode(Watch(7, 0), True))
        for _ in range(20):  # reports may come before it: the next request must not read them
            if decode(link.receive(2.0) or b"") == Ack(7, 0, "unwatched"):
                break
    assert answers[0] == Ack(6, 50, "watching")
    assert isinstance(answers[1], PerformanceReport), answers
    assert answers[1].values.endswith(" missed=0 gain.k=7 gain.y=0 gain.k=7"), answers
    prefix = "READ refused: "
    assert ask(url, ReadPorts(8, " ".join(["gain.y"] * 33))) == Nak(
        8, 0, prefix + "expected at most 32 ports, got more", fatal=True
    )
    assert ask(url, ReadPorts(9, "gain.y gain gain.k=1")) == Nak(
        9, 0, prefix + "expected PBO.port names, got 'gain'", fatal=True
    )
    assert ask(url, ReadPorts(10, "gain.y gain.z")) == Nak(
        10, 0, prefix + "unknown port 'gain.z'; expected one of 'x', 'y', 'k'", fatal=True
    )


@pytest.mark.timeout(120)
def test_requests_a_node_cannot_do_are_refused_in_the_same_words(boot, example_hex):
    url = boot().url
    send(url, example_hex["gain"])
    prefix = "error: the node refused: "
    assert refused(url, "set", "gain.k=1.5") == (
        prefix + "SET refused: gain.k is int32 (a whole number from -2147483648 to 2147483647), "
        "got 1.5: give a fixed-point constant as its raw integer (0x8000 is 0.5 in Q16.16)"
    )
    assert refused(url, "set", "gain.x=3") == (
        prefix + "SET refused: gain.x is an in port, not a constant"
    )
    assert refused(url, "set", "gain.k=0x80000000") == (
        prefix + "SET refused: gain.k is int32 (a whole number from -2147483648 to 2147483647), "
        "got 2147483648"
    )
    assert refused(url, "set", "gain.k=-0x10000000000000000") == (
        prefix + "SET refused: gain.k is int32 (a whole number from -2147483648 to 2147483647), "
        "got -18446744073709551616"
    )
    assert refused(url, "start", "nosuch") == (
        prefix + "START refused: unknown PBO 'nosuch'; registered: 'gain'"
    )
    assert refused(url, "start", "it's") == (  # named as Python's repr names it
        prefix + "START refused: unknown PBO \"it's\"; registered: 'gain'"
    )
    assert refused(url, "rate", "gain=0.001") == (
        prefix + "RATE refused: PBO 'gain': expected a rate of 0.01 to 100000 Hz, got 0.001"
    )
    assert refused(url, "rate", "gain=100000.001") == (  # every digit: not "got 100000"
        prefix + "RATE refused: PBO 'gain': expected a rate of 0.01 to 100000 Hz, got 100000.001"
    )
    assert refused(url, "rate", "gain=4294967") == (
        prefix + "RATE refused: PBO 'gain': expected a rate of 0.01 to 100000 Hz, got 4294967.0"
    )
    assert refused(url, "connect", "gain.y=gain.k") == (
        prefix + "CONNECT refused: port 'gain.k' is a constant port; expected an input"
    )
    assert refused(url, "disconnect", "gain.y=gain.x") == (
        prefix + "DISCONNECT refused: input 'gain.x' is not connected to 'gain.y'"
    )
    held = [f"m{n:02}" for n in range(16)]  # a node holds 16 modules at most
    with open_link(url) as link:
        for tid, name in enumerate([*reversed(held), "x"]):
            link.send(encode(HoldStart(tid, name), True))
            answer = decode(link.receive(5.0) or b"")
    reason = f"HOLD refused: expected at most 16 modules held at once, got {held} and 'x'"
    assert answer == Nak(16, 0, reason, fatal=True)
    assert refused(url, "get", "gain.z") == (
        prefix + "READ refused: unknown port 'gain.z'; expected one of 'x', 'y', 'k'"
    )


def spelled(length: int, start: int = 0) -> str:
    """A name of `length` letters, each told from its neighbours (a cut in the wrong place
    shows)."""
    return "".join(chr(ord("a") + (start + i) % 26) for i in range(length))


def cut(refusal: str) -> str:
    """A refusal as a node sends it: cut at MAX_REFUSAL characters, "..." saying it goes on."""
    return refusal if len(refusal) <= MAX_REFUSAL else refusal[: MAX_REFUSAL - 3] + "..."


@pytest.mark.timeout(120)
def test_names_longer_than_any_are_refused_in_the_same_words(boot, example_hex):
    """A name longer than any PBO's or port's, in the PBO part, the port part, either side of a
    wire, is refused as the unknown name it is, quoted as far as the refusal shows it: the words
    of the Python node, cut at MAX_REFUSAL characters with "..." as there."""
    url = boot().url
    send(url, example_hex["gain"])
    prefix = "error: the node refused: "
    n = spelled(60)  # the names the user found refused in other words
    assert refused(url, "get", f"{n}.y") == (
        prefix + f"READ refused: unknown PBO {n!r}; registered: 'gain'"
    )
    assert refused(url, "set", f"gain.{n}=1") == (
        prefix + f"SET refused: unknown port 'gain.{n}'; expected one of 'x', 'y', 'k'"
    )
    assert refused(url, "connect", f"gain.y=gain.{n}") == (
        prefix + f"CONNECT refused: unknown port 'gain.{n}'; expected one of 'x', 'y', 'k'"
    )
    longest = spelled(120)  # the longest name hexmigrate's command line takes
    assert refused(url, "start", longest) == (
        prefix + f"START refused: unknown PBO {longest!r}; registered: 'gain'"
    )
    registered = "; registered: 'gain'"
    ports = "; expected one of 'x', 'y', 'k'"
    cases: list[tuple[Message, str]] = []
    # Past a PBO's 16 and a port's 29, around where a refusal's cut falls, around the 200 bytes
    # kept, and far past (test_control_fuzz.py tries every length from 150 to 260 on the host).
    for length in (17, 29, 30, 186, 199, 200, 201, 300):
        name, other = spelled(length), spelled(length, 7)
        late = f"{name[:-3]}'{name[-3:]}"  # repr quotes it in "": the cut must not drop that
        both, apart = f"{name}'\"", f"'{name}\""  # repr quotes them in '', escaping \'
        cases += [
            (StartPbo(1, late), f"START refused: unknown PBO {late!r}{registered}"),
            (StartPbo(1, apart), f"START refused: unknown PBO {apart!r}{registered}"),
            (ReadPorts(1, f"{late}.y"), f"READ refused: unknown PBO {late!r}{registered}"),
            (ReadPorts(1, f"{name}.{late}"), f"READ refused: unknown PBO {name!r}{registered}"),
            (ReadPorts(1, f"gain.{late}"), f"READ refused: unknown port {f'gain.{late}'!r}{ports}"),
            (ReadPorts(1, f"{both}.{late}"), f"READ refused: unknown PBO {both!r}{registered}"),
            (ReadPorts(1, f"gain.{both}"), f"READ refused: unknown port {f'gain.{both}'!r}{ports}"),
        ]
        cases += [
            (ReadPorts(1, f"{name}.y"), f"READ refused: unknown PBO {name!r}{registered}"),
            (ReadPorts(1, f"gain.{name}"), f"READ refused: unknown port 'gain.{name}'{ports}"),
            (ReadPorts(1, f"gain.y {name}.{other}"),
             f"READ refused: unknown PBO {name!r}{registered}"),
            (Watch(1, 50, f"gain.y {name}.y"), f"WATCH refused: unknown PBO {name!r}{registered}"),
            (Watch(1, 50, f"gain.{name} gain.y"),
             f"WATCH refused: unknown port 'gain.{name}'{ports}"),
            (SetConstant(1, f"gain.{name}=1"), f"SET refused: unknown port 'gain.{name}'{ports}"),
            (SetConstant(1, f"gain.{name}=1.5"),
             f"SET refused: unknown port 'gain.{name}'{ports}"),
            (SetConstant(1, f"{name}.{other}=1"), f"SET refused: unknown PBO {name!r}{registered}"),
            (SetConstant(1, f"{name}.{other}.k=1"),
             f"SET refused: expected PBO.port=VALUE, got '{name}.{other}.k=1'"),
            (ConnectPorts(1, f"gain.y=gain.{name}"),
             f"CONNECT refused: unknown port 'gain.{name}'{ports}"),
            (ConnectPorts(1, f"gain.{name}=gain.x"),
             f"CONNECT refused: unknown port 'gain.{name}'{ports}"),
            (ConnectPorts(1, f"{name}.y=gain.x"),
             f"CONNECT refused: unknown PBO {name!r}{registered}"),
            (ConnectPorts(1, f"gain.y={other}.{name}"),
             f"CONNECT refused: unknown PBO {other!r}{registered}"),
            (ConnectPorts(1, f"{name}.{other}={other}.x"),
             f"CONNECT refused: unknown PBO {name!r}{registered}"),
            (ConnectPorts(1, f"{name}.{other}"),
             f"CONNECT refused: expected OUT_PBO.port=IN_PBO.port, got "
             f"{f'{name}.{other}'[:60]!r}"),
            (DisconnectPorts(1, f"{name}.y=gain.{other}"),
             f"DISCONNECT refused: input 'gain.{other}' is not connected to '{name}.y'"),
            (DisconnectPorts(1, f"gain.y={name}.x"),
             f"DISCONNECT refused: input '{name}.x' is not connected to 'gain.y'"),
            (StartPbo(1, name), f"START refused: unknown PBO {name!r}{registered}"),
            (StopPbo(1, name), f"STOP refused: unknown PBO {name!r}{registered}"),
            (ClearPbo(1, name), f"CLEAR refused: unknown PBO {name!r}{registered}"),
            (SetRate(1, 10_000, name), f"RATE refused: unknown PBO {name!r}{registered}"),
            (SetRate(1, 1, name),
             f"RATE refused: PBO {name!r}: expected a rate of 0.01 to 100000 Hz, got 0.001"),
            (ReadLog(1, 0, name), f"LOGS refused: unknown PBO {name!r}{registered}"),
            (DescribePbo(1, name), f"DESCRIBE refused: unknown PBO {name!r}{registered}"),
        ]  # fmt: skip
    with open_link(url) as link:
        for number, (request, reason) in enumerate(cases):
            for text in (True, False):  # hex mode, binary mode
                tid = 2 * number + text + 1  # a request sent once: answered now, not again
                link.send(encode(replace(request, tid=tid), text))
                answer = link.receive(5.0)
                assert answer, (text, request)
                assert decode(answer) == Nak(tid, 0, cut(reason), fatal=True), (text, request)


def test_a_hold_of_a_name_beyond_ascii_in_binary_mode_is_acked_with_the_name(boot):
    """Binary mode carries any text: a HOLD of such a name is answered in its words, as a
    name that came in a binary message goes back in one (hex mode refuses the line itself)."""
    name = "g\u00e4in\U0001f600"
    with open_link(boot().url) as link:
        link.send(encode(HoldStart(5, name), False))
        answer = decode(link.receive(5.0) or b"")
    said = f"holding {name}: it stays off when it is installed, for its constants"
    assert answer == Ack(5, 0, said)


@pytest.mark.timeout(120)
def test_a_module_that_faults_goes_to_error_and_the_node_still_answers(boot, test_modules):
    url = boot().url
    send(url, test_modules["nullread"])
    send(url, test_modules["spin"])
    control(url, "start", "nullread")
    control(url, "start", "spin")
    wait_for_state(url, "nullread", "ERROR")
    wait_for_state(url, "spin", "ERROR")
    failures = re.findall(r"last failure: (.*)", control(url, "ps", "--verbose"))
    assert len(failures) == 2, failures
    where = r"cycle faulted: module '{}' at 0x[0-9A-F]{{8}} \(executor\), cycle: "
    assert re.fullmatch(
        where.format("nullread") + r"memory fault: 4-byte read at 0x00000000 \(unmapped "
        r"memory\) by the instruction at 0x[0-9A-F]{8}",
        failures[0],
    ), failures
    # the Python node counts instructions, the firmware time: "watchdog: ... budget of ..."
    assert re.fullmatch(
        where.format("spin") + r"watchdog: \w+ budget of \d+( us)? exhausted at 0x[0-9A-F]{8}",
        failures[1],
    ), failures
    assert "module(s)" in control(url, "ping")
    assert control(url, "clear", "spin").startswith("cleared spin: now OFF on ")
