"""Stopping cleanly on SIGINT and SIGTERM.

A process that runs a job (the ``studies run`` process itself, or a worker
process of the joblib launcher) turns the first SIGINT or SIGTERM into
:class:`Interrupted`, a ``KeyboardInterrupt``, so that
:func:`studies.runtime.tracking.start_run` marks the job's MLflow run KILLED. While
the store is being written (a :func:`critical` section: the store lock is
held) the signal is held back until the section ends, so that no write is cut
in half. Later signals are ignored by a job process: the KILLED path must be
allowed to finish, and after its job an interrupted process starts no other.

Python ignores (prints and drops) an exception raised while it runs a
weakref callback or a ``__del__`` method, and a signal can arrive just then.
So the signal stays pending until the code that handles the interruption
calls :func:`acknowledge`; a signal still pending at the next store write
(:func:`critical`) or at the end of the job is raised there, and the run is
marked KILLED as if the first raise had gone through. The lost raise itself
is not printed (:func:`_quiet_lost_interrupt`, the process's
``sys.unraisablehook``): it is not an error, and its traceback on stderr
would read as one.

The process that launches a sweep (see :mod:`studies.runtime.jobstate`) reacts to its
first signal by stopping new jobs, forwarding SIGTERM to the processes that
run one, waiting until they have closed their runs, and then raising
:class:`Interrupted` itself, which makes the launcher tear its workers down.
A second signal to the launcher stops the waiting at once.
"""

from __future__ import annotations

import contextlib
import functools
import signal
import sys
import threading

__all__ = ["Interrupted", "install", "critical", "deferred", "checkpoint", "job", "set_stopper",
           "received", "acknowledge"]

SIGNALS = (signal.SIGINT, signal.SIGTERM)

_state = {"installed": False, "signum": None, "critical": 0, "pending": None, "job": False,
          "stopper": None}


class Interrupted(KeyboardInterrupt):
    """Raised in place of SIGINT/SIGTERM; ``exit_code`` is ``128 + signal``."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)

    @property
    def exit_code(self) -> int:
        return 128 + self.signum

    def __reduce__(self):
        return (Interrupted, (self.signum,))


def received() -> int | None:
    """The first signal this process received (None if none)."""
    return _state["signum"]


def _handle(signum, frame) -> None:
    first = _state["signum"] is None
    if first:
        _state["signum"] = signum
    if _state["job"]:
        if not first:
            return                      # the run is being closed: let it finish
        _state["pending"] = signum      # until acknowledged (see the module's docstring)
        if _state["critical"]:
            return                      # raised when the store write is done
        raise Interrupted(signum)
    stopper = _state["stopper"]
    if stopper is None:
        # an idle worker: start no further job, wait to be torn down by the launcher
        return
    if not first:
        raise Interrupted(signum)       # second signal: stop waiting for the jobs
    stopper(signum)
    raise Interrupted(signum)


def _quiet_lost_interrupt(unraisable, previous) -> None:
    """``sys.unraisablehook``: an :class:`Interrupted` that Python dropped
    because it was raised inside a weakref callback or ``__del__`` is not
    printed (it stays pending and is raised again, see the module's
    docstring); any other unraisable exception goes to ``previous``, the
    hook that was in place when the handlers were installed."""
    if isinstance(unraisable.exc_value, Interrupted):
        return
    previous(unraisable)


def install() -> bool:
    """Install the handlers (main thread only); True when they are active."""
    if _state["installed"]:
        return True
    if threading.current_thread() is not threading.main_thread():
        return False
    for sig in SIGNALS:
        signal.signal(sig, _handle)
    sys.unraisablehook = functools.partial(_quiet_lost_interrupt, previous=sys.unraisablehook)
    _state["installed"] = True
    return True


def set_stopper(stopper) -> None:
    """Make this process a launcher: ``stopper(signum)`` stops its jobs on the
    first signal (and returns when they are closed); None undoes it."""
    _state["stopper"] = stopper
    if stopper is not None:
        install()


def acknowledge() -> None:
    """The interruption is being handled (the run is being marked KILLED):
    the pending signal is not raised again."""
    _state["pending"] = None


@contextlib.contextmanager
def critical():
    """Hold signals back while the body runs (a store write). A signal whose
    raise was lost (see the module's docstring) is raised before the body."""
    if _state["critical"] == 0:
        checkpoint()
    _state["critical"] += 1
    try:
        yield
    finally:
        _state["critical"] -= 1
    if _state["critical"] == 0:
        checkpoint()


@contextlib.contextmanager
def deferred():
    """Hold signals back in the body; they are raised at the next
    :func:`checkpoint` or when the body ends. For loops that run inside a
    library which catches every exception of a callback and prints it (emcee
    prints a traceback for a KeyboardInterrupt in the log-probability)."""
    with critical():
        yield


def checkpoint() -> None:
    """Raise a signal held back by :func:`deferred` (a safe point of a loop)."""
    if _state["pending"] is not None:
        signum, _state["pending"] = _state["pending"], None
        raise Interrupted(signum)


@contextlib.contextmanager
def job():
    """The body is a job: a signal raises :class:`Interrupted` in it.

    Raises at once when this process was already signalled.
    """
    install()
    if _state["signum"] is not None:
        raise Interrupted(_state["signum"])
    _state["job"] = True
    try:
        yield
        checkpoint()                    # a signal whose raise was lost in the job
    except BaseException:
        acknowledge()                   # delivered: the job is over either way
        raise
    finally:
        _state["job"] = False
