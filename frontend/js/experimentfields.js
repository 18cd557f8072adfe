// The fields of one experiment (system preset, configurations, seeds, episodes, every parameter),
// built from GET /api/systems, shared by the new-experiment and new-study forms. The server
// validates; its 422 messages are shown beside the inputs named by each error's field path.

import { h, nextId, debounce } from './ui.js';
import { fieldErrors, changedParams, ownWords, workBudget, workText } from './stats.js';
import { fmtParam } from './studydata.js';
import { groupTitle } from './jobconfig.js';
import { argumentForms, argumentOf, argumentProblem, compareArguments, families, fmtBytes, labelFor, literalLabels, memoryOf, memoryPerChild, readArguments, ready, sortLabels, validText } from './algorithms.js';

/** sessionStorage key of the experiment the new-experiment form hands to the new-study form. */
export const STUDY_DRAFT = 'mgrao-study-draft';

export function rangeText(p) {
  if (p.kind === 'list' || p.kind === 'events') {
    const items = p.max_items === null || p.max_items === undefined ? `at least ${p.min_items}` : `${p.min_items} to ${p.max_items}`;
    const each = p.kind === 'list' ? `, each ${p.item_kind === 'int' ? 'a whole number' : 'a number'} in ${rangeText({ ...p, kind: p.item_kind })}` : '';
    return `${items} ${p.kind === 'list' ? 'items' : 'events'}${each}`;
  }
  if (p.kind === 'choice') return `one of ${p.choices.join(', ')}`;
  if (p.kind === 'bool') return 'on or off';
  const lo = p.minimum === null || p.minimum === undefined ? '−∞' : p.minimum;
  const hi = p.maximum === null || p.maximum === undefined ? '∞' : p.maximum;
  return `range ${p.exclusive_minimum ? '(' : '['}${lo}, ${hi}]`;
}

/** The field path of a form's argument box (`algorithms:mgrao-{x}:1`): where its refused labels are shown. */
export function argumentPath(form) {
  return `algorithms:${form.template}`;
}

/** A form's template as people read it: `mgrao-<x>:1`, `mgrao-<x>:<y>`. */
export function templateText(form) {
  const text = form.template.replace(`{${form.argument}}`, `<${form.argument}>`);
  return form.second_argument ? text.replace(`{${form.second_argument}}`, `<${form.second_argument}>`) : text;
}

/** The name of a form's values as typed: `x`, or `x:y` for a form of two arguments. */
export function argumentName(form) {
  return form.second_argument ? `${form.argument}:${form.second_argument}` : form.argument;
}

/** A scalar input for one parameter (or one field of an event): a select, a checkbox or a number box. */
function scalarInput(p, name) {
  if (p.kind === 'choice') return h('select', { name }, p.choices.map((c) => h('option', { value: c }, c)));
  if (p.kind === 'bool') return h('input', { type: 'checkbox', name });
  return h('input', { type: 'number', name, step: p.kind === 'int' ? 1 : 'any',
    min: p.minimum ?? undefined, max: p.maximum ?? undefined, placeholder: p.nullable ? 'auto' : undefined });
}

/** A scalar input's value as the API takes it ('' of a number goes to the server, which explains). */
function scalarValue(p, input) {
  if (p.kind === 'bool') return input.checked;
  const raw = input.value.trim();
  if (p.kind === 'choice') return raw;
  if (raw === '') return p.nullable ? null : raw;
  return Number.isFinite(Number(raw)) ? Number(raw) : raw;
}

function setScalar(p, input, value) {
  if (p.kind === 'bool') input.checked = Boolean(value);
  else input.value = value === null || value === undefined ? '' : String(value);
}

/** A `list` parameter's input: numbers separated by commas; `get()` gives the list (an item that is no number as typed). */
export function listInput(p) {
  const input = h('input', { type: 'text', name: p.name, class: 'list-values', placeholder: 'e.g. 1, 2, 4', inputmode: 'decimal' });
  const get = () => input.value.split(',').map((x) => x.trim()).filter((x) => x !== '')
    .map((x) => (x !== '' && Number.isFinite(Number(x)) ? Number(x) : x));
  const set = (value) => { input.value = Array.isArray(value) ? value.join(', ') : ''; };
  return { control: input, get, set };
}

