"""Ctrl-C as a flag: `remembered_interrupts` keeps a Ctrl-C that Python swallowed."""

from __future__ import annotations

import os
import signal
import sys
import weakref

import pytest

from commandline.interrupts import remembered_interrupts


class _Thing:
    """Something a weak reference can point at."""


def test_a_ctrl_c_swallowed_in_a_weakref_callback_is_remembered(monkeypatch):
    ignored: list = []  # what Python reports as "Exception ignored in ..."
    monkeypatch.setattr(sys, "unraisablehook", ignored.append)

    def callback(_reference: weakref.ref) -> None:
        os.kill(os.getpid(), signal.SIGINT)  # its handler runs here, and Python ignores its raise

    with remembered_interrupts() as pressed:
        assert not pressed()
        thing = _Thing()
        reference = weakref.ref(thing, callback)
        del thing  # the callback runs now (CPython: reference counting)
        assert reference() is None
        assert pressed()  # what a job reads at its next step
        with pytest.raises(KeyboardInterrupt):  # outside such a callback, Ctrl-C raises as ever
            os.kill(os.getpid(), signal.SIGINT)
    assert [type(report.exc_value) for report in ignored] == [KeyboardInterrupt]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
