// The job view's learned weights: one seed's final weights (or the mean over seeds), a heatmap of a
// child's parent-group weights (PW) and its combined weights beside the oracle's allocation.
// Every seed draws its own composite types and value profiles, so one seed shows what the mean hides.
// An algorithm whose parent groups change (mgrao-adaptive:x, mgrao-balance) also shows a child's group membership over
// the run: parents by recorded regroupings, each cell the parent's group (the paper's adaptive groups).
// A system with several resources (n_resources > 1) shows one heatmap per resource, titled by resource:
// MG-RAO keeps a PW per resource (the paper's pgw_{c,r,t}); the answer's `resources` lists each one's.
// A system of more children than an answer's page (the answers then say which children they hold: `children`)
// shows one child at a time, chosen by its number and loaded alone, or the mean over every child (stored with
// each run: `mean_over_children`), and says what each run stored of its weights and why.

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

/** What each run stores of a large system's weights, and what the view shows, from an answer's `children`. */
export function childrenNote(page, seedIsMean) {
  const n = (v) => Number(v).toLocaleString('en-US');
  const combined = page.combined_stored === page.total ? 'every child' : `the first ${n(page.combined_stored)}`;
  const groups = page.groups_stored === null || page.groups_stored === undefined ? ''
    : page.groups_stored === page.total ? ' and the parent-group weights of every child'
      : ` and the parent-group weights of the first ${n(page.groups_stored)}`;
  const bound = page.bounds.combined_values === page.bounds.group_values
    ? `a run keeps at most ${n(page.bounds.combined_values)} of each: ${n(page.bounds.combined_values * 8 / 1e6)} MB`
    : `a run keeps at most ${n(page.bounds.combined_values)} and ${n(page.bounds.group_values)}`;
  return `${n(page.total)} children: one child at a time, or their mean over every child. Each run stores the ` +
    `combined weights of ${combined}${groups} (${bound}), and their mean over every child.` +
    (seedIsMean ? ` The mean over seeds covers the first ${n(page.count)} children: choose a seed to see any child.` : '');
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

  // a system of more children than a page: one child by number (loaded alone), or the mean over every child
  const paging = (configs.find((c) => c.weights.children) || { weights: {} }).weights.children || null;
  const ids = { seed: nextId('wseed'), cfg: nextId('cfg'), child: nextId('child'), whole: nextId('whole') };
  const seedSel = h('select', { id: ids.seed, 'data-testid': 'weights-seed' });
  const cfgSel = h('select', { id: ids.cfg }, configs.map((c) => h('option', { value: c.algorithm, selected: c.algorithm === state.algorithm }, c.algorithm)));
  const childSel = paging
    ? h('input', { type: 'number', id: ids.child, min: 0, step: 1, value: state.child || 0, 'data-testid': 'weights-child' })
    : h('select', { id: ids.child });
  const wholeSel = paging ? h('select', { id: ids.whole, 'data-testid': 'weights-children' },
    h('option', { value: 'one', selected: !state.whole }, 'one child'),
    h('option', { value: 'all', selected: !!state.whole }, `mean over all ${paging.total.toLocaleString('en-US')} children`)) : null;
  const childrenInfo = h('p', { class: 'help', id: 'weights-children-note', 'aria-live': 'polite', hidden: !paging });
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

  const offsetOf = (x) => (x.children ? x.children.offset : 0);
  // a large system's view shows one child (or the mean over every child, in every answer): it asks for that child
  // alone, a few kB, not the default page of 100 children's weights
  const pageFor = () => (paging ? { child_offset: state.child || 0, children: 1 } : undefined);
  const covers = (a) => !paging || a.seed === MEAN || state.whole || a.configurations.every((x) =>
    (state.child || 0) >= offsetOf(x) && (state.child || 0) < offsetOf(x) + x.combined.length);

  const load = async () => {
    if (state.seed === MEAN && seeds) { answer = meanAnswer; return; }
    try {
      const one = await api.weights(jobId, state.seed === MEAN || state.seed == null ? undefined : state.seed, pageFor());
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

  // One child's weights of configuration x in the answer (or, with the mean over every child chosen, that mean):
  // combined (types), groups (groups x types; null: left out, with why; [] or undefined: none learned), and each
  // resource's groups. null when the answer does not hold the child.
  const view = (x, child) => {
    const one = (w, i) => ({
      combined: w.combined[i], groups: w.groups === null ? null : (w.groups || [])[i], omitted: w.groups_omitted,
      resources: (w.resources || []).map((r) => ({ resource: r.resource, groups: (r.groups || [])[i] })) });
    if (paging && state.whole) return x.mean_over_children ? one(x.mean_over_children, 0) : null;
    const i = child - offsetOf(x);
    return i >= 0 && i < x.combined.length ? one(x, i) : null;
  };

  const pickChild = (c) => {
    if (!paging) {
      const nChildren = c.combined.length;
      if (childSel.options.length !== nChildren) {
        childSel.replaceChildren(...Array.from({ length: nChildren }, (_, i) => h('option', { value: i, selected: i === (state.child || 0) }, `child ${i}`)));
      }
      return Math.min(Number(childSel.value) || 0, nChildren - 1);
    }
    const page = c.children || paging;
    const last = (answer.seed === MEAN ? page.count : page.combined_stored) - 1;
    childSel.max = String(last);
    childSel.disabled = !!state.whole;
    const child = Math.max(0, Math.min(Math.floor(Number(childSel.value) || 0), last));
    if (String(child) !== childSel.value) childSel.value = String(child);
    childrenInfo.textContent = childrenNote(page, answer.seed === MEAN);
    return child;
  };

  const drawWeights = () => {
    if (!answer) return;
    const c = answer.configurations.find((x) => x.algorithm === cfgSel.value) || answer.configurations[0];
    state.algorithm = c.algorithm;
    const child = pickChild(c);
    state.child = child;
    const v = view(c, child);
    if (!v) return; // its page is on its way (load)
    const who = paging && state.whole ? `the mean over all ${paging.total.toLocaleString('en-US')} children` : `child ${child}`;
    const nTypes = v.combined.length;
    const types = Array.from({ length: nTypes }, (_, i) => i);
    const failed = loadError ? `Cannot load one seed’s weights (${loadError}). ` : '';
    seedNote.textContent = failed + weightsNote(answer.seed, configs.find((x) => x.algorithm === c.algorithm)?.seeds_done ?? 0) +
      (hasOracle ? '' : ' This job did not run the oracle, so there is no best fixed allocation to set beside it.');
    const g = v.groups;
    const width = heat.clientWidth || 600;
    const height = heat.clientHeight || 380;
    const perResource = v.resources.filter((r) => (r.groups || []).length);
    drawResourceHeats(perResource, types, who);
    if (perResource.length > 1) {
      purge(heat);
      heat.hidden = true;
      heatNote.textContent = `${g.length} parent groups of ${who} under ${c.algorithm}, one heatmap per ` +
        `resource (a PW per resource)` + (answer.seed === MEAN ? ', mean over seeds.' : `, seed ${answer.seed}.`);
    } else if (g && g.length) {
      heat.hidden = false;
      heatNote.textContent = `${g.length} parent groups of ${who} under ${c.algorithm}` +
        (answer.seed === MEAN ? ', mean over seeds.' : `, seed ${answer.seed}.`);
      draw(heat, [heatmapTrace(g, g.map((_, i) => i), types)], {
        xaxis: { title: { text: 'Task type' }, ...indexAxis(nTypes, width - 160, 22) },
        yaxis: { title: { text: 'Parent group' }, autorange: 'reversed', ...indexAxis(g.length, height - 110, 16) },
        hovermode: 'closest',
      });
    } else {
      purge(heat);
      heat.hidden = true;
      heatNote.textContent = g === null ? `${c.algorithm}: ${v.omitted}.`
        : `${c.algorithm} stores no group weights; only its combined weights are shown.`;
    }
    drawMembership(c, paging && state.whole ? -1 : child - offsetOf(c), child, height);
    const shown = [c, ...answer.configurations.filter((x) => x.algorithm === bestFixed && x !== c)];
    draw(bars, shown.map((x) => ({
      type: 'bar', name: x.algorithm === bestFixed ? `${x.algorithm} (best fixed allocation)` : x.algorithm, x: types,
      y: (view(x, child) || { combined: [] }).combined,
      marker: { color: colours[x.algorithm]?.color || '#000000' }, meta: { kind: 'bar', config: x.algorithm, child: paging && state.whole ? 'mean' : child },
      hovertemplate: `${x.algorithm}, type %{x}: %{y:.4f}<extra></extra>`,
    })), {
      barmode: 'group', showlegend: true, legend: { orientation: 'h', y: 1.12 }, hovermode: 'closest',
      xaxis: { title: { text: `Task type (${who}${c.resources ? ", resource 0" : ""})` }, ...indexAxis(nTypes, width - 100, 22) },
      yaxis: { title: { text: 'Combined weight' } },
    });
  };

  const drawResourceHeats = (perResource, types, who) => {
    // one heatmap per resource, each titled by its resource; none with one resource
    for (const old of resourceHeats.children) { purge(old); const i = plots.indexOf(old); if (i >= 0) plots.splice(i, 1); }
    resourceHeats.replaceChildren();
    resourceHeats.hidden = perResource.length < 2;
    if (perResource.length < 2) return;
    for (const r of perResource) {
      const g = r.groups; // the child's (or the mean's) PW of resource r (see view)
      const div = h('div', { class: 'chart heat', id: `weights-heatmap-resource-${r.resource}`, role: 'img',
        'data-testid': 'weights-resource-heatmap', 'data-resource': String(r.resource),
        'aria-label': `Heatmap of ${who}’s parent-group weights of resource ${r.resource} per task type` });
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

  const drawMembership = (c, index, child, height) => {
    // Only algorithms whose groups change store a membership (the weights answer says so: null otherwise);
    // the mean over seeds has none, since every seed groups its own parents. `index` is the child's place in the
    // answer's page (-1: the mean over children, which has none).
    if (!c.membership || index < 0 || !c.membership.children[index]) {
      purge(member);
      member.hidden = true;
      memberNote.textContent = c.membership && index >= 0
        ? `Child ${child}’s membership was not stored (only the first children fit the bound).` : '';
      return;
    }
    const f = membershipFigure(c.membership, index);
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
  childSel.addEventListener('change', async () => {
    state.child = Number(childSel.value);
    if (answer && !covers(answer)) await load(); // a large system's child outside the page loaded: that child alone
    drawWeights();
  });
  if (wholeSel) {
    wholeSel.addEventListener('change', async () => {
      state.whole = wholeSel.value === 'all';
      if (answer && !covers(answer)) await load();
      drawWeights();
    });
  }
  fillSeeds();
  queueMicrotask(async () => { await load(); drawWeights(); });

  return h('section', { 'aria-labelledby': 'h-w' },
    h('h2', { id: 'h-w' }, 'Learned weights (final episode)'),
    h('div', { class: 'controls' },
      h('label', { for: ids.seed }, 'Seed'), seedSel,
      h('label', { for: ids.cfg }, 'Configuration'), cfgSel,
      ...(wholeSel ? [h('label', { for: ids.whole }, 'Children'), wholeSel] : []),
      h('label', { for: ids.child }, 'Child'), childSel),
    childrenInfo, seedNote, heatNote,
    h('div', { class: 'grid2' }, heat, bars),
    resourceHeats,
    memberNote, member);
}
