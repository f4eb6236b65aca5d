"""The exception tree of refresh.

Every refusal of the ReFrESH layer raises a subclass of `RefreshError`, so a caller (a CLI, a demo)
can catch one class; each class also inherits the builtin it refines. Messages say where (file and
key path, module, robot), what was expected and what came.

Tree::

    RefreshError
    ├── DatabaseError (ValueError)       a module database or task file that does not validate
    │   └── DatabaseImageError           a module image it names is missing, unreadable or
    │                                    declares another name or other ports
    ├── ConfigurationError (ValueError)  a configuration that does not fit the task or database
    │   ├── RateError                    a metric's module reports slower than the Decider looks
    │   └── UnreportedMetric             a metric the module filling its schema never reports
    │                                    (its evaluator reports other values)
    ├── EstimationError (RuntimeError)   an estimator that could not estimate a configuration
    ├── ApplyError (RuntimeError)        a plan step the applier could not carry out
    ├── NodeLinkError (RuntimeError)     a node over a link that cannot be reached, stopped
    │                                    answering or refused a request (refresh.remote)
    └── RealTimeLost (RuntimeError)      a run in real time whose nodes or manager stayed
                                         behind real time past the runtime's patience
"""

from __future__ import annotations


class RefreshError(Exception):
    """Base class of every error raised by refresh."""


class DatabaseError(RefreshError, ValueError):
    """A database file that is not what it should be, with where, what was expected and what came.

    `file` is the path (or a name for text that came from elsewhere), `key` the dotted key path
    inside it ("" for the whole file).
    """

    def __init__(self, file: str, key: str, expected: str, got: str) -> None:
        self.file = file
        self.key = key
        self.expected = expected
        self.got = got
        where = f"{file}: {key}" if key else file
        super().__init__(f"{where}: expected {expected}, got {got}")


class DatabaseImageError(DatabaseError):
    """A module's image file that is missing, is no module image, or whose descriptor disagrees
    with the database (or a hardware module's bitstreams that do not route as it says); the key
    path is the module's ``source.image`` (``source.bitstreams``), `module` its name."""

    def __init__(
        self, file: str, schema: str, module: str, expected: str, got: str, key: str = "image"
    ) -> None:
        self.module = module
        super().__init__(file, f"schemas.{schema}.modules.{module}.source.{key}", expected, got)


class ConfigurationError(RefreshError, ValueError):
    """A configuration that names unknown modules, robots or schemas, or leaves a slot empty."""


class RateError(ConfigurationError):
    """A module that may report a task metric runs slower than the runtime's Decider looks: it
    would judge stale reports (the message names the module, its rate and the decision period)."""


class UnreportedMetric(ConfigurationError):
    """A task metric that the module filling its schema does not report, while its evaluator
    reports other values: the database's metric names a schema or index no module reports
    under, a configuration error rather than a fault of the task's modules (the message names
    the metric, its schema and index, and what the module reported instead)."""


class EstimationError(RefreshError, RuntimeError):
    """An estimator failed for a reason that is not evidence about the configuration."""


class ApplyError(RefreshError, RuntimeError):
    """A plan step the applier refused or could not complete."""


class NodeLinkError(RefreshError, RuntimeError):
    """A node over a link (`refresh.remote`) that cannot be reached, stopped answering, or
    refused a request; the message names the robot, the node's URL and what the node said."""


class RealTimeLost(RefreshError, RuntimeError):
    """A run in real time whose nodes (or manager) stayed behind real time longer than the
    runtime's patience: no measurement could be judged, so the run stops with that condition
    rather than read the slip as module faults (the message names where, by how much, and
    since when)."""
