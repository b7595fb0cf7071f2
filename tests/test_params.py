"""``configs/planner.yaml`` (:mod:`footstep_gym.planners.params`): every key is read by the planners, the
switches of ``additions`` are booleans, the paper's policies switch all of them off and follow the paper where it
specifies something else than our defaults (``PAPER_READINGS``, docs/model.md §5.3: the reachable T0, the bisection's
N, one RRT sample at a time, the node checked now and after T, a constant penalty), each reading doing what it says.

The "every key read" test runs each registered policy for a few steps with a config whose
sections record which of their fields the code reads: a key the code never reads (a
constant that lives in code instead, or a leftover) fails it by name.
"""

from __future__ import annotations

import dataclasses
import types
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import config as fs_config
from footstep_gym import make_policy
from footstep_gym.errors import ConfigError
from footstep_gym.kernels import select_kernels
from footstep_gym.planners import POLICIES, load_planner_config
from footstep_gym.planners.params import AdditionsParams, PlannerConfig


class RecordingSection:
    """Stands for one config section: attribute reads are recorded as ``"<section>.<key>"``; methods of the
    section run with this object as ``self``, so what they read is recorded too."""

    def __init__(self, name: str, section: Any, seen: set[str]) -> None:
        object.__setattr__(self, "_name", name)
        object.__setattr__(self, "_section", section)
        object.__setattr__(self, "_seen", seen)
        object.__setattr__(self, "_fields", {f.name for f in dataclasses.fields(section)})

    def __getattr__(self, key: str) -> Any:
        if key in self._fields:
            self._seen.add(f"{self._name}.{key}")
            return getattr(self._section, key)
        attr = getattr(type(self._section), key)
        return types.MethodType(attr, self) if callable(attr) else attr


class RecordingConfig:
    """A :class:`PlannerConfig` whose sections are :class:`RecordingSection` s."""

    def __init__(self, cfg: PlannerConfig, seen: set[str]) -> None:
        for f in dataclasses.fields(cfg):
            setattr(self, f.name, RecordingSection(f.name, getattr(cfg, f.name), seen))


def all_keys() -> set[str]:
    data = fs_config.read_yaml("planner.yaml")
    return {f"{section}.{key}" for section, keys in data.items() for key in keys}


def test_recording_section_records_reads_and_method_reads():
    seen: set[str] = set()
    cfg = RecordingConfig(load_planner_config(), seen)
    assert cfg.rrt.iterations > 0
    cfg.pso.delta_bounds()
    assert seen == {"rrt.iterations", "pso.d_front_stride_m", "pso.d_side_stride_m", "pso.d_turn_deg",
                    "pso.d_t_ss_s", "pso.d_t_ds_s"}


def test_every_key_of_planner_yaml_is_read_by_the_planners():
    """Construct each registered policy with a recording config and plan a few steps in each scene."""
    from footstep_gym.registry import resolve

    seen: set[str] = set()
    base = load_planner_config()
    # lookahead keeps the greedy plan while it holds (as in the first steps here): once more with its own search
    own_search = dataclasses.replace(base, lookahead=dataclasses.replace(base.lookahead, greedy_seed=False))
    runs = [(name, base) for name in POLICIES] + [("lookahead", own_search)]
    # The noisy door: the tracker's keys are read once the readings show noise.
    for env_id, kwargs in (("FootstepDoor-v0", {"door_speed": 17.0}), ("FootstepCrowd-v0", {}),
                           ("FootstepDoor-v0", {"tier": "noise", "tier_cell": "train"})):
        env = gym.make(env_id, **kwargs)
        for name, config in runs:
            if resolve(name).reads_truth:  # the oracle acts only bound to its truth, on the numpy route (its own tests)
                continue
            if name.startswith("null-"):  # the null baselines read no config (tests/test_null_baselines.py)
                continue
            policy = make_policy(name, env.unwrapped.robot, seed=0, config=RecordingConfig(config, seen))
            obs, _ = env.reset(seed=0)
            policy.reset(seed=0)
            for _ in range(3):
                obs, *_ = env.step(policy.act(obs, env.unwrapped.sensing()))
        env.close()
    unread = sorted(all_keys() - seen)
    assert not unread, f"keys of configs/planner.yaml never read by the planners: {unread}"


