// Controls shared by a view's utility charts: a log-scale toggle and a y-range, zoom synced across
// the view's charts; and the CSV export of a table. `withAxis` and `axisProblem` are pure.

import { h, nextId, downloadText } from './ui.js';
import { csvOf } from './stats.js';

/** `layout` with the y axis as `axis` says: {log: bool, low: number|null, high: number|null}. */
export function withAxis(layout, axis) {
  const yaxis = { ...(layout.yaxis || {}), type: axis.log ? 'log' : 'linear' };
  const { low, high } = axis;
  if (Number.isFinite(low) && Number.isFinite(high) && low < high && (!axis.log || low > 0)) {
    yaxis.range = axis.log ? [Math.log10(low), Math.log10(high)] : [low, high];
    yaxis.autorange = false;
  } else {
    yaxis.autorange = true;
  }
  return { ...layout, yaxis };
}

/** Why a y-range cannot be used, or '' when it can (or is empty: automatic). */
export function axisProblem(axis) {
  const { low, high } = axis;
  if (low === null && high === null) return '';
  if (!Number.isFinite(low) || !Number.isFinite(high)) return 'Give both ends of the y range, or neither.';
  if (low >= high) return 'The lower end must be below the upper end.';
  if (axis.log && low <= 0) return 'A log scale needs a lower end above 0.';
  return '';
}

/**
 * The y-axis controls of a view: log scale, y from/to. `onChange(axis)` redraws the charts.
 * Returns {element, axis}.
 */
export function axisControls(onChange) {
  const axis = { log: false, low: null, high: null };
  const logId = nextId('log');
  const lowId = nextId('ylow');
  const highId = nextId('yhigh');
  const log = h('input', { type: 'checkbox', id: logId, class: 'log-y' });
  const low = h('input', { type: 'number', id: lowId, step: 'any', class: 'y-low', placeholder: 'auto' });
  const high = h('input', { type: 'number', id: highId, step: 'any', class: 'y-high', placeholder: 'auto' });
  const problem = h('span', { class: 'field-error', 'aria-live': 'polite' });
  const read = () => {
    const value = (el) => (el.value.trim() === '' ? null : Number(el.value));
    const next = { log: log.checked, low: value(low), high: value(high) };
    problem.textContent = axisProblem(next);
    Object.assign(axis, next);
    onChange(axis);
  };
  log.addEventListener('change', read);
  low.addEventListener('change', read);
  high.addEventListener('change', read);
  const element = h('div', { class: 'controls axis-controls' },
    h('label', { class: 'check', for: logId }, log, ' Log y'),
    h('label', { for: lowId }, 'y from'), low, h('label', { for: highId }, 'to'), high, problem);
  return { element, axis };
}

/** Zooming or panning one chart's x axis moves the others' with it (the episodes stay aligned). */
export function syncZoom(charts) {
  let busy = false;
  for (const chart of charts) {
    chart.on?.('plotly_relayout', (change) => {
      if (busy || !window.Plotly) return;
      const update = {};
      if ('xaxis.range[0]' in change) update['xaxis.range'] = [change['xaxis.range[0]'], change['xaxis.range[1]']];
      else if (Array.isArray(change['xaxis.range'])) update['xaxis.range'] = change['xaxis.range'];
      else if (change['xaxis.autorange']) update['xaxis.autorange'] = true;
      if (!Object.keys(update).length) return;
      busy = true;
      Promise.all(charts.filter((c) => c !== chart && c.data).map((c) => window.Plotly.relayout(c, update)))
        .finally(() => { busy = false; });
    });
  }
}

/**
 * A button that downloads a table's data as a CSV file: `rows()` gives its header (units in the column names)
 * and rows of numbers and plain text, never the cells as shown ("+17.6%", "[5.354, 6.130]").
 */
export function tableCsvButton(filename, rows) {
  return h('button', { type: 'button', class: 'small secondary csv-button', 'data-csv': filename, onclick: () => {
    downloadText(filename, 'text/csv', csvOf(rows()));
  } }, 'Table as CSV');
}
