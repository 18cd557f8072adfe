// The new-experiment form's stopping rule: run seeds in blocks until a question is answered (a job's `until`,
// docs/statistics.md "Seeds until decided"), instead of a fixed number of seeds. Its choices and defaults come
// from GET /api/systems (`limits.until`); the server validates, and its errors (`until.half_width`, ...) show
// beside these fields.

import { h } from './ui.js';

const OF_WORDS = { pct_from_uniform: '% from uniform', final_utility: 'final utility' };

/**
 * The rule's fields. `fieldBlock(path, label, control, help)` registers each for the server's errors;
 * `seedsIn` is disabled while the rule is on (the rule runs as many seeds as its question needs).
 * Returns `{ element, body(), load(job) }`: `body()` is `{}` when the rule is off, else `{until, first_seed}`.
 */
export function untilFields(limits, fieldBlock, seedsIn) {
  const on = h('input', { type: 'checkbox', id: 'until-on', name: 'until-on' });
  const halfIn = h('input', { type: 'number', name: 'until-half-width', step: 'any', min: 0, value: 2, id: 'until-half-width' });
  const ofSel = h('select', { name: 'until-of', id: 'until-of' },
    limits.of.map((of) => h('option', { value: of }, OF_WORDS[of] || of)));
  const maxIn = h('input', { type: 'number', name: 'until-max-seeds', min: limits.min_seeds, value: limits.max_seeds, id: 'until-max-seeds' });
  const blockIn = h('input', { type: 'number', name: 'until-block', min: 1, value: limits.block, id: 'until-block' });
  const firstIn = h('input', { type: 'number', name: 'first-seed', min: 0, value: 0, id: 'until-first-seed' });
  const decideIn = h('input', { type: 'text', name: 'until-decide', id: 'until-decide', placeholder: 'e.g. mgrao-5:1, mgrao-max' });
  const judgeIn = h('input', { type: 'text', name: 'until-judge', id: 'until-judge',
    placeholder: `every algorithm but ${limits.not_judged.join(' and ')}` });
  const jointIn = h('input', { type: 'checkbox', name: 'until-joint', id: 'until-joint' });
  const inner = h('div', { class: 'until-fields', hidden: true },
    h('div', { class: 'row' },
      fieldBlock('until.half_width', 'Half width', halfIn,
        'The 95% interval to reach, ± this; with two configurations to decide, the margin of no practical difference'),
      fieldBlock('until.of', 'Of', ofSel, null)),
    h('div', { class: 'row' },
      fieldBlock('until.judge', 'Judge (optional)', judgeIn,
        `Whose intervals must be narrow, comma separated; by default every algorithm but ${limits.not_judged.join(' (the reference) and ')} (a bound)`),
      fieldBlock('until.joint', 'Coverage', h('label', { class: 'check' }, jointIn, ' joint'),
        'Each judged interval covers its own value 95% of the time; joint: all of them at once (each at 1 − 0.05/k)')),
    h('div', { class: 'row' },
      fieldBlock('until.decide', 'Decide between (optional)', decideIn,
        'Two of the algorithms, comma separated: stop once their paired difference is decided (instead of judging)'),
      fieldBlock('first_seed', 'First seed', firstIn, null)),
    h('div', { class: 'row' },
      fieldBlock('until.max_seeds', 'At most seeds', maxIn, `${limits.min_seeds} or more; no rule stops before ${limits.min_seeds}`),
      fieldBlock('until.block', 'Seeds per block', blockIn, 'Seeds run between two checks')));
  // While the rule is on, the seeds field shows its max_seeds: the work budget counts the most it may run.
  let kept = null;
  const mirror = () => {
    if (!on.checked) return;
    seedsIn.value = maxIn.value;
    seedsIn.dispatchEvent(new Event('input', { bubbles: true }));
  };
  const toggle = () => {
    inner.hidden = !on.checked;
    seedsIn.disabled = on.checked;
    if (on.checked) { kept ??= seedsIn.value; mirror(); } else if (kept !== null) { seedsIn.value = kept; kept = null; }
  };
  on.addEventListener('change', toggle);
  maxIn.addEventListener('input', mirror);
  const element = h('fieldset', { class: 'until', id: 'until-fieldset' },
    h('legend', {}, 'Seeds until decided'),
    h('label', { class: 'check' }, on, ' Run seeds in blocks until a question is answered, instead of a fixed number'),
    inner);
  const number = (input) => (input.value === '' ? input.value : Number(input.value));
  return {
    element,
    body() {
      if (!on.checked) return {};
      const until = { of: ofSel.value, max_seeds: number(maxIn), block: number(blockIn) };
      if (halfIn.value !== '') until.half_width = number(halfIn);
      const decide = decideIn.value.split(',').map((s) => s.trim()).filter(Boolean);
      if (decide.length) until.decide = decide;
      const judge = judgeIn.value.split(',').map((s) => s.trim()).filter(Boolean);
      if (judge.length) until.judge = judge;
      if (jointIn.checked) until.joint = true;
      return { until, first_seed: number(firstIn) };
    },
    load(job) { // a cloned job's rule
      if (!job.until) return;
      on.checked = true;
      halfIn.value = job.until.half_width ?? '';
      ofSel.value = job.until.of;
      maxIn.value = job.until.max_seeds;
      blockIn.value = job.until.block;
      decideIn.value = (job.until.decide || []).join(', ');
      judgeIn.value = (job.until.judge || []).join(', ');
      jointIn.checked = Boolean(job.until.joint);
      firstIn.value = job.seeds.length ? job.seeds[0] : 0;
      toggle();
    },
  };
}