def test_yaml_keys_are_the_dataclass_fields():
    cfg = load_planner_config()
    fields = {f"{s.name}.{f.name}" for s in dataclasses.fields(cfg) for f in dataclasses.fields(getattr(cfg, s.name))}
    assert fields == all_keys()


def test_additions_are_booleans_and_all_on_by_default():
    cfg = load_planner_config()
    values = dataclasses.asdict(cfg.additions)
    assert values and all(v is True for v in values.values())
    with pytest.raises(ConfigError, match="additions.waiting_walks must be true or false"):
        load_planner_config({"additions_waiting_walks": 1})
    with pytest.raises(ConfigError, match="unknown key"):
        load_planner_config({"additions": {"no_such_switch": False}})


def test_paper_policies_switch_every_addition_off():
    switches = {f.name for f in dataclasses.fields(AdditionsParams)}
    for name in ("paper-period-aware", "paper-fixed-period"):
        policy = make_policy(name, seed=0)
        assert policy.name == name
        assert not any(getattr(policy.config.additions, s) for s in switches)
    assert make_policy("paper-period-aware").vary_period and not make_policy("paper-fixed-period").vary_period


def test_overrides_apply_on_top_of_a_policys_own_switches():
    policy = make_policy("paper-period-aware", additions_fallback=True, rrt_iterations=50)
    assert policy.config.additions.fallback and not policy.config.additions.waiting_walks
    assert policy.config.rrt.iterations == 50
    policy = make_policy("period-aware", additions={"centred_period": False})
    assert not policy.config.additions.centred_period and policy.config.additions.waiting_walks


# ====================================================================== the paper's readings (docs/model.md §5.3)
def test_paper_policies_follow_the_paper_where_it_differs_from_our_defaults():
    """``paper-*``: the yaml, every addition off, and :data:`PAPER_READINGS` on top; our planners: the yaml as is."""
    from footstep_gym.planners.registry import PAPER_READINGS

    yaml_cfg = load_planner_config()
    assert PAPER_READINGS == {"period_search": {"iterations": 6}, "rrt": {"batch_size": 1},
                              "prediction": {"check": "node"}, "pso": {"violation_weight": 0.0}}
    for name in ("paper-period-aware", "paper-fixed-period"):
        cfg = make_policy(name).config
        for section, values in PAPER_READINGS.items():
            for key, value in values.items():
                assert getattr(getattr(cfg, section), key) == value, (name, section, key)
                assert getattr(getattr(yaml_cfg, section), key) != value, (section, key)  # a reading, not the default
    for name in ("period-aware", "fixed-period", "pso-only"):
        assert make_policy(name).config == yaml_cfg, name
    # §2.2's T0 (the shortest period reachable from the CoM state) is every planner's: so period-aware-no-lipm-windows
    # is the paper's T0 without the first-stride window, as paper-period-aware-with-lipm-windows is the window added.
    assert yaml_cfg.period_search.t0_reachable
    for name in ("paper-period-aware", "period-aware-no-lipm-windows"):
        assert make_policy(name).config.period_search.t0_reachable, name


@pytest.mark.parametrize("name, t0", [("paper-period-aware-t0-0.3", 0.3), ("paper-period-aware-t0-0.37", 0.37)])
def test_paper_planner_with_a_fixed_t0(name, t0):
    """``paper-period-aware-t0-<s>``: the paper's planner, T0 fixed at ``<s>`` s instead of the reachable one."""
    policy = make_policy(name, seed=0)
    paper = make_policy("paper-period-aware").config
    assert policy.name == name and policy.vary_period
    assert (policy.config.period_search.t0_reachable, policy.config.period_search.t0_s) == (False, t0)
    assert dataclasses.replace(policy.config.period_search, t0_reachable=True, t0_s=paper.period_search.t0_s) \
        == paper.period_search
    assert (policy.config.rrt, policy.config.pso, policy.config.additions) == (paper.rrt, paper.pso, paper.additions)


@pytest.mark.parametrize("name", ["period-aware-t0-0.3", "paper-fixed-period-t0-0.3", "paper-period-aware-t0-x",
                                  "paper-period-aware-t0--0.3", "paper-period-aware-t0-inf", "pso-only-t0-0.3"])
def test_fixed_t0_names_need_a_paper_period_search_and_a_positive_time(name):
    with pytest.raises(ValueError, match="unknown policy.*paper-period-aware-t0-0.3"):
        make_policy(name)