/**
 * An `events` parameter's editor: a row per event with an input per field of `p.fields` (their kinds and
 * limits from the schema), a button to remove each row and one to add a row (at most `p.max_items`).
 * `get()` gives the events as the API takes them (a number field left empty is left out: its default applies).
 */
export function eventsInput(p) {
  const rows = [];
  const body = h('tbody');
  const add = h('button', { type: 'button', class: 'small secondary add-event' }, 'Add an event');
  const control = h('div', { class: 'event-list', role: 'group', tabindex: '-1', dataset: { param: p.name } },
    h('table', { class: 'event-table' },
      h('thead', {}, h('tr', {}, p.fields.map((f) => h('th', { scope: 'col', title: f.help }, f.name)), h('th', {}, h('span', { class: 'visually-hidden' }, 'remove')))),
      body),
    add);
  const refresh = () => {
    rows.forEach((row, i) => {
      for (const { f, input } of row.inputs) {
        input.dataset.field = `params.${p.name}[${i}].${f.name}`;
        input.setAttribute('aria-label', `${p.name} ${i + 1}: ${f.name}`);
      }
      row.remove.setAttribute('aria-label', `Remove ${p.name} ${i + 1}`);
    });
    add.disabled = p.max_items !== null && p.max_items !== undefined && rows.length >= p.max_items;
  };
  const addRow = (event = {}) => {
    const inputs = p.fields.map((f) => {
      const input = scalarInput(f, `${p.name}.${f.name}`);
      setScalar(f, input, f.name in event ? event[f.name] : f.default);
      return { f, input };
    });
    const remove = h('button', { type: 'button', class: 'small secondary remove-event' }, '×');
    const tr = h('tr', {}, inputs.map(({ input }) => h('td', {}, input)), h('td', {}, remove));
    const row = { tr, inputs, remove };
    remove.addEventListener('click', () => {
      rows.splice(rows.indexOf(row), 1);
      tr.remove();
      refresh();
      control.dispatchEvent(new Event('input', { bubbles: true }));
    });
    rows.push(row);
    body.append(tr);
    refresh();
  };
  add.addEventListener('click', () => {
    addRow();
    control.dispatchEvent(new Event('input', { bubbles: true }));
    rows[rows.length - 1].inputs[0]?.input.focus();
  });
  const get = () => rows.map((row) => {
    const event = {};
    for (const { f, input } of row.inputs) {
      const value = scalarValue(f, input);
      if (value !== '') event[f.name] = value;
    }
    return event;
  });
  const set = (value) => {
    rows.splice(0).forEach((row) => row.tr.remove());
    for (const event of Array.isArray(value) ? value : []) addRow(event);
    refresh();
  };
  return { control, get, set };
}

/**
 * The experiment's inputs. The configurations' pickers are built from `fams`, the algorithm
 * registry (GET /api/algorithms, algorithms.js `families()`, its literal labels described): a box
 * per literal label, a field of values per form with an argument, checked against the values the
 * registry gives for the chosen system and parent count. `decorate(p, block)` may add controls to
 * each parameter's block (the new-study form adds "sweep"). Returns the parts, `read()` →
 * {system, algorithms, seeds, episodes, params} or {invalidArguments}, and error display helpers
 * keyed by field path.
 */
