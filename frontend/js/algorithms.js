// The algorithm registry as the server serves it (GET /api/algorithms): the one place the dashboard
// learns how labels are written, what they mean, their order and their colour slot. Nothing here
// knows a label or a family: labels are described by the server (canonical spelling, sort key,
// colour key), and the new-experiment form's pickers are built from the families' label forms
// (a literal label, or a template with an argument, its valid values and its help; a form with a
// second argument, MG-RAO's mgrao-{x}:{y}, takes its values as pairs x:y).
//
// Views that order or colour configurations first `await ready(labels)`; after that `describe`,
// `compareLabels`, `sortLabels` and `roleLabel` answer at once (colours.js, comparegroups.js and the
// views call them synchronously). A label the server could not describe sorts last, by spelling.

import { api, request } from './api.js';

const described = new Map(); // label as shown -> its description (GET /api/algorithms?label=)
const registries = new Map(); // "system|n_parents" -> Promise of the families
const memories = new Map(); // "system|overrides|label" -> Promise of its bytes per child (memoryOf)
let roles = {}; // GET /api/systems' algorithms: baseline, reference, best_fixed (labels the metrics read)
let rolesAsked = null;

/** Keep descriptions (as `?label=` answers them) for `labels`, and the roles; for views and tests. */
export function remember(descriptions, labels = null, knownRoles = null) {
  descriptions.forEach((d, i) => {
    described.set(d.label, d);
    if (labels && labels[i] !== undefined) described.set(labels[i], d);
  });
  if (knownRoles) roles = { ...roles, ...knownRoles };
}

/**
 * Keep the descriptions an answer carries (`GET /api/compare`, a job's results) for its `labels`: the
 * server described every label it could, so a label of `labels` left without one is outside the
 * registry (a run logged from outside) and is never asked for.
 */
export function rememberAnswer(descriptions, labels = []) {
  remember(descriptions || []);
  for (const label of labels) if (typeof label === 'string' && !described.has(label)) described.set(label, null);
}

/** Labels outside the registry (a run logged from outside, `kind` external): never asked for. */
export function outsideRegistry(labels = []) {
  rememberAnswer([], labels);
}

/** Forget every description and role (tests). */
export function forget() {
  described.clear();
  registries.clear();
  memories.clear();
  roles = {};
  rolesAsked = null;
}

/**
 * Describe `labels` once (one request for those not yet known) and load the roles. Never throws: a
 * label the server refuses, or an unreachable server, leaves labels undescribed (sorted last,
 * coloured in order).
 */
export async function ready(labels = []) {
  rolesAsked ||= api.systems().then((schema) => { roles = { ...schema.algorithms, ...roles }; }).catch(() => { rolesAsked = null; });
  const missing = [...new Set(labels.filter((l) => typeof l === 'string' && !described.has(l)))];
  const asks = [rolesAsked];
  if (missing.length) {
    asks.push(request('GET', `/algorithms?${missing.map((l) => `label=${encodeURIComponent(l)}`).join('&')}`)
      .then((answer) => remember(answer.data, missing))
      .catch(() => Promise.all(missing.map((l) => describeOne(l))))); // one refused label: describe the rest
  }
  await Promise.all(asks);
}

/** One label described, or its refusal's message: `{description}` or `{message}`. */
export async function describeOne(label, system = null) {
  const query = new URLSearchParams({ label });
  if (system) query.set('system', system);
  try {
    const answer = await request('GET', `/algorithms?${query}`);
    if (!system) remember(answer.data, [label]);
    return { description: answer.data[0] };
  } catch (e) {
    const detail = Array.isArray(e.detail) && e.detail[0];
    return { message: detail ? detail.msg : e.message };
  }
}

/** The description of `label` (null until `ready` has described it, or if the server could not). */
export function describe(label) {
  return described.get(label) || null;
}

/** The label a metric or a view reads: `baseline` (% from uniform), `reference` (% of max), `best_fixed`. */
export function roleLabel(role) {
  return roles[role] || null;
}

