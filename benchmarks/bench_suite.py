"""CI from a fresh clone: ``CI=true bash .ci/run`` timed, phase by phase.

Run: ``python benchmarks/bench_suite.py`` (``--commit REV``, default HEAD: a committed state, as CI sees it).
It clones the repository into a temporary directory (``git clone``, then ``REV`` checked out), gives the run an
empty cache home (``XDG_CACHE_HOME``: numba's cache and pip's, as on a new CI machine) and runs ``.ci/run`` there
with ``CI=true``, a JUnit report added through ``PYTEST_ADDOPTS``. It prints:

* install: from the start to pytest's first line (the system packages when missing, the virtualenv, ``pip
  install -e ".[test]"``);
* compile: the census of kernels compiled before the tests (tests/support/kernels.py; the line pytest prints);
* tests: from then to pytest's last line, with the whole run's counts;
* by directory: each test directory's tests' own seconds, summed (on several workers, these add up to more than
  the wall time: their sum over the wall time is how busy the workers were), and the slowest files.

``--baseline REV`` measures that revision the same way first (an earlier one runs ``pytest`` on one process). The
machine's load average is printed before and after: a figure taken under load is not a quiet machine's, and the
cores' idle share while the tests ran is the whole machine's (/proc/stat). ``--junit PATH`` keeps the measured
revision's JUnit report. ``--durations JUNIT.xml`` writes tests/support/durations.json (each test file's seconds,
the order of a parallel run: tests/support/scheduling.py) from a run's report instead, and measures nothing.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DURATIONS = ROOT / "tests" / "support" / "durations.json"
DEADLINE_S = 3 * 3600
KERNELS = re.compile(r"kernels: (\d+) signatures compiled or loaded in ([\d.]+) s")


def test_seconds(junit: Path) -> dict[str, float]:
    """Each test's seconds (setup, call and teardown) in a JUnit report, by its node id."""
    seconds: dict[str, float] = {}
    for case in ET.parse(junit).getroot().iter("testcase"):
        parts = case.get("classname", "").split(".")
        module = next((i for i, part in enumerate(parts) if part.startswith("test_")), len(parts) - 1)
        nodeid = "/".join(parts[: module + 1]) + ".py::" + "::".join([*parts[module + 1:], case.get("name", "")])
        seconds[nodeid] = seconds.get(nodeid, 0.0) + float(case.get("time") or 0)
    return seconds


def file_seconds(tests: dict[str, float]) -> dict[str, float]:
    """Each test file's seconds, from its tests'."""
    files: collections.Counter[str] = collections.Counter()
    for nodeid, seconds in tests.items():
        files[nodeid.split("::", 1)[0]] += seconds
    return dict(files)


ALONE_S = 20.0
"""A test at least this long is scheduled on its own in tests/support/durations.json, not with its file."""


def write_durations(junit: Path) -> None:
    """tests/support/durations.json: each test of at least ALONE_S seconds, and each file's other tests together."""
    tests = test_seconds(junit)
    durations = {nodeid: seconds for nodeid, seconds in tests.items() if seconds >= ALONE_S}
    rest = file_seconds({nodeid: seconds for nodeid, seconds in tests.items() if nodeid not in durations})
    durations |= rest
    DURATIONS.write_text(json.dumps({k: round(v, 1) for k, v in sorted(durations.items())}, indent=0) + "\n")
    print(f"wrote {DURATIONS.relative_to(ROOT)}: {len(rest)} files and {len(durations) - len(rest)} tests on their "
          f"own, {sum(tests.values()):.0f} s in all")


