// New study form: the new-experiment form's fields (js/experimentfields.js), where any parameter
// can be ticked to sweep (a range prefilled from the schema, or a list of values), plus the group
// count (the argument of the label form GET /api/systems names as studies.group_label) and the
// children sharing one model (the second argument of the form it names as studies.team_label), the
// method, the budget and the objective. The server validates; its 422
// messages appear beside the fields they name (space.<name>, base.*, objective.*).

import { api } from './api.js';
import { h, notice, nextId } from './ui.js';
import { experimentFields, STUDY_DRAFT, templateText } from './experimentfields.js';
import { argumentForms, families, labelFor, literalLabels, ready } from './algorithms.js';
import { defaultSweep, gridPoints, parseValues, studyBody, studyFieldKey, fmtParam } from './studydata.js';

const METHOD_HELP = {
  grid: 'Every combination of the swept values, each run once.',
  random: 'Points drawn at random from the ranges (log-uniform for log ranges), up to the trial budget.',
  tpe: 'Optuna’s TPE sampler proposes each point from the trials so far, up to the trial budget.',
};
/** The metrics' names; % of max is of the reference configuration (GET /api/systems, algorithms.reference). */
const metricNames = (reference) => ({
  final_mean: 'final mean utility',
  pct_from_uniform: '% from uniform',
  pct_of_max: `% of ${reference}`,
  paper_deviation: 'worst deviation from the paper’s figures',
});

