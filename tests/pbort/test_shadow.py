"""Shadow runs of estimators: results, dependency order, snapshots, failures, and above all that
the running configuration is left exactly as it was."""

from __future__ import annotations

import pytest

from pbort import (
    CallResult,
    Kernel,
    Method,
    NativeModule,
    NativePBO,
    PerformanceKind,
    PortSpec,
    PortValue,
    Role,
    Services,
    ShadowRun,
)
from pbort.errors import (
    AlreadyConnectedError,
    ClosedError,
    DuplicateNameError,
    PortTypeMismatchError,
    SetupError,
)

F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL


class Sensor(NativePBO):
    """Executor: y = 1, 2, 3, ...; estimator: y = 100, 101, ... (its own count, own state)."""

    name = "sensor"
    ports = (PortSpec.output("y", dtype="<f8"),)

    def init(self, io):
        self.n = 0

    def cycle(self, io):
        self.n += 1
        io["y"] = float(self.n)

    def evaluate(self, io):
        io.report(NF, 0, 2.0)

    def estimate(self, io):
        io["y"] = 100.0 + self.n
        self.n += 1
        io.report(F, 0, io["y"])


class Gain(NativePBO):
    """y = k * x; the estimator reports y and counts its own steps in its state."""

    name = "gain"
    ports = (
        PortSpec.input("x", dtype="<f8"),
        PortSpec.const("k", dtype="<f8"),
        PortSpec.output("y", dtype="<f8"),
    )

    def init(self, io):
        self.steps = 0

    def cycle(self, io):
        io["y"] = io["k"] * io["x"]

    def evaluate(self, io):
        io.report(F, 0, abs(io["y"]))

    def estimate(self, io):
        self.steps += 1
        self.cycle(io)
        io.report(F, 0, io["y"])
        return -1 if self.steps == io["k"] == 7 else None


class Offset(NativePBO):
    """A module that is not on the kernel: y = x + 0.5."""

    name = "offset"
    ports = (PortSpec.input("x", dtype="<f8"), PortSpec.output("y", dtype="<f8"))

    def estimate(self, io):
        io["y"] = io["x"] + 0.5


def live_system() -> Kernel:
    kernel = Kernel()
    kernel.add(NativeModule(Sensor), frequency=10)
    kernel.add(NativeModule(Gain), frequency=10)
    kernel.connect("sensor.y", "gain.x")
    kernel.configure("gain.k", 2)
    for name in kernel.names:
        kernel.spawn(name)
        kernel.on(name)
    return kernel


def everything(kernel: Kernel) -> dict[str, object]:
    """Whatever a user can observe of a kernel."""
    ports = {"sensor": ["y"], "gain": ["x", "k", "y"]}
    return {
        "now": kernel.now,
        "values": {f"{n}.{p}": kernel.value(f"{n}.{p}") for n, ps in ports.items() for p in ps},
        "states": {n: kernel.state(n) for n in kernel.names},
        "stats": {n: kernel.stats(n) for n in kernel.names},
        "buffers": {n: kernel.performance(n).records() for n in kernel.names},
        "connections": kernel.connections(),
    }


def test_a_shadow_run_leaves_the_running_configuration_exactly_as_it_was() -> None:
    with live_system() as kernel, live_system() as twin:
        kernel.run(until=0.5)
        twin.run(until=0.5)
        before = everything(kernel)
        with kernel.shadow(["sensor", "gain"]) as run:
            estimates = run.run(steps=5)
        assert everything(kernel) == before
        kernel.run(until=1.0)
        twin.run(until=1.0)
        assert everything(kernel) == everything(twin)  # live instances' state was not touched
    assert estimates["sensor"].outputs == {"y": 104.0}
    assert estimates["gain"].outputs == {"y": 208.0}  # the live constant k = 2 came along
    assert [r.value for r in estimates["gain"].reports] == [200.0, 202.0, 204.0, 206.0, 208.0]
    assert estimates["gain"].latest(F) == 208.0
    assert estimates["gain"].steps == 5 and estimates["gain"].failure is None


def test_an_unwired_input_reads_the_live_snapshot_unless_given() -> None:
    with live_system() as kernel:
        kernel.run(until=0.35)
        assert kernel.value("gain.x") == 4.0
        with kernel.shadow(["gain"]) as run:
            assert run.run()["gain"].outputs["y"] == 8.0
        with kernel.shadow(["gain"], inputs={"gain.x": 10, "gain.k": 3}) as run:
            assert run.run()["gain"].outputs["y"] == 30.0


