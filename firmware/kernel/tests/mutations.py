"""Each test of tests/firmware/test_kernel_host.py fails when the behaviour it guards breaks.

Run from the repository's root: ``.venv/bin/python firmware/kernel/tests/mutations.py``. Each
mutation changes one line of the kernel, runs the tests that guard it, and puts the line back;
a mutation the tests do not catch is printed as MISSED and the exit status is 1.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
KERNEL = ROOT / "firmware" / "kernel"
TESTS = "tests/firmware/test_kernel_host.py"

# (file, line as it is, line broken, the -k expression of the tests that must fail)
MUTATIONS = [
    ("descriptor.c", "return STATUS_ERR_EXISTS;", "return STATUS_ERR_INVALID;", "refusals"),
    (
        "lifecycle.c",
        "{METHOD_ON, S(OFF), STATE_ON, STATE_ERROR}",
        "{METHOD_ON, S(OFF) | S(ERROR), STATE_ON, STATE_ERROR}",
        "lifecycle",
    ),
    (
        "pbo.c",
        "if (source == 0) {\n            instance_zero",
        "if (1) {\n            instance_zero",
        "through_the_table",
    ),
    (
        "scheduler.c",
        "return job->phase_us + index / m * REBASE_US + index % m * MILLIHERTZ_US / m;",
        "return job->phase_us + 2 * (index / m * REBASE_US + index % m * MILLIHERTZ_US / m);",
        "at_its_rate",
    ),
    ("scheduler.c", "counters->overruns += (uint32_t)(first_free - next);", "", "not_queued"),
    ("scheduler.c", "job->phase_us = now / REBASE_US * REBASE_US;", "job->phase_us = now;", "grid"),
    (
        "kernel_run.c",
        "(job->priority == best->job.priority && pbo->flow < best->flow)",
        "(job->priority == best->job.priority && pbo->serial < best->serial)",
        "flow",
    ),
    ("flow_order.c", "next->flow = rank;", "next->flow = 0;", "flow"),
    (
        "performance.c",
        "    value->value_milli = value_milli;",
        "    value->value_milli = 0 * value_milli;",
        "evaluator",
    ),
    (
        "kernel_observe.c",
        "power_advance(&kernel.power, kernel_now_us(), draw);",
        "power_advance(&kernel.power, kernel_now_us(), kernel.power.base_draw_uw);",
        "leftover_power",
    ),
    (
        "services.c",
        "if (direction != DIRECTION_OUT && direction != DIRECTION_RESOURCE) {",
        "if (0) {",
        "fault_the_module",
    ),
    (
        "descriptor.c",
        "if (port_count > ABI_MAX_PORTS) {",
        "if (port_count > 0xFFFF) {",
        "fuzzed",
    ),
    ("descriptor.c", "if (c >= 0x80) {", "if (c >= 0xFF) {", "fuzzed"),
    (
        "sram.c",
        "            if (gap_size(i) >= rounded) {",
        "            if (gap_size(i) + 8 >= rounded) {",
        "never_covers",
    ),
    (
        "estimator.c",
        "            instance_put(&run.instance, module, port, input_of(port));",
        "",
        "estimator",
    ),
    (
        "estimator.c",
        "        } else if (module->ports[port].direction != DIRECTION_OUT) {\n"
        "            instance_put(&run.instance, module, port, live);",
        "        } else if (0) {",
        "estimator",
    ),
    (
        "timekeeping.c",
        "    keeping->free_us = modelled;",
        "    keeping->free_us = 0;",
        "slip",
    ),
    (
        "scheduler.c",
        "(first_free - (modelled > next ? modelled",
        "(first_free - (modelled < next ? modelled",
        "slip",
    ),
    (
        "module_log.c",
        "while (kept.end - dropped + size > MODULE_LOG_BYTES)",
        "while (kept.end - dropped + size >= MODULE_LOG_BYTES)",
        "module_log",
    ),
    ("abi.h", "#define ABI_OFFSET_METHODS 188u", "#define ABI_OFFSET_METHODS 184u", "freestanding"),
    (
        "text.c",
        "    text_add_bytes(text, string, text_length(string, UINT32_MAX));",
        "    extern unsigned long strlen(const char *);\n"
        "    text_add_bytes(text, string, (uint32_t)strlen(string));",
        "freestanding",
    ),
]


def caught(name: str, line: str, broken: str, tests: str) -> bool:
    """Whether the tests `tests` fail with `line` of `name` broken; the file is put back."""
    path = KERNEL / name
    original = path.read_text()
    if line not in original:
        raise SystemExit(f"error: {name} no longer holds {line!r}: update the mutation")
    path.write_text(original.replace(line, broken, 1))
    try:
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "pytest",
                "-q",
                "-x",
                "-k",
                tests,
                TESTS,
                "-p",
                "no:cacheprovider",
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=900,
        )
    finally:
        path.write_text(original)
    return done.returncode != 0


def main() -> int:
    missed = 0
    for name, line, broken, tests in MUTATIONS:
        found = caught(name, line, broken, tests)
        missed += not found
        print(f"{'caught' if found else 'MISSED'}  {name}: {line.strip()[:60]!r} ({tests})")
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
