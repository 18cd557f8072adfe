"""Wake-ups between the processes of one ``mgrao serve`` on one machine: a hint that saves a poll, never a guarantee.

The processes share a directory (``MGRAO_WAKE_DIR``; ``mgrao serve`` makes one for itself and its workers) of
Unix datagram sockets:

* each local worker binds ``worker-<pid>``. Whoever queues jobs (the API on a submit, anyone who advances a study
  and makes trials) sends every worker one byte, and an idle worker claims at once instead of at its next poll;
* the API's study driver binds :data:`STUDIES`. A worker whose jobs ended sends their ids there and goes on to its
  next claim while the driver, on the API's own core, advances their studies. When that send fails (no API
  listening, its buffer full) the worker advances the studies itself, as it does without a directory.

Nothing durable goes through a socket: a lost or unread datagram only delays. Workers still poll every
``MGRAO_POLL_S`` and the driver still advances every running study every ``MGRAO_STUDY_POLL_S``; workers on other
machines (``mgrao worker``, the Dask dispatcher without the directory) work by polling alone.
"""

from __future__ import annotations

import logging
import os
import select
import shutil
import socket
import tempfile
from pathlib import Path

log = logging.getLogger("mgrao.wakeup")

ENV = "MGRAO_WAKE_DIR"
STUDIES = "studies"
WORKER_PREFIX = "worker-"
DIR_PREFIX = "mgrao-wake-"


def make_directory(parent: Path | None = None) -> Path:
    """A new wake-up directory for this process (``mgrao-wake-<pid>-<random>``), after sweeping stale ones.

    A directory whose owner was killed (SIGKILL leaves no chance to remove it) names a pid that no longer
    runs: it is removed here, by the next ``mgrao serve`` of the same user. One of a live pid is left alone.
    """
    parent = Path(parent or tempfile.gettempdir())
    sweep_stale(parent)
    return Path(tempfile.mkdtemp(prefix=f"{DIR_PREFIX}{os.getpid()}-", dir=parent))


def sweep_stale(parent: Path) -> list[Path]:
    """Remove this user's wake-up directories under ``parent`` whose process is gone; the ones removed."""
    removed = []
    for entry in parent.glob(f"{DIR_PREFIX}*-*"):
        pid = entry.name[len(DIR_PREFIX):].split("-", 1)[0]
        try:
            if not pid.isdigit() or entry.stat().st_uid != os.getuid() or not entry.is_dir() or _alive(int(pid)):
                continue
        except OSError:
            continue
        shutil.rmtree(entry, ignore_errors=True)
        removed.append(entry)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: alive
        return True
    return True


def directory() -> Path | None:
    """This process's wake-up directory (``MGRAO_WAKE_DIR``), or None: wake-ups off, polling only."""
    value = os.environ.get(ENV)
    return Path(value) if value else None


def send(name: str, payload: bytes = b"!", where: Path | None = None) -> bool:
    """Send one datagram to the socket ``name`` of the directory, without blocking; whether it went."""
    where = where or directory()
    if where is None:
        return False
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.setblocking(False)
        try:
            sock.sendto(payload, str(where / name))
        except OSError:  # nobody listening (refused, missing), its buffer full, a path too long
            return False
    return True


def wake_workers(where: Path | None = None) -> int:
    """Tell every local worker that jobs were queued; how many were told (0 without a directory)."""
    where = where or directory()
    if where is None:
        return 0
    try:
        names = [entry.name for entry in os.scandir(where) if entry.name.startswith(WORKER_PREFIX)]
    except OSError:
        return 0
    return sum(send(name, where=where) for name in names)


class Listener:
    """A bound datagram socket of the directory: :meth:`wait` for a wake-up, :meth:`poke` one's own."""

    def __init__(self, name: str, where: Path | None = None) -> None:
        where = where or directory()
        if where is None:
            raise ValueError(f"no wake-up directory ({ENV} is unset)")
        self.path = where / name
        self.path.unlink(missing_ok=True)  # a dead process's socket of the same name
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(str(self.path))
        self.sock.setblocking(False)

    @classmethod
    def open(cls, name: str) -> Listener | None:
        """A listener in this process's directory, or None (no directory, or it could not be bound: polling)."""
        if directory() is None:
            return None
        try:
            return cls(name)
        except OSError as error:
            log.warning("no wake-up socket %s (%s): polling only", name, error)
            return None

    def wait(self, timeout: float) -> list[bytes]:
        """The datagrams received within ``timeout`` seconds (all that are waiting once one came; [] if none)."""
        try:
            ready, _, _ = select.select([self.sock], [], [], max(0.0, timeout))
        except (OSError, ValueError):  # closed meanwhile
            return []
        out = []
        while ready:
            try:
                out.append(self.sock.recv(65536))
            except (BlockingIOError, OSError):
                break
        return out

    def poke(self) -> None:
        """Wake this listener's own :meth:`wait` (e.g. to stop)."""
        send(self.path.name, b"", self.path.parent)

    def close(self) -> None:
        """Close and remove the socket."""
        self.sock.close()
        self.path.unlink(missing_ok=True)
