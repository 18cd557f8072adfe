"""``mgrao compile``: compile the engine of every family ahead, so that no run or job waits on the compiler.

A combination of learner families and kind of world met for the first time compiles the kernel (tens of
seconds to minutes, :mod:`mgrao_core.compiling`); this compiles, one after another, the kernel of every family
for each kind of world and the paper's configurations' own, into numba's cache, where every later process of
this install loads them in under a second. A server runs it once after each install or upgrade, before it
serves (docs/service.md, "Compiling ahead"). The kernels are compiled one at a time: numba's cache index of a
function is rewritten whole by each process that adds to it, so two compiling at once could lose one.
"""

from __future__ import annotations

import os
import time

import click

from mgrao_cli.engine_loading import load_engine


def _described(spec) -> str:  # noqa: ANN001  (an ExperimentSpec, imported with the engine)
    from mgrao_core.compiling import AHEAD_WORLDS, parts_of

    if len(spec.algorithms) < 5:
        return f"{spec.system}'s configurations ({', '.join(spec.algorithms)})"
    world = [p for p in parts_of(spec) if p in AHEAD_WORLDS]
    return "every family, " + (" and ".join(world) if world else "one resource, complete, no task fails")


@click.command("compile")
def compile_engine() -> None:
    """Compile the engine of every family ahead, for each kind of world (first time only; minutes on 2 cores)."""
    load_engine()
    from mgrao_core.compiling import ahead
    from mgrao_core.runner import compile_for

    specs = ahead()
    click.echo(f"compiling the engine ahead: {len(specs)} kernels, into {os.environ.get('NUMBA_CACHE_DIR', '?')}",
               err=True)
    started = time.perf_counter()
    compiled = 0
    for i, spec in enumerate(specs, 1):
        what = f"{i}/{len(specs)} {_described(spec)}"

        def say(notice, what=what) -> None:  # noqa: ANN001  (a Compiling)
            if notice.seconds is None:
                click.echo(f"  {what}: compiling, about {round(notice.estimate_s)} s on 2 quiet cores", err=True)
            else:
                click.echo(f"  {what}: compiled in {notice.seconds:.1f} s", err=True)

        if compile_for(spec, on_compile=say):
            compiled += 1
        else:
            click.echo(f"  {what}: compiled before", err=True)
    click.echo(f"done in {time.perf_counter() - started:.0f} s ({compiled} compiled now): a run or job of any "
               "family loads its kernel from the cache from now on, until an upgrade changes the engine", err=True)