/** The order of configurations in every view: the registry's sort key, then the label; undescribed last. */
export function compareLabels(a, b) {
  const ka = describe(a)?.sort_key;
  const kb = describe(b)?.sort_key;
  if (ka && !kb) return -1;
  if (kb && !ka) return 1;
  if (ka && kb) {
    for (let i = 0; i < Math.max(ka.length, kb.length); i++) {
      const d = (ka[i] ?? 0) - (kb[i] ?? 0);
      if (d) return d;
    }
  }
  return String(a).localeCompare(String(b));
}

/** `labels` in view order (a new array). */
export function sortLabels(labels) {
  return (labels || []).slice().sort(compareLabels);
}

/** The palette slot `label` prefers (GET /api/algorithms' colour_key), or null. */
export function colourKey(label) {
  const key = describe(label)?.colour_key;
  return Number.isInteger(key) ? key : null;
}

/**
 * The families for a system, a preset or a saved system (`null`: the grammar alone), with a form's `overrides`
 * of its parameters on top: GET /api/algorithms?system=...&params={...}, asked once per pair.
 */
export function families(system = null, overrides = null) {
  const changed = overrides && Object.keys(overrides).length ? JSON.stringify(overrides) : '';
  const key = `${system || ''}|${changed}`;
  if (!registries.has(key)) {
    const query = new URLSearchParams();
    if (system) query.set('system', system);
    if (system && changed) query.set('params', changed);
    const qs = query.toString();
    registries.set(key, request('GET', `/algorithms${qs ? `?${qs}` : ''}`).then((answer) => answer.data)
      .catch((e) => { registries.delete(key); throw e; }));
  }
  return registries.get(key);
}

// ---- label forms: what the new-experiment form's pickers are built from (pure) ---------------

/** Every literal label of `fams` (forms without an argument), family by family. */
export function literalLabels(fams) {
  return (fams || []).flatMap((f) => f.forms.filter((form) => !form.argument).map((form) => form.template));
}

/** The forms of `fams` that take an argument, each with its family's name: `{family, form}`. */
export function argumentForms(fams) {
  return (fams || []).flatMap((f) => f.forms.filter((form) => form.argument).map((form) => ({ family: f.name, form })));
}

/** A value of a form of two arguments, `x:y`, as its two numbers (null if it is not one). */
function pairOf(value) {
  const m = /^(\d+):(\d+)$/.exec(String(value));
  if (!m) return null;
  const pair = [Number(m[1]), Number(m[2])];
  return pair.every((v) => Number.isSafeInteger(v) && v >= 1) ? pair : null;
}

/** The label of `form` with `value` as its argument (`x:y` for a form of two arguments). */
export function labelFor(form, value) {
  if (!form.second_argument) return form.template.replace(`{${form.argument}}`, String(value));
  const [x, y] = String(value).split(':');
  return form.template.replace(`{${form.argument}}`, x).replace(`{${form.second_argument}}`, y);
}

/**
 * The argument of `label` if `form` writes it (its pattern, lower-cased as the server reads labels), else null:
 * a number, or `x:y` for a form of two arguments.
 */
export function argumentOf(form, label) {
  const m = new RegExp(form.pattern).exec(String(label).trim().toLowerCase());
  if (form.second_argument) return m && m[2] !== undefined ? `${Number(m[1])}:${Number(m[2])}` : null;
  return m && m[1] !== undefined ? Number(m[1]) : null;
}

/**
 * Values of `form`'s argument typed in a field ("2, 5 10", or whole labels of the form; pairs "5:2, 10:3" for a
 * form of two arguments): the values in the order typed, repeats dropped, and the tokens that are neither.
 */
export function readArguments(text, form) {
  const values = [];
  const invalid = [];
  for (const raw of String(text || '').split(/[\s,;]+/)) {
    const token = raw.trim();
    if (!token) continue;
    let value;
    if (form.second_argument) {
      const pair = pairOf(token) || pairOf(argumentOf(form, token));
      value = pair ? `${pair[0]}:${pair[1]}` : null;
    } else {
      value = /^\d+$/.test(token) ? Number(token) : argumentOf(form, token);
      if (!(value !== null && Number.isSafeInteger(value) && value >= 1)) value = null;
    }
    if (value !== null) {
      if (!values.includes(value)) values.push(value);
    } else {
      invalid.push(token);
    }
  }
  return { values, invalid };
}

