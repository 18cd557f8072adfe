"""The simulated environment, compiled: one small function per concept of the paper's system.

What a parent does with a composite task (absent parents, proportional values, choosing a child)
and what a child's resources make of an atomic task (its quality) live here; what a child learns
from the values it gets back lives with its algorithm family in :mod:`mgrao_core.algorithms`. Each function is the
compiled twin of a step of the dense reference (:mod:`mgrao_core.reference`), which is built from
:mod:`mgrao_core.equations`, and performs the same floating-point operations in the same order. The
quality models' compiled forms live with their other forms in :mod:`mgrao_core.quality`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from mgrao_core import equations
from mgrao_core.params import SystemParams
from mgrao_core.quality import (
    RESOURCE_COMBINATION_CODES,
    compiled_atomic_quality,
    compiled_combined_resources,
    quality_model,
)
from mgrao_core.world import NEW_COMPOSITE, NEW_PROFILE, is_dynamic

atomic_task_quality = compiled_atomic_quality()
"""Quality of an atomic task under the environment's quality model (see :mod:`mgrao_core.quality`)."""
combined_resources = compiled_combined_resources()
"""Several resources' effective (weight, resource) of a task and their shares (see :mod:`mgrao_core.quality`)."""
neighbour = njit(inline="always")(equations.neighbour)
n_neighbours = njit(inline="always")(equations.n_neighbours)

OWN, FAILED, BORROWED, HANDED_OVER = 0, 1, 2, 3
"""What became of an atomic task when tasks can fail (:func:`resolve_failures`)."""
HIERARCHY_CODES = {"none": 0, "borrow": 1, "hand-over": 2}
"""The kernel's code of each ``hierarchy`` (here, a compiled source: numba reads the codes as constants)."""
NO_HIERARCHY, BORROW, HAND_OVER = HIERARCHY_CODES["none"], HIERARCHY_CODES["borrow"], HIERARCHY_CODES["hand-over"]


class Environment(NamedTuple):
    """The environment's parameters as the kernel reads them (see :mod:`mgrao_core.params`)."""

    n_types: int
    quality_model: int
    half_saturation: float
    quality_at_uniform: float
    quality_floor: float
    load_sharing: bool
    value_noise: float
    per_composite: bool
    epsilon: float
    boltzmann_temperature: float
    tie_first: bool
    leave: float
    join: float
    rejoin_new: bool
    absent_counted: bool
    absent_quality: float
    dynamic: bool
    n_resources: int
    resource_combination: int
    by_share: bool
    need: float
    hierarchy: int
    ring: bool
    handover_cost: float


def environment_of(params: SystemParams) -> Environment:
    """The kernel's view of a validated parameter set."""
    return Environment(
        n_types=params.n_types,
        quality_model=quality_model(params.quality_model).code,
        half_saturation=params.half_saturation,
        quality_at_uniform=params.quality_at_uniform,
        quality_floor=params.quality_floor,
        load_sharing=params.load_sharing,
        value_noise=params.value_noise,
        per_composite=params.routing == "per-composite",
        epsilon=params.epsilon,
        boltzmann_temperature=params.boltzmann_temperature,
        tie_first=params.tie_break == "first",
        leave=params.leave_probability,
        join=params.join_probability,
        rejoin_new=params.rejoin_profile == "new",
        absent_counted=params.absent_tasks == "counted",
        absent_quality=params.effective_absent_quality,
        dynamic=is_dynamic(params),
        n_resources=params.n_resources,
        resource_combination=RESOURCE_COMBINATION_CODES[params.resource_combination],
        by_share=params.resource_credit == "by-share",
        need=equations.need_amount(params.task_need, params.resource_mean, params.n_types),
        hierarchy=HIERARCHY_CODES[params.hierarchy],
        ring=params.neighbours == "ring",
        handover_cost=params.handover_cost,
    )


