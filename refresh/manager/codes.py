"""The manager's host holds every module's code, to estimate with.

The estimators run on the manager's host, not on the nodes (see `refresh.runtime.estimators`
for why): a candidate may use a module no node holds yet, and a faulty node cannot be asked what
its replacement would do. So the host needs the code of every module the database names: each
guest module's image, loaded into a host `Node` of its own (an emulated CPU runs its estimator
as a node's would), and each native module's class, from the same Python file the nodes run it
from (``--natives``, `firmware_sim.core.natives.load_natives`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from firmware_sim.core.node import Node
from firmware_sim.errors import FirmwareSimError
from hexmigrate.errors import HexmigrateError
from pbort.code import ModuleCode
from pbort.native import NativeModule, NativePBO
from refresh.database import ModuleDatabase
from refresh.errors import ConfigurationError
from refresh.runtime import HostEstimators
from refresh.task import TaskSpec


def host_codes(
    database: ModuleDatabase, host: Node, natives: Mapping[str, type[NativePBO]]
) -> dict[str, ModuleCode]:
    """Every module's code by name: each image the database names loaded into `host`, each
    native module's class from `natives` (by PBO name). A native the database names that
    `natives` lacks, or an image that does not load, is refused by the module's name."""
    codes: dict[str, ModuleCode] = {}
    for schema in database.schemas.values():
        for module in schema.modules:
            if module.name in codes:
                continue
            image = module.source.image
            if image is None:
                codes[module.name] = NativeModule(_native(module.name, natives))
                continue
            try:
                codes[module.name] = host.load(image).code
            except (FirmwareSimError, HexmigrateError, OSError) as error:
                raise ConfigurationError(
                    f"module {module.name!r}: cannot load its image {image} on the manager's "
                    f"host to estimate with: {error}"
                ) from error
    return codes


def _native(name: str, natives: Mapping[str, type[NativePBO]]) -> type[NativePBO]:
    native = natives.get(name)
    if native is None:
        raise ConfigurationError(
            f"module {name!r} is native: expected its NativePBO class among the natives "
            f"({', '.join(sorted(natives))}; add yours with --natives MODULE), got none"
        )
    return native


def host_estimators(
    database: ModuleDatabase,
    task: TaskSpec,
    host: Node,
    natives: Mapping[str, type[NativePBO]],
    inputs: Callable[[], Mapping[str, object]] = dict,
) -> HostEstimators:
    """The runtime's estimator factory on `host`'s kernel, with every module's code
    (`host_codes`); `inputs()` the live values estimators start from, at each decision."""
    return HostEstimators(
        host.kernel, host_codes(database, host, natives), database, task, inputs=inputs
    )
