// Job view: live progress while queued/running (polls every second), then results: utility chart
// with bands, seeds on demand, smoothing, paper-style table, failed and handed-over tasks (where tasks can
// fail), weight heatmap and bars, downloads.

import { api } from './api.js';
import { h, statusCell, jobMeta, notice, editJobDialog, confirmDialog, cancelConsequence, keepLabel, nextId, downloadText, downloadWithToken } from './ui.js';
import { draw, purge, loadPlotly, meanBandTraces, seedTraces, SEED_SAMPLE, utilityLayout, bandsBelow, bandAlpha, withEvents } from './charts.js';
import { fmtNumber, fmtPct, fmtCI, decidingDigits, compilingText, maxNote, groupsText, takenText, pctProgress, waitingMessage, smoothingNote, episodesPerPoint, bandCaution, DEFINITIONS, SUMMARY_COLUMNS, summaryCells, seedPoints, MIN_SEED_POINTS } from './stats.js';
import { algorithmStyles } from './colours.js';
import { compareLabels, ready, rememberAnswer, roleLabel } from './algorithms.js';
import { axisControls, withAxis, tableCsvButton } from './chartcontrols.js';
import { fmtParam } from './studydata.js';
import { configRows, differenceSummary, summaryCsv, configJson, listLines } from './jobconfig.js';
import { weightsSection } from './jobweights.js';
import { ruleSection } from './jobrule.js';
import { tasksSection } from './jobtasks.js';

const POINTS = 600;
const SMOOTH_CHOICES = [1, 5, 11, 25, 51, 101]; // episodes, centred