@njit(cache=True)
def apply_changes(profiles, parent_types, changes, event_profiles, event_types, env):
    """The task stream's changes at the start of an episode (scheduled events, unpredictable parents).

    A parent whose ``changes`` has :data:`~mgrao_core.world.NEW_PROFILE` takes the value profile
    ``event_profiles[p]``; one with :data:`~mgrao_core.world.NEW_COMPOSITE` takes the atomic types
    ``event_types[p]`` of its new composite type. Nothing changes in a system whose stream never does.
    """
    if not env.dynamic:
        return
    for p in range(changes.shape[0]):
        if changes[p] & NEW_PROFILE:
            for k in range(profiles.shape[1]):
                profiles[p, k] = event_profiles[p, k]
        if changes[p] & NEW_COMPOSITE:
            for k in range(parent_types.shape[1]):
                parent_types[p, k] = event_types[p, k]


@njit(cache=True)
def composite_tasks_arrive(active, arrives, env, sending):
    """Which parents send a composite task in the episode, into ``sending``.

    A present parent whose composite type arrives (every episode, unless frequencies say otherwise).
    """
    for p in range(active.shape[0]):
        sending[p] = active[p] and (not env.dynamic or arrives[p])


@njit(cache=True)
def parents_leave_and_join(active, profiles, volatility, new_profiles, env):
    """Absent parents: present ones leave, absent ones rejoin, at the start of an episode.

    Each present parent leaves with probability ``leave`` and each absent one rejoins with
    probability ``join``, keeping its value profile or, under ``rejoin_profile="new"``, bringing a
    newly drawn one.
    """
    if env.leave <= 0.0 and env.join <= 0.0:
        return
    for p in range(active.shape[0]):
        if active[p]:
            if volatility[p] < env.leave:
                active[p] = False
        elif volatility[p] < env.join:
            active[p] = True
            if env.rejoin_new:
                for k in range(profiles.shape[1]):
                    profiles[p, k] = new_profiles[p, k]


@njit(cache=True, inline="always")
def proportional_values(profile, noise, value_noise, ctv):
    """Component tasks proportional values ``ctv = sumnorm(profile * exp(value_noise * N))``."""
    total = 0.0
    for k in range(ctv.shape[0]):
        ctv[k] = profile[k] * math.exp(value_noise * noise[k])
        total += ctv[k]
    for k in range(ctv.shape[0]):
        ctv[k] /= total


@njit(cache=True)
def choose_child(estimates, u, env):
    """A parent's epsilon-greedy choice of child from its running estimates of each child.

    The best estimate wins (ties: the first, or one drawn with ``u[2]``); with probability
    ``epsilon`` (``u[0] < epsilon``) one of the others is drawn with ``u[1]`` by a Boltzmann
    distribution over their estimates.
    """
    n_children = estimates.shape[0]
    best_value = estimates[0]
    ties = 1
    for c in range(1, n_children):
        if estimates[c] > best_value:
            best_value = estimates[c]
            ties = 1
        elif estimates[c] == best_value:
            ties += 1
    pick = 0 if env.tie_first else min(int(u[2] * ties), ties - 1)
    best = 0
    for c in range(n_children):
        if estimates[c] == best_value:
            if pick == 0:
                best = c
                break
            pick -= 1
    if n_children == 1 or u[0] >= env.epsilon:
        return best
    top = -np.inf
    for c in range(n_children):
        if c != best and estimates[c] > top:
            top = estimates[c]
    total = 0.0
    for c in range(n_children):
        if c != best:
            total += math.exp((estimates[c] - top) / env.boltzmann_temperature)
    target = u[1] * total
    chosen = -1
    for c in range(n_children):
        if c != best:
            chosen = c
            target -= math.exp((estimates[c] - top) / env.boltzmann_temperature)
            if target < 0.0:
                break
    return chosen


@njit(cache=True)
def allocate_atomic_tasks(estimates, routing, env, child_of):
    """Task allocation of one composite task: the child of each atomic task, into ``child_of``.

    Per composite, the parent chooses one child for the whole composite from its estimates
    ``estimates[0]`` of the composite quality each child returned; per task, it chooses for
    atomic task ``k`` from ``estimates[k]``, the value each child returned for that type.
    """
    n_children = estimates.shape[1]
    if n_children == 1:
        child_of[:] = 0
    elif env.per_composite:
        child_of[:] = choose_child(estimates[0], routing[0], env)
    else:
        for k in range(child_of.shape[0]):
            child_of[k] = choose_child(estimates[k], routing[k], env)


