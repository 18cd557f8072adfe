"""Where numba keeps the compiled engine: in the user's cache, never inside the installed package.

numba caches a ``cache=True`` function in ``NUMBA_CACHE_DIR`` when it is set, else in the
``__pycache__`` beside its source file, else in ``~/.cache/numba``, and when none of them is writable
(a read-only install run by a service user without a writable home) it refuses to compile at all:
"cannot cache function ...: no locator available". Its files beside the source outlive the
package: ``pip uninstall`` (and the uninstall before any reinstall) removes only the files it
installed, and the ``mgrao_core/engine/__pycache__`` left behind makes ``mgrao_core`` a namespace
package that hides the next install, an editable one among them ("cannot import name ... from
'mgrao_core' (unknown location)"). :mod:`mgrao_core.engine` therefore imports this module before
numba:

* a ``NUMBA_CACHE_DIR`` the user set stands when it is usable;
* otherwise ``NUMBA_CACHE_DIR`` is set to the first usable of ``$XDG_CACHE_HOME/mgrao/numba``
  (``~/.cache/mgrao/numba`` without it) and ``<temporary directory>/mgrao-numba-<uid>``, for this
  process and the ones it starts; numba names its files there by the source's directory (its name
  and a hash of its absolute path), so installs in different places keep apart, and an install
  that replaces another in the same place finds the old files stale (numba stamps them with the
  source, :mod:`mgrao_core.engine.cache` with every compiled source) and overwrites them;
* when no directory is usable, the engine is compiled without a cache (once per process and
  combination of families, with a ``RuntimeWarning``) instead of failing the import and with it
  every job, and instead of caching beside its source.

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
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from numba.core.dispatcher import Dispatcher

ENGINE_PACKAGES = ("mgrao_core.engine", "mgrao_core.algorithms")
"""The packages of the ``cache=True`` functions: the engine and the algorithm families' compiled steps
(numba's own place for their cache is each module's ``__pycache__``)."""


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


def choose_cache_dir(environ: Mapping[str, str], temp_dir: str | None = None) -> CacheChoice:
    """The user's ``NUMBA_CACHE_DIR`` if usable, else the first usable of the user's cache and a private temp dir.

    Never the package's own ``__pycache__`` (see the module): None when nothing else is usable.

    Args:
        environ: the environment (``NUMBA_CACHE_DIR``, ``XDG_CACHE_HOME``, ``HOME``).
        temp_dir: the temporary directory (default :func:`tempfile.gettempdir`).
    """
    chosen = environ.get("NUMBA_CACHE_DIR")
    if chosen and _creatable(chosen):  # the user's choice stands
        return CacheChoice(chosen)
    root = _user_cache_root(environ)
    temp = temp_dir or _system_temp_dir()
    owner = os.getuid() if hasattr(os, "getuid") else "user"
    candidates = [(os.path.join(root, "mgrao", "numba"), False)] if root else []
    candidates += [(os.path.join(temp, f"mgrao-numba-{owner}"), True)] if temp else []
    for path, private in candidates:
        if _usable(path, private=private):
            return CacheChoice(path, set_env=True)
    return CacheChoice(None)


def _is_engine(dispatcher: Dispatcher) -> bool:
    """A function of the engine or of an algorithm's compiled steps (wherever the package is installed or copied)."""
    module = getattr(dispatcher.py_func, "__module__", None) or ""
    return any(module == package or module.startswith(package + ".") for package in ENGINE_PACKAGES)


def _compile_without_cache() -> None:
    """Compile the engine's ``cache=True`` functions, and any others numba finds no cache for, uncached.

    numba would still cache the engine beside its source when that is writable; it is kept out
    of there (see the module) and compiled in every process instead.
    """
    from numba.core.dispatcher import Dispatcher

    enable_caching = Dispatcher.enable_caching
    if getattr(enable_caching, "mgrao_uncached", False):
        return
    warned = []

    def warn_once(reason: str) -> None:
        if not warned:
            warned.append(True)
            warnings.warn(f"numba finds no writable cache directory ({reason}); the engine is compiled in every "
                          "process. Set NUMBA_CACHE_DIR to a writable directory to keep it.",
                          RuntimeWarning, stacklevel=3)

    def enable_caching_where_possible(self: Dispatcher) -> None:
        if _is_engine(self):  # the dispatcher keeps the NullCache it was made with
            warn_once("neither the user's cache directory nor a private temporary one is usable, and the "
                      "engine is not cached beside its source")
            return
        try:
            enable_caching(self)
        except RuntimeError as error:
            if "no locator available" not in str(error):
                raise
            warn_once(str(error))

    enable_caching_where_possible.mgrao_uncached = True  # type: ignore[attr-defined]
    Dispatcher.enable_caching = enable_caching_where_possible


def configure(environ: MutableMapping[str, str] = os.environ) -> CacheChoice:
    """Apply :func:`choose_cache_dir` to this process and to the processes it starts."""
    choice = choose_cache_dir(environ)
    if choice.set_env and choice.path is not None:
        if environ.get("NUMBA_CACHE_DIR"):
            warnings.warn(f"NUMBA_CACHE_DIR={environ['NUMBA_CACHE_DIR']} is not a writable directory; the engine "
                          f"is cached in {choice.path} instead", RuntimeWarning, stacklevel=2)
        environ["NUMBA_CACHE_DIR"] = choice.path
        config = sys.modules.get("numba.core.config")
        if config is not None:  # numba was imported first and has read its environment already
            config.CACHE_DIR = choice.path
    if choice.path is None:
        _compile_without_cache()
    return choice


configure()
