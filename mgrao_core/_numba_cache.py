"""Where numba keeps the compiled engine when it cannot write next to the installed package.

numba caches a ``cache=True`` function in the ``__pycache__`` beside its source file, else in
``NUMBA_CACHE_DIR``, else in ``~/.cache/numba``, and when none of them is writable (a read-only
install run by a service user without a writable home) it refuses to compile at all: "cannot cache
function ...: no locator available". :mod:`mgrao_core.engine` imports this module before numba:

* when the user set ``NUMBA_CACHE_DIR`` or the engine's ``__pycache__`` is writable, nothing changes;
* otherwise ``NUMBA_CACHE_DIR`` is set to the first usable of ``$XDG_CACHE_HOME/mgrao/numba``
  (``~/.cache/mgrao/numba`` without it) and ``<temporary directory>/mgrao-numba-<uid>``;
* when no directory is usable, numba compiles without a cache (once per process, with a
  ``RuntimeWarning``) instead of failing the import and with it every job.

A usable directory is one this process can create, owns and can create a file in; the one in the
shared temporary directory must also be private (mode 0700), so that no other user can plant
compiled code there. This is about the machine, not the model: nothing here touches a simulation.
"""

from __future__ import annotations

import os
import stat
import sys
import tempfile
import warnings
from collections.abc import Mapping, MutableMapping
from dataclasses import dataclass

ENGINE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "engine")
"""The directory of the ``cache=True`` functions (numba's own cache is its ``__pycache__``)."""


def _creatable(path: str) -> bool:
    """The test numba makes: the directory exists or can be made, and a file can be created in it."""
    try:
        os.makedirs(path, mode=0o700, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


def _usable(path: str, *, private: bool) -> bool:
    """Creatable, a real directory (no symlink) owned by this user, and 0700 when ``private``."""
    try:
        os.makedirs(path, mode=0o700, exist_ok=True)
        info = os.lstat(path)
        if not stat.S_ISDIR(info.st_mode):
            return False
        if hasattr(os, "getuid") and info.st_uid != os.getuid():
            return False
        if private and info.st_mode & 0o077:
            os.chmod(path, 0o700)  # ours (checked above): tighten it
    except OSError:
        return False
    return _creatable(path)


def _user_cache_root(environ: Mapping[str, str]) -> str | None:
    xdg = environ.get("XDG_CACHE_HOME", "")
    if os.path.isabs(xdg):
        return xdg
    home = environ.get("HOME") or os.path.expanduser("~")  # the password entry without HOME
    return os.path.join(home, ".cache") if os.path.isabs(home) else None


def _system_temp_dir() -> str | None:
    try:
        return tempfile.gettempdir()
    except OSError:  # no writable temporary directory at all
        return None


@dataclass(frozen=True)
class CacheChoice:
    """Where numba will cache the engine (None: nowhere) and whether ``NUMBA_CACHE_DIR`` must say so."""

    path: str | None
    set_env: bool = False


def choose_cache_dir(environ: Mapping[str, str], engine_dir: str = ENGINE_DIR,
                     temp_dir: str | None = None) -> CacheChoice:
    """The user's ``NUMBA_CACHE_DIR``, numba's own ``__pycache__``, or the first usable fallback.

    Args:
        environ: the environment (``NUMBA_CACHE_DIR``, ``XDG_CACHE_HOME``, ``HOME``).
        engine_dir: the directory of the ``cache=True`` functions.
        temp_dir: the temporary directory (default :func:`tempfile.gettempdir`).
    """
    in_tree = os.path.join(engine_dir, "__pycache__")
    chosen = environ.get("NUMBA_CACHE_DIR")
    if chosen:  # the user's choice stands; numba falls back to its other places when it is unusable
        return CacheChoice(chosen if _creatable(chosen) else in_tree if _creatable(in_tree) else None)
    if _creatable(in_tree):
        return CacheChoice(in_tree)
    root = _user_cache_root(environ)
    temp = temp_dir or _system_temp_dir()
    owner = os.getuid() if hasattr(os, "getuid") else "user"
    candidates = [(os.path.join(root, "mgrao", "numba"), False)] if root else []
    candidates += [(os.path.join(temp, f"mgrao-numba-{owner}"), True)] if temp else []
    for path, private in candidates:
        if _usable(path, private=private):
            return CacheChoice(path, set_env=True)
    return CacheChoice(None)


def _compile_without_cache() -> None:
    """Make a ``cache=True`` function that numba finds no cache directory for compile uncached."""
    from numba.core.dispatcher import Dispatcher

    enable_caching = Dispatcher.enable_caching
    if getattr(enable_caching, "mgrao_uncached", False):
        return
    warned = []

    def enable_caching_where_possible(self: Dispatcher) -> None:
        try:
            enable_caching(self)
        except RuntimeError as error:
            if "no locator available" not in str(error):
                raise
            if not warned:
                warned.append(True)
                warnings.warn(f"numba finds no writable cache directory ({error}); the engine is compiled in "
                              "every process. Set NUMBA_CACHE_DIR to a writable directory to keep it.",
                              RuntimeWarning, stacklevel=2)

    enable_caching_where_possible.mgrao_uncached = True  # type: ignore[attr-defined]
    Dispatcher.enable_caching = enable_caching_where_possible


def configure(environ: MutableMapping[str, str] = os.environ) -> CacheChoice:
    """Apply :func:`choose_cache_dir` to this process and to the processes it starts."""
    choice = choose_cache_dir(environ)
    if choice.set_env and choice.path is not None:
        environ["NUMBA_CACHE_DIR"] = choice.path
        config = sys.modules.get("numba.core.config")
        if config is not None:  # numba was imported first and has read its environment already
            config.CACHE_DIR = choice.path
    if choice.path is None:
        _compile_without_cache()
    return choice


configure()