def load() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def cpu_times() -> tuple[int, int]:
    """The machine's CPU time so far, in clock ticks: (idle, all), from /proc/stat (idle and I/O wait count as idle)."""
    fields = [int(x) for x in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    return fields[3] + fields[4], sum(fields[:8])


def measure(revision: str, keep_junit: Path | None = None) -> dict:
    """Clone ``revision`` and time its ``.ci/run`` (see the module); the phases' seconds."""
    with tempfile.TemporaryDirectory(prefix="mgrao-bench-suite-") as tmp:
        clone, cache, junit = Path(tmp) / "mgrao", Path(tmp) / "cache", Path(tmp) / "junit.xml"
        subprocess.run(["git", "clone", "--quiet", "--no-hardlinks", str(ROOT), str(clone)], check=True, timeout=600)
        subprocess.run(["git", "-C", str(clone), "checkout", "--quiet", revision], check=True, timeout=600)
        cache.mkdir()
        env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "MGRAO_", "PYTEST_", "VIRTUAL_ENV"))}
        env |= {"CI": "true", "XDG_CACHE_HOME": str(cache), "PYTEST_ADDOPTS": f"--junitxml={junit}"}
        short = subprocess.check_output(["git", "-C", str(clone), "rev-parse", "--short", "HEAD"], text=True).strip()
        print(f"{revision} ({short}), load average {load()}", flush=True)
        start = time.monotonic()
        marks: dict[str, float] = {}
        tail: collections.deque[str] = collections.deque(maxlen=60)
        with open(Path(tmp) / "ci.log", "w") as log:
            process = subprocess.Popen(["bash", ".ci/run"], cwd=clone, env=env, stdout=subprocess.PIPE,
                                       stderr=subprocess.STDOUT, text=True)
            assert process.stdout is not None
            for line in process.stdout:
                now = time.monotonic() - start
                log.write(line)
                tail.append(line.rstrip())
                if line.startswith("Successfully installed"):  # pip's last line: pytest starts next
                    marks.setdefault("installed", now)
                if "test session starts" in line:  # printed after the census is compiled (tests/conftest.py)
                    marks.setdefault("session", now)
                if census := KERNELS.search(line):
                    marks["kernels"] = now
                    idle_at_tests = cpu_times()
                    marks["compile"] = float(census[2])
                    marks["signatures"] = int(census[1])
            process.wait(timeout=DEADLINE_S)
        total = time.monotonic() - start
        if "kernels" in marks:  # how busy the machine's cores were while the tests ran (other users' work included)
            idle, every = (after - before for after, before in zip(cpu_times(), idle_at_tests, strict=True))
            marks["idle"] = idle / every
        if keep_junit is not None and junit.exists():
            keep_junit.write_bytes(junit.read_bytes())
        summary = next((line for line in reversed(tail) if re.search(r"\d+ (passed|failed)", line)), "")
        result = {"revision": revision, "total": total, "returncode": process.returncode, "summary": summary,
                  "load": load(), **marks}
        result["by_directory"], result["files"] = {}, {}
        if junit.exists():
            files = file_seconds(test_seconds(junit))
            result["files"] = files
            for name, seconds in files.items():
                directory = "/".join(name.split("/")[:2]) if name.count("/") >= 2 else "tests (top level)"
                result["by_directory"][directory] = result["by_directory"].get(directory, 0.0) + seconds
        if process.returncode != 0:
            print("\n".join(tail))
        return result


def report(result: dict) -> None:
    total = result["total"]
    session = result.get("installed", result.get("session", total))
    tests_start = max(result.get("kernels", session), result.get("session", session))
    print(f"\n{result['revision']}: {total:.0f} s ({total / 60:.1f} min) in all, exit {result['returncode']}, "
          f"load average after {result['load']}")
    print(f"  install  {session:7.0f} s   system packages if missing, virtualenv, pip install (the README's)")
    if "compile" in result:
        print(f"  compile  {tests_start - session:7.0f} s   pytest's start and {result['signatures']} kernel "
              f"signatures ({result['compile']:.0f} s compiling)")
    print(f"  tests    {total - tests_start:7.0f} s   {result['summary'].strip('= ')}")
    busy = sum(result["by_directory"].values())
    for directory, seconds in sorted(result["by_directory"].items(), key=lambda item: -item[1]):
        print(f"    {directory:20s} {seconds:7.0f} s of tests ({seconds / busy:.0%})")
    if total > tests_start:
        print(f"    (the tests' seconds summed: {busy:.0f} s, {busy / (total - tests_start):.2f} per second of wall)")
    if "idle" in result:
        print(f"    (the machine's cores idle {result['idle']:.0%} of the time while the tests ran)")
    for name, seconds in sorted(result["files"].items(), key=lambda item: -item[1])[:10]:
        print(f"      {seconds:6.0f} s  {name}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--commit", default="HEAD", help="the revision to measure (default HEAD)")
    parser.add_argument("--baseline", help="an earlier revision, measured first in the same way")
    parser.add_argument("--json", type=Path, help="also write the results there")
    parser.add_argument("--durations", type=Path, metavar="JUNIT",
                        help="write tests/support/durations.json from this JUnit report, and measure nothing")
    parser.add_argument("--junit", type=Path, help="keep the measured revision's JUnit report there (for --durations)")
    args = parser.parse_args()
    if args.durations:
        write_durations(args.durations)
        return
    revisions = [args.baseline, args.commit] if args.baseline else [args.commit]
    results = []
    for revision in revisions:
        results.append(measure(revision, args.junit if revision == args.commit else None))
        report(results[-1])
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    sys.exit(max(r["returncode"] for r in results))


if __name__ == "__main__":
    main()
