"""What ``firmware-sim run`` reports: a dictionary (its ``--json``) and the text it shows."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np

from firmware_sim.core.node import Node
from pbort.code import ModuleCode


def run_report(node: Node, codes: dict[str, ModuleCode], jobs: int) -> dict[str, Any]:
    """The node after a run: time, jobs, modules, every port of `codes`, PBO stats, power, log."""
    kernel = node.kernel
    return {
        "time": kernel.now,
        "jobs": jobs,
        "modules": [
            {
                "name": m.name,
                "load_address": m.load_address,
                "size": m.image.size,
                "flash_blocks": m.flash_blocks,
            }
            for m in node.modules.values()
        ],
        "ports": {
            f"{name}.{port.name}": _plain(kernel.value(f"{name}.{port.name}"))
            for name, code in codes.items()
            for port in code.ports
        },
        "stats": {
            name: {**asdict(kernel.stats(name)), "state": kernel.state(name).name}
            for name in kernel.names
        },
        "power": {
            "draw_mw": node.power.draw,
            "used_j": node.power.used,
            "leftover": node.power.leftover,
            "draws_mw": dict(node.power.draws),
        },
        "log": [{"time": time, "text": text} for time, text in node.log],
    }


def render(report: dict[str, Any]) -> str:
    """`report` as the lines a terminal shows."""
    lines = [f"ran {report['time']:.3f} s of virtual time, {report['jobs']} jobs", "modules"]
    lines += [
        f"  {m['name']:<16} 0x{m['load_address']:08X}  {m['size']} bytes in "
        f"{len(m['flash_blocks'])} flash block(s)"
        for m in report["modules"]
    ]
    lines.append("PBOs")
    lines.append(
        f"  {'PBO':<16} {'state':<10}{'cycles':>8}{'missed':>8}{'overruns':>10}{'long':>6}"
        f"{'faults':>8}{'instructions':>14}{'busy ms':>10}"
    )
    lines += [
        f"  {name:<16} {s['state']:<10}{s['cycles']:>8}{s['missed_deadlines']:>8}"
        f"{s['overruns']:>10}{s['long_jobs']:>6}{s['faults']:>8}{s['instructions']:>14}"
        f"{s['busy_time'] * 1e3:>10.3f}"
        for name, s in report["stats"].items()
    ]
    lines.append("ports")
    lines += [f"  {port} = {value}" for port, value in report["ports"].items()]
    power = report["power"]
    lines.append(
        f"power: draw {power['draw_mw']:.1f} mW, used {power['used_j']:.4f} J, "
        f"leftover {power['leftover']:.2f} / 100"
    )
    lines += [f"log {entry['time']:.4f} s: {entry['text']}" for entry in report["log"]]
    return "\n".join(lines)


def _plain(value: object) -> Any:
    """A port value JSON can hold."""
    return value.tolist() if isinstance(value, np.ndarray) else value