@njit(cache=True, inline="always")
def perform_composite_task(ctv, child_of, task_types, weights, task_share, resources, load, env, values):
    """Children perform the atomic tasks; returns the composite task quality ``taq = sum(ctv * q)``.

    ``resources[c, t]`` is child ``c``'s resource per unit of weight of type ``t`` (its amount over its
    capability factor); ``task_share[c]`` the share of it that learning leaves to its tasks (the weight given is
    ``task_share[c] * w``; 1 without a learning cost, a product that changes no bit). Each atomic task's absolute
    value ``atv = taq * ctv`` goes into ``values``.
    """
    taq = 0.0
    for k in range(ctv.shape[0]):
        c = child_of[k]
        t = task_types[k]
        taq += ctv[k] * atomic_task_quality(task_share[c] * weights[c, t], resources[c, t], load[c, t], env)
    for k in range(ctv.shape[0]):
        values[k] = taq * ctv[k]
    return taq


@njit(cache=True, inline="always")
def perform_composite_task_resources(ctv, child_of, task_types, weights, task_share, resources, needs, load, env,
                                     values, shares, w, a):
    """:func:`perform_composite_task` with several resources: returns ``taq``.

    ``weights (children, R, n_types)`` each child's allocation of each resource (learning leaving ``task_share[c]``
    of every resource to child ``c``'s tasks), ``resources (children, R,
    n_types)`` its amount per unit of weight relative to the type's need, ``needs (n_types, R)``. Each task's
    quality is the quality model at the combination's effective weight and resource; each resource's share
    of it goes into ``shares[k]``; ``w`` and ``a`` are scratch (one entry per resource).
    """
    taq = 0.0
    n_resources = w.shape[0]
    for k in range(ctv.shape[0]):
        c = child_of[k]
        t = task_types[k]
        for r in range(n_resources):
            w[r] = task_share[c] * weights[c, r, t]
            a[r] = resources[c, r, t]
        w_eff, a_eff = combined_resources(w, a, needs[t], env.resource_combination, shares[k])
        taq += ctv[k] * atomic_task_quality(w_eff, a_eff, load[c, t], env)
    for k in range(ctv.shape[0]):
        values[k] = taq * ctv[k]
    return taq


@njit(cache=True)
def resolve_failures(sending, child_of, task_types, weights, task_share, per_weight, env, available, lent, tasks,
                     status, performer, counts):
    """Which atomic tasks fail and which the hierarchy completes, in the order of parents and of their tasks.

    ``available[c, t] = task_share[c] * weights[c, R - 1, t] * per_weight[c, R - 1, t]`` is the amount of the last
    resource child ``c``'s allocation gives type ``t``, and ``tasks[c, t]`` how many of the episode's tasks share it:
    under load sharing its tasks of the type, else 1 where it has one (each gets the whole amount) and 0 where it has
    none. A task gets ``x = (available[c, t] - lent[c, t]) / tasks[c, t]`` and fails below ``env.need``
    (:func:`mgrao_core.equations.need_amount`). Under ``borrow`` it takes the shortfall from the first neighbour
    (:func:`mgrao_core.equations.neighbour`) that keeps ``env.need`` for each of its own tasks of the type after
    lending (``lent``: the lender's loss, for every task of that type it performs; one with no such task can lend
    it all); under ``hand-over`` the first neighbour that meets the need for each of its tasks of the type with this
    one among them performs it. Under load sharing a handed-over task then shares its performer's amount, not its
    child's, and a failed one shares none (``tasks`` moves). Writes ``status`` (:data:`OWN`, :data:`FAILED`,
    :data:`BORROWED`, :data:`HANDED_OVER`) and ``performer`` (the lender, or the neighbour it was handed to) of each
    task of a sending parent, and adds to ``counts``: tasks allocated, failed, completed through a neighbour.
    ``weights`` and ``per_weight`` are ``(children, R, n_types)``.
    """
    n_children, last = weights.shape[0], weights.shape[1] - 1
    for c in range(n_children):
        for t in range(weights.shape[2]):
            available[c, t] = task_share[c] * weights[c, last, t] * per_weight[c, last, t]
            lent[c, t] = 0.0
            tasks[c, t] = 0.0
    joins = 1.0 if env.load_sharing else 0.0  # what one more (or one fewer) task adds to the tasks sharing an amount
    for p in range(sending.shape[0]):
        if sending[p]:
            for k in range(child_of.shape[1]):
                c, t = child_of[p, k], task_types[p, k]
                tasks[c, t] = tasks[c, t] + 1.0 if env.load_sharing else 1.0
    need = env.need
    for p in range(sending.shape[0]):
        if not sending[p]:
            continue
        for k in range(child_of.shape[1]):
            c, t = child_of[p, k], task_types[p, k]
            counts[0] += 1
            status[p, k] = OWN
            performer[p, k] = c
            own = (available[c, t] - lent[c, t]) / tasks[c, t]
            if own >= need:
                continue
            status[p, k] = FAILED
            for i in range(n_neighbours(n_children, env.ring) if env.hierarchy != NO_HIERARCHY else 0):
                d = neighbour(c, i, n_children, env.ring)
                room = available[d, t] - lent[d, t]
                if env.hierarchy == BORROW and room - (need - own) >= need * tasks[d, t]:
                    lent[d, t] += need - own
                    status[p, k] = BORROWED
                elif env.hierarchy == HAND_OVER and room >= need * max(tasks[d, t] + joins, 1.0):
                    tasks[d, t] += joins
                    tasks[c, t] -= joins
                    status[p, k] = HANDED_OVER
                if status[p, k] != FAILED:
                    performer[p, k] = d
                    break
            if status[p, k] == FAILED:
                tasks[c, t] -= joins  # a failed task holds no share of its child's amount
                counts[1] += 1
            else:
                counts[2] += 1


