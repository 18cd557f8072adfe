// Compare view: several stored jobs pooled by configuration and paired by world (server side), per-episode mean
// and band per group, % from uniform bars with CI error bars, and, once those are drawn, the statistics across
// systems (statspanel.js). State lives in the URL:
// #/compare?jobs=1,2&smooth=5&groups=<key>,<key>&bands=0&stats=0  (groups absent = all shown; bands=0: no 95%
// bands; stats=0: the statistics folded away, not computed).

import { api } from './api.js';
import { h, notice, nextId, kindBadge, debounce } from './ui.js';
import { draw, drawWhenSeen, purge, loadPlotly, meanBandTraces, utilityLayout, pctBarTrace, bandsBelow, bandAlpha } from './charts.js';
import { parseIds, badIds, DEFINITIONS, groupKey, pctErrorBars, fmtNumber, fmtPct, fmtCI, seedCount, systemName, smoothingNote, episodesPerPoint, bandCaution, SUMMARY_COLUMNS, summaryCells, pairedText, showsTaskRates, fmtRate, TASK_RATE_DEFINITIONS } from './stats.js';
import { compareLabels, ready, rememberAnswer } from './algorithms.js';
import { configurations, groupLabels, diffTable, facets, facetOf, lineStyles, legendLayout, barsLayout } from './comparegroups.js';
import { statisticsPanel } from './statspanel.js';
import { axisControls, withAxis, syncZoom, tableCsvButton } from './chartcontrols.js';

const POINTS = 500;
const SMOOTH_CHOICES = [1, 5, 11, 25, 51, 101]; // episodes, centred

