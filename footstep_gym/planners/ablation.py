"""The ablation of our additions: ``period-aware`` with each switch of ``additions`` off in turn.

Every switch of ``configs/planner.yaml``'s ``additions`` section (read from
:class:`~.params.AdditionsParams`, so a new switch joins the ablation by itself) gives
one variant, named ``period-aware-no-<switch>`` with the switch's underscores as
hyphens (``period-aware-no-waiting-walks``, ``period-aware-no-centred-period``, ...).
:func:`footstep_gym.make_policy` builds any of them::

    for name in ablation_variants():
        policy = make_policy(name, robot, seed=s)

The list starts with the base policy itself and ends with the paper's planner (every
switch off), so that one table shows what each addition buys and what all of them do.
"""

from __future__ import annotations

import dataclasses

from footstep_gym.planners.params import AdditionsParams
from footstep_gym.planners.reference import variant_name

#: The policy the additions are taken from, one at a time.
BASE = "period-aware"
#: The same planner with every addition off.
PAPER_POLICY = "paper-period-aware"


def switches() -> tuple[str, ...]:
    """The keys of the ``additions`` section, in the YAML's order."""
    return tuple(f.name for f in dataclasses.fields(AdditionsParams))


def ablation_variants(base: str = BASE, *, with_base: bool = True, with_paper: bool = True) -> tuple[str, ...]:
    """Policy names for :func:`footstep_gym.make_policy`: ``base``, then ``base`` with each switch off,
    then the paper's planner (``paper-period-aware``; only for the default ``base``)."""
    names = [variant_name(base, s) for s in switches()]
    if with_base:
        names.insert(0, base)
    if with_paper and base == BASE:
        names.append(PAPER_POLICY)
    return tuple(names)