/** Argument values in increasing order (numbers, or pairs by x then y). */
export function compareArguments(a, b) {
  const pa = pairOf(a) || [Number(a), 0];
  const pb = pairOf(b) || [Number(b), 0];
  return pa[0] - pb[0] || pa[1] - pb[1];
}

/** Why `value` is not valid for `form` here (the form's own help and valid values), or null if it is. */
export function argumentProblem(form, value) {
  if (form.second_argument) {
    const [x, y] = pairOf(value) || [];
    const problems = [[form.argument, x, form.valid, form.argument_help],
      [form.second_argument, y, form.second_valid, form.second_help]]
      .filter(([, v, valid]) => Array.isArray(valid) && !valid.includes(v))
      .map(([name, , valid, help]) => `${name} is the ${help} (valid: ${valid.length ? valid.join(', ') : 'none'})`);
    return problems.length ? `${labelFor(form, value)} is not valid here: ${problems.join('; ')}.` : null;
  }
  if (!Array.isArray(form.valid) || form.valid.includes(value)) return null;
  return `${labelFor(form, value)} is not valid here: ${form.argument} is the ${form.argument_help} ` +
    `(valid: ${form.valid.join(', ')}).`;
}

/** The values `form` takes here, for people: "Valid x here: 1, 2, 5." (and y's, for a form of two). */
export function validText(form) {
  return [[form.argument, form.valid], [form.second_argument, form.second_valid]]
    .filter(([name, valid]) => name && Array.isArray(valid))
    .map(([name, valid]) => `Valid ${name} here: ${valid.length ? valid.join(', ') : 'none'}.`).join(' ');
}

/**
 * Bytes of learning state per child of `labels` in a system (`system`, with a form's `overrides`): each label
 * described for it (GET /api/algorithms?system=...&label=...), asked once per system, overrides and label.
 * Resolves to `{label: bytes}` of those the server described (a label it refuses is left out).
 */
export async function memoryOf(labels, system, overrides = null) {
  const changed = overrides && Object.keys(overrides).length ? JSON.stringify(overrides) : '';
  const key = (label) => `${system}|${changed}|${label}`;
  const missing = [...new Set(labels)].filter((label) => !memories.has(key(label)));
  if (missing.length) {
    const query = new URLSearchParams({ system });
    if (changed) query.set('params', changed);
    for (const label of missing) query.append('label', label);
    const asked = request('GET', `/algorithms?${query}`).then((answer) => answer.data.map((d) => d.memory_per_child))
      .catch(() => { missing.forEach((label) => memories.delete(key(label))); return null; }); // asked again later
    missing.forEach((label, i) => memories.set(key(label), asked.then((bytes) => (bytes ? bytes[i] : null))));
  }
  const bytes = await Promise.all(labels.map((label) => memories.get(key(label))));
  return Object.fromEntries(labels.map((label, i) => [label, bytes[i]]).filter(([, b]) => Number.isFinite(b)));
}

/**
 * Bytes of learning state per child of each label the registry gives it for (its families'
 * `memory_per_child`, with a system): `{label: bytes}`, empty when the registry does not say.
 */
export function memoryPerChild(fams) {
  return Object.assign({}, ...(fams || []).map((f) => (f.memory_per_child && typeof f.memory_per_child === 'object' ? f.memory_per_child : {})));
}

/** Bytes as people read them: 512 B, 2.0 kB, 3.4 MB. */
export function fmtBytes(bytes) {
  if (!Number.isFinite(bytes)) return '';
  if (bytes < 1000) return `${bytes} B`;
  const units = ['kB', 'MB', 'GB', 'TB'];
  let v = bytes / 1000;
  let i = 0;
  while (v >= 1000 && i < units.length - 1) { v /= 1000; i += 1; }
  return `${v.toFixed(1)} ${units[i]}`;
}
