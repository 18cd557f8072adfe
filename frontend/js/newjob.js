// New experiment form, built from GET /api/systems (js/experimentfields.js). The server validates;
// its 422 messages are shown beside the inputs named by each error's `field`.

import { api } from './api.js';
import { h, notice, nextId, confirmDialog } from './ui.js';
import { parseTags, systemName } from './stats.js';
import { experimentFields, STUDY_DRAFT } from './experimentfields.js';
import { families, literalLabels, ready } from './algorithms.js';
import { untilFields } from './untilfields.js';

const PAPER_SEEDS = 100;
const PAPER_EPISODES = 100;

export async function mount(root, params, ctx) {
  root.append(h('div', { class: 'view-head' }, h('h1', {}, 'New experiment'),
    h('div', { class: 'toolbar' }, h('a', { class: 'button secondary', href: '#/studies/new', id: 'to-study',
      onclick: (ev) => { // the study starts from this form's experiment
        ev.preventDefault();
        const experiment = fields ? fields.read() : {};
        try { sessionStorage.setItem(STUDY_DRAFT, JSON.stringify(experiment)); } catch { /* storage off: defaults */ }
        ctx.navigate('/studies/new', { from: 'experiment' });
      } },
    'Sweep parameters: new study'))));
  let schema;
  let fields = null;
  let fams;
  try {
    [schema, fams] = await Promise.all([api.systems(), families()]);
    await ready(literalLabels(fams));
  } catch (e) {
    root.append(notice('error', `Cannot load the systems: ${e.message}`));
    return null;
  }
  fields = experimentFields(schema, params, { fams });
  const nameIn = h('input', { type: 'text', name: 'name', maxlength: 200 });
  const tagsIn = h('input', { type: 'text', name: 'tags' });
  const notesIn = h('textarea', { name: 'notes', rows: 2 });
  fields.onPreset((s) => {
    if (!nameIn.dataset.touched) nameIn.value = '';
    nameIn.placeholder = `${s.name} experiment`;
  });
  nameIn.addEventListener('input', () => { nameIn.dataset.touched = '1'; });
  const rule = untilFields(schema.limits.until, fields.fieldBlock, fields.seedsIn);

  // "Clone into a new experiment" on a job's page: its whole configuration, ready to edit
  let clonedSeeds = null; // the job's seed list when it is not 0 .. n-1 (kept unless the count is edited)
  const cloneNote = h('p', { class: 'help', id: 'clone-note' });
  if (params.clone) {
    try {
      const job = await api.getJob(Number(params.clone));
      // a saved system's job clones into the saved system (its base preset if it was deleted since), with the
      // job's values; its tag system:NAME is the server's to give (it follows the system chosen)
      const chosen = fields.load({ system: systemName(job), base: job.system, algorithms: job.algorithms,
        seeds: job.seeds.length, episodes: job.episodes, params: job.params });
      nameIn.value = `${job.name || `job ${job.id}`} (clone)`;
      nameIn.dataset.touched = '1';
      tagsIn.value = (job.tags || []).filter((t) => !job.saved_system || t !== `system:${job.saved_system}`).join(', ');
      notesIn.value = `Cloned from job ${job.id}.`;
      const plain = job.until || job.seeds.every((seed, i) => seed === i);
      if (!plain) clonedSeeds = job.seeds;
      rule.load(job); // a job run until decided: its rule, from its first seed
      cloneNote.textContent = `A copy of job ${job.id}'s configuration: change what you need and run it.` +
        (plain ? '' : ` It runs the same seeds (${job.seeds.join(', ')}) unless you change their number.`) +
        (job.saved_system && chosen !== job.saved_system ? ` Its saved system ${job.saved_system} is no longer ` +
          `saved: the form holds its base, ${job.system}, with the job's values.` : '');
      fields.seedsIn.addEventListener('input', () => { clonedSeeds = null; }, { once: true });
    } catch (e) {
      cloneNote.textContent = `Cannot clone job ${params.clone}: ${e.message}`;
    }
  }

  const summary = h('div', { class: 'error-summary', id: nextId('summary'), 'aria-live': 'assertive' });
  const submitBtn = h('button', { type: 'submit', class: 'primary' }, 'Run experiment');
  const paperBtn = h('button', { type: 'button', class: 'secondary' }, 'Reproduce the paper (4 jobs)');
  const paperStatus = h('p', { 'aria-live': 'polite', class: 'help' });
  const showErrors = (err) => fields.showErrors(err, summary, 'experiment');

  const budgetSlot = h('div');
  const form = h('form', { class: 'newjob', novalidate: true, 'aria-describedby': summary.id },
    cloneNote, summary,
    h('div', { class: 'grid2' },
      h('div', {},
        fields.fieldBlock('system', 'System preset', fields.systemSel, null), fields.systemDesc, fields.keptNote,
        fields.algoFieldset,
        h('div', { class: 'row' },
          fields.fieldBlock('seeds', 'Seeds (number of runs)', fields.seedsIn, `1 to ${schema.limits.max_seeds}`),
          fields.fieldBlock('episodes', 'Episodes per run', fields.episodesIn, `1 to ${schema.limits.max_episodes}`)),
        rule.element,
        budgetSlot),
      h('div', {},
        fields.fieldBlock('name', 'Name', nameIn, null),
        fields.fieldBlock('tags', 'Tags', tagsIn, 'Comma separated'),
        fields.fieldBlock('notes', 'Notes', notesIn, null))),
    fields.advanced,
    h('div', { class: 'actions' }, submitBtn));

  budgetSlot.append(fields.budgetBlock(form));

  form.addEventListener('submit', async (ev) => {
    ev.preventDefault();
    fields.clearErrors(summary);
    await fields.described(); // the typed configurations' order
    const { invalidArguments, ...experiment } = fields.read();
    const local = invalidArguments ? fields.argumentErrors() : []; // said with the server's, in one pass
    fields.updateBudget();
    // The server's check says every refused field at once, each field's own rule before the work limit on their
    // product (seeds of 1e9: "at most 1000", not "over the work limit" with every factor marked).
    const body = {
      ...experiment,
      ...(clonedSeeds ? { seeds: clonedSeeds } : {}),
      name: nameIn.value.trim() || nameIn.placeholder,
      tags: parseTags(tagsIn.value),
      notes: notesIn.value,
    };
    const ruled = rule.body(); // with a stopping rule: its seeds follow from it
    if (ruled.until) delete body.seeds;
    Object.assign(body, ruled);
    submitBtn.disabled = true;
    submitBtn.textContent = 'Submitting…';
    try {
      // Checked first (always 200): a refusal is shown beside its fields without a 422 in the console.
      const verdict = await api.checkJob(body);
      if (!verdict.valid || local.length) { showErrors({ detail: [...local, ...(verdict.detail || [])] }); return; }
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
    const paperSystems = schema.systems.filter((s) => Object.keys(s.paper || {}).length); // not drift, bursty
    const n = paperSystems.length;
    const ok = await confirmDialog('Reproduce the paper?',
      `This queues ${n} jobs (${paperSystems.map((s) => s.name).join(', ')}), each with its paper configurations, ` +
      `${PAPER_SEEDS} seeds and ${PAPER_EPISODES} episodes, tagged “paper”.`, 'Queue the jobs', false, 'Not now');
    if (!ok) return;
    paperBtn.disabled = true;
    const made = [];
    try {
      for (const s of paperSystems) {
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

  // --- your own system: save the form's system and values under a name, import or export its file ---
  const savedName = h('input', { type: 'text', name: 'saved-name', maxlength: 32, placeholder: 'e.g. rush-hour',
    pattern: '[a-z][a-z0-9-]{0,31}' });
  const savedDesc = h('input', { type: 'text', name: 'saved-description', maxlength: 200 });
  const saveBtn = h('button', { type: 'button', class: 'secondary' }, 'Save as a system');
  const importIn = h('input', { type: 'file', accept: 'application/json,.json', id: nextId('import') });
  const exportLink = h('a', { class: 'export-system', hidden: true }, 'Download this saved system’s file');
  const saveStatus = h('p', { class: 'help', 'aria-live': 'polite' });
  const saveSummary = h('div', { class: 'error-summary', 'aria-live': 'assertive' });
  const saveErrors = { name: savedName, description: savedDesc };
  const showSaveError = (e) => {
    const items = Array.isArray(e.detail) ? e.detail.map((d) => d.msg) : [e.message];
    saveSummary.replaceChildren(h('div', { class: 'notice error', role: 'alert' },
      h('p', {}, 'The system was not saved.'), h('ul', {}, items.map((m) => h('li', {}, m)))));
    for (const d of Array.isArray(e.detail) ? e.detail : []) saveErrors[d.field]?.setAttribute('aria-invalid', 'true');
  };
  const save = async (body) => {
    saveSummary.replaceChildren();
    for (const input of Object.values(saveErrors)) input.removeAttribute('aria-invalid');
    try {
      const saved = await api.saveSystem(body);
      fields.addSaved(saved);
      saveStatus.textContent = `Saved “${saved.name}”: ${saved.base} with ${Object.keys(saved.params).length} changed values. It is chosen above.`;
    } catch (e) {
      showSaveError(e);
    }
  };
  saveBtn.addEventListener('click', () => save({ name: savedName.value.trim(), description: savedDesc.value.trim(),
    ...fields.definition() }));
  importIn.addEventListener('change', async () => {
    const file = importIn.files[0];
    if (!file) return;
    let body;
    try { body = JSON.parse(await file.text()); } catch (e) { showSaveError({ message: `${file.name} is not JSON: ${e.message}` }); return; }
    await save(body);
    importIn.value = '';
  });
  const refreshExport = () => {
    const chosen = fields.preset();
    exportLink.hidden = !chosen.base;
    if (!chosen.base) return;
    const file = { name: chosen.name, description: chosen.description, base: chosen.base, params: chosen.overrides };
    exportLink.href = `data:application/json,${encodeURIComponent(`${JSON.stringify(file, null, 2)}\n`)}`;
    exportLink.download = `${chosen.name}.json`;
  };
  fields.onPreset(refreshExport);
  const ownBox = h('section', { class: 'own-system', 'aria-labelledby': 'own-h' },
    h('h2', { id: 'own-h' }, 'Your own system'),
    h('p', { class: 'help' }, 'Save the chosen system with the values changed in this form (lists and events included) ' +
      'under a name: it then appears among the systems, and runs, compares and sweeps like a preset.'),
    saveSummary,
    h('div', { class: 'row' },
      fields.fieldBlock('saved.name', 'System name', savedName, 'Lowercase letters, digits and -; no preset’s name.'),
      fields.fieldBlock('saved.description', 'Description', savedDesc, 'One line for the system picker.')),
    h('div', { class: 'actions' }, saveBtn,
      h('label', { for: importIn.id, class: 'import-system' }, 'Import a system file ', importIn), exportLink),
    saveStatus);

  root.append(form, ownBox,
    h('section', { class: 'paper-box', 'aria-labelledby': 'paper-h' },
      h('h2', { id: 'paper-h' }, 'Full reproduction'),
      h('p', {}, `The paper’s four systems, each with its published configurations, ${PAPER_SEEDS} seeds × ${PAPER_EPISODES} episodes.`),
      paperBtn, paperStatus));
  if (!params.clone) fields.applyPreset(); // a clone's fields were filled from its job above
  fields.updateBudget();
  return null;
}