@pytest.mark.parametrize("override, match", [
    ({"prediction_check": "body"}, "prediction.check must be one of path, node"),
    ({"period_search_t0_reachable": 1}, "period_search.t0_reachable must be true or false"),
])
def test_reading_switches_are_validated_at_load(override, match):
    with pytest.raises(ConfigError, match=match):
        load_planner_config(override)


def test_kernels_compiled_is_a_boolean_on_by_default_and_reaches_both_searches():
    """``kernels.compiled``: the compiled kernels (default) or the numpy ones, chosen once by the planner for the
    period search's walks and the RRT alike (``tests/test_kernels.py`` plans the same episodes both ways)."""
    assert load_planner_config().kernels.compiled is True
    for compiled in (True, False):
        policy = make_policy("period-aware", seed=0, kernels_compiled=compiled)
        assert policy.kernels is select_kernels(compiled)
        assert policy.period_search.kernels is policy.kernels and policy.path_search.rrt.kernels is policy.kernels
    assert make_policy("paper-period-aware", kernels={"compiled": False}).path_search.rrt.kernels.name == "numpy"
    with pytest.raises(ConfigError, match="kernels.compiled must be true or false"):
        load_planner_config({"kernels_compiled": "no"})


def _door_start(steps=0):
    env = gym.make("FootstepDoor-v0", door_speed=17.0)
    env.reset(seed=0)
    for _ in range(steps):
        env.step(env.unwrapped.robot.nominal_command)
    snap, robot = env.unwrapped.sensing(), env.unwrapped.robot
    env.close()
    return robot, snap


class _Blocked:
    """A body check where nothing is ever free; records the times it was asked about."""

    def __init__(self):
        self.times = []

    def free(self, points, times, normals, period):
        self.times.extend(np.asarray(times, dtype=float).reshape(-1).tolist())
        return np.zeros(len(np.asarray(points).reshape(-1, 2)), dtype=bool)


@pytest.mark.parametrize("reachable", [True, False])
def test_reachable_t0_is_the_shortest_period_one_step_can_reach(reachable):
    """From the steady gait of the env's start, the LIPM reaches T_SS 0.17 s (T = 0.37 s) in one step, not 0.1 s: the
    text's T0 is the first period of the floor grid at or above that (0.4 s); the fixed reading stays at 0.3 s."""
    from footstep_gym.planners.period_search import PeriodSearch, shortest_feasible_period
    from footstep_gym.planners.registry import PAPER
    from footstep_gym.planners.walks import walk_start

    robot, snap = _door_start()
    cfg = load_planner_config({"period_search_t0_reachable": reachable}, defaults={"additions": PAPER})
    start = walk_start(snap, 0.5 * robot.nominal_side_stride)
    choice = PeriodSearch(robot, cfg, select_kernels(False))(snap, start, _Blocked())  # a toy body: numpy
    ps = cfg.period_search
    floor = shortest_feasible_period(robot, snap.com_local, snap.vel_local, snap.support_side,
                                     (float(snap.previous_command[0]), cfg.rrt.step_size_m), ps.t0_s,
                                     robot.nominal_period, ps.floor_grid)
    assert floor == pytest.approx(0.4)
    assert choice.floor == pytest.approx(floor if reachable else ps.t0_s)
    assert choice.period == choice.floor and not choice.any_free  # nothing free: the search returns T0


@pytest.mark.parametrize("check", ["path", "node"])
def test_one_step_check_asks_about_the_node_now_and_after_t_or_the_body_path(check):
    """The paper's fan (long look-ahead off): ``prediction.check: node`` asks about each next node at 0 and at T only;
    ``path`` about the body's path at ``edge_samples`` instants over [0, T]."""
    from footstep_gym.planners.period_search import PeriodSearch
    from footstep_gym.planners.registry import PAPER
    from footstep_gym.planners.walks import walk_start

    robot, snap = _door_start()
    cfg = load_planner_config({"prediction_check": check}, defaults={"additions": PAPER})
    walks = PeriodSearch(robot, cfg, select_kernels(False)).walks(  # a toy body: numpy
        snap, walk_start(snap, 0.5 * robot.nominal_side_stride), _Blocked(), (0,), (1.0,))
    body = walks.body
    assert walks(0.6)  # every node collides
    expected = {0.0, 0.6} if check == "node" else {0.0, 0.3, 0.6}
    assert set(np.round(body.times, 9)) == expected
    if check == "node":
        assert len(body.times) == 2 * cfg.period_search.fan_directions