export async function mount(root, params, ctx) {
  const id = params.id;
  loadPlotly(); // start fetching/evaluating plotly.js while the API answers
  let stopped = false;
  let timer = null;
  let workers = null; // the workers ({warming, ready}) while the job waits in the queue
  let queue = null; // {ahead, running} of GET /api/jobs/{id}/status: what the queued job waits for
  let workersAt = 0;
  const plots = [];
  let smooth = Math.max(1, Number(params.smooth) || 1);
  let redrawUtility = null; // the utility chart's redraw, once results are shown
  const axisUi = axisControls(() => redrawUtility && redrawUtility());
  let showSeeds = params.seeds === '1';
  let showBands = params.bands !== '0';
  const weightsState = {}; // the weights' chosen seed, configuration and child, kept across live redraws

  const title = h('h1', {}, `Job ${id}`);
  const statusBox = h('div', { class: 'job-status', 'aria-live': 'polite' });
  const headActions = h('div', { class: 'toolbar' });
  const metaBox = h('dl', { class: 'meta' });
  const configBox = h('section', { 'aria-labelledby': 'h-config', class: 'config' });
  const ruleBox = h('div'); // a job with a stopping rule: why it stopped, the intervals block by block
  let ruleSignature = null;
  const body = h('div');
  root.append(h('div', { class: 'view-head' }, title, headActions), statusBox, ruleBox, metaBox, configBox, body);

  let job;
  try {
    job = await api.getJob(id);
  } catch (e) {
    title.textContent = `Job ${id}`;
    body.append(notice('error', e.status === 404 ? `There is no job ${id}.` : `Cannot load job ${id}: ${e.message}`,
      h('a', { href: '#/runs' }, 'Back to the runs')));
    return null;
  }

  function renderHead() {
    title.textContent = job.name ? `${job.name}` : `Job ${job.id}`;
    const pairs = [['Id', job.id], ...jobMeta(job)];
    if (job.notes) pairs.push(['Notes', job.notes]);
    metaBox.replaceChildren(...pairs.map(([k, v]) => h('div', { class: k === 'Notes' ? 'notes' : null },
      h('dt', {}, k), h('dd', {}, String(v)))));
    headActions.replaceChildren(...[
      h('button', { type: 'button', class: 'secondary', onclick: async () => {
        const updated = await editJobDialog(job);
        if (updated) { job = updated; renderHead(); }
      } }, 'Edit name, tags, notes'),
      (job.status === 'queued' || job.status === 'running')
        ? h('button', { type: 'button', class: 'danger', onclick: async () => {
          if (!(await confirmDialog('Cancel job?', `Cancel job ${job.id}? ${cancelConsequence(job)}`, 'Cancel job', true, keepLabel(job)))) return;
          try { job = await api.cancelJob(job.id); update(); } catch (e) { statusBox.append(notice('error', e.message)); }
        } }, 'Cancel job')
        : null,
      job.status === 'succeeded' ? h('a', { class: 'button secondary', href: `#/compare?jobs=${job.id}` }, 'Open in compare') : null,
      job.kind === 'external' ? null : h('a', { class: 'button secondary', href: `#/new?clone=${job.id}`, id: 'clone-job' }, 'Clone into a new experiment'),
      job.study_id ? h('a', { class: 'button secondary', href: `#/studies/${job.study_id}` }, `Its study (${job.study_id})`) : null,
    ].filter(Boolean));
  }

  /** The full resolved configuration, the values that differ from the preset highlighted. */
  async function renderConfig() {
    let schema;
    try { schema = await api.systems(); } catch (e) { return; }
    if (stopped) return;
    const rows = configRows(job, schema);
    const groups = [];
    for (const r of rows) {
      if (!groups.length || groups[groups.length - 1].title !== r.group) groups.push({ title: r.group, rows: [] });
      groups[groups.length - 1].rows.push(r);
    }
    const differ = rows.some((r) => r.differs);
    configBox.replaceChildren(
      h('h2', { id: 'h-config' }, 'Configuration'),
      h('p', { class: 'help', id: 'config-summary' }, differenceSummary(job, rows),
        differ ? ' Highlighted: not the preset’s value (the preset’s is beside it).' : ''),
      h('details', { open: differ ? true : null, id: 'config-details' },
        h('summary', {}, `All ${rows.length} parameters, algorithms ${job.algorithms.join(', ')}, ` +
          `${job.seeds.length} seeds, ${job.episodes} episodes`),
        h('div', { class: 'config-groups' }, groups.map((g) => h('div', { class: 'table-wrap' },
          h('table', { class: 'config-table' },
            h('caption', {}, g.title),
            h('tbody', {}, g.rows.map(configRow)))))),
        h('p', { class: 'help' }, `Seeds: ${job.seeds.join(', ')}. Configuration hash ${job.config_hash}.`)));
  }

  /**
   * One parameter's row: name, value and the preset's when it differs. A list or event list
   * (a schedule) takes the card's whole width, one line per item, so it does not wrap a character
   * column.
   */
  function configRow(r) {
    const cls = r.differs ? 'differs' : null;
    if (!Array.isArray(r.value)) {
      return h('tr', { class: cls, 'data-param': r.name },
        h('th', { scope: 'row', title: r.help }, r.name),
        h('td', { class: 'num' }, fmtParam(r.value)),
        h('td', { class: 'num preset help' }, r.differs ? `preset ${fmtParam(r.preset)}` : ''));
    }
    const preset = Array.isArray(r.preset) ? listLines(r.preset).join('; ') : fmtParam(r.preset);
    return h('tr', { class: [cls, 'list-param'].filter(Boolean).join(' '), 'data-param': r.name },
      h('td', { colspan: 3 },
        h('div', { class: 'list-name', title: r.help }, r.name),
        h('ul', { class: 'list-value' }, listLines(r.value).map((line) => h('li', {}, line))),
        r.differs ? h('div', { class: 'preset help' }, `preset: ${preset}`) : null));
  }

  /** The stopping rule's section, drawn again only when a block was judged or the job ended. */
  function renderRule() {
    const signature = JSON.stringify([job.status, job.stopped && job.stopped.seeds, job.stopped && job.stopped.reason]);
    if (signature === ruleSignature) return;
    ruleSignature = signature;
    ruleBox.replaceChildren(...[ruleSection(job)].filter(Boolean));
  }

  function renderStatus() {
    renderRule();
    const pct = pctProgress(job.progress);
    if (job.status === 'queued' || job.status === 'running') {
      const waiting = waitingMessage(workers, pct, queue);
      statusBox.replaceChildren(h('div', { class: 'progress-block' },
        h('span', { class: `badge status-${job.status}` },
          job.status === 'running' ? h('span', { class: 'spinner', 'aria-hidden': 'true' }) : null, job.status),
        h('progress', { class: 'big', max: 100, value: pct, 'aria-label': 'Job progress', id: 'job-progress' }),
        h('span', { class: 'pct', role: 'status', id: 'job-waiting' }, job.status === 'queued' ? waiting
          : (job.compiling ? `Running: ${compilingText(job.compiling)}` : `Running: ${pct}% done`))),
      ...[requeueNote()].filter(Boolean));
    } else if (job.status === 'failed') {
      statusBox.replaceChildren(notice('error', 'This job failed.', h('pre', { class: 'error-text' }, job.error || 'No reason was recorded.')));
    } else if (job.status === 'cancelled') {
      statusBox.replaceChildren(notice('warn', 'This job was cancelled. The runs it completed before are kept and shown below.'),
        ...[requeueNote()].filter(Boolean));
    } else {
      statusBox.replaceChildren(statusCell(job), ...[requeueNote()].filter(Boolean));
    }
  }

  /** Why a job went back to the queue, and what it kept: its attempt count and stored progress. */
  function requeueNote() {
    if (!job.requeue_reason) return null;
    const when = job.status === 'queued' ? `Re-queued after attempt ${job.attempts}` : `Attempt ${job.attempts}, re-queued before`;
    const kept = job.status === 'queued' || job.status === 'running'
      ? ' The runs stored before are kept: the job resumes from them.' : '';
    return h('p', { class: 'requeue help', id: 'requeue-note' }, `${when}: ${job.requeue_reason}.${kept}`);
  }

  async function update() {
    renderHead();
    renderStatus();
    if (!configBox.firstChild) renderConfig();
    results = null;
    seedResults = null;
    storedSignature = '';
    if (job.status === 'succeeded') await showResults();
    else await showStored();
  }

  // ---- live curves: while a job runs (or after it stopped early) its stored chunks are drawn ----
  let storedSignature = ''; // seeds stored per configuration when last drawn
  let liveAt = 0;
  const LIVE_INTERVAL_MS = 3000;

  /** Draw what is stored of an unfinished job; redraw only when a chunk of seeds was added. */
  async function showStored() {
    if (job.status === 'queued' && !(job.progress > 0)) { body.replaceChildren(); return; }
    liveAt = Date.now();
    const nothingYet = () => body.replaceChildren(h('p', { class: 'help', id: 'no-runs-yet', role: 'status' },
      job.status === 'running' || job.status === 'queued'
        ? 'No seed is complete yet: the curves appear as soon as the first chunk of seeds is stored.'
        : 'It stored no runs.'));
    let r;
    try {
      // Nothing stored yet is a state, not an error: ask /results (409 then) only once a run is stored.
      if ((await api.jobStatus(id)).stored_runs === 0) { if (!stopped) nothingYet(); return; }
      // seeds that do not fit one answer are left out here (the results view says why once it draws)
      const points = showSeeds ? await seedCurvePoints().catch(() => { showSeeds = false; return POINTS; }) : POINTS;
      r = await api.results(id, { points, include_seeds: showSeeds ? 'true' : undefined });
    } catch (e) {
      if (stopped) return;
      if (e.status === 409) nothingYet(); // the runs were deleted meanwhile
      else body.replaceChildren(notice('error', `Cannot load the stored results: ${e.message}`));
      return;
    }
    if (stopped) return;
    const signature = r.configurations.map((c) => `${c.algorithm}:${c.seeds_done}`).join(',');
    if (signature === storedSignature) return;
    storedSignature = signature;
    rememberAnswer(r.algorithms, [...job.algorithms, ...r.configurations.map((c) => c.algorithm)]); // no request
    await ready([...job.algorithms, ...r.configurations.map((c) => c.algorithm)]); // their order and colours
    r.configurations.sort((a, b) => compareLabels(a.algorithm, b.algorithm));
    if (showSeeds) { seedResults = r; results = null; } else { results = r; seedResults = null; }
    await showResults();
  }

  async function readWorkers() {
    if (job.status !== 'queued' || Date.now() - workersAt < 2000) return;
    workersAt = Date.now();
    try {
      const st = await api.jobStatus(id);
      workers = st.workers || null;
      queue = { ahead: st.ahead, running: st.running };
    } catch { workers = null; queue = null; }
  }

  async function poll() {
    if (stopped) return;
    try {
      await readWorkers();
      const next = await api.getJob(id);
      if (stopped) return;
      const changed = next.status !== job.status;
      job = next;
      if (changed) window.dispatchEvent(new CustomEvent('jobs-changed'));
      if (changed) await update();
      else {
        renderStatus();
        if (job.status === 'running' && Date.now() - liveAt >= LIVE_INTERVAL_MS) await showStored();
      }
    } catch (e) {
      if (e.status === 404) { stopped = true; statusBox.replaceChildren(notice('error', 'This job was deleted.')); return; }
    }
    if (!stopped && (job.status === 'queued' || job.status === 'running')) timer = setTimeout(poll, 1000);
  }

  // ---- results ---------------------------------------------------------------------------
  let results = null;
  let seedResults = null;

  /**
   * The points per curve with every seed's curve that fit one answer (`max_response_values` of GET /api/systems),
   * or a SeedsTooMany error saying why not and what to do.
   */
  async function seedCurvePoints() {
    const schema = await api.systems();
    const runs = results ? results.configurations.reduce((n, c) => n + (c.seeds_done ?? 0), 0)
      : job.seeds.length * job.algorithms.length;
    const points = seedPoints(POINTS, job.episodes, job.algorithms.length, runs, schema.limits.max_response_values);
    if (points === null) {
      const error = new Error(`${runs.toLocaleString('en-US')} runs are too many to draw one by one: one answer holds ` +
        `${schema.limits.max_response_values.toLocaleString('en-US')} values, fewer than ${MIN_SEED_POINTS} points a ` +
        'seed. The bands show their spread; every episode of every seed is in “Episodes as CSV” below.');
      error.name = 'SeedsTooMany';
      throw error;
    }
    return points;
  }

  async function fetchResults(withSeeds) {
    if (withSeeds && seedResults) return seedResults;
    if (!withSeeds && results) return results;
    const points = withSeeds ? await seedCurvePoints() : POINTS;
    const r = await api.results(id, { points, include_seeds: withSeeds ? 'true' : undefined });
    rememberAnswer(r.algorithms, [...job.algorithms, ...r.configurations.map((c) => c.algorithm)]); // no request
    await ready([...job.algorithms, ...r.configurations.map((c) => c.algorithm)]); // their order and colours
    r.configurations.sort((a, b) => compareLabels(a.algorithm, b.algorithm));
    if (withSeeds) seedResults = r; else results = r;
    return r;
  }

  async function showResults() {
    body.replaceChildren(h('p', { class: 'loading' }, 'Loading results…'));
    let r;
    let seedsRefused = '';
    try {
      r = await fetchResults(showSeeds);
    } catch (e) {
      if (e.name !== 'SeedsTooMany') {
        body.replaceChildren(notice('error', `Cannot load the results: ${e.message}`));
        return;
      }
      showSeeds = false; // asked for in the address: said why not, and drawn without
      seedsRefused = e.message;
      try { r = await fetchResults(false); } catch (err) {
        body.replaceChildren(notice('error', `Cannot load the results: ${err.message}`));
        return;
      }
    }
    if (stopped) return;
    const smoothId = nextId('smooth');
    const seedsId = nextId('seeds');
    const smoothSel = h('select', { id: smoothId }, SMOOTH_CHOICES.map((n) =>
      h('option', { value: n, selected: n === smooth }, n === 1 ? 'none' : `${n} episodes`)));
    const seedsCb = h('input', { type: 'checkbox', id: seedsId, checked: showSeeds });
    const bandsId = nextId('bands');
    const bandsCb = h('input', { type: 'checkbox', id: bandsId, checked: showBands, class: 'show-bands' });
    const caution = h('p', { class: 'help band-caution', id: 'band-caution' });
    const chart = h('div', { class: 'chart', id: 'utility-chart', role: 'img', 'aria-label': 'System utility per episode, mean over seeds with 95% band, per configuration' });
    const chartStatus = h('span', { 'aria-live': 'polite', class: 'help' });
    const seedsNote = h('p', { class: 'help seeds-note', id: 'seeds-note', role: 'status' }, seedsRefused);
    const smoothNote = h('p', { class: 'help', id: 'smoothing-note' });
    plots.push(chart);

    const redraw = async () => {
      const data = showSeeds ? await fetchResults(true) : await fetchResults(false);
      if (stopped) return;
      const traces = [];
      const styles = algorithmStyles(job.algorithms.concat(data.configurations.map((c) => c.algorithm)));
      data.configurations.forEach((c) => {
        const style = styles[c.algorithm];
        if (showSeeds) traces.push(...seedTraces(c.algorithm, c.seeds, style.color, smooth, c.algorithm, data.configurations.length));
        traces.push(...meanBandTraces(c.algorithm, c.episodes, style.color, smooth, c.algorithm, style.dash,
          { bands: showBands, symbol: style.symbol, fillAlpha: bandAlpha(data.configurations.length) }));
      });
      const layout = withEvents(utilityLayout(), (job.params || {}).schedule, job.episodes); // a line per event
      await draw(chart, bandsBelow(traces), withAxis(layout, axisUi.axis));
      caution.textContent = showBands ? bandCaution(data.configurations.map((c) => ({
        runs: c.seeds_done ?? (c.summary || {}).n_runs, episodes: c.episodes }))) : '';
      chart.dataset.rendered = String(Date.now());
      chartStatus.textContent = '';
      const most = Math.max(0, ...data.configurations.map((c) => (c.seeds || []).length));
      smoothNote.textContent = smoothingNote(smooth, episodesPerPoint((data.configurations[0] || {}).episodes?.episode),
        showBands, showSeeds ? { drawn: Math.min(most, SEED_SAMPLE), of: most } : null);
      ctx.setQuery({ smooth: smooth > 1 ? smooth : '', seeds: showSeeds ? '1' : '', bands: showBands ? '' : '0' });
    };
    redrawUtility = redraw;
    smoothSel.addEventListener('change', () => { smooth = Number(smoothSel.value); redraw(); });
    bandsCb.addEventListener('change', () => { showBands = bandsCb.checked; redraw(); });
    seedsCb.addEventListener('change', async () => {
      showSeeds = seedsCb.checked;
      seedsNote.textContent = '';
      chartStatus.textContent = showSeeds ? 'Loading seeds…' : '';
      try {
        await redraw();
      } catch (e) { // the box says what is drawn: unticked again, and why
        showSeeds = false;
        seedsCb.checked = false;
        chartStatus.textContent = '';
        seedsNote.textContent = e.name === 'SeedsTooMany' ? e.message : `Cannot load the seeds: ${e.message}`;
        ctx.setQuery({ smooth: smooth > 1 ? smooth : '', seeds: '', bands: showBands ? '' : '0' });
      }
    });

    body.replaceChildren(
      ...[partialNote(r), oracleCaveat(r)].filter(Boolean),
      h('section', { 'aria-labelledby': 'h-util' },
        h('h2', { id: 'h-util' }, 'System utility per episode'),
        h('div', { class: 'controls' },
          h('label', { for: smoothId }, 'Smoothing (centred mean)'), smoothSel,
          h('label', { class: 'check', for: seedsId }, seedsCb, ' Show individual seeds'),
          h('label', { class: 'check', for: bandsId }, bandsCb, ' 95% bands'), chartStatus),
        seedsNote, axisUi.element, chart, smoothNote, caution),
      summaryTable(r),
      ...[learningSection(r), tasksSection({ job, results: r, plots })].filter(Boolean),
      weightsSection({ jobId: id, results: r, plots, state: weightsState }),
      h('section', { 'aria-labelledby': 'h-dl' }, h('h2', { id: 'h-dl' }, 'Download'),
        h('p', { class: 'downloads' },
          h('a', { class: 'button secondary', href: api.episodesUrl(id, 'csv'), download: `job-${id}-episodes.csv`,
            onclick: downloadWithToken }, 'Episodes as CSV'),
          ' ',
          h('a', { class: 'button secondary', href: api.episodesUrl(id, 'json'), download: `job-${id}-episodes.json`,
            onclick: downloadWithToken }, 'Episodes as JSON'),
          ' ',
          h('button', { type: 'button', class: 'secondary', id: 'download-summary',
            onclick: () => downloadText(`job-${id}-summary.csv`, 'text/csv', summaryCsv(job, r.configurations)) },
          'Final utility and parameters as CSV'),
          ' ',
          h('button', { type: 'button', class: 'secondary', id: 'download-config',
            onclick: () => downloadText(`job-${id}-config.json`, 'application/json', configJson(job)) },
          'Configuration as JSON')),
        h('p', { class: 'help' }, 'The episodes are every stored utility (job_id, algorithm, seed, episode, utility); ' +
          'the CSV of final utilities carries every resolved parameter as a column.')));
    await redraw();
  }

  /** For results of an unfinished job: how many seeds each configuration has stored. */
  function partialNote(r) {
    if (!r.partial) return null;
    const total = job.seeds.length;
    const done = r.configurations.map((c) => `${c.algorithm} ${c.seeds_done} of ${total}`).join(', ');
    const what = job.status === 'running' || job.status === 'queued'
      ? 'Partial results, filling in as chunks of seeds are stored'
      : `Partial results: the job ${job.status} before it completed`;
    return h('p', { class: 'notice warn partial-note', id: 'partial-note', role: 'status' },
      `${what}. Seeds stored: ${done}. Means and intervals are over the stored seeds only.`);
  }

  /** Where the oracle is no upper bound in the job's system, why (as compare says it), above the results. */
  function oracleCaveat(r) {
    const caveats = r.oracle_caveats || [];
    if (!caveats.length) return null;
    return h('div', { class: 'notice warn oracle-caveat', id: 'oracle-caveat', role: 'note' },
      h('strong', {}, 'The oracle is no upper bound here. '),
      'It is the best fixed allocation of a child that receives every task of a stationary stream, with one ' +
      'resource; this system departs from that, so a learner can beat it and it can fall below uniform: ',
      h('ul', {}, caveats.map((c) => h('li', {}, c))));
  }

  /** What learning took: each learner's parent groups at the end and the share of resources it paid for them. */
  function learningSection(r) {
    const learners = r.configurations.filter((c) => c.learning);
    const cost = Number((job.params || {}).learning_cost) || 0;
    if (!learners.some((c) => c.learning.taken || c.learning.groups_change)) return null;
    const table = h('table', { class: 'summary learning-table', id: 'learning-table' },
      h('thead', {}, h('tr', {}, ['Configuration', 'Parent groups at the end', 'Resources learning took']
        .map((c) => h('th', { scope: 'col' }, c)))),
      h('tbody', {}, learners.map((c) => h('tr', { 'data-algorithm': c.algorithm },
        h('th', { scope: 'row' }, c.algorithm),
        h('td', { class: 'groups' }, groupsText(c.learning)),
        h('td', { class: 'num taken' }, cost ? takenText(c.learning) : 'nothing (no learning_cost)')))));
    return h('section', { 'aria-labelledby': 'h-learning' },
      h('h2', { id: 'h-learning' }, 'What learning took'),
      h('div', { class: 'table-wrap' }, table),
      h('p', { class: 'help' }, cost
        ? `learning_cost ${cost}: learning takes that share of every resource from mgrao-max’s children, and from ` +
          'others in proportion to what they keep (docs: “The cost of learning”); the rest goes to their tasks. ' +
          'A range is over the children and seeds: mgrao-balance pays for the groups each child has.'
        : 'Without a learning_cost, learning takes nothing from the tasks.',
        ' Children are counted once per seed; mgrao-balance’s groups are those its children ended with (their ' +
        'recorded memberships).'));
  }

  function summaryTable(r) {
    const paper = r.paper || null;
    const table = h('table', { class: 'summary' },
      h('caption', {}, paper ? 'Ours against the paper’s published % from uniform.' : 'The paper has no figure for these parameters.'),
      h('thead', {}, h('tr', {},
        ['Configuration', 'Runs', 'Final mean', '95% CI', '% from uniform', '95% CI', '% of max']
          .map((c) => h('th', { scope: 'col' }, c)),
        paper ? h('th', { scope: 'col' }, 'Paper: % from uniform') : null)),
      h('tbody', {}, r.configurations.map((c) => {
        const s = c.summary || {};
        const pv = paper ? paper[c.algorithm] : undefined;
        const judged = pv === undefined || pv === null ? 1 : decidingDigits(s.pct_ci95, pv); // the paper view's rule
        return h('tr', {},
          h('th', { scope: 'row' }, c.algorithm),
          h('td', { class: 'num' }, s.n_runs ?? '–'),
          h('td', { class: 'num' }, fmtNumber(s.final_mean)),
          h('td', { class: 'num ci' }, fmtCI(s.ci95)),
          h('td', { class: 'num' }, fmtPct(s.pct_from_uniform)),
          h('td', { class: 'num ci pct-ci' }, fmtCI(s.pct_ci95, judged, true)),
          h('td', { class: 'num' }, fmtPct(s.pct_of_max, 1, false)),
          paper ? h('td', { class: 'num paper' }, pv === undefined || pv === null ? '–' : fmtPct(pv, judged)) : null);
      })));
    return h('section', { 'aria-labelledby': 'h-sum' },
      h('h2', { id: 'h-sum' }, 'Final utility ', tableCsvButton(`job-${id}-final-utility.csv`, () => [
        ['configuration', ...SUMMARY_COLUMNS, ...(paper ? ['paper_pct_from_uniform_percent'] : [])],
        ...r.configurations.map((c) => [c.algorithm, ...summaryCells(c.summary),
          ...(paper ? [paper[c.algorithm] ?? null] : [])])])),
      h('div', { class: 'table-wrap' }, table),
      ...[maxNote(r.configurations, roleLabel('reference'))].filter(Boolean).map((text) => h('p', { class: 'notice warn', id: 'max-note' }, text)),
      h('p', { class: 'help definitions' }, DEFINITIONS));
  }

  await readWorkers();
  await update();
  if (job.status === 'queued' || job.status === 'running') timer = setTimeout(poll, 1000);
  return () => { stopped = true; clearTimeout(timer); for (const p of plots) purge(p); };
}
