"""The planners' registry: :data:`POLICIES`, one :class:`PolicySpec` per name, and the names of their variants.

A :class:`PolicySpec` is a planner class, the ``configs/planner.yaml`` values that make it, and a
one-line description; :func:`policy_spec` resolves a registered name or a variant
(``<planner>-no-<switch>``, ``<planner>-with-<switch>``, ``paper-period-aware-t0-<s>``).
The registry sits below the planners it lists (:mod:`.staged`, :mod:`.oracle`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from footstep_gym.planners.classical import CLASSICAL_POLICIES
from footstep_gym.planners.null import NULL_POLICIES
from footstep_gym.planners.oracle import DESCRIPTION as ORACLE_DESCRIPTION
from footstep_gym.planners.lattice import LatticePlanner
from footstep_gym.planners.lookahead import LookaheadPlanner
from footstep_gym.planners.oracle import OraclePlanner
from footstep_gym.planners.oracle_lookahead import BUDGET as ORACLE_LOOKAHEAD_BUDGET
from footstep_gym.planners.oracle_lookahead import DESCRIPTION as ORACLE_LOOKAHEAD_DESCRIPTION
from footstep_gym.planners.oracle_lookahead import OracleLookaheadPlanner
from footstep_gym.planners.params import AdditionsParams, PlannerConfig, load_planner_config
from footstep_gym.planners.reactive import REACTIVE_POLICIES
from footstep_gym.planners.staged import FixedPeriodPlanner, PeriodAwarePlanner, PSOOnlyPlanner, SnapshotPlanner
from footstep_gym.policy import Policy
from footstep_gym.robot import Robot


@dataclass(frozen=True)
class PolicySpec:
    """A registered planner: its class, the ``configs/planner.yaml`` overrides that make it, what it is.

    ``planner``: a :class:`~footstep_gym.policy.Policy` subclass built as ``planner(robot, config, seed,
    name)`` (a :class:`~footstep_gym.planners.staged.SnapshotPlanner` is; checked here, when the entry is
    made); a policy with another constructor runs without registration (``eval_planner.py --policy
    module:attr``, :mod:`footstep_gym.registry`). ``additions``: switches of the ``additions`` section
    set on top of the YAML (e.g. all off for the paper's planners); ``readings``: other keys,
    ``{section: {key: value}}`` (e.g. :data:`PAPER_READINGS`); ``description``: one line
    (``eval_planner.py --help``).
    """

    planner: type[SnapshotPlanner]
    additions: Mapping[str, bool] = field(default_factory=dict)
    readings: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    description: str = ""

    def __post_init__(self) -> None:
        import inspect

        cls = self.planner
        if not (isinstance(cls, type) and issubclass(cls, Policy)):
            raise TypeError(f"PolicySpec: {cls!r} is not a footstep_gym.policy.Policy subclass")
        try:
            inspect.signature(cls).bind("robot", "config", "seed", "name")
        except TypeError:
            raise TypeError(f"PolicySpec: {cls.__name__}{inspect.signature(cls)} cannot be built as "
                            f"{cls.__name__}(robot, config, seed, name); a policy with another constructor runs "
                            "unregistered: --policy module:attr") from None

    def defaults(self) -> dict[str, dict[str, Any]]:
        """The policy's own config values, ``{section: {key: value}}``, for :func:`load_planner_config`."""
        out = {section: dict(values) for section, values in self.readings.items()}
        if self.additions:
            out["additions"] = {**out.get("additions", {}), **self.additions}
        return out

    def build(self, name: str, robot: Robot, seed: int | None = None, config: PlannerConfig | None = None,
              **overrides: Any) -> Policy:
        """The planner named ``name`` (this spec's registry name) for ``robot``: ``configs/planner.yaml`` with
        this spec's values and ``overrides`` on top, or ``config`` as given (exclusive with ``overrides``).

        What :func:`footstep_gym.make_policy` calls; use that (it takes any policy name and a robot profile).
        """
        if config is None or overrides:
            if config is not None:
                raise ValueError("pass either config or overrides, not both")
            config = load_planner_config(overrides, defaults=self.defaults())
        return self.planner(robot, config, seed, name)


#: Every switch of ``additions`` off: the paper's planner, nothing else (docs/model.md §5).
PAPER = {f.name: False for f in dataclasses.fields(AdditionsParams)}

#: Where the paper specifies something other than our defaults of ``configs/planner.yaml``, the paper's
#: planners follow the paper (docs/model.md §5.3, one row per deviation, with what the paper says):
PAPER_READINGS: dict[str, dict[str, Any]] = {
    # (§2.2's T0, "a short walking period that the robot can use", is the YAML's period_search.t0_reachable.)
    # N is not given; Table 2's periods move in 10-20 ms steps: (T_n - T0) / 2^6 = 6 ms.
    "period_search": {"iterations": 6},
    # Algorithm 2 draws and extends one sample at a time.
    "rrt": {"batch_size": 1},
    # Algorithm 2 step 11 tests "the selected node"; §2.2 checks "the predicted position of the obstacle and the
    # current obstacle position".
    "prediction": {"check": "node"},
    # Eq. (7): P is a constant when infeasible (its value 1 cannot be meant: Table 2's own repairs cost more).
    "pso": {"violation_weight": 0.0},
}

#: The registry of scripted policies, by name.
POLICIES: dict[str, PolicySpec] = {
    "period-aware": PolicySpec(
        PeriodAwarePlanner,
        description="the paper's planner: binary search for the period, modified RRT, PSO (with our additions)"),
    "fixed-period": PolicySpec(FixedPeriodPlanner, description="the same planner with the period held at the "
                                                               "nominal T_n"),
    "pso-only": PolicySpec(PSOOnlyPlanner, description="PSO alone over the whole command box"),
    "paper-period-aware": PolicySpec(PeriodAwarePlanner, PAPER, PAPER_READINGS,
                                     description="the paper's planner as written: Algorithms 1-2, PSO when "
                                                 "infeasible, none of our additions"),
    "paper-fixed-period": PolicySpec(FixedPeriodPlanner, PAPER, PAPER_READINGS,
                                     description="the paper's planner as written, the period held at T_n"),
    "lattice": PolicySpec(LatticePlanner, description="A* over a discrete footstep set x walking periods in space "
                                                       "and time (the discrete search the paper argues against)"),
    "lookahead": PolicySpec(LookaheadPlanner, description="receding horizon: K footsteps with their periods optimised "
                                                           "by the cross-entropy method, the first executed"),
    # An upper bound, not a baseline: period-aware told the truth (reads_truth; tables mark it "(upper bound)").
    # It reads the noise-free truth: nothing to track.
    "oracle": PolicySpec(OraclePlanner, additions={"tracking": False}, readings={"kernels": {"compiled": False}},
                         description=ORACLE_DESCRIPTION),
    # The solvability reference (protocol 3): lookahead told the truth, seeded by the oracle, a larger budget.
    "oracle-lookahead": PolicySpec(OracleLookaheadPlanner, additions={"tracking": False},
                                   readings={"kernels": {"compiled": False}, "lookahead": ORACLE_LOOKAHEAD_BUDGET},
                                   description=ORACLE_LOOKAHEAD_DESCRIPTION),
    # Baselines that sense but do not plan (footstep_gym.planners.reactive: the normalised score's lower anchor) and
    # classical crowd-navigation methods made to walk (footstep_gym.planners.classical): configs/baselines.yaml.
    **{name: PolicySpec(cls, description=cls.description)  # type: ignore[arg-type]
       for name, cls in {**REACTIVE_POLICIES, **CLASSICAL_POLICIES}.items()},
    # The floor, not planners: blind policies (footstep_gym.planners.null) no benchmark cell may let succeed.
    **{name: PolicySpec(cls, description=cls.description)  # type: ignore[arg-type]
       for name, cls in NULL_POLICIES.items()},
}

#: ``<policy>-no-<switch>``: a staged policy of :data:`POLICIES` with one switch of ``additions`` off.
VARIANT_SEPARATOR = "-no-"
#: ``<policy>-with-<switch>``: a staged policy of :data:`POLICIES` with one switch of ``additions`` on (the
#: paper's planners plus one of our additions: which ones rescue it).
WITH_SEPARATOR = "-with-"
#: ``<paper policy>-t0-<seconds>``: a paper planner with T0 fixed (``period_search.t0_reachable`` off, ``t0_s``).
T0_SEPARATOR = "-t0-"


def switch_of(label: str) -> str:
    """The ``additions`` key a variant label names (``waiting-walks`` -> ``waiting_walks``)."""
    return label.replace("-", "_")


def variant_name(policy: str, switch: str) -> str:
    """The name of ``policy`` with switch ``switch`` off: ``period-aware`` + ``waiting_walks`` ->
    ``period-aware-no-waiting-walks``."""
    return f"{policy}{VARIANT_SEPARATOR}{switch.replace('_', '-')}"


def with_name(policy: str, switch: str) -> str:
    """The name of ``policy`` with switch ``switch`` on: ``paper-period-aware`` + ``fallback`` ->
    ``paper-period-aware-with-fallback``."""
    return f"{policy}{WITH_SEPARATOR}{switch.replace('_', '-')}"


def fixed_t0_name(policy: str, t0_s: float) -> str:
    """The name of paper planner ``policy`` with T0 fixed at ``t0_s`` [s]: ``paper-period-aware-t0-0.3``."""
    return f"{policy}{T0_SEPARATOR}{t0_s:g}"


def _fixed_t0_spec(name: str) -> PolicySpec | None:
    """``<paper policy>-t0-<seconds>``: that policy with ``period_search.t0_reachable`` off and ``t0_s`` set."""
    base, sep, value = name.rpartition(T0_SEPARATOR)
    spec = POLICIES.get(base)
    if not sep or spec is None or spec.planner is not PeriodAwarePlanner or spec.additions.get("lipm_windows", True):
        return None  # only a period-searching planner without the LIPM's windows (which set T0 themselves)
    try:
        t0 = float(value)
    except ValueError:
        return None
    if not (math.isfinite(t0) and t0 > 0):
        return None
    readings = {section: dict(values) for section, values in spec.readings.items()}
    readings["period_search"] = {**readings.get("period_search", {}), "t0_reachable": False, "t0_s": t0}
    return PolicySpec(spec.planner, spec.additions, readings, f"{base} with T0 fixed at {t0:g} s")


def _switched_spec(name: str) -> PolicySpec | None:
    """``<staged policy>-no-<switch>`` (that switch off) or ``<staged policy>-with-<switch>`` (on), else ``None``."""
    switches = [f.name for f in dataclasses.fields(AdditionsParams)]
    for separator, on, word in ((VARIANT_SEPARATOR, False, "off"), (WITH_SEPARATOR, True, "on")):
        base, sep, label = name.partition(separator)
        if sep and base in POLICIES and switch_of(label) in switches:
            spec = POLICIES[base]
            if issubclass(spec.planner, PeriodAwarePlanner):
                return PolicySpec(spec.planner, {**spec.additions, switch_of(label): on}, spec.readings,
                                  f"{base} with the addition {switch_of(label)} {word}")
    return None


def policy_spec(name: str) -> PolicySpec:
    """The :class:`PolicySpec` of a registered name, of a variant ``<policy>-no-<switch>`` /
    ``<policy>-with-<switch>`` or of ``<paper policy>-t0-<seconds>``."""
    if name in POLICIES:
        return POLICIES[name]
    switched = _switched_spec(name)
    if switched is not None:
        return switched
    fixed = _fixed_t0_spec(name)
    if fixed is not None:
        return fixed
    switches = [f.name for f in dataclasses.fields(AdditionsParams)]
    variants = ", ".join(variant_name("period-aware", s) for s in switches)
    raise ValueError(f"unknown policy {name!r}; known: {', '.join(sorted(POLICIES))}, <staged policy>-no-<switch> "
                     f"such as {variants}, <staged policy>-with-<switch> such as "
                     f"{with_name('paper-period-aware', switches[0])}, and {fixed_t0_name('paper-period-aware', 0.3)} "
                     f"(the paper's planner with T0 fixed at 0.3 s)")