export async function mount(root, params, ctx) {
  const t0 = performance.now();
  delete root.dataset.allDrawnMs; // set again once every chart of this view is drawn
  loadPlotly(); // start fetching/evaluating plotly.js while the API answers
  const state = {
    jobs: parseIds(params.jobs),
    smooth: Math.max(1, Number(params.smooth) || 1),
    groups: params.groups ? params.groups.split(',').filter(Boolean) : null,
    points: Math.min(5000, Math.max(10, Number(params.points) || POINTS)),
    bands: params.bands !== '0',
    stats: params.stats !== '0',
  };
  const plots = [];
  let stopped = false;
  const controller = new AbortController();

  root.append(h('div', { class: 'view-head' }, h('h1', {}, 'Compare jobs')));
  const idsId = nextId('ids');
  const idsIn = h('input', { id: idsId, type: 'text', value: state.jobs.join(', '), placeholder: 'e.g. 3, 5, 8', 'aria-describedby': `${idsId}-help` });
  const picker = h('div', { class: 'picker' });
  const pickForm = h('form', { class: 'inline compare-pick', onsubmit: (e) => {
    e.preventDefault();
    ctx.navigate('/compare', { jobs: parseIds(idsIn.value).join(','), smooth: state.smooth > 1 ? state.smooth : '' });
  } },
  h('label', { for: idsId }, 'Job ids'), idsIn,
  h('button', { type: 'submit', class: 'primary' }, 'Compare'),
  h('small', { id: `${idsId}-help`, class: 'help' }, 'Comma separated ids of succeeded jobs, or tick them below.'));
  const body = h('div', { 'aria-live': 'polite' });
  root.append(pickForm, picker, body);

  // Succeeded jobs to pick from (tick to add/remove), the 20 newest or those a search finds (name, notes, tags):
  // folded away under the charts' jobs, so asked for once the charts on screen are drawn; at once when no job is given.
  const pickList = h('ul', { class: 'pick-list' });
  const pickSearch = h('input', { type: 'search', id: nextId('pick-search'), class: 'pick-search',
    placeholder: 'name, notes or tag', 'aria-label': 'Search succeeded jobs' });
  const pickCount = h('span', { class: 'help', 'aria-live': 'polite' });
  const fillPicker = (q) => api.listJobs({ status: 'succeeded', limit: 20, q: q || undefined },
    { signal: controller.signal }).then((page) => {
    if (stopped) return;
    const chosen = new Set(parseIds(idsIn.value));
    pickList.replaceChildren(...page.data.map((j) => {
      const cbId = nextId('pick');
      return h('li', {}, h('input', { type: 'checkbox', id: cbId, checked: chosen.has(j.id), onchange: (e) => {
        const ids = parseIds(idsIn.value).filter((x) => x !== j.id);
        if (e.target.checked) ids.push(j.id);
        idsIn.value = ids.join(', ');
      } }), h('label', { for: cbId }, `#${j.id} ${j.name || ''} (${systemName(j)}, ${seedCount(j)} seeds × ${j.episodes})`, kindBadge(j)));
    }));
    pickCount.textContent = q ? `${page.count.toLocaleString('en-US')} found${page.count > page.data.length ? `, the ${page.data.length} newest shown` : ''}.`
      : `The ${page.data.length} newest of ${page.count.toLocaleString('en-US')}; search for older ones.`;
  }).catch(() => {});
  pickSearch.addEventListener('input', debounce(() => fillPicker(pickSearch.value.trim()), 250));
  const loadPicker = () => fillPicker('').then(() => {
    if (stopped || picker.childElementCount) return;
    picker.append(h('details', { open: state.jobs.length === 0, id: 'job-picker' }, h('summary', {}, 'Succeeded jobs'),
      h('p', { class: 'controls' }, pickSearch, pickCount), pickList));
  });

  const wrong = badIds(params.jobs);
  if (wrong.length || !state.jobs.length) loadPicker();
  if (wrong.length) {
    body.append(notice('error', `jobs=${params.jobs}: ${wrong.map((w) => `“${w}”`).join(', ')} ${wrong.length > 1 ? 'are not job ids' : 'is not a job id'}. ` +
      'Give job ids as whole numbers separated by commas, e.g. 3, 5, 8.'));
    return () => { stopped = true; controller.abort(); };
  }
  if (!state.jobs.length) {
    body.append(notice('empty', 'Pick two or more succeeded jobs to compare them. You can also select jobs on the Runs page.'));
    return () => { stopped = true; controller.abort(); };
  }

  body.append(h('p', { class: 'loading' }, `Loading ${state.jobs.length} job${state.jobs.length > 1 ? 's' : ''}…`));
  let data;
  try {
    data = await api.compare(state.jobs, state.points, { signal: controller.signal });
  } catch (e) {
    if (e.name === 'AbortError') return null;
    body.replaceChildren(notice('error', `Cannot compare jobs ${state.jobs.join(', ')}: ${e.message}`));
    loadPicker();
    return () => { stopped = true; controller.abort(); };
  }
  rememberAnswer(data.algorithms, data.groups.map((g) => g.algorithm)); // described with the data: no request
  await ready(data.groups.map((g) => g.algorithm)); // their order and colours
  if (stopped) return null;
  const groups = data.groups.slice().sort((a, b) => String(facetOf(a)).localeCompare(String(facetOf(b)))
    || compareLabels(a.algorithm, b.algorithm) || String(a.label).localeCompare(String(b.label)));
  if (!groups.length) {
    body.replaceChildren(notice('empty', 'These jobs have no results to compare (only succeeded jobs have results).'));
    loadPicker();
    return () => { stopped = true; controller.abort(); };
  }
  const configs = configurations(data.jobs, data.groups);
  const external = new Set(data.jobs.filter((j) => j.kind === 'external').map((j) => j.id));
  const labels = groupLabels(groups).map((l, i) => (groups[i].job_ids.some((id) => external.has(id)) ? `${l} · external` : l));
  const styles = lineStyles(groups, data.jobs);
  const systems = facets(groups);
  const keys = groups.map(groupKey);
  const shown = new Set(state.groups ? keys.filter((k) => state.groups.includes(k)) : keys);

  const smoothId = nextId('smooth');
  const smoothSel = h('select', { id: smoothId }, SMOOTH_CHOICES.map((n) =>
    h('option', { value: n, selected: n === state.smooth }, n === 1 ? 'none' : `${n} episodes`)));
  const groupBoxes = h('fieldset', { class: 'groups' }, h('legend', {}, 'Shown configurations'),
    groups.map((g, i) => {
      const id = nextId('grp');
      return h('label', { class: `check swatch dash-${styles[i].dash}`, for: id, style: `--c: ${styles[i].color}` },
        h('input', { type: 'checkbox', id, value: keys[i], checked: shown.has(keys[i]), onchange: (e) => {
          if (e.target.checked) shown.add(keys[i]); else shown.delete(keys[i]);
          redraw();
        } }), ` ${labels[i]}`);
    }),
    h('span', { class: 'group-buttons' },
      h('button', { type: 'button', class: 'small secondary', onclick: () => setAll(true) }, 'All'),
      h('button', { type: 'button', class: 'small secondary', onclick: () => setAll(false) }, 'None')));
  function setAll(on) {
    for (const cb of groupBoxes.querySelectorAll('input[type=checkbox]')) {
      cb.checked = on;
      if (on) shown.add(cb.value); else shown.delete(cb.value);
    }
    redraw();
  }
  smoothSel.addEventListener('change', () => { state.smooth = Number(smoothSel.value); redraw(); });
  const bandsId = nextId('bands');
  const bandsCb = h('input', { type: 'checkbox', id: bandsId, checked: state.bands, class: 'show-bands', onchange: () => {
    state.bands = bandsCb.checked;
    redraw();
  } });
  const caution = h('p', { class: 'help band-caution', id: 'band-caution' });
  const legendNote = h('p', { class: 'help', id: 'legend-note' });

  // One chart per system (their utilities differ by an order of magnitude); the first keeps the id.
  const charts = systems.map((system, k) => h('div', {
    class: 'chart', id: k === 0 ? 'compare-chart' : `compare-chart-${k + 1}`, 'data-system': system, role: 'img',
    'aria-label': `System utility per episode per pooled configuration, ${system} system`,
  }));
  const bars = h('div', { class: 'chart bars', id: 'compare-bars', role: 'img', 'aria-label': 'Percent from uniform per configuration with 95% confidence intervals' });
  plots.push(...charts, bars);
  const smoothNote = h('p', { class: 'help', id: 'smoothing-note' });
  const axisUi = axisControls(() => redraw());
  const noneShown = h('div', { id: 'none-shown' });
  const diff = diffTable(groups.map((g) => g.config_hash), configs);
  const diffTableEl = h('table', { class: 'summary diff', id: 'param-diff' },
      h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Parameter'),
        diff.hashes.map((hash) => h('th', { scope: 'col', title: hash }, `${configs[hash].system} ${hash.slice(0, 6)}`)))),
      h('tbody', {}, diff.rows.map((r) => h('tr', {}, h('th', { scope: 'row' }, r.name),
        r.values.map((v) => h('td', { class: 'num' }, v))))));
  const diffSection = diff.rows.length ? h('section', { 'aria-labelledby': 'h-diff' },
    h('h2', { id: 'h-diff' }, 'What differs between the configurations ', tableCsvButton('compare-parameters.csv', () => [
      ['parameter', ...diff.hashes.map((hash) => `${configs[hash].system} ${hash.slice(0, 6)}`)],
      ...diff.rows.map((r) => [r.name, ...diff.hashes.map((hash) => rawParam(r.name === 'system' ? configs[hash].system
        : configs[hash][r.name]))])])),
    h('div', { class: 'table-wrap' }, diffTableEl)) : null;
  const jobsLine = h('p', { class: 'help' }, 'Jobs: ', data.jobs.map((j, i) => [i ? ', ' : '',
    h('a', { href: `#/jobs/${j.id}` }, `#${j.id} ${j.name || ''}`), ` (${j.status})`]));
  const tableBody = h('tbody');
  // what became of the atomic tasks: columns only where a job lets tasks fail or some configuration's did
  const taskRates = showsTaskRates(groups.map((g) => g.summary), data.jobs.map((j) => j.params));
  const columnTitles = { Paired: 'Seeds shared with uniform: the % from uniform stands on these',
    Failed: 'Share of its atomic tasks that failed, pooled over its seeds',
    'By a neighbour': 'Share of its atomic tasks a neighbouring child completed (borrowed resource or hand-over), pooled over its seeds' };
  const pooledTable = h('table', { class: 'summary', id: 'pooled-table' },
    h('thead', {}, h('tr', {}, ['Configuration', 'Jobs', 'Runs', 'Paired', 'Final mean', '95% CI', '% from uniform', '95% CI', '% of max',
      ...(taskRates ? ['Failed', 'By a neighbour'] : [])]
      .map((c) => h('th', { scope: 'col', title: columnTitles[c] || null }, c)))),
    tableBody);
  const partial = groups.filter((g) => g.summary && g.summary.partial);
  const mismatched = groups.filter((g) => (g.mismatched_seeds || []).length);
  const pairingNotes = h('div', { id: 'pairing-notes' },
    partial.length ? notice('warn', `${partial.map((g) => labels[groups.indexOf(g)]).join(', ')}: only some seeds pair with ` +
      'uniform (◐ in the table); its % from uniform and % of max stand on the paired seeds, its final mean on all of them.') : null,
    mismatched.length ? notice('warn', mismatched.map((g) => `${labels[groups.indexOf(g)]}: seeds ${g.mismatched_seeds.join(', ')} ` +
      'differ between the pooled jobs (the first job’s runs are used): built-in runs of one configuration should be ' +
      'identical; was one job run on another version?').join(' ')) : null);
  const stats = statisticsPanel(state.jobs, (label) => {
    const i = groups.findIndex((g) => (g.label ?? g.algorithm) === label);
    return i >= 0 ? styles[i].color : '#1d2430';
  }, { open: state.stats, signal: controller.signal, onToggle: (open) => { state.stats = open; saveQuery(); } });

  body.replaceChildren(
    jobsLine,
    h('div', { class: 'controls' }, h('label', { for: smoothId }, 'Smoothing (centred mean)'), smoothSel,
      h('label', { class: 'check', for: bandsId }, bandsCb, ' 95% bands')),
    groupBoxes,
    ...(diffSection ? [diffSection] : []),
    noneShown,
    h('section', { 'aria-labelledby': 'h-cu' }, h('h2', { id: 'h-cu' }, 'System utility per episode'),
      systems.length > 1 ? h('p', { class: 'help' }, 'One chart per system: their utilities lie on different scales.') : null,
      axisUi.element, h('div', { class: systems.length > 1 ? 'grid2 facets' : '' }, charts), legendNote, smoothNote, caution),
    h('div', { class: 'grid2 wide' },
      h('section', { 'aria-labelledby': 'h-cb' }, h('h2', { id: 'h-cb' }, '% from uniform (95% CI)'), bars),
      h('section', { 'aria-labelledby': 'h-ct' }, h('h2', { id: 'h-ct' }, 'Pooled final utility ', tableCsvButton('compare-final-utility.csv', () => [
        ['system', 'configuration', 'job_ids', ...SUMMARY_COLUMNS],
        ...groups.map((g) => [facetOf(g), g.label ?? g.algorithm, (g.job_ids || []).join(' '), ...summaryCells(g.summary)])])),
        pairingNotes, h('div', { class: 'table-wrap' }, pooledTable), h('p', { class: 'help definitions' }, DEFINITIONS),
        taskRates ? h('p', { class: 'help definitions', id: 'task-rate-definitions' }, TASK_RATE_DEFINITIONS) : null)),
    stats.element);

  function saveQuery() {
    ctx.setQuery({
      jobs: state.jobs.join(','),
      smooth: state.smooth > 1 ? state.smooth : '',
      points: state.points !== POINTS ? state.points : '',
      groups: shown.size === keys.length ? '' : (shown.size ? keys.filter((k) => shown.has(k)).join(',') : 'none'),
      bands: state.bands ? '' : '0',
      stats: state.stats ? '' : '0',
    });
  }

  function redraw() {
    saveQuery();
    const traces = systems.map(() => []);
    const barIdx = [];
    const together = systems.map((system) => groups.filter((g, i) => facetOf(g) === system && shown.has(keys[i])).length);
    groups.forEach((g, i) => {
      if (!shown.has(keys[i])) return;
      traces[systems.indexOf(facetOf(g))].push(...meanBandTraces(labels[i], g.episodes, styles[i].color, state.smooth,
        labels[i], styles[i].dash, { bands: state.bands, symbol: styles[i].symbol,
          fillAlpha: bandAlpha(together[systems.indexOf(facetOf(g))]) }));
      if (g.summary && g.summary.pct_from_uniform !== null && g.summary.pct_from_uniform !== undefined) barIdx.push(i);
    });
    noneShown.replaceChildren(...(shown.size ? [] : [notice('empty',
      'No configuration is ticked: tick one or more under “Shown configurations” to draw it.')]));
    smoothNote.textContent = smoothingNote(state.smooth, episodesPerPoint((groups[0].episodes || {}).episode), state.bands);
    tableBody.replaceChildren(...groups.map((g, i) => {
      const s = g.summary || {};
      return h('tr', { class: shown.has(keys[i]) ? '' : 'muted' },
        h('th', { scope: 'row' }, h('span', { class: 'dot', style: `background: ${styles[i].color}`, 'aria-hidden': 'true' }), labels[i]),
        h('td', { class: 'job-links' }, (g.job_ids || []).map((jobId, k) => [k ? ', ' : '',
          (g.checked_job_ids || []).includes(jobId)
            ? h('span', { class: 'checked-job', title: `Job ${jobId} was read and its runs checked against the ` +
              'jobs before it: each of its seeds is theirs too, so none is counted twice' },
            h('a', { href: `#/jobs/${jobId}` }, `#${jobId}`), ' (checked)')
            : h('a', { href: `#/jobs/${jobId}`, title: `Job ${jobId}` }, `#${jobId}`)])),
        h('td', { class: 'num' }, s.n_runs ?? '–'),
        h('td', { class: `num paired${s.partial ? ' partial' : ''}`, title: s.partial ? `only ${s.n_paired} of its ${s.n_runs} seeds ` +
          'pair with uniform' : null }, pairedText(s), s.partial ? ' ◐' : ''),
        h('td', { class: 'num' }, fmtNumber(s.final_mean)),
        h('td', { class: 'num ci' }, fmtCI(s.ci95)),
        h('td', { class: 'num' }, fmtPct(s.pct_from_uniform)),
        h('td', { class: 'num ci' }, fmtCI(s.pct_ci95, 1, true)),
        h('td', { class: 'num' }, fmtPct(s.pct_of_max, 1, false)),
        ...(taskRates ? [h('td', { class: 'num', 'data-rate': 'failure_rate' }, fmtRate(s.failure_rate)),
          h('td', { class: 'num', 'data-rate': 'handover_rate' }, fmtRate(s.handover_rate))] : []));
    }));
    const cautions = systems.map((system) => {
      const text = bandCaution(groups.filter((g, i) => facetOf(g) === system && shown.has(keys[i]))
        .map((g) => ({ runs: (g.summary || {}).n_runs, episodes: g.episodes })));
      return text && systems.length > 1 ? `${system}: ${text}` : text;
    }).filter(Boolean);
    caution.textContent = state.bands ? cautions.join(' ') : '';
    const unlabelled = [];
    // The charts on screen are drawn first; one below the fold when it scrolls near or once the page is idle.
    const stampWhenDrawn = (el, drawing) => drawing.then(() => { el.dataset.rendered = String(Date.now()); });
    const onScreen = [];
    const p1 = Promise.all(charts.map((c, k) => {
      // the plot area keeps its height and the legend its place below the axis title, however many groups
      const names = traces[k].filter((t) => t.meta.kind === 'mean').map((t) => t.name);
      const fit = legendLayout(names, c.clientWidth || 600);
      c.style.height = `${fit.height}px`;
      if (!fit.showlegend) unlabelled.push(systems[k]);
      const title = systems.length > 1 ? systems[k] : '';
      const layout = { ...utilityLayout(title), ...fit };
      if (title) layout.title = { text: title, x: 0.01, xanchor: 'left', y: 1, yref: 'container', yanchor: 'top', pad: { t: 10 } };
      const drawing = drawWhenSeen(c, () => draw(c, bandsBelow(traces[k]), withAxis(layout, axisUi.axis)), { after: shownFirst });
      if (c.dataset.drawn === 'now') onScreen.push(drawing);
      return stampWhenDrawn(c, drawing);
    }));
    const barFit = barsLayout(barIdx.map((i) => labels[i]));
    bars.style.height = `${barFit.height}px`;
    const barTrace = pctBarTrace(barIdx.map((i) => labels[i]), pctErrorBars(barIdx.map((i) => groups[i].summary)), barIdx.map((i) => styles[i].color));
    const barDrawing = drawWhenSeen(bars, () => draw(bars, [barTrace],
      { yaxis: { title: { text: '% from uniform' }, zeroline: true }, xaxis: { automargin: true, tickangle: barFit.tickangle },
        height: barFit.height, margin: barFit.margin, hovermode: 'closest', showlegend: false }), { after: shownFirst });
    if (bars.dataset.drawn === 'now') onScreen.push(barDrawing);
    const p2 = stampWhenDrawn(bars, barDrawing);
    legendNote.textContent = unlabelled.length ? `${systems.length > 1 ? `${unlabelled.join(', ')}: t` : 'T'}oo many ` +
      'configurations for a legend on the chart: their colours and dashes are those under “Shown configurations” above.' : '';
    resolveShown(Promise.all(onScreen));
    return { onScreen: Promise.all(onScreen), all: Promise.all([p1, p2]) };
  }
  // The first draw's charts on screen: until they are drawn, no chart off screen is drawn in idle time.
  let resolveShown;
  const shownFirst = new Promise((resolve) => { resolveShown = resolve; });

  const drawn = redraw();
  await drawn.onScreen;
  if (stopped) return null;
  loadPicker();
  stats.load(); // the statistics across systems: asked for once the charts on screen are drawn
  const ms = performance.now() - t0;
  performance.mark('compare-rendered'); // what the viewport shows is drawn
  root.dataset.renderMs = ms.toFixed(1);
  drawn.all.then(() => {
    if (charts.length > 1) syncZoom(charts); // every chart drawn: each has its plotly_relayout
    performance.mark('compare-all-drawn'); // and every chart, those below the fold too
    root.dataset.allDrawnMs = (performance.now() - t0).toFixed(1);
  });
  return () => { stopped = true; controller.abort(); for (const p of plots) purge(p); };
}

/** A parameter's value as a CSV cell: numbers and text as they are, lists and objects as JSON. */
function rawParam(v) {
  return v !== null && typeof v === 'object' ? JSON.stringify(v) : v;
}