export function experimentFields(schema, params, { decorate = null, seeds = 3, fams = [] } = {}) {
  const knownParams = new Set(schema.parameters.map((p) => p.name));
  const literals = sortLabels(literalLabels(fams));
  const errorEls = new Map(); // field path -> {input, error}
  const presetListeners = [];

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

  // --- preset, or a saved system (a base preset and overrides: GET /api/systems' `saved`) -------
  const asChoice = (saved) => ({ name: saved.name, base: saved.base, overrides: saved.params, params: saved.resolved,
    algorithms: saved.algorithms, description: saved.description || `Saved: ${saved.base} with ${Object.keys(saved.params).join(', ') || 'no changes'}.` });
  const choices = [...schema.systems, ...(schema.saved || []).map(asChoice)];
  const savedGroup = h('optgroup', { label: 'Saved systems' }, (schema.saved || []).map((s) =>
    h('option', { value: s.name, selected: s.name === params.system }, `${s.name} (${s.base})`)));
  const systemSel = h('select', { name: 'system' }, schema.systems.map((s) =>
    h('option', { value: s.name, selected: s.name === (params.system || 'single') }, s.name)), savedGroup);
  savedGroup.hidden = !savedGroup.children.length;
  const systemDesc = h('p', { class: 'help', id: nextId('sysdesc') });

  // --- algorithms: a box per literal label, a field of values per form with an argument ------
  const algoBoxes = literals.map((a) => h('input', { type: 'checkbox', name: 'algorithms', value: a, id: nextId('algo') }));
  const algoErr = h('span', { class: 'field-error', id: nextId('algoerr'), 'aria-live': 'polite' });
  const argumentFields = argumentForms(fams).map(({ family, form }) => {
    const input = h('input', { type: 'text', name: `${family}-${argumentName(form)}`, class: 'argument-values',
      placeholder: form.second_argument ? 'e.g. 5:2, 10:4' : 'e.g. 2, 5', id: nextId('arg'),
      dataset: { template: form.template, field: argumentPath(form) } });
    const check = h('small', { class: 'help argument-check', id: nextId('argcheck'), 'aria-live': 'polite' });
    const error = h('span', { class: 'field-error', id: nextId('argerr'), 'aria-live': 'polite' });
    input.setAttribute('aria-describedby', `${input.id}-help ${check.id} ${error.id} ${algoErr.id}`);
    const block = h('div', { class: 'field' },
      h('label', { for: input.id }, `Values of ${argumentName(form)} in ${templateText(form)}`), input,
      h('small', { class: 'help', id: `${input.id}-help` },
        `Comma separated; each adds a configuration ${templateText(form)}: ${form.description}.`),
      check, error);
    errorEls.set(argumentPath(form), { input, error }); // a label of this form that is refused: marked here alone
    return { form, input, check, block };
  });
  errorEls.set('algorithms', { input: algoBoxes[0] || argumentFields[0]?.input, error: algoErr });
  const algoFieldset = h('fieldset', { class: 'algos', dataset: { for: 'algorithms' }, 'aria-describedby': algoErr.id },
    h('legend', {}, 'Configurations'),
    h('div', { class: 'checks' }, algoBoxes.map((cb) => h('label', { class: 'check', for: cb.id }, cb, ' ', cb.value,
      h('small', { class: 'memory', dataset: { label: cb.value } })))),
    argumentFields.map((f) => f.block),
    algoErr);

  const seedsIn = h('input', { type: 'number', name: 'seeds', min: 1, max: schema.limits.max_seeds, step: 1, value: seeds, inputmode: 'numeric' });
  const episodesIn = h('input', { type: 'number', name: 'episodes', min: 1, max: schema.limits.max_episodes, step: 1, value: 100, inputmode: 'numeric' });

  // --- advanced parameters ------------------------------------------------------------------
  const paramInputs = new Map();
  const groups = {};
  for (const p of schema.parameters) (groups[p.group] ||= []).push(p);
  const advanced = h('details', { class: 'advanced' }, h('summary', {}, 'Advanced: every parameter'),
    h('p', { class: 'help' }, 'Prefilled with the chosen preset’s values. Only values you change are sent as overrides.'),
    Object.entries(groups).map(([group, ps]) => h('fieldset', { class: 'param-group' }, h('legend', {}, groupTitle(group, schema.group_titles)),
      ps.map((p) => {
        const sequence = p.kind === 'list' ? listInput(p) : p.kind === 'events' ? eventsInput(p) : null;
        const input = sequence ? sequence.control : scalarInput(p, p.name);
        paramInputs.set(p.name, sequence ? { p, input, get: sequence.get, set: sequence.set } : { p, input });
        const def = p.default === null ? 'auto' : p.kind === 'bool' ? (p.default ? 'on' : 'off')
          : Array.isArray(p.default) ? (p.default.length ? JSON.stringify(p.default) : 'none') : p.default;
        const block = fieldBlock(`params.${p.name}`, p.name, input, `${p.help} Default ${def}; ${rangeText(p)}${p.nullable ? '; empty = auto' : ''}.`);
        if (decorate && !sequence) decorate(p, block, input); // a list or event list is held fixed (never swept)
        return block;
      }))));

  function preset() {
    return choices.find((s) => s.name === systemSel.value) || schema.systems[0];
  }

  /** A system just saved (POST /api/systems/saved's answer): in the picker, chosen. */
  function addSaved(saved) {
    const choice = asChoice(saved);
    choices.push(choice);
    savedGroup.append(h('option', { value: saved.name }, `${saved.name} (${saved.base})`));
    savedGroup.hidden = false;
    systemSel.value = saved.name;
    applyPreset();
  }

  /** What the form holds as a saved system's definition: the base preset and every value that differs from it. */
  function definition() {
    const chosen = preset();
    const base = chosen.base || chosen.name;
    const basePreset = schema.systems.find((s) => s.name === base);
    return { base, params: changedParams(rawParams(), basePreset.params) };
  }

  // --- the values valid for the system beside each argument field, as n_parents changes -----
  let described = Promise.resolve(); // the typed labels' descriptions, on their way
  const validListeners = [];
  let systemFams = fams; // the registry for the chosen system and parent count (the grammar's until it comes)
  let typedMemory = {}; // the memory per child of typed labels the registry's examples leave out, for that system
  let asked = 0;
  /** The form's values of the parameters that differ from the chosen system's, each within its own limits. */
  function validOverrides() {
    const out = {};
    for (const [name, value] of Object.entries(readParams())) {
      const p = paramInputs.get(name)?.p;
      const number = (p?.kind === 'int' || p?.kind === 'float') && value !== null;
      if (number && (!Number.isFinite(Number(value)) || Number(value) < p.minimum || Number(value) > p.maximum
        || (p.kind === 'int' && !Number.isInteger(Number(value))))) continue; // its own error says so on submit
      out[name] = value;
    }
    return out;
  }
  /** The form of `template` as the registry gives it for the chosen system (its valid values). */
  function currentForm(template) {
    return argumentForms(systemFams).map((f) => f.form).find((form) => form.template === template)
      || argumentForms(fams).map((f) => f.form).find((form) => form.template === template) || null;
  }
  let memoryAsked = 0;
  function refreshArgumentChecks() {
    const memory = { ...memoryPerChild(systemFams), ...typedMemory }; // when the registry gives it (with a system)
    const perChild = (label) => (Number.isFinite(memory[label]) ? `${fmtBytes(memory[label])} per child` : '');
    for (const el of algoFieldset.querySelectorAll('small.memory')) {
      el.textContent = perChild(el.dataset.label) ? ` (${perChild(el.dataset.label)})` : '';
    }
    const labels = [];
    for (const f of argumentFields) {
      const form = currentForm(f.form.template);
      const { values } = readArguments(f.input.value, form);
      const problems = values.map((v) => argumentProblem(form, v)).filter(Boolean);
      labels.push(...values.filter((v) => !argumentProblem(form, v)).map((v) => labelFor(form, v)));
      const sizes = values.map((v) => labelFor(form, v)).filter(perChild).map((l) => `${l} ${perChild(l)}`);
      f.check.textContent = validText(form) +
        (sizes.length ? ` Memory: ${sizes.join(', ')}.` : '') + (problems.length ? ` ${problems.join(' ')}` : '');
      f.check.classList.toggle('warn', problems.length > 0);
    }
    described = ready(labels); // their order among the configurations
    const unknown = labels.filter((l) => !Number.isFinite(memory[l]));
    if (unknown.length && systemFams !== fams) { // typed labels the registry's examples leave out (mgrao-5:2)
      const mine = ++memoryAsked;
      memoryOf(unknown, preset().name, validOverrides()).then((bytes) => {
        if (mine !== memoryAsked || !Object.keys(bytes).length) return;
        typedMemory = { ...typedMemory, ...bytes };
        refreshArgumentChecks();
      });
    }
  }
  async function refreshValid() {
    const mine = ++asked;
    try {
      const got = await families(preset().name, validOverrides()); // a saved system's, with the form's changes
      if (mine !== asked) return;
      systemFams = got;
      typedMemory = {};
    } catch { /* unreachable: the server checks the values on submit */ }
    refreshArgumentChecks();
    for (const listener of validListeners) listener();
  }
  for (const f of argumentFields) f.input.addEventListener('input', refreshArgumentChecks);
  const refreshSoon = debounce(refreshValid, 150); // the valid x and the memory follow every parameter
  for (const { input } of paramInputs.values()) {
    input.addEventListener('input', refreshSoon);
    input.addEventListener('change', refreshSoon);
  }

  // --- letters in a number field: say the range at once (the browser reads them as empty) ---
  const numberRanges = [[seedsIn, `a whole number from 1 to ${schema.limits.max_seeds}`],
    [episodesIn, `a whole number from 1 to ${schema.limits.max_episodes}`],
    ...[...paramInputs.values()].filter(({ p }) => p.kind === 'int' || p.kind === 'float')
      .map(({ p, input }) => [input, `a number, ${rangeText(p)}`])];
  for (const [input, range] of numberRanges) {
    input.addEventListener('input', () => {
      const target = [...errorEls.values()].find((e) => e.input === input);
      if (!target) return;
      const outside = input.validity.rangeUnderflow || input.validity.rangeOverflow || input.validity.stepMismatch;
      if (input.validity.badInput || outside) {
        target.error.textContent = input.validity.badInput ? `Not a number: must be ${range}.`
          : `Must be ${range} (got ${input.value}).`;
        target.error.dataset.local = '1';
        input.setAttribute('aria-invalid', 'true');
      } else if (target.error.dataset.local) {
        target.error.textContent = '';
        delete target.error.dataset.local;
        input.removeAttribute('aria-invalid');
      }
    });
  }

  // --- changing the preset keeps the parameters the user changed, and says so ----------------
  let shownPreset = null;
  const keptNote = h('p', { class: 'help kept-edits', id: nextId('kept'), 'aria-live': 'polite' });
  function edits() {
    return shownPreset ? changedParams(rawParams(), shownPreset.params) : {};
  }
  systemSel.addEventListener('change', () => {
    const mine = edits();
    applyPreset();
    const now = preset().params;
    const kept = Object.entries(mine).filter(([name, v]) => paramInputs.has(name) && name in changedParams({ [name]: v }, now));
    for (const [name, value] of kept) setParam(name, value);
    refreshValid();
    if (!kept.length) { keptNote.replaceChildren(); return; }
    keptNote.replaceChildren(`Kept your changes on the ${preset().name} preset: ${kept.map(([n, v]) => `${n} ${fmtParam(v)}`).join(', ')}. `,
      h('button', { type: 'button', class: 'small secondary', onclick: () => { applyPreset(); keptNote.replaceChildren(); } },
        'Use the preset’s values'));
  });

  function setParam(name, value) {
    const entry = paramInputs.get(name);
    if (entry.set) entry.set(value);
    else setScalar(entry.p, entry.input, value);
  }

  function applyPreset() {
    const s = preset();
    shownPreset = s;
    systemDesc.textContent = s.description;
    showAlgorithms(s.algorithms);
    for (const { p } of paramInputs.values()) setParam(p.name, s.params[p.name]);
    refreshValid();
    for (const listener of presetListeners) listener(s);
  }

  /** Tick the literal labels among `labels` and put the others' arguments in their forms' fields. */
  function showAlgorithms(labels) {
    for (const cb of algoBoxes) cb.checked = labels.includes(cb.value);
    const rest = labels.filter((a) => !literals.includes(a));
    for (const f of argumentFields) {
      f.input.value = rest.map((a) => argumentOf(f.form, a)).filter((v) => v !== null).join(', ');
    }
  }

  /** Every parameter input's value as the API takes it. */
  function rawParams() {
    const values = {};
    for (const { p, input, get } of paramInputs.values()) {
      if (get) { values[p.name] = get(); continue; }
      if (p.kind === 'bool') { values[p.name] = input.checked; continue; }
      const raw = input.value.trim();
      if (p.kind === 'choice') values[p.name] = raw;
      else if (raw === '') values[p.name] = p.nullable ? null : raw; // '' goes to the server, which explains
      else values[p.name] = Number(raw);
    }
    return values;
  }

  function readParams() {
    return changedParams(rawParams(), preset().params);
  }

  /**
   * Fill the inputs from an experiment as read() gives it (the preset first, then its changes). Its `system` is
   * a preset or a saved system; `base`, if given, is taken where that system is no longer among the choices (a
   * saved system deleted since). Returns the system chosen, or null (neither is).
   */
  function load(experiment) {
    const system = [experiment && experiment.system, experiment && experiment.base]
      .find((name) => name && choices.some((s) => s.name === name));
    if (!system) return null;
    systemSel.value = system;
    applyPreset();
    if (Array.isArray(experiment.algorithms)) showAlgorithms(experiment.algorithms);
    if (experiment.seeds !== undefined) seedsIn.value = String(experiment.seeds);
    if (experiment.episodes !== undefined) episodesIn.value = String(experiment.episodes);
    for (const [name, value] of Object.entries(experiment.params || {})) {
      if (paramInputs.has(name)) setParam(name, value);
    }
    return system;
  }

  /**
   * What the argument boxes hold that is no value (`abc` in "1, abc, 3"), as errors beside their boxes
   * (`{field, msg}`, as the API's detail), in the box's own words: the server never sees them.
   */
  function argumentErrors() {
    return argumentFields.map((f) => [f, readArguments(f.input.value, f.form).invalid]).filter(([, bad]) => bad.length)
      .map(([f, bad]) => ({ field: argumentPath(f.form), local: true, msg: `${bad.join(', ')}: not ${bad.length > 1 ? 'values' : 'a value'} ` +
        `of ${argumentName(f.form)} (${f.form.second_argument ? 'type pairs of whole numbers, e.g. 5:2' : 'type whole numbers, e.g. '
        + (currentForm(f.form.template)?.valid || [2, 5]).slice(0, 2).join(', ')})` }));
  }

  /**
   * The experiment as the API takes it, the values of the argument boxes that can be read; with `invalidArguments`
   * (the tokens that cannot, their errors from argumentErrors) when some cannot.
   */
  function read() {
    const labels = algoBoxes.filter((cb) => cb.checked).map((cb) => cb.value);
    const invalid = [];
    for (const f of argumentFields) {
      const typed = readArguments(f.input.value, f.form);
      invalid.push(...typed.invalid);
      labels.push(...typed.values.sort(compareArguments).map((v) => labelFor(f.form, v)));
    }
    return {
      ...(invalid.length ? { invalidArguments: invalid } : {}),
      system: systemSel.value,
      algorithms: sortLabels(labels),
      seeds: seedsIn.value === '' ? seedsIn.value : Number(seedsIn.value),
      episodes: episodesIn.value === '' ? episodesIn.value : Number(episodesIn.value),
      params: readParams(),
    };
  }

  // --- the work budget: the product of limits.work_factors against limits.max_work (GET /api/systems) ---
  let budgetBox = null;
  const budgetText = h('p', { class: 'budget-text', id: nextId('budget') });
  const budgetErr = h('span', { class: 'field-error', id: nextId('budgeterr'), 'aria-live': 'polite' });
  const factorBlock = (path) => errorEls.get(path)?.input.closest('.field, fieldset');

  /** Show the budget as it stands and mark the fields that drive it while it is over the limit. */
  function updateBudget() {
    if (!budgetBox) return null;
    const experiment = read();
    const budget = experiment.invalidArguments ? null : workBudget(experiment, preset().params, schema.limits);
    budgetBox.classList.toggle('over', Boolean(budget && budget.over));
    budgetText.textContent = budget ? workText(budget) : `Work: fill in every field to see it against the limit of ` +
      `${schema.limits.max_work.toLocaleString('en-US')} atomic tasks per experiment.`;
    for (const name of schema.limits.work_factors || []) {
      const path = name === 'seeds' || name === 'algorithms' || name === 'episodes' ? name : `params.${name}`;
      factorBlock(path)?.classList.toggle('over-budget', Boolean(budget && budget.over));
    }
    return budget;
  }

  /** The budget line (new-experiment form): placed once, updated on every edit of `form`. */
  function budgetBlock(form) {
    budgetBox = h('div', { class: 'budget', 'data-for': 'work' }, budgetText, budgetErr);
    errorEls.set('work', { input: seedsIn, error: budgetErr });
    const soon = () => setTimeout(updateBudget, 0); // after the form's own handlers (a preset change)
    form.addEventListener('input', soon);
    form.addEventListener('change', soon);
    presetListeners.push(soon);
    return budgetBox;
  }

  function clearErrors(summary) {
    summary.replaceChildren();
    for (const { input, error } of errorEls.values()) {
      error.textContent = '';
      input.removeAttribute('aria-invalid');
      input.closest('.field, fieldset')?.classList.remove('invalid');
    }
  }

  /**
   * A refused configuration (`algorithms[3]`) as the box at fault: the argument box of its form, or its own
   * checkbox; its message without the path (it names the label). Other items as they are.
   */
  function atFault(item, labels) {
    const field = typeof item.field === 'string' ? item.field : '';
    const match = /^(?:base\.)?algorithms\[(\d+)\]$/.exec(field);
    if (!match || !labels[Number(match[1])]) return item;
    const label = labels[Number(match[1])];
    const msg = String(item.msg || '').replace(/^(?:base\.)?algorithms\[\d+\]: /, '');
    const box = argumentFields.find((f) => argumentOf(currentForm(f.form.template) || f.form, label) !== null);
    if (box) return { ...item, field: argumentPath(box.form), msg };
    const cb = algoBoxes.find((c) => c.value === label);
    return cb ? { ...item, field: `algorithms=${label}`, msg } : { ...item, msg };
  }

  /** Put each 422 message beside its input (`keyOf` maps the API's field path to ours). */
  function showErrors(err, summary, what, keyOf = (key) => key) {
    const sent = read().algorithms || [];
    for (const cb of algoBoxes) { // a refused literal label: its checkbox alone, the message under the list
      errorEls.set(`algorithms=${cb.value}`, { input: cb, error: algoErr, alone: true });
    }
    const detail = Array.isArray(err.detail) ? err.detail.map((item) => atFault(item, sent)) : err.detail;
    const byField = fieldErrors(detail, knownParams);
    const unplaced = [];
    let first = null;
    for (const [apiPath, msg] of Object.entries(byField)) {
      const path = keyOf(apiPath);
      const target = errorEls.get(path) || errorEls.get(path.replace(/\[\d+\]$/, '')); // algorithms[3]: beside the list
      if (!target) { unplaced.push(ownWords(path, msg)); continue; }
      const words = ownWords(path, msg);
      target.error.textContent = target.error.textContent ? `${target.error.textContent}; ${words}` : words;
      target.input.setAttribute('aria-invalid', 'true');
      if (!target.alone) target.input.closest('.field, fieldset')?.classList.add('invalid');
      if (path.startsWith('params.') || path.startsWith('space.')) advanced.open = true;
      first ||= target.input;
    }
    if (budgetBox && Object.keys(byField).some((key) => keyOf(key) === 'work')) { // over a work limit: mark what drives it
      for (const name of schema.limits.work_factors || []) {
        const path = name === 'seeds' || name === 'algorithms' || name === 'episodes' ? name : `params.${name}`;
        const block = factorBlock(path);
        block?.classList.add('invalid');
        errorEls.get(path)?.input.setAttribute('aria-invalid', 'true');
      }
    }
    const msgs = Object.keys(byField).length ? unplaced : [err.message];
    const placed = Object.keys(byField).length - unplaced.length;
    const refused = (Array.isArray(detail) && detail.some((item) => !item.local)) ? `The server rejected the ${what}`
      : `The ${what} was not started`; // a box's unreadable values never reach the server
    const lead = !Object.keys(byField).length ? `The ${what} could not be started.`
      : (placed ? `${refused}; see the marked fields${unplaced.length ? ', and:' : '.'}`
        : `${refused}:`); // "see the marked fields" only where a field is marked
    const box = h('div', { class: 'notice error', role: 'alert', tabindex: '-1' },
      h('p', {}, err.lead || lead),
      msgs.length ? h('ul', {}, msgs.map((m) => h('li', {}, m))) : null);
    summary.replaceChildren(box);
    if (first && !unplaced.length) first.focus();
    else { // an error of no field (or beside the fields, one of none): brought into view and focused, not left above
      box.scrollIntoView({ block: 'center' });
      box.focus({ preventScroll: true });
    }
  }

  return {
    fieldBlock, errorEls, systemSel, systemDesc, algoFieldset, algoBoxes, argumentFields, seedsIn, episodesIn, advanced,
    paramInputs, preset, applyPreset, read, argumentErrors, load, addSaved, definition, clearErrors, showErrors, keptNote, budgetBlock, updateBudget,
    currentForm, described: () => described, onValid: (listener) => validListeners.push(listener),
    onPreset: (listener) => presetListeners.push(listener),
  };
}