export async function mount(root, params, ctx) {
  root.append(h('h1', {}, 'New study'));
  let schema;
  let fams;
  try {
    [schema, fams] = await Promise.all([api.systems(), families()]);
    await ready(literalLabels(fams));
  } catch (e) {
    root.append(notice('error', `Cannot load the systems: ${e.message}`));
    return null;
  }
  const limits = schema.studies;
  const METRICS = metricNames(schema.algorithms.reference);
  // the label form whose argument a study's `groups` dimension sweeps (its label with the argument's name)
  const groupForm = argumentForms(fams).map((f) => f.form).find((form) => labelFor(form, form.argument) === limits.group_label);
  // the label form whose second argument a study's `team_size` dimension sweeps
  const teamForm = argumentForms(fams).map((f) => f.form).find((form) => form.second_argument
    && labelFor(form, `${form.argument}:${form.second_argument}`) === limits.team_label);
  const sweeps = new Map(); // parameter name -> {p, box, read(), points()}
  const errorTargets = []; // the sweep editors' error places, registered once the fields exist
  const summary = h('div', { class: 'error-summary', id: nextId('summary'), 'aria-live': 'assertive' });

  // --- sweep editors --------------------------------------------------------------------
  function sweepEditor(p, input, path) {
    const box = h('div', { class: 'sweep', hidden: true });
    const modeSel = h('select', { id: nextId('mode'), 'aria-label': `${p.name}: range or values` },
      h('option', { value: 'range' }, 'range'), h('option', { value: 'values' }, 'values'));
    const lowIn = h('input', { type: 'number', step: 'any', id: nextId('low'), 'aria-label': `${p.name} from` });
    const highIn = h('input', { type: 'number', step: 'any', id: nextId('high'), 'aria-label': `${p.name} to` });
    const stepsIn = h('input', { type: 'number', min: 2, max: limits.max_steps, step: 1, id: nextId('steps'), 'aria-label': `${p.name} steps` });
    const logCb = h('input', { type: 'checkbox', id: nextId('log') });
    const valuesIn = h('input', { type: 'text', id: nextId('values'), 'aria-label': `${p.name} values`, placeholder: 'comma separated' });
    const error = h('span', { class: 'field-error', 'aria-live': 'polite' });
    const rangeRow = h('div', { class: 'sweep-row' }, 'from', lowIn, 'to', highIn,
      h('span', { class: 'steps-part' }, 'in', stepsIn, 'steps'), h('label', { class: 'check', for: logCb.id }, logCb, ' log'));
    const valuesRow = h('div', { class: 'sweep-row' }, valuesIn);
    const numeric = p.kind === 'int' || p.kind === 'float';
    if (!numeric) modeSel.disabled = true;
    box.append(h('div', { class: 'sweep-row' }, h('label', { for: modeSel.id }, 'Sweep over'), modeSel), rangeRow, valuesRow, error);
    errorTargets.push([path, { input: lowIn, error }]);
    const show = () => {
      const values = !numeric || modeSel.value === 'values';
      rangeRow.hidden = values;
      valuesRow.hidden = !values;
      rangeRow.querySelector('.steps-part').hidden = methodSel.value !== 'grid';
      updateSize();
    };
    const prefill = () => {
      const current = p.kind === 'bool' ? input.checked : input.value === '' ? p.default : Number(input.value);
      const d = defaultSweep(p, current);
      if (d.values) {
        modeSel.value = 'values';
        valuesIn.value = d.values.map((v) => (typeof v === 'boolean' ? (v ? 'on' : 'off') : v)).join(', ');
      } else {
        modeSel.value = 'range';
        lowIn.value = String(d.low);
        highIn.value = String(d.high);
        stepsIn.value = String(d.steps);
        logCb.checked = d.log;
        valuesIn.value = [d.low, d.high].map(fmtParam).join(', ');
      }
      show();
    };
    for (const el of [modeSel, lowIn, highIn, stepsIn, logCb, valuesIn]) el.addEventListener('input', show);
    modeSel.addEventListener('change', show);
    return {
      p, box, prefill, show,
      read() {
        if (modeSel.value === 'values' || !numeric) {
          const parsed = parseValues(valuesIn.value, p.kind);
          return { name: p.name, mode: 'values', values: parsed.values, invalid: parsed.invalid };
        }
        const num = (el) => (el.value === '' ? el.value : Number(el.value));
        return { name: p.name, mode: 'range', low: num(lowIn), high: num(highIn), steps: num(stepsIn), log: logCb.checked };
      },
      points() {
        const row = this.read();
        return row.mode === 'values' ? row.values.length : gridPoints(row);
      },
    };
  }

  const fields = experimentFields(schema, params, {
    seeds: 10,
    fams,
    decorate(p, block, input) {
      const path = `space.${p.name}`;
      const tick = h('input', { type: 'checkbox', id: nextId('sweep'), dataset: { sweep: p.name } });
      const editor = sweepEditor(p, input, path);
      tick.addEventListener('change', () => {
        editor.box.hidden = !tick.checked;
        input.disabled = tick.checked;
        if (tick.checked) { sweeps.set(p.name, editor); editor.prefill(); } else sweeps.delete(p.name);
        updateObjective();
        updateSize();
      });
      block.classList.add('sweepable');
      block.append(h('label', { class: 'check sweep-tick', for: tick.id }, tick, ' sweep'), editor.box);
    },
  });

  for (const [path, target] of errorTargets) fields.errorEls.set(path, target);

  // --- the group count, systems, search, objective ---------------------------------------
  const groupsTick = h('input', { type: 'checkbox', id: nextId('groups') });
  const groupsIn = h('input', { type: 'text', id: nextId('gvals'), placeholder: 'e.g. 2, 5' });
  const groupsErr = h('span', { class: 'field-error', 'aria-live': 'polite' });
  const groupsHelp = h('small', { class: 'help' });
  fields.errorEls.set('space.groups', { input: groupsIn, error: groupsErr });
  const groupsBox = h('fieldset', { class: 'groups-sweep', hidden: !groupForm }, h('legend', {}, 'Group count'),
    h('label', { class: 'check', for: groupsTick.id }, groupsTick,
      groupForm ? ` sweep ${groupForm.argument} of ${templateText(groupForm)} (adds that configuration to each trial)` : ''),
    h('div', { class: 'field', hidden: true }, h('label', { for: groupsIn.id }, `Values of ${groupForm ? groupForm.argument : ''}`), groupsIn, groupsHelp, groupsErr));
  const groupsField = groupsBox.querySelector('.field');
  const validGroups = () => (groupForm && fields.currentForm(groupForm.template)?.valid) || [];
  const refreshGroupsHelp = () => {
    groupsHelp.textContent = groupForm ? `Valid ${groupForm.argument} here: ${validGroups().join(', ')}.` : '';
  };
  groupsTick.addEventListener('change', () => {
    groupsField.hidden = !groupsTick.checked;
    if (groupsTick.checked && !groupsIn.value) {
      const valid = validGroups();
      const inner = valid.slice(1, -1); // neither end of the valid values
      groupsIn.value = (inner.length ? inner : valid.slice(0, 1)).join(', ');
    }
    refreshGroupsHelp();
    updateObjective();
    updateSize();
  });
  groupsIn.addEventListener('input', updateSize);

  // the children sharing one model: y of mgrao-x:y (x from the group count's sweep, else 1)
  const teamTick = h('input', { type: 'checkbox', id: nextId('team') });
  const teamIn = h('input', { type: 'text', id: nextId('tvals'), placeholder: 'e.g. 2, 4' });
  const teamErr = h('span', { class: 'field-error', 'aria-live': 'polite' });
  const teamHelp = h('small', { class: 'help' });
  fields.errorEls.set('space.team_size', { input: teamIn, error: teamErr });
  const teamBox = h('fieldset', { class: 'team-sweep', hidden: !teamForm }, h('legend', {}, 'Children sharing one model'),
    h('label', { class: 'check', for: teamTick.id }, teamTick,
      teamForm ? ` sweep ${teamForm.second_argument} of ${templateText(teamForm)} (with the group count’s ${teamForm.argument}, else 1; adds that configuration to each trial)` : ''),
    h('div', { class: 'field', hidden: true }, h('label', { for: teamIn.id }, `Values of ${teamForm ? teamForm.second_argument : ''}`), teamIn, teamHelp, teamErr));
  const teamField = teamBox.querySelector('.field');
  const validTeams = () => [1, ...((teamForm && fields.currentForm(teamForm.template)?.second_valid) || [])];
  const refreshTeamHelp = () => {
    teamHelp.textContent = teamForm ? `Valid ${teamForm.second_argument} here: ${validTeams().join(', ')} (1: each child its own).` : '';
  };
  teamTick.addEventListener('change', () => {
    teamField.hidden = !teamTick.checked;
    if (teamTick.checked && !teamIn.value) teamIn.value = validTeams().slice(0, 2).join(', ');
    refreshTeamHelp();
    updateObjective();
    updateSize();
  });
  teamIn.addEventListener('input', updateSize);

  // every preset, then every saved system (the server inlines a saved one into the study when it is made)
  const alsoChoices = [...schema.systems.map((s) => [s.name, s.name]),
    ...(schema.saved || []).map((s) => [s.name, `${s.name} (saved, ${s.base})`])];
  const alsoBoxes = alsoChoices.map(([name, label]) =>
    h('input', { type: 'checkbox', value: name, id: nextId('also'), dataset: { label } }));
  const alsoErr = h('span', { class: 'field-error', 'aria-live': 'polite' });
  fields.errorEls.set('system', { input: fields.systemSel, error: alsoErr });
  const alsoBox = h('fieldset', {}, h('legend', {}, 'Run every trial on'),
    h('div', { class: 'checks' }, alsoBoxes.map((cb) => h('label', { class: 'check', for: cb.id }, cb, ' ', cb.dataset.label))),
    h('small', { class: 'help' }, 'The chosen system, and any others, presets or saved systems: each trial is then a job per system, each with its own preset’s configurations (a saved system’s changes on top); the paper’s deviation (paper presets only) is the worst over them, other objectives read the chosen system.'),
    alsoErr);
  const syncSystems = () => {
    for (const cb of alsoBoxes) {
      if (cb.value === fields.systemSel.value) { cb.checked = true; cb.disabled = true; } else cb.disabled = false;
    }
  };
  fields.onPreset(() => { syncSystems(); refreshGroupsHelp(); refreshTeamHelp(); updateObjective(); });
  fields.onValid(() => { refreshGroupsHelp(); refreshTeamHelp(); }); // the system's valid values have come

  const methodSel = h('select', { name: 'method' }, limits.methods.map((m) => h('option', { value: m, selected: m === (params.method || 'grid') }, m)));
  const methodHelp = h('small', { class: 'help' });
  const trialsIn = h('input', { type: 'number', name: 'max_trials', min: 1, max: limits.max_trials, step: 1, value: 100 });
  const flightIn = h('input', { type: 'number', name: 'max_in_flight', min: 1, max: limits.max_in_flight, step: 1, value: 4 });
  const seedIn = h('input', { type: 'number', name: 'seed', min: 0, step: 1, value: 0 });
  const sizeNote = h('p', { class: 'grid-size', 'aria-live': 'polite' });
  methodSel.addEventListener('change', () => { for (const e of sweeps.values()) e.show(); updateSize(); });

  const metricSel = h('select', { name: 'metric' }, limits.metrics.map((m) => h('option', { value: m, selected: m === 'pct_from_uniform' }, METRICS[m] || m)));
  const configSel = h('select', { name: 'configuration' });
  const directionSel = h('select', { name: 'direction' }, ['maximize', 'minimize'].map((d) => h('option', { value: d }, d)));
  metricSel.addEventListener('change', () => {
    directionSel.value = metricSel.value === 'paper_deviation' ? 'minimize' : 'maximize';
    updateObjective();
  });
  for (const cb of fields.algoBoxes) cb.addEventListener('change', updateObjective);
  for (const f of fields.argumentFields) f.input.addEventListener('input', updateObjective);

  function updateObjective() {
    const base = fields.read();
    const labels = base.algorithms ? base.algorithms.slice() : [];
    if (teamTick.checked) labels.push(limits.team_label);
    else if (groupsTick.checked) labels.push(limits.group_label);
    const reference = schema.algorithms.reference; // the default objective: % of max's own configuration
    const keep = configSel.value || (labels.includes(reference) ? reference : labels[labels.length - 1]);
    configSel.replaceChildren(...labels.map((l) => h('option', { value: l, selected: l === keep }, l)));
    configSel.disabled = metricSel.value === 'paper_deviation';
  }

  function updateSize() {
    methodHelp.textContent = METHOD_HELP[methodSel.value] || '';
    const dims = [...sweeps.values()].map((e) => e.points());
    if (groupsTick.checked) dims.push(parseValues(groupsIn.value, 'int').values.length);
    if (teamTick.checked) dims.push(parseValues(teamIn.value, 'int').values.length);
    if (!dims.length) { sizeNote.textContent = 'Tick “sweep” beside the parameters to vary (below), or sweep the group count or the children sharing a model.'; return; }
    if (methodSel.value === 'grid') {
      const cells = dims.reduce((a, b) => a * b, 1);
      sizeNote.textContent = `Grid: ${dims.join(' × ')} = ${cells} trials${cells > limits.max_trials ? ` (over the limit of ${limits.max_trials})` : ''}.`;
      if (cells >= 1 && cells <= limits.max_trials) trialsIn.value = String(Math.max(cells, 1));
    } else {
      sizeNote.textContent = `${dims.length} dimensions; ${trialsIn.value} trials (the budget).`;
    }
  }
  trialsIn.addEventListener('input', updateSize);

  const nameIn = h('input', { type: 'text', name: 'name', maxlength: 200, placeholder: 'e.g. lr by decay' });
  const block = (path, label, control, help) => fields.fieldBlock(path, label, control, help);
  const submitBtn = h('button', { type: 'submit', class: 'primary' }, 'Start study');

  const form = h('form', { class: 'newjob newstudy', novalidate: true, 'aria-describedby': summary.id },
    summary,
    h('div', { class: 'grid2' },
      h('div', {},
        h('h2', {}, 'Base experiment'),
        block('system', 'System preset', fields.systemSel, null), fields.systemDesc, fields.keptNote,
        alsoBox,
        fields.algoFieldset,
        h('div', { class: 'row' },
          block('seeds', 'Seeds per trial', fields.seedsIn, `1 to ${schema.limits.max_seeds}; the 95% CI of each trial is over these`),
          block('episodes', 'Episodes per run', fields.episodesIn, `1 to ${schema.limits.max_episodes}`))),
      h('div', {},
        h('h2', {}, 'Search'),
        block('name', 'Name', nameIn, null),
        block('method', 'Method', methodSel, null), methodHelp,
        h('div', { class: 'row' },
          block('max_trials', 'Trial budget', trialsIn, `1 to ${limits.max_trials}; a grid runs every cell`),
          block('max_in_flight', 'Trials in flight', flightIn, `1 to ${limits.max_in_flight}`),
          block('seed', 'Sampler seed', seedIn, 'random and tpe: the same seed draws the same points')),
        h('h2', {}, 'Objective'),
        h('div', { class: 'row' },
          block('objective.metric', 'Metric', metricSel, null),
          block('objective.configuration', 'Of configuration', configSel, null),
          block('objective.direction', 'Direction', directionSel, null)),
        groupsBox,
        teamBox,
        sizeNote)),
    fields.advanced,
    h('div', { class: 'actions' }, submitBtn));
  fields.advanced.querySelector('summary').textContent = 'Parameters: tick “sweep” to vary one';
  fields.advanced.open = true;

  form.addEventListener('submit', async (ev) => {
    ev.preventDefault();
    fields.clearErrors(summary);
    const showErrors = (err) => fields.showErrors(err, summary, 'study', studyFieldKey);
    await fields.described(); // the typed configurations' order
    const { invalidArguments, ...base } = fields.read();
    const rows = [...sweeps.values()].map((e) => e.read());
    if (groupsTick.checked) {
      const parsed = parseValues(groupsIn.value, 'int');
      rows.push({ name: 'groups', mode: 'values', values: parsed.values, invalid: parsed.invalid });
    }
    if (teamTick.checked) {
      const parsed = parseValues(teamIn.value, 'int');
      rows.push({ name: 'team_size', mode: 'values', values: parsed.values, invalid: parsed.invalid });
    }
    const systems = [fields.systemSel.value, ...alsoBoxes.filter((cb) => cb.checked && cb.value !== fields.systemSel.value).map((cb) => cb.value)];
    const local = [...(invalidArguments ? fields.argumentErrors() : []),
      ...rows.filter((r) => r.invalid && r.invalid.length).map((r) => ({ field: `space.${r.name}`, local: true,
        msg: `not ${r.invalid.length > 1 ? 'values' : 'a value'}: ${r.invalid.join(', ')}` }))];
    if (local.length) { // not sent while a value cannot be read; the base experiment's own errors said with them
      let detail = [];
      try {
        const verdict = await api.checkJob({ ...base, system: systems[0] });
        detail = verdict.valid ? [] : verdict.detail;
      } catch { /* the study's own answer says the rest */ }
      showErrors({ detail: [...local, ...detail] });
      return;
    }
    const num = (el) => (el.value === '' ? el.value : Number(el.value));
    const body = studyBody({ ...base, system: systems.length > 1 ? systems : systems[0] }, rows, {
      name: nameIn.value.trim() || `${systems.join('+')}: ${rows.map((r) => r.name).join(' × ') || 'study'}`,
      method: methodSel.value, metric: metricSel.value, direction: directionSel.value,
      configuration: configSel.value, max_trials: num(trialsIn), max_in_flight: num(flightIn), seed: num(seedIn),
    });
    if (systems.length > 1) {
      delete body.base.algorithms; // each system runs its own preset's configurations
      if (body.objective.configuration) body.objective.system = systems[0];
    }
    submitBtn.disabled = true;
    submitBtn.textContent = 'Submitting…';
    try {
      const answer = await api.createStudy(body);
      ctx.navigate(`/studies/${answer.study.id}`);
    } catch (e) {
      if (e.status === 422) showErrors(e);
      else showErrors({ message: e.message, detail: null });
    } finally {
      submitBtn.disabled = false;
      submitBtn.textContent = 'Start study';
    }
  });

  root.append(h('p', { class: 'help' }, 'A study runs the base experiment once per trial, each trial with other values of the swept parameters, as ordinary jobs. ',
    h('a', { href: '/project-docs/studies.html' }, 'How studies work'), ' · ', h('a', { href: '/docs#/studies' }, 'their API')), form);
  fields.applyPreset();
  if (params.from === 'experiment') {
    try {
      const draft = JSON.parse(sessionStorage.getItem(STUDY_DRAFT) || 'null');
      if (draft) fields.load(draft);
    } catch { /* no draft */ }
  }
  syncSystems();
  updateObjective();
  updateSize();
  return null;
}
