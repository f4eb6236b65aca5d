"""The runtime: ReFrESH watching a task, deciding and repairing, for any task and applier.

The caller owns the world and the clock (virtual or real) and tells the runtime when a decision
period has passed: either it advances the world itself and calls `step()` once per
`decision_period` (the visual-servoing experiment does, sampling every camera frame in between),
or it hands `run(until, advance)` a function that lets the world run on for some seconds.

`deploy()` starts the task's initial configuration through the Maintainer's plan, as any later one.
At each `step()` the Decider reads the evaluators' reports (`applier.sources()`) and judges the
period; a look less than `settle` seconds after a switch counts towards no detection (the new
configuration's loop settles first), so a fault is declared `debounce` violating looks after it
at the earliest. Acting on it is one decision (`refresh.adaptation.decide`: locate with the
task's strategy, Base Choice by default; synthesize around each faulty module; choose),
estimated by a fresh estimator from the caller's factory, then the plan to the chosen
configuration applied (images migrate first, while the old configuration runs on), or, when
nothing helps, a safe stop: every module of the task is stopped and nothing runs. After a
switch, the task counts as recovered once P_T has stayed 1 for `recovery_hold` seconds; the
recovery is dated from when P_T first came back.

The applier may let the world run while it works (a migration over a slow wire): a `step()` that
comes meanwhile judges as usual but starts no second decision. Every event goes to `log`, on the
runtime's clock.

Outages (docs/refresh.md, "Outages"): each `step()` first asks the applier which robots' nodes
are lost (`lost_after` seconds silent, or gone). A newly lost robot is marked lost in the
database (equation (1) fails any configuration that places a module there), and when the
running configuration uses it the runtime repairs at once, without the debounce or the settle
(the loss is a fact, not a noisy sample): the Locator and Generator then find configurations on
the robots that remain. A lost robot is tried again every `lost_after` seconds; once its node
answers, the runtime reads what it has (its modules in flash, its PBOs and their states), stops
any module of the task it still runs outside the running configuration, and counts its
resources again. A loss that no configuration on the remaining robots repairs stops the task
safely with a reason that names the lost node first (Base Choice's verdict, "more than one fault
suspected", alone reads as two faulty modules).

Module logs: each `step()` also records, as `module_log` events, the lines the robots' modules
logged since the last (`applier.module_logs()`), so that a module saying why it misbehaves is
heard in the manager's output, beside the decisions it led to.

Real time (docs/refresh.md, "Real time"): each `step()` then asks the applier which nodes
slipped behind real time since the last (their reports say: `pbort.timekeeping`) and `host_slip`
how late the caller's own loop came. A period in which one slipped more than `slip_tolerance`
is not judged: its measurements were taken by an emulator that fell behind, and a fault read
into them would repair the wrong thing. Such a period neither counts towards a detection (the
violations seen so far are forgotten) nor towards or against a recovery (only judged periods
make up its hold), nor do the periods within `settle` of real time held again, while the loop
catches up. "real time lost on NODE by X ms" is recorded when it starts, "real time held
again" when a period is clean. When nothing could be judged for `real_time_patience` seconds
(real time lost, or the loop catching up after), the run stops with `RealTimeLost`, between
decisions, never halfway through one.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from commandline import one_line
from pbort.module_log import EchoLimit
from refresh.adaptation import decide
from refresh.appliers.base import ApplierBase, Inventory
from refresh.configuration import Configuration, initial_configuration
from refresh.database import ModuleDatabase
from refresh.decider import Decider, Detection
from refresh.errors import ConfigurationError, NodeLinkError, RealTimeLost, RefreshError
from refresh.estimators.base import EstimatorFactory
from refresh.events import EventLog
from refresh.location import brute_force, compare
from refresh.maintainer import Maintainer
from refresh.runtime.history import History, Reconfiguration
from refresh.runtime.rates import check_rates
from refresh.runtime.settings import RuntimeSettings
from refresh.task import TaskSpec

_EPSILON = 1e-9
"""Seconds: two times closer than this are one (sums of periods are not exact)."""


class Runtime:
    """ReFrESH's run loop for `task` over `database`, applying plans through `applier`,
    estimating with what `estimators` makes per decision, on `clock` (seconds of the run).

    A caller that drives it may set two hooks: `on_rejoin(robot, inventory)` is told of each
    lost robot once it is back and counted again (what its node had when it answered), and
    `on_switch(configuration)` of each configuration once it runs (the caller may need to know
    which module now drives what). A database whose metric modules report slower than the
    Decider looks is refused (`RateError`, see `refresh.runtime.rates`).
    """

    def __init__(
        self,
        database: ModuleDatabase,
        task: TaskSpec,
        applier: ApplierBase,
        estimators: EstimatorFactory,
        clock: Callable[[], float],
        settings: RuntimeSettings | None = None,
    ) -> None:
        self.settings = settings if settings is not None else RuntimeSettings()
        check_rates(database, task, self.settings.decision_period)
        self.database = database
        self.task = task
        self.applier = applier
        self.estimators = estimators
        self.clock = clock
        self.on_switch: Callable[[Configuration], None] | None = None
        self.on_rejoin: Callable[[str, Inventory], None] | None = None
        self.host_slip: Callable[[], float] = lambda: 0.0
        """How late (s) the caller's own loop came since it was last asked (a real-time
        session's sleeps under load); 0 on a virtual clock."""
        self.log = EventLog(clock=clock, start=0.0)
        """Every event, dated by the runtime's clock."""
        self.maintainer = Maintainer(database, applier, self.log)
        self.decider = Decider(task, database, self.log, self.settings.debounce)
        self.history = History()
        self.current: Configuration | None = None
        """What runs: None before `deploy()` and after a safe stop."""
        self._good_since: float | None = None  # P_T = 1 since then, after a switch
        self._good_periods = 0  # judged periods with P_T = 1 after `_good_since`
        self._deciding = False  # a decision is being carried out: no second one meanwhile
        self._tried: dict[str, float] = {}  # a lost robot -> when it was last tried again
        self._why: dict[str, str] = {}  # a lost robot -> why its node was declared lost
        self._slipping_since: float | None = None  # real time lost since then
        self._held_at: float | None = None  # real time held again then, after it was lost
        self._unjudged_since: float | None = None  # no period judged since then, lacking time
        self._echo: dict[str, EchoLimit] = {}  # by robot: its modules' lines shown per second

    def deploy(self) -> Configuration:
        """Start the task's initial configuration (its modules, constants and wiring) and return
        it; a runtime deploys once."""
        if self.history.configurations:
            raise ConfigurationError(
                f"task {self.task.name!r}: expected a runtime that has not deployed yet, got one "
                f"that deployed at {self.history.configurations[0][0]:g} s"
            )
        target = initial_configuration(self.task, self.database)
        self._switch(target)
        return target

    @property
    def deciding(self) -> bool:
        """Whether a decision is being carried out (the world may run meanwhile: a migration's
        time)."""
        return self._deciding

    def value(self, schema: str, port: str) -> float:
        """A scalar port of the module filling `schema` in the running configuration, on
        whichever robot it runs."""
        return self.applier.read(*self.where(schema, port))

    def where(self, schema: str, port: str) -> tuple[str, str]:
        """Where a port of the module filling `schema` in the running configuration is: its
        robot and its name there (``instance.port``)."""
        if self.current is None:
            raise ConfigurationError(
                f"read {schema}.{port}: expected a running configuration, got none"
            )
        instance = self.current.instance_of(schema)
        return self.current.robot_of(instance), f"{instance}.{port}"

    def run(self, until: float, advance: Callable[[float], None]) -> None:
        """Let the world run to `until` seconds, one decision period at a time (`advance(s)` runs
        it `s` seconds further), with a `step()` after each period. An `advance` that leaves the
        runtime's clock where it was is refused: the loop would never end."""
        period = self.settings.decision_period
        while (now := self.clock()) < until - _EPSILON:
            advance(min(period, until - now))
            if self.clock() <= now:
                raise ConfigurationError(
                    f"advance({min(period, until - now):g}): expected the runtime's clock to move "
                    f"on from {now:g} s, got {self.clock():g} s (is the clock the world's?)"
                )
            self.step()

    def step(self) -> Detection | None:
        """One decision period: judge, watch a recovery, and act on a declared fault. Returns
        the Decider's detection, if it declared one."""
        lost = self._watch_nodes()
        self._record_module_logs()
        for why in self.applier.stopped_bridges():
            self.log.record("bridge_stopped", why)
        slipping = self._watch_real_time()
        if self.current is None:
            return None
        if self._deciding:
            lost = set()  # the decision under way repairs first; the loss is acted on after it
        if lost & set(self.current.robots):
            self._deciding = True
            try:
                self._repair(self.current, sorted(lost & set(self.current.robots)))
            finally:
                self._deciding = False
            return None
        if slipping or self._catching_up():  # nothing measured in this period is judged
            self.decider.violations = 0
            return None
        self._unjudged_since = None
        try:
            detection = self.decider.step(self.current, self.applier.sources())
        except NodeLinkError as error:  # a link failed as the Decider read: lost at the next look
            self.log.record("link_failed", str(error))
            return None
        pending = self.history.pending_recovery()
        if pending is not None:
            self._watch_recovery(pending)
        if self._settling():  # the new configuration's loop is still settling: no fault yet
            self.decider.violations = 0
            return None
        if detection is not None and not self._deciding:
            self._deciding = True
            try:
                self._repair(self.current)
            finally:
                self._deciding = False
        return detection

    def _watch_nodes(self) -> set[str]:
        """Mark the robots newly lost and try the lost ones again; the robots lost now."""
        lost = self.applier.lost(self.settings.lost_after)
        now = self.clock()
        for robot, why in lost.items():
            if robot not in self.database.lost:
                self.database.lose(robot)
                self._tried[robot] = now
                self._why[robot] = why
                self.log.record("node_lost", f"robot {robot}: {why}", robot=robot, why=why)
        for robot in sorted(self.database.lost):
            if now - self._tried[robot] >= self.settings.lost_after - _EPSILON:
                self._tried[robot] = now
                self._try_rejoin(robot)
        return set(self.database.lost)

    def _record_module_logs(self) -> None:
        """An event for each line a module logged since the last look (its text as data, at
        most `ECHOED_PER_SECOND` a second of the run per PBO, the rest counted)."""
        for robot, pbo, line in self.applier.module_logs():
            limit = self._echo.setdefault(robot, EchoLimit(now=self.clock))
            for shown in limit.shown(pbo, one_line(line.text)):
                self.log.record(
                    "module_log",
                    f"robot {robot}: {shown}",
                    robot=robot,
                    pbo=pbo,
                    line=line.number,
                    node_time=line.time,
                )

    def _watch_real_time(self) -> bool:
        """Whether a node or the caller's loop slipped more than the tolerance in this period;
        records when real time is lost and held again, and stops the run (RealTimeLost) once
        nothing was judged for the patience for want of real time (lost, or caught up after)."""
        tolerance = self.settings.slip_tolerance
        slips = {
            f"robot {robot}'s node": (slip.seconds, slip.missed)
            for robot, slip in self.applier.slipped().items()
            if slip.seconds > tolerance
        }
        host = self.host_slip()
        if host > tolerance:
            slips["the manager"] = (host, 0)
        now = self.clock()
        if not slips:
            if self._slipping_since is not None:
                self.log.record(
                    "real_time_held",
                    f"real time held again after {now - self._slipping_since:.3f} s lost",
                    seconds=now - self._slipping_since,
                )
                self._slipping_since = None
                self._held_at = now
            return False
        if self._slipping_since is None:
            self._slipping_since = now
            if self._unjudged_since is None:
                self._unjudged_since = now
            for where, (slip, missed) in slips.items():
                self.log.record(
                    "real_time_lost",
                    f"real time lost on {where} {_how(slip, missed)}: its measurements are "
                    "not judged",
                    where=where,
                    slip=slip,
                    missed=missed,
                )
        since = self._unjudged_since
        assert since is not None
        if now - since >= self.settings.real_time_patience - _EPSILON and not self._deciding:
            where, (slip, missed) = max(slips.items(), key=lambda item: item[1])
            patience = self.settings.real_time_patience
            raise RealTimeLost(
                f"real time lost on {where} {_how(slip, missed)}, and nothing judged for "
                f"{now - since:.3f} s since {since:.3f} s (at most {patience:g} s allowed): the "
                "run stops, as no measurement can be judged (a machine less busy, fewer nodes "
                "per core, or the run in lock-step keeps time)"
            )
        return True

    def _try_rejoin(self, robot: str) -> None:
        """Reach lost `robot` again; once it answers, stop what of the task it runs outside the
        running configuration and count its resources again."""
        inventory = self.applier.rejoin(robot)
        if inventory is None:
            return
        placed = set() if self.current is None else self._instances_on(robot)
        modules = {module.name for module in self.database.modules()}
        for name in inventory.running():
            if name in modules and name not in placed:
                self.applier.stop(robot, name)
        self.database.rejoin(robot)
        del self._tried[robot]
        self._why.pop(robot, None)
        self.log.record(
            "node_rejoined",
            f"robot {robot}: node back with modules {', '.join(inventory.modules) or 'none'}; "
            f"PBOs {', '.join(f'{n} {s}' for n, s in inventory.pbos) or 'none'}",
            robot=robot,
            modules=list(inventory.modules),
            pbos=dict(inventory.pbos),
        )
        if self.on_rejoin is not None:
            self.on_rejoin(robot, inventory)

    def _instances_on(self, robot: str) -> set[str]:
        assert self.current is not None
        return {
            instance
            for placement, instance in zip(
                self.current.placements, self.current.instances, strict=True
            )
            if placement.robot == robot
        }

    def _switch(self, target: Configuration) -> None:
        """Apply the Maintainer's plan from what runs to `target`."""
        self.maintainer.apply(self.maintainer.plan(self.current, target))
        self.current = target
        if self.on_switch is not None:
            self.on_switch(target)
        self.decider.violations = 0  # what it counted was about the old configuration
        self.history.configurations.append((self.clock(), target.label()))

    def _catching_up(self) -> bool:
        """True within `settle` seconds of real time held again: a closed loop that lost real
        time (frames late, a tracker left behind) takes that long to be itself again, and what
        it measures meanwhile is the loss, not a module."""
        held = self._held_at
        return held is not None and self.clock() - held < self.settings.settle - _EPSILON

    def _settling(self) -> bool:
        """True within `settle` seconds of the last switch."""
        last = self.history.switched_at()
        return last is not None and self.clock() - last < self.settings.settle - _EPSILON

    def _watch_recovery(self, pending: Reconfiguration) -> None:
        """Confirm recovery once P_T has held for `recovery_hold` in judged periods since it
        first came back (a period not judged for lack of real time adds nothing)."""
        assert pending.applied_at is not None
        if self.decider.violations:
            self._good_since = None
            return
        if self._good_since is None:
            self._good_since, self._good_periods = self.clock(), 0
            return
        self._good_periods += 1
        since = self._good_since
        held = self._good_periods * self.settings.decision_period
        if held >= self.settings.recovery_hold - _EPSILON:
            pending.recovered_at = since
            self.log.record(
                "recovered",
                f"P_T = 1 again {1e3 * (since - pending.applied_at):.1f} ms after the switch",
                seconds=since - pending.applied_at,
            )
            self._good_since = None

    def _repair(self, current: Configuration, lost: list[str] | None = None) -> None:
        """Locate, synthesize, choose; migrate and switch, or stop the task safely (also when
        the last repairs, as many as the settings allow, all failed to bring P_T back). `lost`
        names the robots whose node loss this repair answers: a stop then says so, since the
        Locator's verdict alone ("more than one fault suspected") reads as a double fault of
        modules when the first fault is a node that stopped answering."""
        failed = self.history.failed_repairs()
        if failed >= self.settings.repair_attempts:
            self._stop_safely(current, f"{failed} repairs in a row did not bring P_T back")
            return
        detected_at = self.clock()
        estimator = self.estimators(detected_at, self.settings.estimate_steps)
        started = time.perf_counter()
        decision = decide(current, self.database, self.task, estimator, self.log)
        seconds = time.perf_counter() - started
        record = Reconfiguration(
            detected_at,
            decision,
            seconds,
            test_cases=decision.location.total,
            brute_force=brute_force.count(current, self.database),
        )
        if self.settings.compare_locations:
            steps = self.settings.estimate_steps
            record.comparison = compare(
                current,
                self.database,
                self.task,
                lambda: self.estimators(detected_at, steps),
                decision.location,
            )
        self.history.reconfigurations.append(record)
        if decision.target is None:
            reason = decision.location.module if decision.choice is None else "no candidate"
            if lost:
                reason = _lost_reason(lost, reason)
            self._stop_safely(
                current, reason, {robot: self._why.get(robot, "") for robot in lost or ()}
            )
            return
        self._switch(decision.target)
        record.applied_at = self.clock()
        record.target = decision.target

    def _stop_safely(
        self, current: Configuration, reason: str, lost: dict[str, str] | None = None
    ) -> None:
        """No configuration repairs the task (`reason`; `lost`: the robots whose node loss
        led to it, and why): stop every module of the task. A module the applier cannot stop
        (it failed on its own) is logged, and the others are stopped all the same."""
        for placement, instance in zip(current.placements, current.instances, strict=True):
            try:
                self.applier.stop(placement.robot, instance)
            except RefreshError as error:
                self.log.record(
                    "stop_failed",
                    f"stop {instance} on {placement.robot}: {error}",
                    instance=instance,
                    robot=placement.robot,
                )
        self.history.stopped_at = self.clock()
        data: dict[str, object] = {"reason": reason}
        if lost:
            data["lost"] = lost
        self.log.record("stopped", f"no repair ({reason}): the task is stopped", **data)
        self.current = None


def _lost_reason(robots: list[str], verdict: str) -> str:
    """Why a repair of a node loss found nothing, in words that put the loss first."""
    nodes = " and ".join(f"robot {robot}'s node" for robot in robots)
    return (
        f"{nodes} lost, and no configuration on the robots that remain satisfies P_T (the "
        f"Locator's verdict: {verdict})"
    )


def _how(slip: float, missed: int) -> str:
    """How real time was lost, in words: by how much, and the releases missed."""
    if not missed:
        return f"by {1e3 * slip:.0f} ms"
    return f"by {1e3 * slip:.0f} ms ({missed} release{'s' if missed != 1 else ''} missed)"