@njit(cache=True, inline="always")
def perform_composite_task_failing(ctv, child_of, task_types, weights, task_share, per_weight, needs, tasks, env,
                                   status, performer, lent, values, shares, w, a):
    """:func:`perform_composite_task_resources` where tasks can fail (after :func:`resolve_failures`): returns ``taq``.

    A failed task's quality is 0 and its returned value 0 (the failure is its answer). A task performed by its own
    child gets its allocation less what the child lent of the type; a borrowing one exactly the need of the last
    resource (its other resources its child's own); a handed-over one its neighbour's amount, less what the
    neighbour lent, its quality times ``1 - handover_cost``; each shares its performer's amount with ``tasks``
    others (:func:`resolve_failures`'s). ``weights``, ``per_weight`` are ``(children, R, n_types)``, ``needs
    (n_types, R)`` (read with several resources only); ``w``, ``a`` scratch of ``R``.
    """
    taq = 0.0
    n_resources = w.shape[0]
    last = n_resources - 1
    for k in range(ctv.shape[0]):
        if status[k] == FAILED:
            for r in range(n_resources):
                shares[k, r] = 0.0
            continue
        c = child_of[k] if status[k] == BORROWED else performer[k]
        t = task_types[k]
        for r in range(n_resources):
            w[r] = task_share[c] * weights[c, r, t]
            a[r] = per_weight[c, r, t]
        sharing = max(tasks[c, t], 1.0)
        if status[k] == BORROWED:
            w[last] = env.need * sharing / a[last]
        elif lent[c, t] > 0.0:
            w[last] -= lent[c, t] / a[last]
        if n_resources == 1:
            w_eff, a_eff = w[0], a[0]
            shares[k, 0] = 1.0
        else:
            w_eff, a_eff = combined_resources(w, a, needs[t], env.resource_combination, shares[k])
        quality = atomic_task_quality(w_eff, a_eff, sharing, env)
        if status[k] == HANDED_OVER:
            quality *= 1.0 - env.handover_cost
        taq += ctv[k] * quality
    for k in range(ctv.shape[0]):
        values[k] = 0.0 if status[k] == FAILED else taq * ctv[k]
    return taq


@njit(cache=True)
def update_estimates(estimates, tries, child_of, values, taq, per_composite):
    """A parent's running mean of what each child gave back.

    Per composite that is the composite quality, per task each atomic task's absolute value. The
    first return replaces the initial estimate.
    """
    if per_composite:
        _running_mean(estimates[0], tries[0], child_of[0], taq)
    else:
        for k in range(child_of.shape[0]):
            _running_mean(estimates[k], tries[k], child_of[k], values[k])


@njit(cache=True)
def _running_mean(estimates, tries, c, value):
    tries[c] += 1
    if tries[c] == 1:
        estimates[c] = value
    else:
        estimates[c] += (value - estimates[c]) / tries[c]
