"""A worker started by ``mgrao serve`` ends when that serve process ends, however it ends.

``mgrao serve`` puts its own pid in ``MGRAO_SUPERVISOR_PID`` when it starts a worker; the worker calls
:func:`bind_to_supervisor` first thing. Without that variable (``mgrao worker`` started by hand, by
systemd, on another machine) nothing happens: such a worker outlives the shell that started it.

When the supervisor dies, even by SIGKILL, the worker sends itself SIGTERM, which is its normal
graceful stop (it hands a running job back to the queue and exits), and if it is still alive
``GRACE_S`` seconds later it exits hard. Two mechanisms notice the death:

* Linux's ``prctl(PR_SET_PDEATHSIG, SIGTERM)``: immediate, but it fires when the parent *thread*
  that started the worker ends, not only the parent process. ``mgrao serve`` starts restarted
  workers from its watcher thread, which ends only when serve stops its workers anyway;
* a daemon thread that compares ``os.getppid()`` with the supervisor's pid every ``POLL_S``
  seconds (any POSIX system; it also covers a supervisor that died before the prctl call). It is
  the one that enforces the hard exit.
"""

from __future__ import annotations

import ctypes
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable

SUPERVISOR_ENV = "MGRAO_SUPERVISOR_PID"
POLL_S = 0.5
GRACE_S = 10.0
"""Seconds a worker has for its graceful stop after its supervisor died."""
EXIT_ORPHANED = 3
"""Exit status of a worker that had to exit hard after its supervisor died."""
_PR_SET_PDEATHSIG = 1

log = logging.getLogger("mgrao.lifeline")


class StopEvent(threading.Event):
    """A process's stop flag, set by its signal handlers: :class:`threading.Event` on a reentrant lock.

    A Python signal handler runs in the main thread between two of its bytecodes, so it may run while the main
    thread is inside the event's own lock: in :meth:`wait`, or in the :meth:`set` of a first signal when a second
    comes (``mgrao serve``'s SIGTERM and the parent-death SIGTERM of a worker that serve's watcher thread started
    arrive together). On :class:`threading.Event`'s own lock the handler then waited for its own thread: the
    worker hung until it was killed, 30 s later. Here it takes the lock again and goes on. A handler that runs
    between a :meth:`wait`'s look at the flag and its sleep wakes nobody: that wait sleeps out its timeout (the
    workers' and the dispatcher's waits have one).
    """

    def __init__(self) -> None:
        super().__init__()
        self._cond = threading.Condition(threading.RLock())  # the lock every method of Event takes


def stop_on_signals(stop: Callable[..., object]) -> None:
    """SIGTERM and SIGINT call ``stop(signum, frame)``: a clean stop (a worker's or the dispatcher's).

    A signal that comes while ``stop`` runs for an earlier one is dropped: the stop is under way (see
    :class:`StopEvent`, the flag ``stop`` should set).
    """
    handling = False

    def handler(signum: int, frame: object) -> None:
        nonlocal handling
        if handling:
            return
        handling = True
        try:
            stop(signum, frame)
        finally:
            handling = False

    signal.signal(signal.SIGTERM, handler)
    signal.signal(signal.SIGINT, handler)


def bind_to_supervisor(environ: dict[str, str] | os._Environ = os.environ) -> int | None:
    """Stop this process when the ``mgrao serve`` that started it dies.

    Returns:
        The supervisor's pid, or None when this process was not started by ``mgrao serve``.
    """
    value = environ.pop(SUPERVISOR_ENV, None)  # not passed on to anything this process starts
    if not value:
        return None
    try:
        supervisor = int(value)
    except ValueError:
        log.warning("ignoring %s=%r: not a process id", SUPERVISOR_ENV, value)
        return None
    _set_parent_death_signal()
    threading.Thread(target=_watch, args=(supervisor,), name="lifeline", daemon=True).start()
    return supervisor


def _set_parent_death_signal() -> None:
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, ctypes.c_ulong(signal.SIGTERM), 0, 0, 0) != 0:
            log.warning("prctl(PR_SET_PDEATHSIG) failed: %s; relying on the parent watch",
                        os.strerror(ctypes.get_errno()))
    except (OSError, AttributeError) as error:
        log.warning("prctl is unavailable (%s); relying on the parent watch", error)


def _watch(supervisor: int) -> None:
    while os.getppid() == supervisor:
        time.sleep(POLL_S)
    log.warning("supervisor %s is gone: stopping", supervisor)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(GRACE_S)
    log.error("still running %s s after the supervisor died: exiting now", GRACE_S)
    os._exit(EXIT_ORPHANED)
