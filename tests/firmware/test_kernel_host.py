"""The firmware's PBO/RT kernel (firmware/kernel/, C) on the host: compiled with the address and
undefined-behaviour sanitizers behind a fake board (firmware/kernel/tests/host_driver.c: guest
memory in arrays, a virtual clock, modules as C functions with descriptors from fake_module.c),
it refuses, switches, wires, schedules and accounts as the Python kernel does; and it builds
freestanding for RV32IM.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_sim.core.guest import AreaLayout
from hexmigrate import descriptor as abi
from hexmigrate.errors import AbiMismatchError, DescriptorError

ROOT = Path(__file__).resolve().parents[2]
KERNEL = ROOT / "firmware" / "kernel"
HOST_FLAGS = ["-std=c11", "-Wall", "-Wextra", "-Werror", "-fsanitize=address,undefined", "-g"]
RV32_FLAGS = [  # firmware/firmware.mk's, without an include path: the kernel needs none
    "-march=rv32im_zicsr",
    "-mabi=ilp32",
    "-nostdlib",
    "-ffreestanding",
    "-Os",
    "-ffunction-sections",
    "-fdata-sections",
    "-fno-common",
]
DESCRIPTOR = 224


def kernel_sources() -> list[str]:
    return sorted(str(path) for path in KERNEL.glob("*.c"))


@pytest.fixture(scope="module")
def driver(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The kernel and the host driver, compiled with the sanitizers."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not installed")
    binary = tmp_path_factory.mktemp("kernel") / "host_driver"
    subprocess.run(
        [
            "gcc",
            *HOST_FLAGS,
            f"-I{KERNEL}",
            *kernel_sources(),
            str(KERNEL / "tests" / "host_driver.c"),
            str(KERNEL / "tests" / "fake_module.c"),
            "-o",
            str(binary),
        ],
        check=True,
    )
    return binary


def run(driver: Path, scenario: str, stdin: str = "") -> dict[str, str]:
    """`key=value` lines of one scenario; any sanitizer finding fails the test."""
    done = subprocess.run(
        [str(driver), scenario], input=stdin, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0 and "runtime error" not in done.stderr, done.stderr
    lines = [line.partition("=") for line in done.stdout.splitlines()]
    return {key: value for key, _, value in lines}


def test_registration_refusals_carry_the_python_nodes_status(driver: Path) -> None:
    seen = run(driver, "register")
    statuses = {key.removeprefix("register."): int(value.split()[0]) for key, value in seen.items()}
    assert statuses == {
        "ok": 0,
        "exists": -4,
        "magic": -2,
        "abi": -2,
        "dup": -1,
        "shape": -1,
        "size3": -1,
        "name": -1,
        "huge": -3,
        "method": -1,
        "outside": -1,
        "ports": -1,
    }
    assert "a module 'first' is already loaded" in seen["register.exists"]
    assert "expected a vector of 1xN (one row), got 2x3" in seen["register.shape"]
    assert "expected distinct, non-empty port names, got ['x', 'x']" in seen["register.dup"]


def test_lifecycle_transitions_are_refused_as_python_refuses_them(driver: Path) -> None:
    seen = run(driver, "lifecycle")
    assert seen["on_before_init"] == (
        "-11 PBO 'gain': cannot on from state NOT_CREATED; allowed from OFF"
    )
    assert seen["start_unconfigured"] == (
        "-12 PBO 'gain': on returned -1; now ERROR; it logged: gain: k is not configured"
    )
    assert seen["on_in_error"] == "-11 PBO 'gain': cannot on from state ERROR; allowed from OFF"
    assert seen["set_while_on"] == (
        "-11 PBO 'gain': cannot configure 'k' in state ON; allowed in NOT_CREATED, OFF"
    )
    assert seen["kill_while_on"] == (
        "-11 PBO 'gain': cannot kill from state ON; allowed from OFF, ERROR"
    )
    assert seen["set_range"].startswith("-11 gain.k is int32 (a whole number from")
    assert seen["set_input"] == "-11 gain.x is an in port, not a constant"
    assert (seen["clear"], seen["start"], seen["stop"], seen["kill"]) == ("0 ", "0 ", "0 ", "0 ")
    assert seen["state.gain"] == "KILLED"
    assert seen["unknown"] == "-10 unknown PBO 'nope'; registered: 'gain'"
    assert seen["stop_unknown"] == "-10 unknown PBO 'nope'; registered: 'gain'"
    assert seen["failure.gain"] == "on returned -1"


def test_gain_output_goes_through_the_table_and_a_connection(driver: Path) -> None:
    seen = run(driver, "wiring")
    assert seen["connect_wrong_way"] == "-11 port 'gain.x' is an input port; expected an output"
    assert seen["connect_const"] == "-11 port 'gain.k' is a constant port; expected an input"
    assert seen["connect_to_nothing"] == "-10 unknown port 'ramp.z'; expected one of 'y'"
    assert seen["connect_again"].startswith("-11 input 'gain.x' is already connected to 'ramp.y'")
    # ramp registered first runs first at each instant: gain sees its value with latency 0
    assert (seen["read.ramp.y"], seen["read.gain.x"], seen["read.gain.y"]) == ("100", "100", "300")
    assert seen["ran"] == "200"
    assert seen["stats.gain"].startswith("cycles:100 missed:0 overruns:0 long:0 faults:0")
    assert seen["disconnect_wrong"] == "-11 input 'gain.x' is not connected to 'gain.y'"
    assert seen["disconnected.gain.y"] == "0"  # disconnected: x reads its zero value


def test_a_pbo_runs_at_its_rate(driver: Path) -> None:
    seen = run(driver, "rate")
    assert seen["rate_low"].startswith("-11 PBO 'slow': expected a rate of 10 to 100000000 mHz")
    assert seen["ran"] == "25"  # 25 Hz for one second
    assert seen["stats.slow"].startswith("cycles:25 missed:0 overruns:0 long:0")


def test_on_releases_at_once_then_on_the_period_s_grid_from_the_clock_s_zero(driver: Path) -> None:
    # as tests/pbort/test_scheduler.py's: switched on at 50 and 420 ms, off at 300 ms, 10 Hz
    done = subprocess.run([str(driver), "grid"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and "runtime error" not in done.stderr, done.stderr
    lines = done.stdout.splitlines()
    cycles = [int(line.removeprefix("cycle_at=")) for line in lines if "cycle_at=" in line]
    assert cycles == [50_000, 100_000, 200_000, 420_000, 500_000]


def test_a_chain_registered_against_its_flow_crosses_in_one_period(driver: Path) -> None:
    # as tests/pbort/test_scheduler.py's: ties go by the wiring, not by registration
    seen = run(driver, "flow")
    assert seen["connect_first"].strip() == seen["connect_second"].strip() == "0"
    assert seen["read.ramp.y"] == seen["read.second.y"] == "100"


def test_a_job_longer_than_its_period_is_counted_not_queued(driver: Path) -> None:
    # docs/pbort.md: 100 Hz, 12 ms cycles: 50 cycles, 50 missed deadlines, 50 overruns
    seen = run(driver, "overrun")
    assert seen["stats.hog"].startswith("cycles:50 missed:50 overruns:50 long:50 faults:0")


def test_evaluator_values_and_leftover_power(driver: Path) -> None:
    seen = run(driver, "evaluator")
    # after 100 cycles the evaluator reported 0.5 mW + 1 µW a cycle, y = k * x = 0
    assert (seen["perf.F0"], seen["perf.N0"]) == ("0", "600")
    assert int(seen["leftover"]) == 99998  # 1 s at ~50.5 mW of 3600 J
    # an hour at 50 mW base plus 0.5 mW + 100 µW/s growing: 3600 s x (50.5 + 180) mW = 829.8 J
    assert int(seen["leftover_hour"]) == pytest.approx(100_000 * (3600 - 829.8) / 3600, abs=5)


def test_bad_service_arguments_fault_the_module_into_error(driver: Path) -> None:
    seen = run(driver, "faults")
    for name, said in (
        ("writer", "PORT_WRITE: expected an OUT or RESOURCE port, got port 0 ('x')"),
        ("foreign", "PERF_REPORT: expected the context 0x"),
        ("reader", "inside the task window or the stack, got a buffer in SRAM"),
    ):
        assert seen[f"state.{name}"] == "ERROR"
        assert seen[f"failure.{name}"].startswith("cycle faulted: module ")
        assert said in seen[f"failure.{name}"]


def test_a_module_area_never_covers_another_pbos_variable(driver: Path) -> None:
    # a freed 64-byte block before two output variables is not reused for a 72-byte area
    seen = run(driver, "isolation")
    assert seen["spawn_d"] == "0 "
    assert seen["read.c.y0"] == "77"


def test_an_estimator_runs_beside_the_live_configuration(driver: Path) -> None:
    seen = run(driver, "estimator")
    assert seen["open_ramp"] == (
        "-11 module 'ramp' has no estimate method; only E-PBOs can run in a shadow run"
    )
    assert seen["open_twice"] == "-11 a shadow run of 'gain' is open; close it first"
    assert seen["give_output"].startswith("-11 port 'gain.y' is an out port")
    # the live input's snapshot (ramp.y = 10), the given k = 5: y = 50, reported as F0
    assert (seen["estimate.gain.x"], seen["estimate.gain.y"]) == ("10 ", "50 ")
    assert (seen["done"], seen["estimate.perf.F0"]) == ("2", "50")
    assert seen["give_late"].startswith("-11 the shadow run of 'gain' has started")
    assert (seen["done_failing"], seen["estimate.failure"]) == (
        "0",
        "estimate returned -1 at step 1",
    )
    assert seen["estimate.live.y"] == "30"  # without given values: the live k = 3 and x = 10
    # the live PBO kept its constant, its rate and its counters
    assert (seen["read.gain.k"], seen["read.gain.y"]) == ("3", "60")
    assert seen["stats.gain"].startswith("cycles:20 missed:0 overruns:0 long:0 faults:0")


def test_slip_and_missed_releases_when_the_firmware_was_busy_elsewhere(driver: Path) -> None:
    # 100 Hz, 50 µs jobs; the firmware is away from 500 to 550 ms: the job released at 500 ms
    # runs 50 ms late (its slip), the releases at 510..550 ms are skipped: missed on a slip
    seen = run(driver, "slip")
    assert seen["slip"] == "50000 missed=5"
    assert seen["slip_since_600ms"] == "0"
    assert seen["stats.gain"].startswith("cycles:95 missed:1 overruns:5 long:0 faults:0")


def test_a_job_late_because_another_held_the_cpu_did_not_slip(driver: Path) -> None:
    # 10 Hz hog (12 ms jobs) and gain released at the same instants: gain starts 12 ms late
    # every time, as the model says, so nothing slipped
    seen = run(driver, "busy")
    assert seen["slip"] == "0 missed=0"
    # hog at 100 Hz runs every 20 ms in the model; away from 500 to 550 ms: its job released at
    # 500 ms slips 50 ms; of the releases it then skips (510..560 ms), 520..560 count as missed:
    # 510 ms the model skipped too
    assert seen["long_slip"] == "50000 missed=5"


def test_module_log_keeps_the_newest_lines_numbered(driver: Path) -> None:
    done = subprocess.run([str(driver), "log"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "runtime error" not in done.stderr, done.stderr
    lines = done.stdout.splitlines()
    assert "logged=100" in lines
    after, _, everything = "\n".join(lines).partition("since0\n")
    assert after.splitlines()[-3:] == [
        "line=98 970000 tick 98",
        "line=99 980000 tick 99",
        "line=100 990000 tick 100",
    ]
    kept = [line.split()[0] for line in everything.splitlines()]
    numbers = [int(word.removeprefix("line=")) for word in kept]
    # the newest, oldest first, none skipped; as many as the 1536-byte log holds (a short line
    # takes 32 bytes with its header): the oldest were dropped to bound the RAM
    assert numbers == list(range(53, 101))


def test_the_loaders_seam_registers_under_the_descriptors_name(driver: Path) -> None:
    seen = run(driver, "loader")
    assert seen["installed_misnamed"] == (
        "it registers a PBO named 'gain' but its descriptor is named 'other'"
    )
    assert seen["pbos_after_refusal"] == "0"
    assert (seen["installed"], seen["row"]) == ("", "gain NOT_CREATED 100000")
    assert seen["replaced"] == " count=1"
    assert seen["pbos_after_removal"] == "0"


GUESTS = [
    ROOT / "module_sdk" / "examples" / "gain.c",
    ROOT / "module_sdk" / "examples" / "moving_average.c",
    ROOT / "visual_servoing" / "guest" / "dehazer.c",
    ROOT / "patrol" / "guest" / "kalman.c",
    ROOT / "patrol" / "guest" / "pursuit.c",
]


@pytest.mark.parametrize("source", GUESTS, ids=lambda path: path.stem)
def test_the_repositorys_modules_register_with_the_ports_python_decodes(
    driver: Path, tmp_path: Path, source: Path
) -> None:
    """The SDK's build of a real module, placed at its link base: the C kernel accepts its
    descriptor and lists the ports hexmigrate decodes from the same bytes."""
    if shutil.which("riscv64-unknown-elf-gcc") is None:
        pytest.skip("riscv64-unknown-elf-gcc is not installed")
    from module_sdk.build import build_module

    built = build_module(source, tmp_path)
    data = built.bin.read_bytes()
    descriptor = abi.Descriptor.decode(data[-DESCRIPTOR:])  # the image's last part
    seen = subprocess.run(
        [str(driver), "image", str(built.bin)], capture_output=True, text=True, timeout=60
    )
    assert seen.returncode == 0 and "runtime error" not in seen.stderr, seen.stderr
    kinds = {"scalar": 0, "vector": 1, "frame": 2}
    directions = {"in": 0, "out": 1, "const": 2, "resource": 3}
    assert seen.stdout.splitlines() == [
        "register=0 ",
        f"pbo={descriptor.name} NOT_CREATED",
        *(
            f"port={p.name} {directions[p.direction]} {kinds[p.type]} {p.element_size}"
            for p in descriptor.ports
        ),
    ]


def port_bytes(name: bytes, direction: int, kind: int, size: int, rows: int, cols: int) -> bytes:
    return (
        name[:12].ljust(12, b"\0")
        + bytes([direction, kind])
        + size.to_bytes(2, "little")
        + rows.to_bytes(2, "little")
        + cols.to_bytes(2, "little")
    )


NAMES = st.one_of(st.binary(max_size=16), st.sampled_from([b"gain", b"x", b"_a1", b"9", b""]))
PORTS = st.builds(
    port_bytes,
    st.one_of(st.binary(max_size=12), st.sampled_from([b"x", b"y", b"k"])),
    st.integers(0, 5),
    st.integers(0, 4),
    st.sampled_from([0, 1, 2, 3, 4, 8, 0xFFFF]),
    st.sampled_from([0, 1, 2, 64, 0xFFFF]),
    st.sampled_from([0, 1, 3, 100, 0xFFFF]),
)


@st.composite
def descriptors(draw: st.DrawFn) -> bytes:
    """Mostly well-formed descriptors with one field pushed off the rails, or raw bytes."""
    if draw(st.booleans()):
        return draw(st.binary(min_size=DESCRIPTOR, max_size=DESCRIPTOR))
    magic = draw(st.sampled_from([0x314F4250, 0x314F4251, 0]))
    ports = draw(st.lists(PORTS, max_size=8))
    count = draw(st.one_of(st.just(len(ports)), st.integers(0, 0xFFFF)))
    methods = draw(
        st.lists(
            st.sampled_from([0, 0x08000004, 0x08000008, 0x08000002, 0x08000200, 0xFFFFFFFC]),
            min_size=9,
            max_size=9,
        )
    )
    body = (
        magic.to_bytes(4, "little")
        + draw(st.sampled_from([1, 1, 1, 2])).to_bytes(2, "little")
        + count.to_bytes(2, "little")
        + draw(NAMES)[:16].ljust(16, b"\0")
        + draw(st.sampled_from([0, 12, 4096, 0xFFFFFFFF])).to_bytes(4, "little")
        + b"".join(ports).ljust(160, b"\0")
        + b"".join(m.to_bytes(4, "little") for m in methods)
    )
    assert len(body) == DESCRIPTOR
    return body


IMAGE = range(0x0800_0000, 0x0800_0200)  # the fuzz driver's module image
WINDOW, SRAM = 65536, 131072  # its task window and SRAM, all free between descriptors
WHERE = "module image at 0x08000000, init subroutine at 0x08000000: "


def python_verdict(data: bytes) -> str:
    """What the Python node answers to REGISTER with `data` (firmware_sim's Registrar), as the
    driver prints the C kernel's answer: the status, then the refusal."""
    image = f"module image at 0x{IMAGE.start:08X}..0x{IMAGE.stop - 1:08X}"
    try:
        descriptor = abi.Descriptor.decode(data)
    except AbiMismatchError as error:
        return f"-2 {WHERE}REGISTER refused (ERR_ABI): {error}"
    except DescriptorError as error:
        return f"-1 {WHERE}REGISTER refused (ERR_INVALID): {error}"
    name = descriptor.name
    names = [port.name for port in descriptor.ports]
    if len(set(names)) != len(names):
        reason = f"module {name!r}: expected distinct, non-empty port names, got {names}"
        return f"-1 {WHERE}REGISTER refused (ERR_INVALID): {reason}"
    for method, address in descriptor.methods.items():
        if address and (address not in IMAGE or address % 4):
            reason = (
                f"module {name!r}: expected method {method} at a 4-byte aligned address inside "
                f"the {image}, got 0x{address:08X}"
            )
            return f"-1 {WHERE}REGISTER refused (ERR_INVALID): {reason}"
    size = AreaLayout.of(descriptor).size
    if size > min(WINDOW, SRAM):
        reason = (
            f"module {name!r}: needs a {size}-byte area, but the task window holds {WINDOW} "
            f"bytes and the largest free SRAM block is {SRAM} bytes"
        )
        return f"-3 {WHERE}REGISTER refused (ERR_NO_MEMORY): {reason}"
    return "0 "


@settings(max_examples=300, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(descriptors(), min_size=1, max_size=40))
def test_fuzzed_descriptors_get_the_python_nodes_answer_without_sanitizer_findings(
    driver: Path, batch: list[bytes]
) -> None:
    done = subprocess.run(
        [str(driver), "fuzz"],
        input="".join(d.hex() + "\n" for d in batch),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0 and "runtime error" not in done.stderr, done.stderr
    answers = done.stdout.splitlines()
    assert len(answers) == len(batch)
    for data, answer in zip(batch, answers, strict=True):
        expected = python_verdict(data)
        # the kernel's message buffer holds 239 characters: a longer refusal is cut there
        assert answer == expected[: len(answer)] and len(answer) >= min(len(expected), 239)


def test_kernel_builds_freestanding_for_rv32im(tmp_path: Path) -> None:
    """Every file compiles for RV32IM without libc (abi_check.c checks the layout against
    pbo_module.h there), and the objects need nothing but libgcc's 64-bit arithmetic and the
    memcpy/memset every freestanding gcc program may call."""
    if shutil.which("riscv64-unknown-elf-gcc") is None:
        pytest.skip("riscv64-unknown-elf-gcc is not installed")
    objects = []
    for source in kernel_sources():
        target = tmp_path / (Path(source).stem + ".o")
        subprocess.run(
            [
                "riscv64-unknown-elf-gcc",
                *RV32_FLAGS,
                "-std=c11",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-c",
                source,
                "-o",
                str(target),
            ],
            check=True,
        )
        objects.append(str(target))
    linked = tmp_path / "kernel_linked.o"
    subprocess.run(
        ["riscv64-unknown-elf-ld", "-melf32lriscv", "-r", *objects, "-o", str(linked)], check=True
    )
    undefined = subprocess.run(
        ["riscv64-unknown-elf-nm", "-u", str(linked)], capture_output=True, text=True, check=True
    ).stdout.split()
    needed = set(undefined) - {"U", "memcpy", "memset", "memmove"}
    assert all(name.startswith("__") and name.endswith("di3") for name in needed), needed
