// A job run until its question is answered (its `until`, docs/statistics.md "Seeds until decided"): why it
// stopped, and the intervals the rule judged after each block, narrowing as seeds are added.

import { h } from './ui.js';
import { draw } from './charts.js';
import { algorithmStyles } from './colours.js';
import { fmtNumber } from './stats.js';

const REASONS = {
  half_width: (u, s) => `Stopped after ${s.seeds} seeds: every judged interval is within ±${u.half_width} (the rule's half width).`,
  decided: (u, s) => s.outcome === 'equivalent'
    ? `Stopped after ${s.seeds} seeds: ${u.decide[0]} and ${u.decide[1]} are equivalent (their difference is within ±${u.half_width}).`
    : `Stopped after ${s.seeds} seeds: ${s.outcome} is better (the interval of ${u.decide[0]} − ${u.decide[1]} excludes 0).`,
  max_seeds: (u, s) => `Stopped at max_seeds, ${s.seeds} seeds, with the question unanswered.`,
  cancelled: (u, s) => `Cancelled after ${s.seeds} seeds judged, before the rule answered.`,
};

/** The level of each judged interval, in words: 95% each, or Bonferroni's level when they hold jointly. */
export function levelText(until) {
  const judged = (until.judge || []).length;
  if (!until.joint || judged < 2) return '95%';
  return `${+(100 * (1 - 0.05 / judged)).toFixed(2)}%`;
}

/** What the rule asks, in words: which configurations it judges, and whether their intervals hold one by one or jointly. */
export function ruleText(until) {
  const of = until.of === 'pct_from_uniform' ? '% from uniform' : 'final utility';
  if (until.decide) {
    const question = `decide ${until.decide[0]} against ${until.decide[1]} (paired ${of}${until.half_width != null ? `, no practical difference within ±${until.half_width}` : ''})`;
    return `Seeds run in blocks of ${until.block} until ${question}; at most ${until.max_seeds} seeds.`;
  }
  const judged = until.judge && until.judge.length ? until.judge.join(', ') : 'every configuration';
  const coverage = until.joint && until.judge.length > 1
    ? `jointly: each at ${levelText(until)}, so that all ${until.judge.length} hold at once 95% of the time`
    : `each covering its own value 95% of the time, not all at once`;
  return `Seeds run in blocks of ${until.block} until the ${levelText(until)} interval of ${of} is within ±${until.half_width} ` +
    `for ${judged} (${coverage}); at most ${until.max_seeds} seeds.`;
}

/** The sentence of a job's verdict so far. */
export function stoppedText(until, stopped) {
  if (!stopped || stopped.reason == null) {
    return stopped && stopped.seeds ? `Running: ${stopped.seeds} seeds judged, not answered yet.` : 'No block judged yet.';
  }
  return REASONS[stopped.reason](until, stopped);
}

/** The traces of each judged interval against the seeds it stood on: a band from low to high, the mean inside. */
export function intervalTraces(stopped) {
  const keys = [...new Set(stopped.blocks.flatMap((b) => Object.keys(b.intervals)))];
  const styles = algorithmStyles(keys.filter((k) => !k.includes(' - ')));
  const traces = [];
  for (const key of keys) {
    const points = stopped.blocks.filter((b) => b.intervals[key] && b.intervals[key][1] != null);
    const x = points.map((b) => b.seeds);
    const [mean, low, high] = [0, 1, 2].map((j) => points.map((b) => b.intervals[key][j]));
    const color = (styles[key] || {}).color || '#444';
    traces.push({ x: [...x, ...x.slice().reverse()], y: [...high, ...low.slice().reverse()], fill: 'toself',
      type: 'scatter', mode: 'lines', line: { width: 0 }, fillcolor: color, opacity: 0.18, hoverinfo: 'skip',
      showlegend: false, legendgroup: key });
    traces.push({ x, y: mean, type: 'scatter', mode: 'lines+markers', name: key, legendgroup: key,
      line: { color }, marker: { size: 5 }, customdata: points.map((b) => [b.intervals[key][1], b.intervals[key][2]]),
      hovertemplate: `${key}<br>%{x} seeds: %{y:.2f} [%{customdata[0]:.2f}, %{customdata[1]:.2f}]<extra></extra>` });
  }
  return traces;
}

/** The section of a job with a stopping rule (null without one): the rule, why it stopped, the intervals. */
export function ruleSection(job) {
  if (!job.until) return null;
  const { until } = job;
  const stopped = job.stopped || { reason: null, seeds: 0, blocks: [], intervals: {} };
  const chart = h('div', { class: 'chart rule-chart', id: 'rule-chart', role: 'img',
    'aria-label': 'The intervals the rule judged after each block, against the seeds run' });
  const last = Object.entries(stopped.intervals || {}).map(([key, [mean, low, high]]) => h('tr', {},
    h('th', { scope: 'row' }, key), h('td', { class: 'num' }, fmtNumber(mean, 2)),
    h('td', { class: 'num' }, low == null ? '–' : `[${fmtNumber(low, 2)}, ${fmtNumber(high, 2)}]`),
    h('td', { class: 'num' }, low == null ? '–' : fmtNumber((high - low) / 2, 2))));
  const section = h('section', { class: 'card', id: 'stopping-rule', 'aria-labelledby': 'h-rule' },
    h('h2', { id: 'h-rule' }, 'Stopping rule'),
    h('p', { class: 'help' }, ruleText(until)),
    h('p', { id: 'rule-reason', role: 'status', class: stopped.reason ? `rule-${stopped.reason}` : null },
      stoppedText(until, stopped)),
    last.length ? h('div', { class: 'table-wrap' }, h('table', { id: 'rule-intervals' },
      h('caption', {}, `What the rule judged after ${stopped.seeds} seeds`),
      h('thead', {}, h('tr', {}, ['', 'mean', '95% interval', 'half width'].map((t) => h('th', { scope: 'col' }, t)))),
      h('tbody', {}, last))) : null,
    stopped.blocks.length ? chart : null);
  if (stopped.blocks.length) {
    const guide = until.decide ? [0, ...(until.half_width != null ? [-until.half_width, until.half_width] : [])] : [];
    draw(chart, intervalTraces(stopped), {
      margin: { t: 10, r: 10, b: 45, l: 60 },
      xaxis: { title: { text: 'seeds judged' } },
      yaxis: { title: { text: until.decide ? `${until.decide[0]} − ${until.decide[1]}` : (until.of === 'pct_from_uniform' ? '% from uniform' : 'final utility') } },
      shapes: guide.map((y) => ({ type: 'line', xref: 'paper', x0: 0, x1: 1, y0: y, y1: y,
        line: { dash: y === 0 ? 'solid' : 'dot', width: 1, color: '#888' } })),
    });
  }
  return section;
}