def test_a_candidate_may_mix_running_registered_and_unregistered_modules() -> None:
    with live_system() as kernel:
        kernel.add(NativeModule(Gain), "spare")  # registered, never spawned
        kernel.configure("spare.k", 10)
        wiring = [("sensor.y", "offset.x"), ("offset.y", "spare.x")]
        with kernel.shadow(["spare", NativeModule(Offset), "sensor"], wiring) as run:
            assert run.order == ("sensor", "offset", "spare")
            estimates = run.run(steps=2)
        assert estimates["spare"].outputs["y"] == 1015.0  # (101 + 0.5) * 10: one step end to end
        assert kernel.state("spare").name == "NOT_CREATED"


def test_a_feedback_loop_runs_the_first_listed_module_first() -> None:
    with ShadowRun(
        {"g": NativeModule(Gain), "o": NativeModule(Offset)},
        wiring=[("g.y", "o.x"), ("o.y", "g.x")],
        inputs={"g.k": 2},
    ) as run:
        assert run.order == ("g", "o")
        assert run.run(steps=1)["o"].outputs["y"] == 0.5
        assert run.run(steps=1)["o"].outputs["y"] == 1.5  # g read o's previous 0.5


class Recording:
    """A ModuleCode wrapper that records what the shadow run does with its instances."""

    def __init__(self, code: NativeModule) -> None:
        self.code = code
        self.events: list[str] = []

    @property
    def name(self) -> str:
        return self.code.name

    @property
    def ports(self) -> tuple[PortSpec, ...]:
        return self.code.ports

    def implements(self, method: Method) -> bool:
        return self.code.implements(method)

    def instantiate(self, role: Role, services: Services) -> Recording.Instance:
        self.events.append(f"instantiate {role.value}")
        return Recording.Instance(self.code.instantiate(role, services), self.events)

    class Instance:
        def __init__(self, inner, events: list[str]) -> None:
            self.inner, self.events = inner, events

        def put(self, port: str, value: PortValue) -> None:
            self.inner.put(port, value)

        def get(self, port: str) -> PortValue:
            return self.inner.get(port)

        def call(self, method: Method) -> CallResult:
            self.events.append(method.value)
            return self.inner.call(method)

        def release(self) -> None:
            self.events.append("release")
            self.inner.release()


def test_estimator_instances_see_init_estimates_kill_and_are_released() -> None:
    code = Recording(NativeModule(Gain))
    with Kernel() as kernel:
        kernel.add(code, frequency=10)
        with kernel.shadow(["gain"]) as run:
            run.run(steps=2)
        run.close()
        assert code.events == [
            "instantiate estimator",
            "init",
            "estimate",
            "estimate",
            "kill",
            "release",
        ]
        with pytest.raises(ClosedError, match="shadow run is closed"):
            run.run()


def test_closing_the_kernel_closes_its_open_shadow_runs() -> None:
    code = Recording(NativeModule(Gain))
    kernel = Kernel()
    kernel.add(code)
    kernel.shadow(["gain"])  # never closed by the caller
    kernel.close()
    assert code.events == ["instantiate estimator", "init", "kill", "release"]


def test_a_failing_estimator_stops_and_says_where() -> None:
    with ShadowRun({"g": NativeModule(Gain)}, inputs={"g.k": 7, "g.x": 1}) as run:
        estimates = run.run(steps=10)["g"]
    assert estimates.failure == "estimate returned -1 at step 7"
    assert estimates.steps == 6
    assert estimates.outputs["y"] == 7.0


def test_bad_candidates_are_refused_before_any_instance_is_made() -> None:
    class Plain(NativePBO):
        name = "plain"
        ports = (PortSpec.output("y"),)

    class Estimating(Plain):
        def estimate(self, io):
            io["y"] = 1

    code = Recording(NativeModule(Gain))
    with pytest.raises(SetupError, match="module 'plain' has no estimate method"):
        ShadowRun({"g": code, "plain": NativeModule(Plain)})
    with pytest.raises(PortTypeMismatchError, match=r"cannot connect 'e.y' \(<i4 scalar\)"):
        ShadowRun({"g": code, "e": NativeModule(Estimating)}, [("e.y", "g.x")])
    with pytest.raises(AlreadyConnectedError, match=r"input 'g.x' is wired to 's.y'"):
        ShadowRun({"g": code, "s": NativeModule(Sensor)}, [("s.y", "g.x")], {"g.x": 1.0})
    assert code.events == []
    with Kernel() as kernel:
        kernel.add(NativeModule(Gain))
        with pytest.raises(DuplicateNameError, match="module 'gain' is given twice"):
            kernel.shadow(["gain", NativeModule(Gain)])
