// New experiment form, built from GET /api/systems. The server validates; its 422 messages are
// shown beside the inputs named by each error's `field`.

import { api } from './api.js';
import { h, notice, nextId, confirmDialog } from './ui.js';
import { parseRatios, parseTags, fieldErrors, changedParams, sortAlgorithms } from './stats.js';

const PAPER_SEEDS = 100;
const PAPER_EPISODES = 100;

function rangeText(p) {
  if (p.kind === 'choice') return `one of ${p.choices.join(', ')}`;
  if (p.kind === 'bool') return 'on or off';
  const lo = p.minimum === null || p.minimum === undefined ? '−∞' : p.minimum;
  const hi = p.maximum === null || p.maximum === undefined ? '∞' : p.maximum;
  return `range ${p.exclusive_minimum ? '(' : '['}${lo}, ${hi}]`;
}

export async function mount(root, params, ctx) {
  root.append(h('h1', {}, 'New experiment'));
  let schema;
  try {
    schema = await api.systems();
  } catch (e) {
    root.append(notice('error', `Cannot load the systems: ${e.message}`));
    return null;
  }
  const knownParams = new Set(schema.parameters.map((p) => p.name));
  const fixed = schema.algorithms.fixed;
  const errorEls = new Map(); // field path -> {input, error}

  const fieldBlock = (path, labelText, control, helpText) => {
    const id = control.id || nextId('in');
    control.id = id;
    control.dataset.field = path;
    const errId = `${id}-err`;
    const helpId = `${id}-help`;
    const error = h('span', { id: errId, class: 'field-error', 'aria-live': 'polite' });
    control.setAttribute('aria-describedby', helpText ? `${helpId} ${errId}` : errId);
    errorEls.set(path, { input: control, error });
    return h('div', { class: 'field', dataset: { for: path } },
      h('label', { for: id }, labelText), control,
      helpText ? h('small', { id: helpId, class: 'help' }, helpText) : null, error);
  };

  // --- preset -----------------------------------------------------------------------------
  const systemSel = h('select', { name: 'system' }, schema.systems.map((s) =>
    h('option', { value: s.name, selected: s.name === (params.system || 'single') }, s.name)));
  const systemDesc = h('p', { class: 'help', id: nextId('sysdesc') });

  // --- algorithms ---------------------------------------------------------------------------
  const algoBoxes = fixed.map((a) => h('input', { type: 'checkbox', name: 'algorithms', value: a, id: nextId('algo') }));
  const ratioIn = h('input', { type: 'text', name: 'ratios', placeholder: 'e.g. 2, 5, 10', id: nextId('ratios') });
  const algoErr = h('span', { class: 'field-error', id: nextId('algoerr'), 'aria-live': 'polite' });
  errorEls.set('algorithms', { input: algoBoxes[0], error: algoErr });
  const algoFieldset = h('fieldset', { class: 'algos', dataset: { for: 'algorithms' }, 'aria-describedby': algoErr.id },
    h('legend', {}, 'Configurations'),
    h('div', { class: 'checks' }, algoBoxes.map((cb) => h('label', { class: 'check', for: cb.id }, cb, ' ', cb.value))),
    h('div', { class: 'field' },
      h('label', { for: ratioIn.id }, `More ${schema.algorithms.pattern} ratios`), ratioIn,
      h('small', { class: 'help', id: `${ratioIn.id}-help` }, 'Comma separated x values; each adds a configuration mgrao-x:1.')),
    algoErr);
  ratioIn.setAttribute('aria-describedby', `${ratioIn.id}-help ${algoErr.id}`);

  const seedsIn = h('input', { type: 'number', name: 'seeds', min: 1, max: schema.limits.max_seeds, step: 1, value: 3, inputmode: 'numeric' });
  const episodesIn = h('input', { type: 'number', name: 'episodes', min: 1, max: schema.limits.max_episodes, step: 1, value: 100, inputmode: 'numeric' });
  const nameIn = h('input', { type: 'text', name: 'name', maxlength: 200 });
  const tagsIn = h('input', { type: 'text', name: 'tags' });
  const notesIn = h('textarea', { name: 'notes', rows: 2 });

  // --- advanced parameters ------------------------------------------------------------------
  const paramInputs = new Map();
  const groups = {};
  for (const p of schema.parameters) (groups[p.group] ||= []).push(p);
  const advanced = h('details', { class: 'advanced' }, h('summary', {}, 'Advanced: every parameter'),
    h('p', { class: 'help' }, 'Prefilled with the chosen preset’s values. Only values you change are sent as overrides.'),
    Object.entries(groups).map(([group, ps]) => h('fieldset', { class: 'param-group' }, h('legend', {}, group),
      ps.map((p) => {
        let input;
        if (p.kind === 'choice') {
          input = h('select', { name: p.name }, p.choices.map((c) => h('option', { value: c }, c)));
        } else if (p.kind === 'bool') {
          input = h('input', { type: 'checkbox', name: p.name });
        } else {
          input = h('input', { type: 'number', name: p.name, step: p.kind === 'int' ? 1 : 'any',
            min: p.minimum ?? undefined, max: p.maximum ?? undefined, placeholder: p.nullable ? 'auto' : undefined });
        }
        paramInputs.set(p.name, { p, input });
        const def = p.default === null ? 'auto' : p.kind === 'bool' ? (p.default ? 'on' : 'off') : p.default;
        return fieldBlock(`params.${p.name}`, p.name, input, `${p.help} Default ${def}; ${rangeText(p)}${p.nullable ? '; empty = auto' : ''}.`);
      }))));

  function preset() {
    return schema.systems.find((s) => s.name === systemSel.value) || schema.systems[0];
  }

  function applyPreset() {
    const s = preset();
    systemDesc.textContent = s.description;
    for (const cb of algoBoxes) cb.checked = s.algorithms.includes(cb.value);
    ratioIn.value = s.algorithms.filter((a) => !fixed.includes(a)).map((a) => a.replace(/^mgrao-/, '').replace(/:1$/, '')).join(', ');
    for (const { p, input } of paramInputs.values()) {
      const v = s.params[p.name];
      if (p.kind === 'bool') input.checked = Boolean(v);
      else input.value = v === null || v === undefined ? '' : String(v);
    }
    if (!nameIn.dataset.touched) nameIn.value = '';
    nameIn.placeholder = `${s.name} experiment`;
  }
  systemSel.addEventListener('change', applyPreset);
  nameIn.addEventListener('input', () => { nameIn.dataset.touched = '1'; });

  function readParams() {
    const values = {};
    for (const { p, input } of paramInputs.values()) {
      if (p.kind === 'bool') { values[p.name] = input.checked; continue; }
      const raw = input.value.trim();
      if (p.kind === 'choice') values[p.name] = raw;
      else if (raw === '') values[p.name] = p.nullable ? null : raw; // '' goes to the server, which explains
      else values[p.name] = Number(raw);
    }
    return changedParams(values, preset().params);
  }

  const summary = h('div', { class: 'error-summary', id: nextId('summary'), 'aria-live': 'assertive' });
  const submitBtn = h('button', { type: 'submit', class: 'primary' }, 'Run experiment');
  const paperBtn = h('button', { type: 'button', class: 'secondary' }, 'Reproduce the paper (4 jobs)');
  const paperStatus = h('p', { 'aria-live': 'polite', class: 'help' });

  function clearErrors() {
    summary.replaceChildren();
    for (const { input, error } of errorEls.values()) {
      error.textContent = '';
      input.removeAttribute('aria-invalid');
      input.closest('.field, fieldset')?.classList.remove('invalid');
    }
  }

  function showErrors(err) {
    const byField = fieldErrors(err.detail, knownParams);
    const unplaced = [];
    let first = null;
    for (const [path, msg] of Object.entries(byField)) {
      const target = errorEls.get(path);
      if (!target) { unplaced.push(msg); continue; }
      target.error.textContent = msg;
      target.input.setAttribute('aria-invalid', 'true');
      target.input.closest('.field, fieldset')?.classList.add('invalid');
      if (path.startsWith('params.')) advanced.open = true;
      first ||= target.input;
    }
    const msgs = Object.keys(byField).length ? unplaced : [err.message];
    summary.replaceChildren(h('div', { class: 'notice error', role: 'alert' },
      h('p', {}, Object.keys(byField).length ? 'The server rejected the experiment; see the marked fields.' : 'The experiment could not be started.'),
      msgs.length ? h('ul', {}, msgs.map((m) => h('li', {}, m))) : null));
    if (first) first.focus();
  }

  const form = h('form', { class: 'newjob', novalidate: true, 'aria-describedby': summary.id },
    summary,
    h('div', { class: 'grid2' },
      h('div', {},
        fieldBlock('system', 'System preset', systemSel, null), systemDesc,
        algoFieldset,
        h('div', { class: 'row' },
          fieldBlock('seeds', 'Seeds (number of runs)', seedsIn, `1 to ${schema.limits.max_seeds}`),
          fieldBlock('episodes', 'Episodes per run', episodesIn, `1 to ${schema.limits.max_episodes}`))),
      h('div', {},
        fieldBlock('name', 'Name', nameIn, null),
        fieldBlock('tags', 'Tags', tagsIn, 'Comma separated'),
        fieldBlock('notes', 'Notes', notesIn, null))),
    advanced,
    h('div', { class: 'actions' }, submitBtn));

  form.addEventListener('submit', async (ev) => {
    ev.preventDefault();
    clearErrors();
    const ratios = parseRatios(ratioIn.value);
    if (ratios.invalid.length) {
      showErrors({ detail: [{ field: 'algorithms', msg: `not a ratio: ${ratios.invalid.join(', ')} (type whole numbers like 2, 5)` }] });
      return;
    }
    const algorithms = sortAlgorithms([...algoBoxes.filter((cb) => cb.checked).map((cb) => cb.value), ...ratios.algorithms]);
    const body = {
      system: systemSel.value,
      algorithms,
      seeds: seedsIn.value === '' ? seedsIn.value : Number(seedsIn.value),
      episodes: episodesIn.value === '' ? episodesIn.value : Number(episodesIn.value),
      params: readParams(),
      name: nameIn.value.trim() || nameIn.placeholder,
      tags: parseTags(tagsIn.value),
      notes: notesIn.value,
    };
    submitBtn.disabled = true;
    submitBtn.textContent = 'Submitting…';
    try {
      const job = await api.createJob(body);
      ctx.navigate(`/jobs/${job.id}`);
    } catch (e) {
      if (e.status === 422) showErrors(e);
      else showErrors({ message: e.message, detail: null });
    } finally {
      submitBtn.disabled = false;
      submitBtn.textContent = 'Run experiment';
    }
  });

  paperBtn.addEventListener('click', async () => {
    const n = schema.systems.length;
    const ok = await confirmDialog('Reproduce the paper?',
      `This queues ${n} jobs (${schema.systems.map((s) => s.name).join(', ')}), each with its paper configurations, ` +
      `${PAPER_SEEDS} seeds and ${PAPER_EPISODES} episodes, tagged “paper”.`, 'Queue the jobs');
    if (!ok) return;
    paperBtn.disabled = true;
    const made = [];
    try {
      for (const s of schema.systems) {
        paperStatus.textContent = `Queuing ${s.name}…`;
        const job = await api.createJob({ system: s.name, algorithms: s.algorithms, seeds: PAPER_SEEDS,
          episodes: PAPER_EPISODES, tags: ['paper'], name: `paper: ${s.name}`, notes: 'Full reproduction of the paper.' });
        made.push(job.id);
      }
      ctx.navigate('/runs', { tag: 'paper' });
    } catch (e) {
      paperStatus.textContent = `Queued ${made.length} of ${n} jobs; then: ${e.message}`;
      paperBtn.disabled = false;
    }
  });

  root.append(form,
    h('section', { class: 'paper-box', 'aria-labelledby': 'paper-h' },
      h('h2', { id: 'paper-h' }, 'Full reproduction'),
      h('p', {}, `The paper’s four systems, each with its published configurations, ${PAPER_SEEDS} seeds × ${PAPER_EPISODES} episodes.`),
      paperBtn, paperStatus));
  applyPreset();
  return null;
}
