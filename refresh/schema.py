"""The JSON Schema of a module database file, and validation with errors that say where.

A database file is TOML (read with `tomllib`); its document is checked against `DOCUMENT` with
`jsonschema` before anything is built from it, so a typo in a key or a string where a number belongs
is reported with the file, the dotted key path, what was expected and what came, instead of
surfacing later as a KeyError deep in the Locator. A "number" here is a finite one (TOML has
``nan`` and ``inf``), within the range its use allows. Checks a JSON Schema cannot express (a
module naming a robot that does not exist, say) are made by `refresh.load` with the same error
type.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, TypeGuard

from jsonschema import Draft202012Validator, validators
from jsonschema.exceptions import ValidationError

from refresh.errors import DatabaseError
from refresh.location import STRATEGIES

NAME = r"^[A-Za-z_][A-Za-z0-9_]*$"
"""Names of robots, schemas, modules, ports, resources and metrics: kernel-safe (no '.')."""
FUNCTIONALITY = r"^[A-Za-z0-9]+(:[A-Za-z0-9]+)*$"
"""A fabric slot's functionality with its parameters, ``median3x3:160`` (the crossbar checks
the rest)."""
PLACEMENT = rf"^{NAME[1:-1]}(@{NAME[1:-1]})?$"
"""A module of the task's initial configuration, ``Module`` or ``Module@robot``."""

MAX_AMOUNT = 1e15
"""The largest capacity, reserve or need of a resource: far above any robot's in any unit (mW,
bytes), and below 2**53, past which a whole number changes when it is read as a float."""
MIN_FREQUENCY, MAX_FREQUENCY = 0.01, 100_000
"""A module's frequency in Hz: what a node's RATE takes (`firmware_sim.core.node.RATE_MIN` and
`RATE_MAX`, not imported: loading a database does not need the node's modules)."""
MAX_INDEX = 2**31 - 1
"""The largest report index: a module reports under an int32 (the module ABI's
PBO_SYS_PERF_REPORT)."""

