// The job view's learned weights: one seed's final weights (or the mean over seeds), a heatmap of a
// child's parent-group weights (PW) and its combined weights beside the oracle's allocation.
// Every seed draws its own composite types and value profiles, so one seed shows what the mean hides.
// An algorithm whose parent groups change (mgrao-adaptive:x, mgrao-balance) also shows a child's group membership over
// the run: parents by recorded regroupings, each cell the parent's group (the paper's adaptive groups).
// A system with several resources (n_resources > 1) shows one heatmap per resource, titled by resource:
// MG-RAO keeps a PW per resource (the paper's pgw_{c,r,t}); the answer's `resources` lists each one's.

import { api } from './api.js';
import { h, notice, nextId } from './ui.js';
import { draw, purge, heatmapTrace, indexAxis } from './charts.js';
import { algorithmStyles } from './colours.js';
import { roleLabel } from './algorithms.js';

const MEAN = 'mean';

/** What the weights describe, in one line: the seed, or the mean and why it washes out. */
export function weightsNote(seed, nSeeds) {
  if (seed === MEAN) {
    return `Mean over ${nSeeds} seeds. Every seed draws its own composite types and value profiles, ` +
      'so the mean washes out the structure a learner found: choose a seed to see it.';
  }
  return `Seed ${seed}: its final weights (every seed draws its own composite types and value profiles).`;
}

/**
 * The membership heatmap's data for one child: `z[p][r]` is parent p's group in record r, recorded at
 * episode `episodes[r]` (the first record at episode 0, one every `membership.every` episodes after).
 */
export function membershipFigure(membership, child) {
  const records = (membership && membership.children[child]) || [];
  const nParents = records.length ? records[0].length : 0;
  return {
    z: Array.from({ length: nParents }, (_, p) => records.map((r) => r[p])),
    episodes: records.map((_, i) => i * membership.every),
    parents: Array.from({ length: nParents }, (_, p) => p),
  };
}

/**
 * The section. `results` is the job's results answer (its configurations carry the mean weights);
 * `state` keeps the chosen seed, configuration and child across redraws of a running job.
 */
