"""The batched kernel: many (seed, algorithm) lanes through the episodes of a block, in parallel.

Each lane is one run: one seed, one algorithm. Lanes are independent and run in parallel
(``numba.prange``); within a lane everything is sequential and in a fixed order, so a lane's
numbers do not depend on which other lanes run beside it, on the thread count, or on how the
episodes are split into blocks.

An episode follows the paper's five processing steps (section 3), with the child's allocation
fixed at its start (the paper: an allocation cannot change instantly):

1. composite tasks arrive, one per present parent whose composite type arrives in the episode (the
   task stream's changes first, then absent parents leave and rejoin);
2. each parent decomposes its composite task into atomic tasks (their proportional values);
3. each parent allocates the atomic tasks to children;
4. each child performs its atomic tasks with the resources its allocation gives their types;
5. each composite task completes: its quality counts in the system utility, and the absolute
   values go back, composite by composite in a random order of parents, to the parents'
   estimates of their children and to the children, which learn from them (algorithm 1).

What a child does in steps 1 (its allocation) and 5 (learning) is its algorithm family's: a fixed
family's child copies its lane's ``fixed_weights``; a learner's child runs the family's compiled
steps (:attr:`Family.steps <mgrao_core.algorithms.base.Family.steps>`), chosen by the lane's family
code. Each learner family's lanes come as one argument of :func:`run_block` and :func:`finish`, after
the kernel's own, in the order of :data:`mgrao_core.algorithms.LEARNERS` (numba's parallel loop takes
no tuple of them). docs/algorithms.md says how a new learner is wired in here.

**Only what a chunk uses is compiled.** A learner family with no lane in the chunk is passed as
``None``, and so are the several resources (:class:`SeveralResources`) of a system with one. numba
compiles the kernel once per signature, and before it types a signature it drops every branch
guarded by ``argument is not None`` of an argument that is ``None`` (its dead-branch pruning), so
the code of families a job does not run, and of several resources, is neither typed nor compiled
(the paper's defaults compile in about a third of the time of the kernel with every family). Each
guard tests the argument itself, as an operand of its own (``mgrao_lanes is not None and kind ==
MGRAO``): a guard numba cannot see (on a copy of the argument, or folded into another expression)
would leave the branch to be compiled with ``None``, which fails to type. The numbers do not depend
on which branches were compiled.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from mgrao_core.algorithms import KINDS
from mgrao_core.algorithms.adaptive import compiled as adaptive
from mgrao_core.algorithms.balance import compiled as balance
from mgrao_core.algorithms.bandit import compiled as bandit
from mgrao_core.algorithms.independent_q import compiled as independent_q
from mgrao_core.algorithms.mgrao import compiled as mgrao
from mgrao_core.engine.environment import (
    allocate_atomic_tasks,
    apply_changes,
    composite_tasks_arrive,
    parents_leave_and_join,
    perform_composite_task,
    perform_composite_task_failing,
    perform_composite_task_resources,
    proportional_values,
    resolve_failures,
    update_estimates,
)

MGRAO = KINDS["mgrao"]
ADAPTIVE = KINDS["mgrao-adaptive"]
INDEPENDENT_Q = KINDS["independent-q"]
BANDIT = KINDS["bandit"]
BALANCE = KINDS["mgrao-balance"]


class Lanes(NamedTuple):
    """Per-lane inputs and state (updated in place), first axis the lane (see :data:`mgrao_core.lanes.ENVIRONMENT`).

    Attributes:
        seed_index: index of the lane's seed in the block's per-seed arrays.
        kind: the code of the lane's family (:data:`mgrao_core.algorithms.KINDS`).
        groups: parent groups ``m`` per child of the lane's algorithm.
        task_share: ``(lanes, children)`` the share of each child's resources its tasks get, what learning leaves
            (:func:`mgrao_core.algorithms.task_share`, or a family's own each episode; 1 without ``learning_cost``).
        fixed_weights: ``(lanes, children, n_types)`` the allocation of a fixed family's lanes.
        weights: ``(lanes, children, n_types)`` each child's allocation in this episode (with several
            resources: of the first resource).
        resource_weights: ``(lanes, children, R, n_types)`` with several resources (``R > 1``), each child's
            allocation of each resource; ``(lanes, children, 0, n_types)`` with one.
        estimates, tries: ``(lanes, parents, choices, children)`` each parent's running mean of
            what each child gave back, and how often it tried it.
        active: ``(lanes, parents)`` which parents are present.
        profiles: ``(lanes, parents, types_per_composite)`` each parent's value profile.
        parent_types: ``(lanes, parents, types_per_composite)`` the atomic types of each parent's composite type.
    """

    seed_index: np.ndarray
    kind: np.ndarray
    groups: np.ndarray
    task_share: np.ndarray
    fixed_weights: np.ndarray
    weights: np.ndarray
    resource_weights: np.ndarray
    estimates: np.ndarray
    tries: np.ndarray
    active: np.ndarray
    profiles: np.ndarray
    parent_types: np.ndarray


class Worlds(NamedTuple):
    """What each seed drew once.

    ``resources (seeds, children, n_types)``: each child's resource per unit of weight of each type,
    ``ar[c] / capability[c, t]`` (:attr:`mgrao_core.world.World.type_resources_single`). A parent's atomic types
    are the lane's (``Lanes.parent_types``), since the task stream may change them.
    """

    resources: np.ndarray


class SeveralResources(NamedTuple):
    """What each seed drew once of several resources (``R > 1``; docs/model.md, "Several resources").

    ``per_resource (seeds, children, R, n_types)`` (:attr:`mgrao_core.world.World.resource_per_type`) and
    ``needs (seeds, n_types, R)``. The kernel takes ``None`` instead with one resource.
    """

    per_resource: np.ndarray
    needs: np.ndarray


class Outside(NamedTuple):
    """An environment's side of each lane's episode (:mod:`mgrao_core.stepper`): what it gives, what it reads.

    In: ``resource_weights (lanes, children, R, n_types)``, with several resources, each child's allocation of
    each resource (a fixed family's lanes hold it instead of one split for every resource); ``(lanes, children,
    0, n_types)`` with one. Out, what the last episode sent back: ``sending (lanes, parents)`` the parents that
    sent a composite task; ``child_of (lanes, parents, types_per_composite)`` the child each atomic task went
    to and ``values`` the absolute value it returned (both stale where the parent did not send). The runner
    passes ``None``: nothing is read or written, or compiled.
    """

    resource_weights: np.ndarray
    sending: np.ndarray
    child_of: np.ndarray
    values: np.ndarray


class Failing(NamedTuple):
    """Where atomic tasks can fail (``task_need > 0``; docs/model.md, "Tasks that fail, and hierarchical allocation").

    ``counts (lanes, 3)``: each lane's atomic tasks allocated, failed, and completed through a neighbour, added to
    every episode. The kernel takes ``None`` instead where no task can fail: the code is neither typed nor compiled.
    """

    counts: np.ndarray


class Draws(NamedTuple):
    """The block's randomness per seed, first axes ``(seeds, episodes)``.

    See :class:`mgrao_core.world.EpisodeDraws`.
    """

    noise: np.ndarray
    order: np.ndarray
    volatility: np.ndarray
    new_profiles: np.ndarray
    routing: np.ndarray
    changes: np.ndarray
    event_profiles: np.ndarray
    event_types: np.ndarray
    arrives: np.ndarray


@njit(cache=True, parallel=True)
def run_block(lanes, worlds, several, links, draws, env, utilities, outside, failing, mgrao_lanes, adaptive_lanes,
              independent_q_lanes, bandit_lanes, balance_lanes):
    """Run every lane through the episodes of one block.

    The system utility of each lane and episode goes into ``utilities (lanes, episodes)``, and what came
    back in the last episode into ``outside`` (:class:`Outside`, which may also give the allocation of each of
    several resources; ``None``: nowhere);
    ``several`` is the seeds' :class:`SeveralResources` (``None`` with one resource); ``links`` each seed's
    ``(seeds, n_parents, k)`` children a parent offers its tasks to in a sparse world (``None``: every child; a
    parent's estimates and routing are then of its ``k`` links, and a chosen slot is mapped to its child);
    ``failing`` the lanes' :class:`Failing` counts where tasks can fail (``None``: none can);
    ``mgrao_lanes``, ``adaptive_lanes``, ``independent_q_lanes``, ``bandit_lanes`` and ``balance_lanes`` are each
    learner family's compiled lanes (:class:`~mgrao_core.algorithms.mgrao.compiled.MgraoLanes` and the like), in
    registry order, ``None`` for a family with no lane here (the module says why).
    """
    n_lanes = lanes.seed_index.shape[0]
    n_episodes = utilities.shape[1]
    n_parents, types_per_composite = lanes.parent_types.shape[1], lanes.parent_types.shape[2]
    n_children = lanes.weights.shape[1]
    n_links = lanes.estimates.shape[3]  # the children a parent chooses among: every child, or its links
    for lane in prange(n_lanes):
        s = lanes.seed_index[lane]
        kind = lanes.kind[lane]
        active = lanes.active[lane]
        sending = np.ones(n_parents, dtype=np.bool_)  # present, and the composite type arrives
        parent_types = lanes.parent_types[lane]
        weights = lanes.weights[lane]
        m = lanes.groups[lane]
        task_share = lanes.task_share[lane]
        if mgrao_lanes is not None:  # the views once per lane, unpacked for the learning (its docstring says why)
            mgrao_views = mgrao.lane_of(mgrao_lanes, lane)
            Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due, row_kl = mgrao_views
        if adaptive_lanes is not None:
            adaptive_views = adaptive.lane_of(adaptive_lanes, lane)
        if balance_lanes is not None:
            balance_views = balance.lane_of(balance_lanes, lane)
        child_of = np.zeros((n_parents, types_per_composite), dtype=np.int64)
        slot_of = np.zeros((n_parents, types_per_composite), dtype=np.int64)  # in a sparse world: the link chosen
        ctv = np.zeros((n_parents, types_per_composite))
        values = np.zeros((n_parents, types_per_composite))
        taq = np.zeros(n_parents)
        load = np.ones((n_children, lanes.weights.shape[2]))
        n_resources = env.n_resources
        resource_weights = lanes.resource_weights[lane]
        shares = np.zeros((n_parents, types_per_composite, n_resources))
        w_scratch = np.zeros(n_resources)
        a_scratch = np.zeros(n_resources)
        learner_of = np.zeros((n_parents, types_per_composite), dtype=np.int64)
        # MG-RAO's returned values sorted child by child, each child's in the order they came back (step 5)
        bucket = np.zeros(n_parents * types_per_composite, dtype=np.int64)
        bucket_start = np.zeros(n_children + 1, dtype=np.int64)
        bucket_fill = np.zeros(n_children, dtype=np.int64)
        credit = np.zeros((n_parents, types_per_composite))
        if outside is not None:  # the lane's rows, taken here: numba's parallel loop loses a write such as
            # outside.values[lane, p, k] = x, made through the tuple's attribute (numba 0.68)
            given_resource_weights = outside.resource_weights[lane]
            observed_sending = outside.sending[lane]
            observed_child_of = outside.child_of[lane]
            observed_values = outside.values[lane]
        # where tasks can fail: what became of each atomic task, the amounts of the last resource, what each child
        # lent and how many tasks share each amount, and one resource's allocation and amounts as those of several
        # (R = 1); allocated whatever ``failing`` is, since an array defined under a pruned branch of numba's parallel
        # loop is freed wrongly (numba 0.68)
        status = np.zeros((n_parents, types_per_composite), dtype=np.int64)
        performer = np.zeros((n_parents, types_per_composite), dtype=np.int64)
        available = np.zeros((n_children, lanes.weights.shape[2]))
        lent = np.zeros((n_children, lanes.weights.shape[2]))
        sharing = np.ones((n_children, lanes.weights.shape[2]))
        one_weights = weights.reshape((n_children, 1, weights.shape[1]))
        one_resources = worlds.resources[s].reshape((n_children, 1, weights.shape[1]))
        one_needs = np.ones((weights.shape[1], 1))
        for e in range(n_episodes):
            # 1. Composite tasks arrive at the parents present whose composite type arrives.
            apply_changes(lanes.profiles[lane], parent_types, draws.changes[s, e], draws.event_profiles[s, e],
                          draws.event_types[s, e], env)
            parents_leave_and_join(active, lanes.profiles[lane], draws.volatility[s, e], draws.new_profiles[s, e], env)
            composite_tasks_arrive(active, draws.arrives[s, e], env, sending)
            for c in range(n_children):
                if several is not None and mgrao_lanes is not None and kind == MGRAO:  # a PW, allocation per resource
                    for r in range(n_resources):
                        mgrao.allocate(mgrao_lanes, mgrao_views, m, c * n_resources + r, resource_weights[c, r])
                    weights[c, :] = resource_weights[c, 0, :]
                    continue
                if mgrao_lanes is not None and kind == MGRAO:
                    mgrao.allocate(mgrao_lanes, mgrao_views, m, c, weights[c])
                elif adaptive_lanes is not None and kind == ADAPTIVE:
                    adaptive.allocate(adaptive_lanes, adaptive_views, m, c, weights[c])
                elif independent_q_lanes is not None and kind == INDEPENDENT_Q:
                    independent_q.allocate(independent_q_lanes, lane, m, c, weights[c])
                elif bandit_lanes is not None and kind == BANDIT:
                    bandit.allocate(bandit_lanes, lane, m, c, weights[c])
                elif balance_lanes is not None and kind == BALANCE:
                    balance.allocate(balance_lanes, balance_views, m, c, weights[c], task_share)
                else:
                    weights[c, :] = lanes.fixed_weights[lane, c, :]
                if several is not None and outside is not None:  # the environment's allocation of each resource
                    for r in range(n_resources):
                        resource_weights[c, r, :] = given_resource_weights[c, r, :]
                elif several is not None:  # one split for every resource
                    for r in range(n_resources):
                        resource_weights[c, r, :] = weights[c, :]
            # 2-3. Parents decompose their composite tasks and allocate the atomic tasks.
            for p in range(n_parents):
                if sending[p]:
                    proportional_values(lanes.profiles[lane, p], draws.noise[s, e, p], env.value_noise, ctv[p])
                    if links is not None:  # a slot among the parent's links, then its child
                        if n_links == 1:
                            slot_of[p, :] = 0
                        else:
                            allocate_atomic_tasks(lanes.estimates[lane, p], draws.routing[s, e, p], env, slot_of[p])
                        for k in range(types_per_composite):
                            child_of[p, k] = links[s, p, slot_of[p, k]]
                    elif n_children == 1:  # no choice (and no routing draws to index)
                        child_of[p, :] = 0
                    else:
                        allocate_atomic_tasks(lanes.estimates[lane, p], draws.routing[s, e, p], env, child_of[p])
            if env.load_sharing:
                load[:, :] = 0.0
                for p in range(n_parents):
                    if sending[p]:
                        for k in range(types_per_composite):
                            load[child_of[p, k], parent_types[p, k]] += 1.0
            # 4. Children perform the atomic tasks; composite qualities make the system utility.
            if failing is not None and several is not None:
                resolve_failures(sending, child_of, parent_types, resource_weights, task_share, several.per_resource[s],
                                 env, available, lent, sharing, status, performer, failing.counts[lane])
            elif failing is not None:
                resolve_failures(sending, child_of, parent_types, one_weights, task_share, one_resources, env,
                                 available, lent, sharing, status, performer, failing.counts[lane])
            utility = 0.0
            for p in range(n_parents):
                if failing is not None and sending[p]:
                    if several is not None:
                        taq[p] = perform_composite_task_failing(ctv[p], child_of[p], parent_types[p], resource_weights,
                                                                task_share, several.per_resource[s], several.needs[s],
                                                                sharing, env, status[p], performer[p], lent, values[p],
                                                                shares[p], w_scratch, a_scratch)
                    else:
                        taq[p] = perform_composite_task_failing(ctv[p], child_of[p], parent_types[p], one_weights,
                                                                task_share, one_resources, one_needs, sharing, env,
                                                                status[p], performer[p], lent, values[p], shares[p],
                                                                w_scratch, a_scratch)
                    utility += taq[p]
                elif several is not None and sending[p]:
                    taq[p] = perform_composite_task_resources(ctv[p], child_of[p], parent_types[p], resource_weights,
                                                              task_share, several.per_resource[s], several.needs[s],
                                                              load, env, values[p], shares[p], w_scratch, a_scratch)
                    utility += taq[p]
                elif sending[p]:
                    taq[p] = perform_composite_task(ctv[p], child_of[p], parent_types[p],
                                                    weights, task_share, worlds.resources[s], load, env, values[p])
                    utility += taq[p]
                elif env.absent_counted and not active[p]:
                    utility += env.absent_quality
            utilities[lane, e] = utility
            if outside is not None:
                for p in range(n_parents):
                    observed_sending[p] = sending[p]
                    for k in range(types_per_composite):
                        observed_child_of[p, k] = child_of[p, k]
                        observed_values[p, k] = values[p, k]
            # 5. Values come back composite by composite, in a random order of parents: to each parent's estimates of
            # its children (each parent's own: taken in the order of parents), and to the children, which learn them
            # in the order they came back.
            for p in range(n_parents):
                if not sending[p]:
                    continue
                if links is not None and n_links > 1:
                    update_estimates(lanes.estimates[lane, p], lanes.tries[lane, p], slot_of[p], values[p], taq[p],
                                     env.per_composite)
                elif links is None and n_children > 1:
                    update_estimates(lanes.estimates[lane, p], lanes.tries[lane, p], child_of[p], values[p], taq[p],
                                     env.per_composite)
            # the learners that take the values parent by parent (MG-RAO on one resource learns below, child by child;
            # a fixed family learns nothing)
            in_order = (kind == MGRAO and several is not None) or kind == ADAPTIVE or kind == INDEPENDENT_Q \
                or kind == BANDIT or kind == BALANCE
            for i in range(n_parents if in_order else 0):
                p = draws.order[s, e, i]
                if not sending[p]:
                    continue
                if several is not None and mgrao_lanes is not None and kind == MGRAO:  # each resource's PW: its share
                    for r in range(n_resources):
                        for k in range(types_per_composite):
                            learner_of[p, k] = child_of[p, k] * n_resources + r
                            credit[p, k] = values[p, k] * shares[p, k, r] if env.by_share else values[p, k]
                        mgrao.learn(mgrao_lanes, Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts,
                                    rebase_due, row_kl, m, p, n_parents, learner_of, parent_types, credit)
                elif adaptive_lanes is not None and kind == ADAPTIVE:
                    adaptive.learn(adaptive_lanes, adaptive_views, m, p, n_parents, child_of[p],
                                   parent_types[p], values[p])
                elif independent_q_lanes is not None and kind == INDEPENDENT_Q:
                    independent_q.learn(independent_q_lanes, lane, m, p, n_parents, child_of[p], parent_types[p],
                                        values[p])
                elif bandit_lanes is not None and kind == BANDIT:
                    bandit.learn(bandit_lanes, lane, m, p, n_parents, child_of[p], parent_types[p], values[p],
                                 weights)
                elif balance_lanes is not None and kind == BALANCE:
                    balance.learn(balance_lanes, balance_views, p, n_parents, child_of[p], parent_types[p], values[p])
            if mgrao_lanes is not None and kind == MGRAO and several is None:
                # Each child learns from its values in the order they came back; children never share a value, so
                # taking them child by child is the same arithmetic in another order of children, and each child's
                # state is visited once instead of at every value (many children: the cache keeps it)
                sort_by_child(sending, child_of, draws.order[s, e], bucket, bucket_start, bucket_fill)
                bounded = m > mgrao_lanes.min_bounded_groups
                for c in range(n_children):
                    for b in range(bucket_start[c], bucket_start[c + 1]):
                        p = bucket[b] // types_per_composite
                        k = bucket[b] - p * types_per_composite
                        mgrao.learn_value(Y, F, H, cs, G, rows, slot, n_rows, k_since_rebase, counts, rebase_due,
                                          row_kl, c, bounded, (p * m) // n_parents, parent_types[p, k], values[p, k],
                                          mgrao_lanes)


@njit(cache=True)
def sort_by_child(sending, child_of, order, bucket, start, fill):
    """The atomic tasks of the parents that sent one, child by child, each child's in the order values come back.

    Composite by composite in ``order``, atomic task by atomic task: ``bucket[start[c]:start[c + 1]]`` are child
    ``c``'s, each as ``p * types_per_composite + k``.
    """
    n_children = fill.shape[0]
    per_composite = child_of.shape[1]
    start[:] = 0
    for p in range(child_of.shape[0]):
        if sending[p]:
            for k in range(per_composite):
                start[child_of[p, k] + 1] += 1
    for c in range(n_children):
        start[c + 1] += start[c]
        fill[c] = start[c]
    for i in range(order.shape[0]):
        p = order[i]
        if sending[p]:
            for k in range(per_composite):
                c = child_of[p, k]
                bucket[fill[c]] = p * per_composite + k
                fill[c] += 1


@njit(cache=True)
def finish(lanes, several, mgrao_lanes, adaptive_lanes, independent_q_lanes, bandit_lanes, balance_lanes):
    """Materialise every learner lane's final state and allocation (after the last episode).

    The arguments after ``lanes`` are :func:`run_block`'s (``None`` where it takes ``None``).
    """
    n_resources = lanes.resource_weights.shape[2]
    for lane in range(lanes.kind.shape[0]):
        kind = lanes.kind[lane]
        if several is not None and mgrao_lanes is not None and kind == MGRAO:
            mgrao.finish_resources(mgrao_lanes, lane, lanes.groups[lane], lanes.resource_weights[lane])
            lanes.weights[lane, :, :] = lanes.resource_weights[lane, :, 0, :]
        elif mgrao_lanes is not None and kind == MGRAO:
            mgrao.finish(mgrao_lanes, lane, lanes.groups[lane], lanes.weights[lane])
        elif adaptive_lanes is not None and kind == ADAPTIVE:
            adaptive.finish(adaptive_lanes, lane, lanes.groups[lane], lanes.weights[lane])
        elif independent_q_lanes is not None and kind == INDEPENDENT_Q:
            independent_q.finish(independent_q_lanes, lane, lanes.groups[lane], lanes.weights[lane])
        elif bandit_lanes is not None and kind == BANDIT:
            bandit.finish(bandit_lanes, lane, lanes.groups[lane], lanes.weights[lane])
        elif balance_lanes is not None and kind == BALANCE:
            balance.finish(balance_lanes, lane, lanes.weights[lane])
        if several is not None and kind != MGRAO:  # one split for every resource
            for r in range(n_resources):
                lanes.resource_weights[lane, :, r, :] = lanes.weights[lane]
