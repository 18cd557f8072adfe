// The job view's failed and handed-over atomic tasks (task_need and hierarchy; docs/model.md, "Tasks that fail,
// and hierarchical allocation"): per configuration, the share of its atomic tasks that failed and the share a
// neighbouring child completed, pooled over its seeds (its summary's failure_rate and handover_rate). Shown only
// where a task can fail (task_need > 0) or some configuration has a nonzero rate; nothing otherwise.

import { h } from './ui.js';
import { draw } from './charts.js';
import { algorithmStyles } from './colours.js';
import { tableCsvButton } from './chartcontrols.js';
import { fmtRate, showsTaskRates, TASK_RATE_DEFINITIONS } from './stats.js';

const RATES = [['failure_rate', 'Failed'], ['handover_rate', 'By a neighbour']];

/**
 * One bar trace per configuration over the two rates (in %), in the configuration's colour: the bars of the
 * two rates grouped, each configuration's beside the others' as in every chart of the view.
 */
export function taskRateTraces(configurations, styles) {
  return configurations.map((c) => {
    const s = c.summary || {};
    const name = c.algorithm;
    return {
      type: 'bar', name, x: RATES.map(([, title]) => title), y: RATES.map(([key]) => 100 * (s[key] ?? 0)),
      marker: { color: (styles[name] || {}).color }, meta: { kind: 'task-rate', config: name },
      customdata: RATES.map(([key]) => fmtRate(s[key])),
      hovertemplate: `%{x}: %{customdata}<extra>${name.replace(/</g, '&lt;')}</extra>`,
    };
  });
}

/**
 * The section (null when no task can fail and none did). `results` is the job's results answer; `plots`
 * collects the chart so that the view purges it when left.
 */
export function tasksSection({ job, results, plots }) {
  const configurations = results.configurations;
  if (!showsTaskRates(configurations.map((c) => c.summary), [job.params])) return null;
  const styles = algorithmStyles([...job.algorithms, ...configurations.map((c) => c.algorithm)]); // the utility chart's
  const chart = h('div', { class: 'chart bars task-rates', id: 'task-rates-chart', role: 'img',
    'aria-label': 'Per configuration, the share of its atomic tasks that failed and the share a neighbour completed' });
  plots.push(chart);
  const none = configurations.every((c) => !(c.summary?.failure_rate > 0) && !(c.summary?.handover_rate > 0));
  const table = h('table', { class: 'summary', id: 'task-rates-table' },
    h('thead', {}, h('tr', {}, ['Configuration', 'Failed', 'By a neighbour'].map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, configurations.map((c) => h('tr', { 'data-config': c.algorithm },
      h('th', { scope: 'row' }, c.algorithm),
      ...RATES.map(([key]) => h('td', { class: 'num', 'data-rate': key }, fmtRate((c.summary || {})[key])))))));
  draw(chart, taskRateTraces(configurations, styles), {
    barmode: 'group', hovermode: 'closest', margin: { l: 64, r: 16, t: 16, b: 52 },
    yaxis: { title: { text: '% of atomic tasks' }, rangemode: 'tozero', zeroline: true },
  }).then(() => { chart.dataset.rendered = String(Date.now()); });
  return h('section', { 'aria-labelledby': 'h-tasks', id: 'task-rates' },
    h('h2', { id: 'h-tasks' }, 'Atomic tasks that failed / a neighbour completed ', tableCsvButton(`job-${job.id}-task-rates.csv`,
      () => [['configuration', 'failure_rate_share', 'handover_rate_share'],
        ...configurations.map((c) => [c.algorithm, ...RATES.map(([key]) => (c.summary || {})[key] ?? null)])])),
    none ? h('p', { class: 'help', id: 'task-rates-none', role: 'status' },
      'No atomic task failed or was completed by a neighbour in the runs stored.') : null,
    h('div', { class: 'grid2' }, chart, h('div', { class: 'table-wrap' }, table)),
    h('p', { class: 'help definitions' }, TASK_RATE_DEFINITIONS));
}
