// Plotly helpers. Plotly itself is loaded by a classic <script> in index.html (window.Plotly).
// Every trace carries `meta` {kind: 'mean'|'band'|'seed'|'bar', config} so tests and code can find it.

import { bandPolygon, smoothSeries, centredAverage } from './stats.js';

function rgba(hex, alpha) {
  const n = parseInt(hex.slice(1), 16);
  return `rgba(${(n >> 16) & 255}, ${(n >> 8) & 255}, ${n & 255}, ${alpha})`;
}

// The unversioned address redirects to the versioned one; index.html names the versioned one directly.
export const PLOTLY_FALLBACK_SRC = '/vendor/plotly.min.js';

/** The address of plotly.js: the one the server wrote into index.html's prefetch link (cached for a year). */
export function plotlySrc() {
  const link = typeof document !== 'undefined' && document.getElementById('plotly-src');
  return (link && link.getAttribute('href')) || PLOTLY_FALLBACK_SRC;
}

export function plotlyReady() {
  return typeof window !== 'undefined' && !!window.Plotly;
}

let plotlyPromise = null;

/** Load plotly.js once, as a classic <script> from the page's origin; resolves to window.Plotly or null. */
export function loadPlotly() {
  if (plotlyReady()) return Promise.resolve(window.Plotly);
  if (!plotlyPromise) {
    plotlyPromise = new Promise((resolve) => {
      const script = document.createElement('script');
      script.src = plotlySrc();
      script.id = 'plotly-js';
      script.addEventListener('load', () => resolve(window.Plotly || null));
      script.addEventListener('error', () => { plotlyPromise = null; resolve(null); });
      document.head.append(script);
    });
  }
  return plotlyPromise;
}

const CONFIG = {
  responsive: true,
  displaylogo: false,
  showSendToCloud: false, // plotly.js 4 adds a "Share chart..." button that uploads the data to Plotly's cloud
  modeBarButtonsToRemove: ['select2d', 'lasso2d', 'autoScale2d'],
  toImageButtonOptions: { format: 'svg' }, // the camera button saves the chart as SVG, for papers
};

function baseLayout(extra = {}) {
  return {
    margin: { l: 64, r: 16, t: 24, b: 52 },
    paper_bgcolor: '#ffffff',
    plot_bgcolor: '#ffffff',
    font: { family: 'system-ui, -apple-system, "Segoe UI", Roboto, sans-serif', size: 13, color: '#1d2430' },
    legend: { orientation: 'h', y: -0.22, x: 0 },
    hovermode: 'x unified',
    ...extra,
  };
}

/** Draw (or redraw) a plot; shows a message instead when plotly.js is missing. */
export async function draw(el, traces, layout, config = {}) {
  const Plotly = await loadPlotly();
  if (!Plotly) {
    el.textContent = `Charts are unavailable: ${plotlySrc()} did not load.`;
    el.classList.add('chart-missing');
    return el;
  }
  el.classList.remove('chart-missing');
  return Plotly.react(el, traces, baseLayout(layout), { ...CONFIG, ...config });
}

export function purge(el) {
  forgetDraw(el);
  if (plotlyReady() && el) window.Plotly.purge(el);
}

// Charts drawn when seen: el -> {drawn, pending, promise, resolve, observer}
const lazy = new WeakMap();

/** True when `el` has a box on screen within `margin` pixels of the viewport. */
export function nearViewport(el, margin = 0) {
  const r = el.getBoundingClientRect();
  if (!r.width && !r.height) return false;
  return r.top < window.innerHeight + margin && r.bottom > -margin && r.left < window.innerWidth + margin && r.right > -margin;
}

/** When the page is next idle after its next frame (requestIdleCallback, else a timeout); returns a cancel. */
function afterFirstPaint(fn) {
  let cancelled = false;
  const run = () => { if (!cancelled) fn(); };
  requestAnimationFrame(() => setTimeout(() => {
    if (cancelled) return;
    if (typeof window.requestIdleCallback === 'function') window.requestIdleCallback(run, { timeout: 3000 });
    else setTimeout(run, 50);
  }, 0));
  return () => { cancelled = true; };
}

/**
 * Draw a chart now when it is on screen (or within `margin` px of it), else when it scrolls near
 * (IntersectionObserver) or, whichever comes first, in idle time after the page's first paint: a
 * chart below the fold does not hold up the ones a reader sees first, and every chart is drawn.
 * `drawFn()` draws it (returns a promise); called again before the chart was drawn, only the last
 * `drawFn` runs. Once a chart was drawn, later calls draw at once. Resolves when `drawFn` has drawn;
 * `el.dataset.drawn` says how it was triggered (`now`, `seen` or `idle`). `options.after`: a promise
 * (the charts on screen drawn) before which the idle time does not count, so that an off-screen chart
 * never runs ahead of them; `options.margin`: pixels around the viewport that count as near.
 */