_NUMBER = {"type": "number", "minimum": 0, "maximum": MAX_AMOUNT}
_INDEX = {"type": "integer", "minimum": 0, "maximum": MAX_INDEX}
_PORTS = {
    "type": "object",
    "propertyNames": {"pattern": NAME},
    "additionalProperties": {"type": "string", "pattern": NAME},  # a type name
}
_SOURCE = {
    "oneOf": [
        {"const": "native"},
        {
            "type": "object",
            "properties": {"image": {"type": "string", "minLength": 1}},
            "required": ["image"],
            "additionalProperties": False,
        },
        {
            "type": "object",
            "properties": {
                "bitstreams": {
                    "type": "array",
                    "items": {"type": "string", "minLength": 1},
                    "minItems": 1,
                    "maxItems": 16,
                }
            },
            "required": ["bitstreams"],
            "additionalProperties": False,
        },
    ]
}
_HARDWARE = {
    "type": "object",
    "properties": {
        "functionalities": {
            "type": "array",
            "items": {"type": "string", "pattern": NAME},
            "minItems": 1,
            "maxItems": 16,
        },
        "slots": {
            "type": "array",
            "items": {"type": "integer", "minimum": 0, "maximum": 15},
            "minItems": 1,
            "maxItems": 16,
            "uniqueItems": True,
        },
    },
    "required": ["functionalities", "slots"],
    "additionalProperties": False,
}
_FABRIC = {
    "type": "object",
    "properties": {
        "slots": {
            "type": "array",
            # kind[:p0[:p1]], as the crossbar writes it: no spaces or control characters,
            # which its parser would skip and refresh check would print
            "items": {"type": "string", "maxLength": 64, "pattern": FUNCTIONALITY},
            "minItems": 2,
            "maxItems": 16,
        },
        "width": {"type": "integer", "minimum": 1, "maximum": 32},
    },
    "required": ["slots"],
    "additionalProperties": False,
}
_MODULE = {
    "type": "object",
    "properties": {
        "robots": {
            "type": "array",
            "items": {"type": "string", "pattern": NAME},
            "minItems": 1,
            "uniqueItems": True,
        },
        "inputs": _PORTS,
        "outputs": _PORTS,
        "needs": {
            "type": "object",
            "propertyNames": {"pattern": NAME},
            "additionalProperties": _NUMBER,
        },
        "source": _SOURCE,
        "frequency": {"type": "number", "minimum": MIN_FREQUENCY, "maximum": MAX_FREQUENCY},
        "constants": {
            "type": "object",
            "propertyNames": {"pattern": NAME},
            "additionalProperties": {"type": ["number", "boolean"]},
        },
        "hardware": _HARDWARE,
    },
    "required": ["robots", "source"],
    "additionalProperties": False,
}
_SCHEMA = {
    "type": "object",
    "properties": {
        "kind": {"enum": ["sensor", "actuator", "computation"]},
        "modules": {
            "type": "object",
            "propertyNames": {"pattern": NAME},
            "additionalProperties": _MODULE,
            "minProperties": 1,
        },
    },
    "required": ["kind", "modules"],
    "additionalProperties": False,
}
_RESOURCE = {
    "type": "object",
    "properties": {
        "capacity": _NUMBER,
        "reserve": _NUMBER,
        "report": _INDEX,
    },
    "required": ["capacity"],
    "additionalProperties": False,
}
_ROBOT = {
    "type": "object",
    "properties": {
        "resources": {
            "type": "object",
            "propertyNames": {"pattern": NAME},
            "additionalProperties": _RESOURCE,
        },
        "fabric": _FABRIC,
    },
    "additionalProperties": False,
}
_METRIC = {
    "type": "object",
    "properties": {
        "schema": {"type": "string", "pattern": NAME},
        "index": _INDEX,
        "threshold": {"type": "number"},
        "direction": {"enum": ["at_most", "at_least"]},
        "weight": {"type": "number", "minimum": 0},
    },
    "required": ["schema", "threshold"],
    "additionalProperties": False,
}
_TASK = {
    "type": "object",
    "properties": {
        "name": {"type": "string", "pattern": NAME},
        "robot": {"type": "string", "pattern": NAME},
        "states": {
            "type": "array",
            "items": {"type": "string", "pattern": NAME},
            "minItems": 1,
            "uniqueItems": True,
        },
        "schemas": {
            "type": "array",
            "items": {"type": "string", "pattern": NAME},
            "minItems": 1,
            "uniqueItems": True,
        },
        "alpha": {"type": "number", "minimum": 0, "maximum": 1},
        "metrics": {
            "type": "object",
            "propertyNames": {"pattern": NAME},
            "additionalProperties": _METRIC,
        },
        "initial": {"type": "array", "items": {"type": "string", "pattern": PLACEMENT}},
        "location": {"enum": list(STRATEGIES)},
    },
    "required": ["name", "robot", "states", "schemas"],
    "additionalProperties": False,
}

MAX_DIGITS = 30
"""The characters of a number an error message shows at most (TOML reads whole numbers of
thousands of digits)."""

DOCUMENT: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "type": "object",
    "properties": {
        "robots": {
            "type": "object",
            "propertyNames": {"pattern": NAME},
            "additionalProperties": _ROBOT,
            "minProperties": 1,
        },
        "schemas": {
            "type": "object",
            "propertyNames": {"pattern": NAME},
            "additionalProperties": _SCHEMA,
            "minProperties": 1,
        },
        "task": _TASK,
    },
    "required": ["robots", "schemas"],
    "additionalProperties": False,
}
"""The whole file: robots, schemas (with their modules) and optionally the task."""


def _finite_number(checker: object, instance: object) -> bool:
    """JSON Schema's "number", but finite: TOML reads ``nan``, ``inf`` and ``-inf``, which pass
    every bound (a NaN compares false) and would reach the Decider's comparisons and the nodes;
    a whole number too large for a float is no number this toolchain can use either."""
    if not _is_number(instance):
        return False
    try:
        return math.isfinite(instance)
    except OverflowError:  # an int past the float range
        return False


_CHECKER = validators.extend(
    Draft202012Validator,
    type_checker=Draft202012Validator.TYPE_CHECKER.redefine("number", _finite_number),
)
_VALIDATOR = _CHECKER(DOCUMENT)


def validate(document: Mapping[str, Any], file: str) -> None:
    """Raise `DatabaseError` for the deepest violation of `DOCUMENT`, if any: the most specific
    one (a wrong capacity rather than the whole file's missing schemas), the first on a tie."""
    errors = list(_VALIDATOR.iter_errors(document))
    if errors:
        error = max(errors, key=lambda e: len(e.absolute_path))
        raise _explain(_deepest(error), file)


