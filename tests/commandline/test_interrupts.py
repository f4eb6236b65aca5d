"""Ctrl-C as a flag: `remembered_interrupts` keeps a Ctrl-C that Python swallowed; neither it
nor `stop_requests` takes a SIGINT that was ignored (a shell's background command)."""

from __future__ import annotations

import os
import signal
import sys
import weakref

import pytest

from commandline.interrupts import remembered_interrupts, stop_requests


class _Thing:
    """Something a weak reference can point at."""


@pytest.fixture
def sigint(request):
    """SIGINT's handler for the test: `request.param`, Python's own unless parametrized (pytest
    may have been started with it ignored, as a shell's ``&`` does); the one before afterwards."""
    before = signal.signal(signal.SIGINT, getattr(request, "param", signal.default_int_handler))
    yield
    signal.signal(signal.SIGINT, before)


def test_a_ctrl_c_swallowed_in_a_weakref_callback_is_remembered(monkeypatch, sigint):
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


@pytest.mark.parametrize("sigint", [signal.SIG_IGN], indirect=True)
@pytest.mark.parametrize("flag", [remembered_interrupts, stop_requests])
def test_a_sigint_ignored_before_stays_ignored(sigint, flag):
    with flag() as asked:
        os.kill(os.getpid(), signal.SIGINT)  # a Ctrl-C meant for the script that ran it with &
        assert not asked()
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