export function weightsSection({ jobId, results, plots, state }) {
  const bestFixed = roleLabel('best_fixed'); // the oracle's label (GET /api/systems, algorithms.best_fixed)
  const colours = algorithmStyles(results.configurations.map((c) => c.algorithm)); // the utility chart's
  const configs = results.configurations.filter((c) => c.weights && Array.isArray(c.weights.combined) && c.weights.combined.length);
  if (!configs.length) return h('section', {}, h('h2', {}, 'Learned weights'), notice('empty', 'No learned weights were stored for this job.'));
  const nGroups = (w) => ((w.groups || [])[0] || []).length;
  const learners = configs.filter((c) => c.algorithm !== bestFixed);
  const preferred = (learners.length ? learners : configs).reduce((best, c) => (nGroups(c.weights) > nGroups(best.weights) ? c : best));
  if (!state.algorithm || !configs.some((c) => c.algorithm === state.algorithm)) state.algorithm = preferred.algorithm;
  const hasOracle = configs.some((c) => c.algorithm === bestFixed);

  const ids = { seed: nextId('wseed'), cfg: nextId('cfg'), child: nextId('child') };
  const seedSel = h('select', { id: ids.seed, 'data-testid': 'weights-seed' });
  const cfgSel = h('select', { id: ids.cfg }, configs.map((c) => h('option', { value: c.algorithm, selected: c.algorithm === state.algorithm }, c.algorithm)));
  const childSel = h('select', { id: ids.child });
  const heat = h('div', { class: 'chart heat', id: 'weights-heatmap', role: 'img', 'aria-label': 'Heatmap of a child’s parent-group weights per task type' });
  const bars = h('div', { class: 'chart bars', id: 'weights-bars', role: 'img', 'aria-label': 'A child’s combined weights per task type, beside the oracle’s allocation' });
  const seedNote = h('p', { class: 'help', id: 'weights-seed-note', 'aria-live': 'polite' });
  const heatNote = h('p', { class: 'help', id: 'weights-heat-note', 'aria-live': 'polite' });
  const member = h('div', { class: 'chart heat', id: 'membership-heatmap', role: 'img', hidden: true,
    'aria-label': 'Heatmap of a child’s parent-group membership over the run: parents by regroupings' });
  const memberNote = h('p', { class: 'help', id: 'membership-note', 'aria-live': 'polite' });
  const resourceHeats = h('div', { class: 'grid2', id: 'weights-resource-heatmaps', hidden: true });
  plots.push(heat, bars, member);

  let answer = null; // the weights of the chosen seed ({configurations}), or the means
  const meanAnswer = { seed: MEAN, configurations: configs.map((c) => ({ algorithm: c.algorithm, ...c.weights })) };

  let seeds = null; // the seeds with stored runs, once the first answer came
  let loadError = ''; // why one seed's weights could not be loaded (the mean is shown instead)
  const fillSeeds = () => {
    const nMean = configs[0].seeds_done ?? (seeds || []).length;
    seedSel.replaceChildren(
      ...(seeds || []).map((s) => h('option', { value: String(s), selected: String(s) === String(state.seed) }, `seed ${s}`)),
      h('option', { value: MEAN, selected: state.seed === MEAN }, `mean over ${nMean} seeds`));
  };

  const load = async () => {
    if (state.seed === MEAN && seeds) { answer = meanAnswer; return; }
    try {
      const one = await api.weights(jobId, state.seed === MEAN || state.seed == null ? undefined : state.seed);
      seeds = one.seeds;
      if (state.seed !== MEAN) state.seed = one.seed;
      answer = state.seed === MEAN ? meanAnswer : one;
      fillSeeds();
    } catch (e) {
      answer = meanAnswer;
      state.seed = MEAN;
      fillSeeds();
      loadError = e.message;
    }
  };

  const drawWeights = () => {
    if (!answer) return;
    const c = answer.configurations.find((x) => x.algorithm === cfgSel.value) || answer.configurations[0];
    state.algorithm = c.algorithm;
    const nChildren = c.combined.length;
    if (childSel.options.length !== nChildren) {
      childSel.replaceChildren(...Array.from({ length: nChildren }, (_, i) => h('option', { value: i, selected: i === (state.child || 0) }, `child ${i}`)));
    }
    const child = Math.min(Number(childSel.value) || 0, nChildren - 1);
    state.child = child;
    const nTypes = c.combined[child].length;
    const types = Array.from({ length: nTypes }, (_, i) => i);
    const failed = loadError ? `Cannot load one seed’s weights (${loadError}). ` : '';
    seedNote.textContent = failed + weightsNote(answer.seed, configs.find((x) => x.algorithm === c.algorithm)?.seeds_done ?? 0) +
      (hasOracle ? '' : ' This job did not run the oracle, so there is no best fixed allocation to set beside it.');
    const g = (c.groups || [])[child];
    const width = heat.clientWidth || 600;
    const height = heat.clientHeight || 380;
    const perResource = (c.resources || []).filter((r) => ((r.groups || [])[child] || []).length);
    drawResourceHeats(c, child, perResource, types);
    if (perResource.length > 1) {
      purge(heat);
      heat.hidden = true;
      heatNote.textContent = `${g.length} parent groups of child ${child} under ${c.algorithm}, one heatmap per ` +
        `resource (a PW per resource)` + (answer.seed === MEAN ? ', mean over seeds.' : `, seed ${answer.seed}.`);
    } else if (g && g.length) {
      heat.hidden = false;
      heatNote.textContent = `${g.length} parent groups of child ${child} under ${c.algorithm}` +
        (answer.seed === MEAN ? ', mean over seeds.' : `, seed ${answer.seed}.`);
      draw(heat, [heatmapTrace(g, g.map((_, i) => i), types)], {
        xaxis: { title: { text: 'Task type' }, ...indexAxis(nTypes, width - 160, 22) },
        yaxis: { title: { text: 'Parent group' }, autorange: 'reversed', ...indexAxis(g.length, height - 110, 16) },
        hovermode: 'closest',
      });
    } else {
      purge(heat);
      heat.hidden = true;
      heatNote.textContent = c.groups === null ? `${c.algorithm}: ${c.groups_omitted}.`
        : `${c.algorithm} stores no group weights; only its combined weights are shown.`;
    }
    drawMembership(c, child, height);
    const shown = [c, ...answer.configurations.filter((x) => x.algorithm === bestFixed && x !== c)];
    draw(bars, shown.map((x) => ({
      type: 'bar', name: x.algorithm === bestFixed ? `${x.algorithm} (best fixed allocation)` : x.algorithm, x: types, y: x.combined[child],
      marker: { color: colours[x.algorithm]?.color || '#000000' }, meta: { kind: 'bar', config: x.algorithm, child },
      hovertemplate: `${x.algorithm}, type %{x}: %{y:.4f}<extra></extra>`,
    })), {
      barmode: 'group', showlegend: true, legend: { orientation: 'h', y: 1.12 }, hovermode: 'closest',
      xaxis: { title: { text: `Task type (child ${child}${c.resources ? ", resource 0" : ""})` }, ...indexAxis(nTypes, width - 100, 22) },
      yaxis: { title: { text: 'Combined weight' } },
    });
  };

  const drawResourceHeats = (c, child, perResource, types) => {
    // one heatmap per resource, each titled by its resource; none with one resource
    for (const old of resourceHeats.children) { purge(old); const i = plots.indexOf(old); if (i >= 0) plots.splice(i, 1); }
    resourceHeats.replaceChildren();
    resourceHeats.hidden = perResource.length < 2;
    if (perResource.length < 2) return;
    for (const r of perResource) {
      const g = r.groups[child];
      const div = h('div', { class: 'chart heat', id: `weights-heatmap-resource-${r.resource}`, role: 'img',
        'data-testid': 'weights-resource-heatmap', 'data-resource': String(r.resource),
        'aria-label': `Heatmap of child ${child}’s parent-group weights of resource ${r.resource} per task type` });
      resourceHeats.append(div);
      plots.push(div);
      const width = div.clientWidth || 600;
      const height = div.clientHeight || 380;
      draw(div, [heatmapTrace(g, g.map((_, i) => i), types)], {
        title: { text: `Resource ${r.resource}: parent-group weights (PW)`, y: 0.98, yanchor: "top" },
        margin: { l: 64, r: 16, t: 44, b: 52 },
        xaxis: { title: { text: 'Task type' }, ...indexAxis(types.length, width - 160, 22) },
        yaxis: { title: { text: 'Parent group' }, autorange: 'reversed', ...indexAxis(g.length, height - 110, 16) },
        hovermode: 'closest',
      });
    }
  };

  const drawMembership = (c, child, height) => {
    // Only algorithms whose groups change store a membership (the weights answer says so: null otherwise);
    // the mean over seeds has none, since every seed groups its own parents.
    if (!c.membership || !c.membership.children[child]) {
      purge(member);
      member.hidden = true;
      memberNote.textContent = c.membership ? `Child ${child}’s membership was not stored (only the first children fit the bound).`
        : '';
      return;
    }
    const f = membershipFigure(c.membership, child);
    member.hidden = false;
    memberNote.textContent = `Group membership of child ${child} under ${c.algorithm}, seed ${answer.seed}: ` +
      `each parent’s group at episode 0 and after regroupings (a record every ${c.membership.every} episodes). ` +
      'Parents that stay in one group form stable models; a parent that keeps moving is one the child finds unpredictable.';
    draw(member, [{
      type: 'heatmap', z: f.z, x: f.episodes, y: f.parents, colorscale: 'Viridis',
      colorbar: { title: { text: 'group' } }, meta: { kind: 'membership', config: c.algorithm, child },
      hovertemplate: 'parent %{y}, episode %{x}: group %{z}<extra></extra>',
    }], {
      xaxis: { title: { text: 'Episode (record)' } },
      yaxis: { title: { text: 'Parent' }, autorange: 'reversed', ...indexAxis(f.parents.length, height - 110, 12) },
      hovermode: 'closest',
    });
  };

  seedSel.addEventListener('change', async () => {
    state.seed = seedSel.value === MEAN ? MEAN : Number(seedSel.value);
    await load();
    drawWeights();
  });
  cfgSel.addEventListener('change', drawWeights);
  childSel.addEventListener('change', () => { state.child = Number(childSel.value); drawWeights(); });
  fillSeeds();
  queueMicrotask(async () => { await load(); drawWeights(); });

  return h('section', { 'aria-labelledby': 'h-w' },
    h('h2', { id: 'h-w' }, 'Learned weights (final episode)'),
    h('div', { class: 'controls' },
      h('label', { for: ids.seed }, 'Seed'), seedSel,
      h('label', { for: ids.cfg }, 'Configuration'), cfgSel,
      h('label', { for: ids.child }, 'Child'), childSel),
    seedNote, heatNote,
    h('div', { class: 'grid2' }, heat, bars),
    resourceHeats,
    memberNote, member);
}
