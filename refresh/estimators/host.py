"""Estimators on the manager's host: `HostEstimators`, the factory of `KernelEstimator`s on a host
node that holds every module's code.

They run there, not on the robots' nodes: a candidate may use a module no robot holds yet (the
Dehazer before its migration), estimating must not take CPU from the running configuration (paper
Fig. 9: the estimators run beside it without disturbing it), and a node that is faulty or
unreachable cannot be asked what its replacement would do. So the host needs the code of every
module the database names (`host_codes`): each guest module's image, loaded into a host `Node` of
its own (an emulated CPU runs its estimator as a node's would), and each native module's class,
from the same Python file the nodes run it from (``--natives``,
`firmware_sim.core.natives.load_natives`). The host kernel is brought to the time of the
decision before each estimate (`KernelEstimator`'s `at`), so an estimator that asks the time sees
the decision's, not the host's own clock, which would still be near 0 in a virtual-time run.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from firmware_sim.core.node import Node
from firmware_sim.errors import FirmwareSimError
from hexmigrate.errors import HexmigrateError
from pbort.code import ModuleCode
from pbort.kernel import Kernel
from pbort.native import NativeModule, NativePBO
from refresh.database import ModuleDatabase
from refresh.errors import ConfigurationError
from refresh.estimators.kernel import KernelEstimator
from refresh.task import TaskSpec


class HostEstimators:
    """`KernelEstimator`s on `kernel` (the manager's host), with `codes` by module name (or
    ``Module@robot``); `inputs()` gives, at each decision, the live values estimators start from
    (``module.port``: an external input, or a constant over the database's)."""

    def __init__(
        self,
        kernel: Kernel,
        codes: Mapping[str, ModuleCode],
        database: ModuleDatabase,
        task: TaskSpec,
        inputs: Callable[[], Mapping[str, object]] = dict,
    ) -> None:
        self.kernel = kernel
        self.codes = dict(codes)
        self.database = database
        self.task = task
        self.inputs = inputs

    def __call__(self, now: float, steps: int) -> KernelEstimator:
        """A `KernelEstimator` for a decision at `now`, on the live inputs of this moment."""
        return KernelEstimator(
            self.kernel,
            self.codes,
            self.database,
            self.task,
            inputs=self.inputs(),
            steps=steps,
            at=now,
        )


def host_codes(
    database: ModuleDatabase, host: Node, natives: Mapping[str, ModuleCode]
) -> dict[str, ModuleCode]:
    """Every module's code: the natives' (by name, or ``Module@robot`` where a robot's differs)
    and each image the database names, loaded into `host`. A native the database names that
    `natives` lacks, or an image that does not load, is refused by the module's name."""
    codes: dict[str, ModuleCode] = dict(natives)
    for module in database.modules():
        image = module.source.image
        if image is None:
            if not any(key.partition("@")[0] == module.name for key in natives):
                raise ConfigurationError(
                    f"module {module.name!r} is native: expected its code among the natives "
                    f"({', '.join(sorted(natives)) or 'none'}; add yours with --natives MODULE), "
                    "got none"
                )
            continue
        if module.name in codes:
            continue
        try:
            codes[module.name] = host.load(image).code
        except (FirmwareSimError, HexmigrateError, OSError) as error:
            raise ConfigurationError(
                f"module {module.name!r}: cannot load its image {image} on the manager's "
                f"host to estimate with: {error}"
            ) from error
    return codes


def host_estimators(
    database: ModuleDatabase,
    task: TaskSpec,
    host: Node,
    natives: Mapping[str, type[NativePBO]],
    inputs: Callable[[], Mapping[str, object]] = dict,
) -> HostEstimators:
    """The runtime's estimator factory on `host`'s kernel, with every module's code
    (`host_codes`, the natives' classes as `NativeModule`s); `inputs()` the live values
    estimators start from, at each decision."""
    codes = host_codes(database, host, {name: NativeModule(cls) for name, cls in natives.items()})
    return HostEstimators(host.kernel, codes, database, task, inputs=inputs)
