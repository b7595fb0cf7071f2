"""The ablation of our additions, both ways: ours less one addition, and the paper's planner plus one.

Every switch of ``configs/planner.yaml``'s ``additions`` section (read from
:class:`~.params.AdditionsParams`, so a new switch joins the ablation by itself) gives
two variants, named with the switch's underscores as hyphens:

* ``period-aware-no-<switch>``: our planner with that addition off. What it loses shows
  whether the addition is *necessary* (given all the others);
* ``paper-period-aware-with-<switch>``: the paper's planner (every addition off, the paper's
  readings of :data:`~.registry.PAPER_READINGS`) with that addition on. What it gains shows
  whether the addition alone is *sufficient* to rescue the paper's planner.

:func:`footstep_gym.make_policy` builds any of them::

    for name in ablation_variants():
        policy = make_policy(name, robot, seed=s)

The list starts with the base policy itself, then its ``-no-`` variants, then the paper's
planner (every switch off) and its ``-with-`` variants, so that one table shows what each
addition buys in both directions.
"""

from __future__ import annotations

import dataclasses

from footstep_gym.planners.params import AdditionsParams
from footstep_gym.planners.registry import variant_name, with_name

#: The policy the additions are taken from, one at a time.
BASE = "period-aware"
#: The same planner with every addition off; the additions are added to it one at a time.
PAPER_POLICY = "paper-period-aware"


def switches() -> tuple[str, ...]:
    """The keys of the ``additions`` section, in the YAML's order."""
    return tuple(f.name for f in dataclasses.fields(AdditionsParams))


def rescue_variants(paper: str = PAPER_POLICY, *, with_paper: bool = True) -> tuple[str, ...]:
    """``paper`` (if ``with_paper``), then ``paper`` with each switch on: ``paper-period-aware-with-<switch>``."""
    names = [with_name(paper, s) for s in switches()]
    if with_paper:
        names.insert(0, paper)
    return tuple(names)


def ablation_variants(base: str = BASE, *, with_base: bool = True, with_paper: bool = True) -> tuple[str, ...]:
    """Policy names for :func:`footstep_gym.make_policy`: ``base``, then ``base`` with each switch off; for the
    default ``base`` and ``with_paper``, then the paper's planner and the paper's planner with each switch on
    (:func:`rescue_variants`)."""
    names = [variant_name(base, s) for s in switches()]
    if with_base:
        names.insert(0, base)
    if with_paper and base == BASE:
        names.extend(rescue_variants())
    return tuple(names)
