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
    from mgrao_core.compiling import AHEAD_WORLDS, kind_name, parts_of

    if len(spec.algorithms) < 5:
        return f"{spec.system}'s configurations ({', '.join(spec.algorithms)})"
    world = [p for p in parts_of(spec) if p in AHEAD_WORLDS]
    described = " and ".join(world) if world else "one resource, complete, no task fails"
    return f"every family, {described} ({kind_name(frozenset(world))})"


def _kinds(context: click.Context, parameter: click.Parameter, text: str) -> list:  # noqa: ARG001  (click's callback)
    from mgrao_core.compiling import kinds_from_text

    try:
        return kinds_from_text(text)
    except ValueError as error:
        raise click.BadParameter(str(error)) from error


@click.command("compile")
@click.option("--worlds", default="all", show_default=True, callback=_kinds,
              help="The kinds of world to compile for: 'all', or kinds separated by commas, each 'plain' (one "
                   "resource, complete, no task fails: the paper's, whose configurations' own kernel comes with it) "
                   "or parts joined by '+' from several, sparse, failing (e.g. plain,several+failing).")
@click.option("--list", "listing", is_flag=True, help="List the kernels it would compile, and compile none.")
def compile_engine(worlds: list, listing: bool) -> None:
    """Compile the engine of every family ahead, for each kind of world (first time only; minutes on 2 cores)."""
    from mgrao_core.compiling import ahead

    specs = ahead(kinds=worlds)
    if listing:
        for i, spec in enumerate(specs, 1):
            click.echo(f"{i}/{len(specs)} {_described(spec)}")
        return
    load_engine()
    from mgrao_core.runner import compile_for

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
