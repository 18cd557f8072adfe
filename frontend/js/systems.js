// Systems view: the saved systems (GET /api/systems/saved), each with its parameters beside its base preset's,
// the jobs that ran it (their tag system:<name>), an editor of its description and changed values (PUT), and
// delete with a confirmation that says what becomes of those jobs (DELETE). #/systems and #/systems/<name>.

import { api } from './api.js';
import { h, notice, nextId, confirmDialog, statusCell } from './ui.js';
import { fmtDate, sameValue, ownWords, fieldErrors } from './stats.js';
import { fmtParam } from './studydata.js';
import { groupTitle } from './jobconfig.js';

const JOBS_SHOWN = 50;

/** The jobs that ran saved system `name` (its tag), newest first: {data, count}. */
function jobsOf(name, limit = JOBS_SHOWN) {
  return api.listJobs({ tag: `system:${name}`, limit });
}

/** "3 jobs" / "1 job" / "no job". */
function jobsWord(n) {
  if (!n) return 'no job';
  return `${n.toLocaleString('en-US')} ${n === 1 ? 'job' : 'jobs'}`;
}

/** What deleting `name` does to the `n` jobs that ran it: the confirmation's text. */
export function deleteConsequence(saved, n) {
  const one = n === 1;
  const jobs = n ? `${one ? 'The one job that ran it keeps its' : `The ${jobsWord(n)} that ran it keep their`} ` +
    `results, ${one ? 'its' : 'their'} configuration (${saved.base} with these values) and ${one ? 'its' : 'their'} ` +
    `tag system:${saved.name}, so ${one ? 'it is' : 'they are'} still listed and compared under ${saved.name}; ` +
    `cloning ${one ? 'it' : 'one'} gives ${saved.base} with the job's values.` : 'No job ran it.';
  return `Delete the saved system ${saved.name}? It leaves the system picker and this page. ${jobs} ` +
    'Saving a system under the same name later starts a new one.';
}

export async function mount(root, params, ctx) {
  if (params.name) return mountOne(root, params.name, ctx);
  root.append(h('div', { class: 'view-head' }, h('h1', {}, 'Systems'),
    h('div', { class: 'toolbar' }, h('a', { class: 'button primary', href: '#/new' }, 'New experiment'))),
  h('p', { class: 'help' }, 'Your saved systems: a preset with values changed, saved under a name from the new ',
    'experiment form (“Your own system”) or with “mgrao systems”, and run, compared and swept like a preset.'));
  const body = h('div', { 'aria-live': 'polite' }, h('p', { class: 'loading' }, 'Loading the saved systems…'));
  root.append(body);
  let saved;
  try {
    saved = await api.listSaved();
  } catch (e) {
    body.replaceChildren(notice('error', `Cannot load the saved systems: ${e.message}`));
    return null;
  }
  if (!saved.length) {
    body.replaceChildren(notice('empty', 'No system is saved yet. In New experiment, choose a preset, change its ' +
      'values and save it under “Your own system”.', h('a', { class: 'button primary', href: '#/new' }, 'New experiment')));
    return null;
  }
  const counts = await Promise.all(saved.map((s) => jobsOf(s.name, 1).then((a) => a.count).catch(() => null)));
  body.replaceChildren(h('div', { class: 'table-wrap' }, h('table', { class: 'systems', id: 'systems-table' },
    h('thead', {}, h('tr', {}, ['Name', 'Based on', 'Changed values', 'Jobs', 'Description'].map((c) => h('th', { scope: 'col' }, c)))),
    h('tbody', {}, saved.map((s, i) => h('tr', { dataset: { name: s.name } },
      h('th', { scope: 'row' }, h('a', { href: `#/systems/${s.name}` }, s.name)),
      h('td', {}, s.base),
      h('td', { class: 'changed' }, Object.entries(s.params).map(([k, v]) => `${k} ${fmtParam(v)}`).join(', ') || 'none'),
      h('td', { class: 'num' }, counts[i] === null ? '–' : h('a', { href: `#/runs?tag=system:${s.name}` }, String(counts[i]))),
      h('td', {}, s.description || '')))))));
  return null;
}