_MISMATCH = frozenset({"type", "const", "enum"})
"""Validators that only say the value is of another alternative's kind."""


def _deepest(error: ValidationError) -> ValidationError:
    """For `oneOf`, the alternative's error that got furthest into the document; on a tie, one
    from an alternative the value's kind matches (a `source` table with an unknown key is
    reported as that key, not as "expected 'native'")."""
    while error.context:
        error = max(
            error.context, key=lambda e: (len(e.absolute_path), e.validator not in _MISMATCH)
        )
    return error


def key_path(parts: Iterable[object]) -> str:
    """Dotted key path with list indices in brackets: ``schemas.camera.modules.Cam.robots[0]``."""
    text = ""
    for part in parts:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def _explain(error: ValidationError, file: str) -> DatabaseError:
    """Turn a jsonschema error into expected/got wording."""
    path = list(error.absolute_path)
    value = error.validator_value
    got = describe(error.instance)
    if error.validator == "required":
        missing = [k for k in value if k not in error.instance]
        return DatabaseError(file, key_path([*path, missing[0]]), "a value (required key)", "none")
    if error.validator == "additionalProperties":
        allowed = ", ".join(error.schema.get("properties", {}))
        extra = [k for k in error.instance if k not in error.schema.get("properties", {})]
        return DatabaseError(
            file, key_path([*path, extra[0]]), f"one of the keys {allowed}", "an unknown key"
        )
    if error.validator == "propertyNames":
        return DatabaseError(file, key_path(path), f"names matching {NAME}", got)
    if error.validator == "pattern":
        return DatabaseError(file, key_path(path), f"a name matching {value}", got)
    expectations = {
        "type": lambda: _article(_plural(value, finite=_is_number(error.instance))),
        "enum": lambda: "one of " + ", ".join(repr(v) for v in value),
        "const": lambda: repr(value),
        "minimum": lambda: f"a number >= {_bound(value)}",
        "maximum": lambda: f"a number <= {_bound(value)}",
        "maxItems": lambda: f"at most {value} item(s)",
        "maxLength": lambda: f"a string of at most {value} characters",
        "exclusiveMinimum": lambda: f"a number > {_bound(value)}",
        "minItems": lambda: f"at least {value} item(s)",
        "minProperties": lambda: f"at least {value} entr{'y' if value == 1 else 'ies'}",
        "uniqueItems": lambda: "items without repeats",
        "minLength": lambda: "a non-empty string",
    }
    expected = expectations.get(error.validator, lambda: error.message)()
    return DatabaseError(file, key_path(path), expected, got)


def _plural(value: str | Sequence[str], finite: bool = False) -> str:
    """The TOML names of JSON Schema types; `finite` says "finite number", for a number that is
    refused for being NaN or infinite (else "expected a number, got the number nan")."""
    number = "finite number" if finite else "number"
    names = {"object": "table", "array": "list", "number": number, "integer": "integer"}
    types = [value] if isinstance(value, str) else list(value)
    return " or ".join(names.get(t, t) for t in types)


def _article(noun: str) -> str:
    """`noun` after "a" or "an", as it sounds: "a table", "an integer"."""
    return f"{'an' if noun[0] in 'aeiou' else 'a'} {noun}"


def _bound(value: float) -> str:
    """A bound as a reader writes it: ``1e+15`` rather than ``1000000000000000.0``, and a whole
    number with all its digits."""
    return f"{value:g}" if isinstance(value, float) else str(value)


def _is_number(value: object) -> TypeGuard[int | float]:
    """A TOML integer or float (a boolean is neither)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def describe(value: object) -> str:
    """A short description of a value for an error message: its TOML type and the value."""
    if isinstance(value, dict):
        return f"a table with keys {', '.join(value) or '(none)'}"
    if isinstance(value, list):
        return f"a list of {len(value)} item(s)"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if not _is_number(value):  # a TOML date or time
        return f"the date or time {value}"
    text = repr(value)
    if len(text) > MAX_DIGITS:
        return f"the number {text[:MAX_DIGITS]}... ({len(text.lstrip('-'))} digits)"
    return f"the number {text}"
