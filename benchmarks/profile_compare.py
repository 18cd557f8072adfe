"""Where a cached reload of the compare view spends its time (a profile, not a test): prints a breakdown.

Starts ``mgrao serve --workers 0`` on a database holding the benchmark's compare jobs (tag
``bench-compare``, as ``benchmarks/bench_dashboard.py`` builds them), loads the compare view twice in
one browser context to fill the HTTP and code caches, then loads it ``--repeat`` more times under
Chrome DevTools Protocol tracing (Playwright's ``browser.start_tracing``) and, separately, under the
V8 sampling profiler (``Profiler`` domain). Per load it reports, from navigation start to the
``compare-rendered`` mark:

* the renderer main thread's busy time split into plotly.js's evaluation (compile and top level), our
  ES modules' evaluation, other script, style and layout (forced by script, or by the frame), paint
  (pre-paint, paint, layerize, commit), HTML parsing and garbage collection;
* every ``Plotly.react``/``Plotly.newPlot`` call's duration and start (a wrapper installed before the
  page's scripts run, as user timing measures ``plotly:<element id>``);
* the fetches (resource start to finish, from the trace's network events);
* the JavaScript self time by file (the sampling profile): plotly.js, our modules, the rest.

Run:  python benchmarks/profile_compare.py --reuse <bench.db> [--repeat 9] [--hash '#/compare?...']
      (``--json out.json``: the raw per-load figures too)
Needs /usr/bin/chromium (Debian) and playwright's Python package.
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import statistics
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks.bench_dashboard import CHROMIUM, CHROMIUM_ARGS, call  # noqa: E402
from tests.support.local_service import free_port, serve_command, stop, wait_healthy  # noqa: E402

CATEGORIES = [
    "devtools.timeline", "v8.execute", "v8", "blink.user_timing", "loading", "netlog",
    "disabled-by-default-devtools.timeline", "disabled-by-default-devtools.timeline.frame",
]

# Wrap Plotly.react/newPlot as soon as plotly.js assigns window.Plotly: a user timing measure per call.
WRAP_PLOTLY = """
(() => {
  let inner;
  Object.defineProperty(window, 'Plotly', { configurable: true, enumerable: true,
    get() { return inner; },
    set(value) {
      inner = value;
      for (const name of ['react', 'newPlot', 'relayout', 'restyle', 'purge']) {
        const fn = value && value[name];
        if (typeof fn !== 'function' || fn.__wrapped) continue;
        const wrapped = function (el, ...rest) {
          const id = (el && el.id) || 'plot';
          const t0 = performance.now();
          const out = fn.call(this, el, ...rest);
          const sync = performance.now();
          performance.measure(`plotly-sync:${name}:${id}`, { start: t0, end: sync });
          Promise.resolve(out).then(() =>
            performance.measure(`plotly:${name}:${id}`, { start: t0, end: performance.now() }));
          return out;
        };
        wrapped.__wrapped = true;
        value[name] = wrapped;
      }
    } });
})();
"""

SCRIPT_EVENTS = {"EvaluateScript", "v8.evaluateModule", "FunctionCall", "TimerFire", "FireAnimationFrame",
                 "EventDispatch", "RunMicrotasks", "v8.compile", "v8.compileModule", "V8.CompileCode",
                 "v8.produceCache", "v8.produceModuleCache", "XHRReadyStateChange", "FireIdleCallback",
                 "v8.run", "V8.Execute", "v8.callFunction", "v8.callAsConstructor"}
STYLE_LAYOUT = {"UpdateLayoutTree", "Layout", "RecalculateStyles", "UpdateLayerTree",
                "IntersectionObserverController::computeIntersections"}
PAINT = {"PrePaint", "Paint", "PaintImage", "Layerize", "Commit", "CompositeLayers", "UpdateLayer",
         "RasterTask", "Decode Image", "PaintSetup"}
GC = {"MajorGC", "MinorGC", "V8.GCScavenger", "V8.GCCompactor", "V8.GCFinalizeMC", "BlinkGC.AtomicPhase",
      "V8.GC_MC_BACKGROUND_MARKING", "BlinkGC.CompleteSweep"}


def median(xs):
    return statistics.median(xs) if xs else float("nan")


def main_thread(events):
    """(pid, tid) of the renderer main thread that holds the navigation."""
    names = {(e["pid"], e["tid"]): e["args"]["name"] for e in events
             if e.get("ph") == "M" and e.get("name") == "thread_name"}
    mains = {k for k, v in names.items() if v == "CrRendererMain"}
    counts = defaultdict(int)
    for e in events:
        if (e.get("pid"), e.get("tid")) in mains and e.get("ph") == "X":
            counts[(e["pid"], e["tid"])] += 1
    return max(counts, key=counts.get)


def script_url(e):
    data = (e.get("args") or {}).get("data") or {}
    return data.get("url") or (e.get("args") or {}).get("fileName") or ""


def classify_script(url):
    if "plotly" in url:
        return "plotly.js"
    if "/js/" in url:
        return "our modules"
    return "other script"


def breakdown(trace: dict) -> dict:
    """Self time on the main thread by kind between navigation start and compare-rendered (ms)."""
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    marks = [e for e in events if e.get("cat", "").startswith("blink.user_timing")]
    mark = max((e for e in marks if e.get("name") == "compare-rendered"), key=lambda e: e["ts"])
    end = mark["ts"]
    start = end - mark["args"]["data"]["startTime"] * 1000  # the page's time origin (navigation start)
    marks = [e for e in marks if e.get("pid") == mark["pid"]]  # this page's renderer, not another's
    first = [e["ts"] for e in marks if e.get("name") == "compare-first-chart" and e["ts"] > start]
    all_drawn = [e["ts"] for e in marks if e.get("name") == "compare-all-drawn" and e["ts"] > start]
    pid, tid = mark["pid"], mark["tid"]  # the mark is made on the page's main thread
    main = sorted((e for e in events if e.get("pid") == pid and e.get("tid") == tid and e.get("ph") == "X"
                   and "dur" in e and e["ts"] < end and e["ts"] + e["dur"] > start),
                  key=lambda e: (e["ts"], -e["dur"]))
    # self time: each event's duration minus its children's (events nest on one thread)
    stack: list[dict] = []
    totals: dict[str, float] = defaultdict(float)
    busy = 0.0

    # Plotly calls (until each returned): the script and layout inside them are the chart's drawing
    opened: dict[str, list[float]] = defaultdict(list)
    windows = []
    for e in sorted(marks, key=lambda e: e["ts"]):
        name = e.get("name", "")
        if name.startswith("plotly-sync:") and e.get("ph") == "b":
            opened[name].append(e["ts"])
        elif name.startswith("plotly-sync:") and e.get("ph") == "e" and opened[name]:
            windows.append((opened[name].pop(0), e["ts"]))

    def in_plotly_call(ts):
        return any(a <= ts < b for a, b in windows)

    def kind(e, parents):
        name = e["name"]
        if name in SCRIPT_EVENTS:
            url = script_url(e)
            if "plotly" in url and name in ("EvaluateScript", "v8.run", "v8.compile"):
                return "plotly.js evaluation (top level)"
            if name in ("v8.evaluateModule", "v8.compileModule", "v8.produceModuleCache"):
                return "our modules: compile, evaluate"
            if in_plotly_call(e["ts"]):
                return "Plotly.react: script"
            for p in reversed(parents):  # (a module's evaluation event may hold later calls: not inherited)
                if p.get("_kind", "").startswith(("plotly.js", "Plotly.react")):
                    return p["_kind"]
            return "script: ours and the rest"
        if name in STYLE_LAYOUT:
            if in_plotly_call(e["ts"]):
                return "Plotly.react: forced style+layout"
            in_script = any(p["name"] in SCRIPT_EVENTS for p in parents)
            return "style+layout forced by other script" if in_script else "style+layout (frame)"
        if name in PAINT:
            return "paint, layerize, commit"
        if name in GC:
            return "garbage collection"
        if name in ("ParseHTML", "ParseAuthorStyleSheet") or name.startswith(("DocumentLoader", "NavigationBodyLoader",
                                                                            "HTMLDocumentParser", "LocalWindowProxy")):
            return "navigation, HTML and CSS parsing"
        for p in reversed(parents):
            k = p.get("_kind")
            if k and k != "other (task overhead)":
                return k
        return "other (task overhead)"

    # self time: each event's interval less its children's (events nest on one thread), cut at the
    # Plotly calls' edges so that the script running inside a call counts as that call's
    roots: list[dict] = []
    for e in main:
        e = dict(e, _end=e["ts"] + e["dur"], _children=[])
        while stack and stack[-1]["_end"] <= e["ts"]:
            stack.pop()
        e["_kind"] = kind(e, stack)
        (stack[-1]["_children"] if stack else roots).append(e)
        stack.append(e)
    cuts = sorted({t for w in windows for t in w})

    def add_self(e):
        edges = [e["ts"]]
        for c in e["_children"]:
            edges += [c["ts"], c["_end"]]
        edges.append(e["_end"])
        for k in range(0, len(edges), 2):
            a, b = max(edges[k], start), min(edges[k + 1], end)
            points = [a] + [t for t in cuts if a < t < b] + [b]
            for x, y in zip(points, points[1:], strict=False):
                if y <= x:
                    continue
                label = e["_kind"]
                if label.startswith("script: ours") and in_plotly_call((x + y) / 2):
                    label = "Plotly.react: script"
                totals[label] += y - x
        for c in e["_children"]:
            add_self(c)

    for e in roots:
        busy += max(0.0, min(e["_end"], end) - max(e["ts"], start))
        add_self(e)
    # fetches: resource send -> finish
    sends = {e["args"]["data"]["requestId"]: e for e in events
             if e.get("name") == "ResourceSendRequest" and e.get("pid") == pid}
    finishes = {e["args"]["data"]["requestId"]: e for e in events if e.get("name") == "ResourceFinish"}
    fetches = []
    for rid, s in sends.items():
        url = s["args"]["data"].get("url", "")
        f = finishes.get(rid)
        if f and url.startswith("http") and s["ts"] >= start - 50_000:
            fetches.append((url, (s["ts"] - start) / 1000, (f["ts"] - start) / 1000))
    measures = defaultdict(list)
    for e in marks:
        name = e.get("name", "")
        if name.startswith("plotly") and e.get("ph") in ("b", "e") and e["ts"] >= start:
            measures[name].append(e["ts"])
    plots = []
    for name, ts in measures.items():
        ts.sort()
        for k in range(0, len(ts) - 1, 2):
            plots.append((name, (ts[k] - start) / 1000, (ts[k + 1] - ts[k]) / 1000))
    return {
        "total_ms": (end - start) / 1000,
        "first_chart_ms": (min(first) - start) / 1000 if first else None,
        "all_drawn_ms": (min(all_drawn) - start) / 1000 if all_drawn else None,
        "busy_ms": busy / 1000,
        "self_ms": {k: v / 1000 for k, v in totals.items()},
        "fetches": sorted(fetches, key=lambda x: x[1]),
        "plotly_calls": sorted(plots, key=lambda x: x[1]),
    }


def cpu_by_file(profile: dict) -> dict:
    """Self time (ms) of the sampling profile by file kind."""
    nodes = {n["id"]: n for n in profile["nodes"]}
    totals: dict[str, float] = defaultdict(float)
    for node_id, delta in zip(profile["samples"], profile["timeDeltas"], strict=False):
        frame = nodes[node_id]["callFrame"]
        url, fn = frame.get("url", ""), frame.get("functionName", "")
        key = classify_script(url) if url else (fn or "(anonymous)")
        totals[key] += delta / 1000
    return dict(totals)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reuse", type=Path, required=True, help="a bench_dashboard.py database (bench.db)")
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--hash", default=None, help="the view's address (default: the bench's compare, smooth=5)")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--profile-dir", action="store_true",
                    help="a browser profile on disk (a user's browser: V8's code cache kept) instead of incognito")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright

    tmp = Path(tempfile.mkdtemp(prefix="mgrao-profile-"))
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    env = {**os.environ, "MGRAO_DATABASE_URL": f"sqlite:///{args.reuse.resolve()}"}
    env.pop("MGRAO_API_TOKEN", None)
    with open(tmp / "serve.log", "wb") as log:
        proc = subprocess.Popen(serve_command(port, 0), env=env, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT)
    try:
        wait_healthy(base, proc)
        ids = [j["id"] for j in call(base, "GET", "/jobs?tag=bench-compare&limit=200")["data"]][:10]
        hash_ = args.hash or f"/#/compare?jobs={','.join(map(str, ids))}&smooth=5"
        with sync_playwright() as p:
            options = {"viewport": {"width": 1366, "height": 768}, "base_url": base}
            if args.profile_dir:  # a browser profile on disk, as a user's: V8's code cache is kept
                ctx = p.chromium.launch_persistent_context(
                    tempfile.mkdtemp(prefix="mgrao-profile-chromium-"), executable_path=CHROMIUM,
                    args=CHROMIUM_ARGS, **options)
            else:  # an incognito context, as bench_dashboard.py's: the HTTP cache only
                browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
                ctx = browser.new_context(**options)
            ctx.add_init_script(WRAP_PLOTLY)

            def load(page):
                page.goto(hash_)
                page.wait_for_selector("main[data-render-ms] #compare-chart[data-rendered]", timeout=60000)
                page.wait_for_timeout(300)  # let the trace's last frame land

            for _ in range(2):  # fill the HTTP cache and V8's code cache
                page = ctx.new_page()
                load(page)
                page.close()
            rows = []
            for _ in range(args.repeat):
                page = ctx.new_page()
                if not args.profile_dir:  # the browser's own tracing (a CDP session's misses the nesting here)
                    browser.start_tracing(page=page, categories=CATEGORIES)
                    load(page)
                    rows.append(breakdown(json.loads(browser.stop_tracing())))
                    page.close()
                    continue
                cdp = ctx.new_cdp_session(page)
                done: list[dict] = []

                def complete(event, done=done):
                    done.append(event)
                cdp.on("Tracing.tracingComplete", complete)
                cdp.send("Tracing.start", {"traceConfig": {"includedCategories": CATEGORIES},
                                           "transferMode": "ReturnAsStream"})
                load(page)
                cdp.send("Tracing.end")
                while not done:
                    page.wait_for_timeout(50)
                stream, chunks = done[0]["stream"], []
                while True:
                    chunk = cdp.send("IO.read", {"handle": stream, "size": 1 << 20})
                    data = chunk["data"]
                    chunks.append(base64.b64decode(data) if chunk.get("base64Encoded") else data.encode())
                    if chunk.get("eof"):
                        break
                cdp.send("IO.close", {"handle": stream})
                cdp.detach()
                rows.append(breakdown(json.loads(b"".join(chunks))))
                page.close()
            cpu = []
            for _ in range(args.repeat):  # sampled separately: the sampler would slow the traced loads
                page = ctx.new_page()
                cdp = ctx.new_cdp_session(page)
                cdp.send("Profiler.enable")
                cdp.send("Profiler.setSamplingInterval", {"interval": 200})
                cdp.send("Profiler.start")
                load(page)
                cpu.append(cpu_by_file(cdp.send("Profiler.stop")["profile"]))
                cdp.detach()
                page.close()
            ctx.close()
            if not args.profile_dir:
                browser.close()
    finally:
        stop(proc, timeout=15)

    print(f"compare view, cached reload, {args.repeat} traced loads (medians, ms): {hash_}")
    print(f"  navigation start -> compare-rendered: {median([r['total_ms'] for r in rows]):.0f}"
          f" (main thread busy {median([r['busy_ms'] for r in rows]):.0f})")
    for key in ("first_chart_ms", "all_drawn_ms"):
        vals = [r[key] for r in rows if r[key] is not None]
        if vals:
            print(f"  navigation start -> {key[:-3].replace('_', ' ')}: {median(vals):.0f}")
    kinds = sorted({k for r in rows for k in r["self_ms"]},
                   key=lambda k: -median([r["self_ms"].get(k, 0) for r in rows]))
    print("  main thread self time by kind:")
    for k in kinds:
        print(f"    {k:<34} {median([r['self_ms'].get(k, 0) for r in rows]):7.1f}")
    calls = defaultdict(lambda: ([], []))
    for r in rows:
        for name, at, dur in r["plotly_calls"]:
            calls[name][0].append(at)
            calls[name][1].append(dur)
    print("  plotly calls (start after navigation, duration; 'plotly-sync' = until the call returned):")
    for name, (at, dur) in sorted(calls.items(), key=lambda kv: median(kv[1][0])):
        print(f"    {name:<44} at {median(at):6.0f}  {median(dur):6.1f}  (n={len(dur)})")
    fetch = defaultdict(lambda: ([], []))
    for r in rows:
        for url, s, f in r["fetches"]:
            short = url.split(base, 1)[-1]
            if "/js/" in short:
                short = "(our modules: " + short.rsplit("/", 1)[-1] + ")"
            fetch[short][0].append(s)
            fetch[short][1].append(f)
    print("  fetches (median start -> finish after navigation):")
    for url, (s, f) in sorted(fetch.items(), key=lambda kv: median(kv[1][0])):
        if url.startswith("(our modules"):
            continue
        print(f"    {url[:90]:<90} {median(s):6.0f} -> {median(f):6.0f}")
    mods = [(median(s), median(f)) for url, (s, f) in fetch.items() if url.startswith("(our modules")]
    if mods:
        print(f"    our {len(mods)} modules: first start {min(m[0] for m in mods):.0f}, "
              f"last finish {max(m[1] for m in mods):.0f}")
    print("  sampled JavaScript self time by file (whole load incl. idle):")
    keys = sorted({k for c in cpu for k in c}, key=lambda k: -median([c.get(k, 0) for c in cpu]))
    for k in keys[:12]:
        print(f"    {k:<34} {median([c.get(k, 0) for c in cpu]):7.1f}")
    if args.json:
        args.json.write_text(json.dumps({"traces": rows, "cpu": cpu}, indent=1))


if __name__ == "__main__":
    main()