async function mountOne(root, name, ctx) {
  const title = h('h1', {}, name);
  const actions = h('div', { class: 'toolbar' });
  const body = h('div', { 'aria-live': 'polite' }, h('p', { class: 'loading' }, 'Loading…'));
  root.append(h('div', { class: 'view-head' }, title, actions), body);
  let saved;
  let schema;
  let jobs;
  try {
    [saved, schema, jobs] = await Promise.all([api.getSaved(name), api.systems(), jobsOf(name)]);
  } catch (e) {
    body.replaceChildren(notice('error', e.status === 404 ? `There is no saved system ${name}.` : `Cannot load ${name}: ${e.message}`,
      h('a', { href: '#/systems' }, 'Back to the systems')));
    return null;
  }
  const base = schema.systems.find((s) => s.name === saved.base);
  const byName = new Map(schema.parameters.map((p) => [p.name, p]));
  const summary = h('div', { class: 'error-summary', 'aria-live': 'assertive' });

  const draw = () => {
    actions.replaceChildren(
      h('a', { class: 'button primary', href: `#/new?system=${encodeURIComponent(saved.name)}` }, 'New experiment on it'),
      h('button', { type: 'button', class: 'secondary', id: 'edit-system', onclick: edit }, 'Edit'),
      h('button', { type: 'button', class: 'danger', id: 'delete-system', onclick: remove }, 'Delete'));
    body.replaceChildren(
      h('p', { id: 'system-summary' }, `A saved system based on ${saved.base}`,
        saved.description ? `: ${saved.description.replace(/[.]$/, '')}.` : '.',
        ` ${Object.keys(saved.params).length} of its ${schema.parameters.length} values differ from ${saved.base}’s (highlighted).`),
      summary,
      parameterTable(),
      jobsSection());
  };

  /** Every parameter: this system's value beside its base preset's, grouped as the schema groups them. */
  function parameterTable() {
    const groups = {};
    for (const p of schema.parameters) (groups[p.group] ||= []).push(p);
    return h('section', { 'aria-labelledby': 'h-params' }, h('h2', { id: 'h-params' }, 'Parameters'),
      h('div', { class: 'table-wrap' }, h('table', { class: 'config-table system-params', id: 'system-params' },
        h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Parameter'), h('th', { scope: 'col' }, saved.name),
          h('th', { scope: 'col' }, `${saved.base} (base)`))),
        Object.entries(groups).map(([group, ps]) => h('tbody', {},
          h('tr', { class: 'group' }, h('th', { colspan: 3, scope: 'rowgroup' }, groupTitle(group, schema.group_titles))),
          ps.map((p) => {
            const mine = saved.resolved[p.name];
            const theirs = base ? base.params[p.name] : undefined;
            const differs = !sameValue(mine, theirs);
            return h('tr', { class: differs ? 'differs' : null, dataset: { param: p.name } },
              h('th', { scope: 'row', title: p.help }, p.name),
              h('td', { class: 'num mine' }, fmtParam(mine)),
              h('td', { class: 'num base' }, fmtParam(theirs)));
          }))))));
  }

  function jobsSection() {
    return h('section', { 'aria-labelledby': 'h-jobs' },
      h('h2', { id: 'h-jobs' }, `Jobs that ran it (${jobs.count})`),
      jobs.count ? h('ul', { class: 'system-jobs', id: 'system-jobs' }, jobs.data.map((j) => h('li', {},
        h('a', { href: `#/jobs/${j.id}` }, j.name || `job ${j.id}`), ' ', statusCell(j), ` ${fmtDate(j.created_at)}`)))
        : h('p', { class: 'help' }, 'No job has run it yet.'),
      jobs.count > jobs.data.length ? h('p', {}, h('a', { href: `#/runs?tag=system:${saved.name}` },
        `All ${jobs.count} in the runs table`)) : null);
  }

  /** Edit its description and its changed values (a value back at the base's is no longer a change). */
  function edit() {
    const rows = new Map();
    const desc = h('input', { type: 'text', name: 'description', maxlength: 200, value: saved.description || '', id: nextId('desc') });
    const table = h('tbody');
    const errorOf = new Map();
    const addRow = (pname, value) => {
      if (rows.has(pname)) return;
      const p = byName.get(pname);
      const input = h('input', { type: 'text', name: pname, value: typeof value === 'object' ? JSON.stringify(value) : String(value),
        'aria-label': `${pname} of ${saved.name}`, dataset: { field: `params.${pname}` } });
      const error = h('span', { class: 'field-error', 'aria-live': 'polite' });
      errorOf.set(`params.${pname}`, { input, error });
      const tr = h('tr', { dataset: { param: pname } }, h('th', { scope: 'row', title: p?.help }, pname),
        h('td', {}, input, error), h('td', { class: 'help' }, `base ${fmtParam(base ? base.params[pname] : undefined)}`),
        h('td', {}, h('button', { type: 'button', class: 'small secondary', 'aria-label': `Back to ${saved.base}'s ${pname}`,
          onclick: () => { rows.delete(pname); tr.remove(); } }, 'Use the base’s')));
      rows.set(pname, input);
      table.append(tr);
    };
    for (const [k, v] of Object.entries(saved.params)) addRow(k, v);
    const more = h('select', { 'aria-label': 'Change another parameter' }, h('option', { value: '' }, 'Change another parameter…'),
      schema.parameters.filter((p) => !(p.name in saved.params)).map((p) => h('option', { value: p.name }, p.name)));
    more.addEventListener('change', () => { if (more.value) addRow(more.value, base ? base.params[more.value] : ''); more.value = ''; });
    const save = h('button', { type: 'submit', class: 'primary' }, 'Save');
    const form = h('form', { class: 'edit-system', novalidate: true },
      h('div', { class: 'field' }, h('label', { for: desc.id }, 'Description'), desc),
      h('table', { class: 'config-table' }, h('thead', {}, h('tr', {}, ['Parameter', saved.name, 'Base', ''].map((c) => h('th', { scope: 'col' }, c)))), table),
      more,
      h('div', { class: 'actions' }, h('button', { type: 'button', class: 'secondary', onclick: draw }, 'Back'), save));
    form.addEventListener('submit', async (ev) => {
      ev.preventDefault();
      summary.replaceChildren();
      for (const { input, error } of errorOf.values()) { error.textContent = ''; input.removeAttribute('aria-invalid'); }
      const values = {};
      for (const [pname, input] of rows) {
        const raw = input.value.trim();
        let value = raw;
        try { value = JSON.parse(raw); } catch { /* text: a choice's value, or the server explains */ }
        values[pname] = value;
      }
      try {
        saved = await api.replaceSaved(saved.name, { name: saved.name, description: desc.value.trim(), base: saved.base, params: values });
        draw();
        summary.replaceChildren(notice('ok', `Saved ${saved.name}. Jobs that ran it before keep their own values.`));
      } catch (e) {
        const byField = fieldErrors(e.detail, new Set(byName.keys()));
        const left = [];
        for (const [path, msg] of Object.entries(byField)) {
          const target = errorOf.get(path);
          if (target) { target.error.textContent = ownWords(path, msg); target.input.setAttribute('aria-invalid', 'true'); } else left.push(ownWords(path, msg));
        }
        summary.replaceChildren(notice('error', `${saved.name} was not saved${Object.keys(byField).length - left.length ? '; see the marked values' : ''}.`,
          ...(left.length || !e.detail ? [h('ul', {}, (left.length ? left : [e.message]).map((m) => h('li', {}, m)))] : [])));
      }
    });
    body.replaceChildren(h('h2', {}, `Edit ${saved.name}`), summary, form);
  }

  async function remove() {
    const ok = await confirmDialog(`Delete ${saved.name}?`, deleteConsequence(saved, jobs.count), 'Delete the system', true,
      'Keep it');
    if (!ok) return;
    try {
      await api.deleteSaved(saved.name);
      ctx.navigate('/systems');
    } catch (e) {
      summary.replaceChildren(notice('error', `Cannot delete ${saved.name}: ${e.message}`));
    }
  }

  draw();
  return null;
}
