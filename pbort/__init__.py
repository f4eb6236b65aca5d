"""pbort: a PBO/RT-like real-time kernel: port-based objects, E-PBOs, state-variable table,
cooperative scheduler with virtual or real time. Independent of any CPU and of hexmigrate.

One concept per module:

======================  =======================================================================
``ports``               PortSpec: a port's direction, kind, element type and shape (contract)
``code``                ModuleCode / Instance: what a back end gives the kernel (contract)
``errors``              the exception tree under KernelError
``lifecycle``           the PBO states and the one table of legal transitions
``native``              NativePBO / NativeModule: modules written as Python classes
``svt``                 the state-variable table: variables, inputs, wiring
``clock``               VirtualClock (deterministic) and RealTimeClock
``scheduler``           one CPU, non-preemptive, periodic and aperiodic jobs, deadline counters
``stats``               the counters per PBO
``performance_buffer``  performance buffers filled by evaluators and estimators
``shadow``              shadow runs of estimators beside the running configuration
``pbo``                 one PBO registered on a kernel
``kernel``              Kernel: registration, wiring, lifecycle calls, running, observation
======================  =======================================================================
"""

from pbort.clock import Clock, RealTimeClock, VirtualClock
from pbort.code import CallResult, Instance, Method, ModuleCode, PerformanceKind, Role, Services
from pbort.kernel import Kernel
from pbort.lifecycle import State
from pbort.native import NativeModule, NativePBO, PortIO
from pbort.performance_buffer import PerformanceBuffer, Report
from pbort.ports import Direction, PortKind, PortSpec, PortValue
from pbort.shadow import Estimate, ShadowRun
from pbort.stats import Stats

__all__ = [
    "CallResult",
    "Clock",
    "Direction",
    "Estimate",
    "Instance",
    "Kernel",
    "Method",
    "ModuleCode",
    "NativeModule",
    "NativePBO",
    "PerformanceBuffer",
    "PerformanceKind",
    "PortIO",
    "PortKind",
    "PortSpec",
    "PortValue",
    "RealTimeClock",
    "Report",
    "Role",
    "Services",
    "ShadowRun",
    "State",
    "Stats",
    "VirtualClock",
]
