"""Modules link libgcc: float and int64_t arithmetic run the same at any load address, and the
SDK's pbo_printf formats integers, text and Q16.16 into the node's log."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firmware_sim.core.memory_map import FLASH_BASE
from firmware_sim.core.node import Node
from hexmigrate.elf import image_from_elf
from module_sdk.build import ModuleBuild, build_module
from pbort.code import Method, Role, Services

GUEST = Path(__file__).parent / "guests" / "arith.c"
INPUTS = (0, 1, -1, 7, 1000, -123456, 1_000_000, -999_999)  # scaled * 1000 fits int32
ADDRESSES = (FLASH_BASE + 0x1000, FLASH_BASE + 0x2_3100)  # 256-byte blocks, far apart


@pytest.fixture(scope="module")
def arith(tmp_path_factory: pytest.TempPathFactory) -> ModuleBuild:
    return build_module(GUEST, tmp_path_factory.mktemp("arith"))


def expected(x: int) -> dict[str, int]:
    """What arith.c computes, in single precision where it uses float (each operation rounded
    to float32, as soft float does) and exactly where it uses int64_t."""
    f32 = np.float32
    scaled = f32(f32(f32(x) * f32(1.5)) / f32(3.25)) + f32(0.25)
    big = x * 1_000_000_007
    quotient = abs(big) // 12345 * (1 if big >= 0 else -1)  # C truncates toward zero
    value = f32(abs(x))
    root = value / f32(2.0) if value > f32(1.0) else f32(1.0)
    for _ in range(20):
        root = f32(0.5) * f32(root + f32(value / root))
    return {
        "scaled": int(f32(scaled * f32(1000.0))),
        "quotient": int(np.int64(quotient).astype(np.int32)),
        "remainder": abs(big) % (1 << 64) % 977,
        "root": int(f32(root * f32(1000.0))),
    }


def run_at(build: ModuleBuild, address: int) -> tuple[dict[int, dict[str, int]], list[str]]:
    """The outputs for each of INPUTS, and the lines logged, with the module loaded at `address`."""
    logged: list[str] = []
    services = Services(report=lambda *_: None, now=lambda: 0.0, log=logged.append)
    with Node() as node:
        installed = node.load(image_from_elf(build.elf), address)
        assert installed.image.load_base == address
        instance = installed.code.instantiate(Role.EXECUTOR, services)
        outputs = {}
        for x in INPUTS:
            instance.put("x", x)
            result = instance.call(Method.CYCLE)
            assert result.ok, result.fault
            outputs[x] = {port: instance.get(port) for port in expected(0)}
        instance.release()
    return outputs, logged


def test_float_and_int64_division_give_the_same_outputs_at_two_load_addresses(arith):
    first, _ = run_at(arith, ADDRESSES[0])
    second, _ = run_at(arith, ADDRESSES[1])
    assert first == second
    assert first == {x: expected(x) for x in INPUTS}


def test_pbo_printf_formats_integers_text_and_fixed_point(arith):
    _, logged = run_at(arith, ADDRESSES[0])
    assert logged[INPUTS.index(-123456)] == (
        "arith: x=-123456 [  -42|7   |beef|ABCDEF] q=-1.5000 r=3.14 s=ok!%"
    )
    assert len(logged) == len(INPUTS)
