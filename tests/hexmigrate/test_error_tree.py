"""hexmigrate's exceptions form one tree under `HexmigrateError`, and the tree drawn at the top of
hexmigrate/errors.py is the one the classes make: a reader can trust it to know what to catch."""

from __future__ import annotations

import builtins
import inspect
import re

from hexmigrate import errors

NODE = re.compile(r"^(?P<indent>[ │├└─]*)(?P<name>[A-Z]\w+)(?: \((?P<builtin>\w+)\))?")


def drawn_tree() -> dict[str, tuple[str | None, str | None]]:
    """Class name -> (parent drawn above it, builtin named beside it), from the docstring."""
    doc = errors.__doc__ or ""
    lines = doc.split("Tree::", 1)[1].strip("\n").splitlines()
    tree: dict[str, tuple[str | None, str | None]] = {}
    parents: list[tuple[int, str]] = []
    for line in lines:
        found = NODE.match(line.strip("\n")[4:])  # the block is indented by 4
        if found is None:
            continue
        depth = len(found["indent"])
        while parents and parents[-1][0] >= depth:
            parents.pop()
        tree[found["name"]] = (parents[-1][1] if parents else None, found["builtin"])
        parents.append((depth, found["name"]))
    return tree


def defined_exceptions() -> dict[str, type[BaseException]]:
    return {
        name: cls
        for name, cls in vars(errors).items()
        if inspect.isclass(cls)
        and issubclass(cls, BaseException)
        and cls.__module__ == errors.__name__
    }


def test_every_exception_of_errors_py_is_drawn_and_nothing_else():
    assert set(drawn_tree()) == set(defined_exceptions())


def test_each_class_hangs_under_the_parent_it_is_drawn_under():
    classes = defined_exceptions()
    for name, (parent, _) in drawn_tree().items():
        cls = classes[name]
        if parent is None:
            assert cls.__bases__ == (Exception,), name
        else:
            assert cls.__bases__[0] is classes[parent], name


def test_each_class_refines_the_builtin_drawn_beside_it():
    classes = defined_exceptions()
    for name, (_, builtin) in drawn_tree().items():
        if builtin is not None:
            assert getattr(builtins, builtin) in classes[name].__bases__, name


def test_the_errors_a_transfer_meets_are_caught_as_the_builtins_they_refine():
    assert issubclass(errors.LinkUrlError, ValueError) and issubclass(errors.LinkUrlError, OSError)
    assert issubclass(errors.NoAnswer, TimeoutError)
    assert issubclass(errors.TransferInterrupted, ConnectionError)
    assert issubclass(errors.MessageError, ValueError)
    interrupted = errors.TransferInterrupted("link cut after 512 bytes", 7, 512)
    assert (str(interrupted), interrupted.tid, interrupted.programmed) == (
        "link cut after 512 bytes",
        7,
        512,
    )
    assert interrupted.errno is None and interrupted.filename is None  # one line in a CLI