class _Gate:
    """Blocks ``x >= x0`` until ``until`` [s]: a node beyond ``x0`` is blocked now and free one period later."""

    def __init__(self, x0, until):
        self.x0, self.until = x0, until

    def free(self, points, times, normals, period):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return ~((p[:, 0] >= self.x0) & (np.asarray(times, dtype=float).reshape(-1) < self.until))


def test_rrt_node_check_refuses_a_node_blocked_now():
    """Not time-aware (the paper's RRT): ``check_node`` tests every node now and after T, so a zone that clears before
    T still blocks it; the body-path check looks at T only and grows into the zone."""
    from footstep_gym.planners.rrt import ModifiedRRT
    from footstep_gym.planners.walks import walk_start

    robot, snap = _door_start()
    start = walk_start(snap, 0.5 * robot.nominal_side_stride)
    gate = _Gate(float(start.node[0]) + 0.05, until=0.5)
    reached = {}
    for check_node in (False, True):
        rrt = ModifiedRRT(robot, iterations=200, batch_size=1, step_size=0.1, goal_sample_rate=0.2, n_paths=3,
                          sample_margin=0.5, edge_samples=3, time_aware=False, check_node=check_node,
                          kernels=select_kernels(False))
        rrt.plan(start, start.node + [0.6, 0.0], 0.05, gate, 0.8, np.random.default_rng(0))
        reached[check_node] = float(rrt.tree.xy[: rrt.tree.n, 0].max())
    assert reached[True] < gate.x0 <= reached[False]


@pytest.mark.parametrize("time_aware", [True, False])
def test_compiled_rrt_with_node_check_grows_the_numpy_tree(time_aware):
    """``check_node`` in the compiled kernels' ``extend_tree`` against the numpy kernels, one sample at a time
    (``batch_size: 1``, the paper's reading): the same nodes, parents and goal nodes from the same generator."""
    from footstep_gym.planners.prediction import BodyModel, ObstaclePredictor
    from footstep_gym.planners.rrt import ModifiedRRT
    from footstep_gym.planners.walks import walk_start

    robot, snap = _door_start(steps=6)
    start = walk_start(snap, 0.5 * robot.nominal_side_stride)
    body = BodyModel(ObstaclePredictor(snap, horizon=30.0), robot, 0.01, sway=False)
    trees = []
    for compiled in (False, True):
        rrt = ModifiedRRT(robot, iterations=300, batch_size=1, step_size=0.1, goal_sample_rate=0.2, n_paths=3,
                          sample_margin=0.5, edge_samples=3, time_aware=time_aware, check_node=True,
                          kernels=select_kernels(compiled))
        rrt.plan(start, snap.goal, snap.goal_tolerance, body, 0.5, np.random.default_rng(3))
        trees.append((rrt.tree, list(rrt.goal_nodes)))
    (want, want_goals), (got, got_goals) = trees
    assert got.n == want.n > 20 and got_goals == want_goals
    assert want.n < 301  # the door refused some samples
    for name in ("side", "parent", "depth"):
        np.testing.assert_array_equal(getattr(got, name)[: got.n], getattr(want, name)[: want.n], err_msg=name)
    for name in ("xy", "heading", "cost", "body"):  # the compiled and numpy arithmetic agree to rounding
        np.testing.assert_allclose(getattr(got, name)[: got.n], getattr(want, name)[: want.n], rtol=0, atol=1e-12)


def test_paper_planner_plans_with_one_sample_at_a_time():
    """``rrt.batch_size: 1`` (Algorithm 2): the paper's planner grows its tree sample by sample and walks."""
    env = gym.make("FootstepCrossing-v0", crossing_x=5.0)
    policy = make_policy("paper-period-aware", env.unwrapped.robot, seed=0)
    assert policy.path_search.rrt.batch_size == 1 and policy.path_search.rrt.check_node
    obs, _ = env.reset(seed=0)
    policy.reset(seed=0)
    for _ in range(3):
        obs, _, terminated, _, info = env.step(policy.act(obs, env.unwrapped.sensing()))
        assert not terminated and policy.last_info["rrt_nodes"] > 1
    env.close()