export function drawWhenSeen(el, drawFn, options = {}) {
  const margin = options.margin ?? 100;
  let state = lazy.get(el);
  if (!state) {
    state = { drawn: false, pending: null };
    lazy.set(el, state);
  }
  if (state.drawn || nearViewport(el, margin)) {
    if (!state.drawn) el.dataset.drawn = 'now';
    state.drawn = true;
    return Promise.resolve(drawFn());
  }
  state.pending = drawFn;
  if (!state.promise) {
    state.promise = new Promise((resolve) => { state.resolve = resolve; });
    const run = (how) => {
      if (state.drawn || !state.pending) return;
      state.drawn = true;
      state.observer.disconnect();
      state.cancelIdle();
      const fn = state.pending;
      state.pending = null;
      el.dataset.drawn = how;
      Promise.resolve(fn()).then(state.resolve, state.resolve);
    };
    state.observer = new IntersectionObserver((entries) => {
      if (entries.some((e) => e.isIntersecting)) run('seen');
    }, { rootMargin: `${margin}px` });
    state.observer.observe(el);
    let cancel = null;
    let forgotten = false;
    state.cancelIdle = () => { forgotten = true; if (cancel) cancel(); };
    Promise.resolve(options.after).catch(() => {}).then(() => {
      if (!forgotten) cancel = afterFirstPaint(() => run('idle'));
    });
  }
  return state.promise;
}

/** Stop waiting to draw `el` (the view is left). */
export function forgetDraw(el) {
  const state = el && lazy.get(el);
  if (!state) return;
  if (state.observer) state.observer.disconnect();
  if (state.cancelIdle) state.cancelIdle();
  lazy.delete(el);
}

// A band light enough to read every line through it, even where the bands of several
// configurations overlap (3 seeds: a t-interval 4.3 standard errors wide each side), with a faint edge.
export const BAND_FILL_ALPHA = 0.07;
export const BAND_EDGE_ALPHA = 0.35;

/**
 * The fill opacity of each of `n` bands drawn together: 7%, less from six bands on so that where
 * they all overlap they cover at most about 30% (fifty bands at 7% would make a slab again).
 */
export function bandAlpha(n) {
  return Math.round(Math.min(BAND_FILL_ALPHA, 0.35 / Math.max(1, n)) * 1000) / 1000;
}

/**
 * One band trace (95% CI, filled, no legend) and one mean line trace for a configuration.
 * `options.bands` false leaves the band out; `options.fillAlpha` is its opacity (`bandAlpha`);
 * `options.symbol` marks the line (at most 12 markers), for configurations past the palette's eight colours.
 */
export function meanBandTraces(name, series, color, smooth = 1, legendgroup = name, dash = 'solid', options = {}) {
  const s = smoothSeries(series, smooth);
  const band = bandPolygon(s.episode, s.low, s.high);
  const interval = s.low.map((low, i) => [low, s.high[i]]);
  const mean = {
    type: 'scatter', mode: options.symbol ? 'lines+markers' : 'lines', x: s.episode, y: s.mean, name, legendgroup,
    customdata: interval, line: { width: 2, color, dash }, meta: { kind: 'mean', config: name },
    hovertemplate: '%{y:.4f} (95% CI %{customdata[0]:.4f} to %{customdata[1]:.4f})<extra>' +
      name.replace(/</g, '&lt;') + '</extra>',
  };
  if (options.symbol) mean.marker = { symbol: options.symbol, size: 7, color, maxdisplayed: 12 };
  if (options.bands === false) return [mean];
  const fill = options.fillAlpha ?? BAND_FILL_ALPHA;
  const edge = Math.min(BAND_EDGE_ALPHA, fill * 5); // fainter edges too where many bands overlap
  return [
    {
      type: 'scatter', mode: 'lines', x: band.x, y: band.y, fill: 'toself',
      fillcolor: rgba(color, fill), line: { width: 0.6, color: rgba(color, edge) },
      hoverinfo: 'skip', showlegend: false, name: `${name} 95% CI`, legendgroup,
      meta: { kind: 'band', config: name },
    },
    mean,
  ];
}

const LAYER = { seed: 0, band: 1 };

/** The traces with the seeds first, then every band, then the lines: neither seeds nor bands cover a mean line. */
export function bandsBelow(traces) {
  const layer = (t) => LAYER[t.meta && t.meta.kind] ?? 2;
  return traces.map((t, i) => [t, i]).sort((a, b) => layer(a[0]) - layer(b[0]) || a[1] - b[1]).map(([t]) => t);
}

/** Individual seeds drawn per configuration at most: more hide the mean and band they are drawn beneath. */
export const SEED_SAMPLE = 20;

/** At most `most` of `seeds`, spread evenly over them in their order (the first and the last among them). */
export function sampleSeeds(seeds, most = SEED_SAMPLE) {
  const all = seeds || [];
  if (all.length <= most) return all.slice();
  if (most <= 1) return all.slice(0, most);
  return Array.from({ length: most }, (_, i) => all[Math.round((i * (all.length - 1)) / (most - 1))]);
}

/**
 * Faint lines for individual seeds of a configuration: a sample of at most SEED_SAMPLE (sampleSeeds), drawn
 * beneath the bands and mean lines (bandsBelow), fainter the more configurations share the chart.
 */
export function seedTraces(name, seeds, color, smooth = 1, legendgroup = name, configurations = 1) {
  const alpha = Math.max(0.12, 0.35 / Math.sqrt(Math.max(1, configurations)));
  return sampleSeeds(seeds).map((s) => ({
    type: 'scatter', mode: 'lines', x: s.episode, y: centredAverage(s.episode, s.utility, smooth),
    name: `${name} seed ${s.seed}`, legendgroup, showlegend: false, hoverinfo: 'skip',
    line: { width: 0.7, color: rgba(color, alpha) }, meta: { kind: 'seed', config: name, seed: s.seed },
  }));
}

export function utilityLayout(title = '') {
  return {
    xaxis: { title: { text: 'Episode' }, zeroline: false },
    yaxis: { title: { text: 'System utility' }, zeroline: false },
    title: title ? { text: title } : undefined,
  };
}

/**
 * A utility chart's layout with a dashed vertical line at each scheduled event's episode (the job's
 * `schedule` parameter: events apply at the start of their episode, 0-based like the chart's axis),
 * labelled with what changes; events at or past `episodes` never fire and are not drawn.
 */
export function withEvents(layout, schedule, episodes) {
  const fired = (Array.isArray(schedule) ? schedule : []).filter((e) => Number.isInteger(e.episode) && e.episode < episodes);
  if (!fired.length) return layout;
  const shapes = fired.map((e) => ({ type: 'line', xref: 'x', yref: 'paper', x0: e.episode, x1: e.episode, y0: 0, y1: 1,
    line: { color: '#6b7280', width: 1, dash: 'dash' } }));
  const annotations = fired.map((e, i) => ({ xref: 'x', yref: 'paper', x: e.episode, y: 1, yanchor: 'bottom',
    showarrow: false, font: { size: 10, color: '#4b5563' }, yshift: 2 + 11 * (i % 2),
    text: `${e.change}${e.change === 'frequencies' ? ` → ${e.period}` : ''} ${Math.round(100 * (e.fraction ?? 1))}%` }));
  const top = Math.max(layout.margin?.t ?? 24, 24 + (fired.length > 1 ? 24 : 13)); // room for the labels above
  return { ...layout, shapes: [...(layout.shapes || []), ...shapes], margin: { ...(layout.margin || {}), t: top },
    annotations: [...(layout.annotations || []), ...annotations] };
}

/** Bar chart of % from uniform with asymmetric error bars. */
export function pctBarTrace(labels, bars, colors) {
  return {
    type: 'bar', x: labels, y: bars.y, marker: { color: colors },
    error_y: { type: 'data', symmetric: false, array: bars.plus, arrayminus: bars.minus, color: '#333', thickness: 1.2 },
    hovertemplate: '%{x}: %{y:.1f}%<extra></extra>', meta: { kind: 'bar' },
  };
}

/**
 * An axis over the indices 0..n-1 labelled every `dtick`-th index, so that labels sit at least
 * `minGap` pixels apart on an axis `pixels` long (50 parent groups on 300 px: every 5th).
 */
export function indexAxis(n, pixels, minGap = 16) {
  const fit = Math.max(1, Math.floor(pixels / minGap));
  const steps = [1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000];
  const dtick = steps.find((s) => Math.ceil(n / s) <= fit) || Math.ceil(n / fit);
  return { tickmode: 'linear', tick0: 0, dtick };
}

export function heatmapTrace(z, groupLabels, typeLabels) {
  return {
    type: 'heatmap', z, x: typeLabels, y: groupLabels, colorscale: 'Viridis',
    colorbar: { title: { text: 'weight' } }, hovertemplate: 'group %{y}, type %{x}: %{z:.4f}<extra></extra>',
    meta: { kind: 'heatmap' },
  };
}
