"""One policy interface and one factory (issue 18 §2): ``footstep_gym.policy.Policy``, ``footstep_gym.make_policy``.

Every name is listed once with its description: planners in ``footstep_gym.planners.POLICIES`` (``PolicySpec``),
agents in ``footstep_gym.rl.AGENTS`` (``AgentEntry``). No module reaches into another's private helpers.
"""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import pytest

import footstep_gym
from footstep_gym import make_policy, policies
from footstep_gym.planners import POLICIES, PolicySpec
from footstep_gym.policy import Policy
from footstep_gym.rl import AGENTS, AgentEntry, ZooAgent

REPO = Path(__file__).resolve().parents[1]


def test_one_factory_and_one_interface():
    import footstep_gym.evaluation as evaluation
    import footstep_gym.planners as planners

    assert footstep_gym.make_policy is policies.make_policy and "make_policy" in footstep_gym.__all__
    for package in (planners, evaluation):
        assert not hasattr(package, "make_policy") and "make_policy" not in package.__all__
    assert "Policy" not in planners.__all__  # the interface lives in footstep_gym.policy
    for gone in ("footstep_gym.training", "footstep_gym.evaluation.policies", "footstep_gym.evaluation.agents"):
        assert importlib.util.find_spec(gone) is None, gone  # RL code is in footstep_gym.rl
    assert issubclass(ZooAgent, Policy)
    for spec in POLICIES.values():
        assert issubclass(spec.planner, Policy)


def test_every_name_is_listed_once_with_a_description():
    assert not set(POLICIES) & set(AGENTS)
    assert policies.policy_names() == (*POLICIES, *AGENTS)
    for name, spec in POLICIES.items():
        assert isinstance(spec, PolicySpec) and spec.description and policies.describe(name) == spec.description
    for name, entry in AGENTS.items():
        assert isinstance(entry, AgentEntry) and entry.description and policies.describe(name) == entry.description
    assert AGENTS["ppo-fixed-period"].algo == "ppo" and AGENTS["ppo-fixed-period"].folder == "ppo-fixed-period"
    assert AGENTS["ppo-all"].folder == "ppo" and AGENTS["ppo-all"].trained_on == "FootstepMix-v0"
    assert policies.describe("period-aware-no-fallback") == "period-aware with the addition fallback off"
    assert policies.describe("paper-period-aware-t0-0.3") == "paper-period-aware with T0 fixed at 0.3 s"


@pytest.mark.parametrize("name", [*POLICIES, "period-aware-no-waiting-walks", "fixed-period-no-fallback",
                                  "paper-period-aware-t0-0.25"])
def test_the_factory_makes_every_planner_and_variant(name):
    policy = make_policy(name, seed=0)
    assert isinstance(policy, Policy) and policy.name == name and policies.is_policy(name)
    assert policy.last_info == {}


def test_the_factory_takes_a_robot_profile_and_planner_options():
    from footstep_gym.robot import load_robot

    assert make_policy("paper-period-aware", "darwin-op", seed=0).robot == load_robot("darwin-op")
    policy = make_policy("period-aware", {"body_radius": 0.12}, rrt_iterations=50)
    assert policy.robot.body_radius == 0.12 and policy.config.rrt.iterations == 50
    with pytest.raises(ValueError, match="pass either config or overrides"):
        make_policy("period-aware", config=policy.config, rrt_iterations=50)


@pytest.mark.parametrize("call, message", [
    (lambda: make_policy("teleport"), r"unknown policy 'teleport'; known: .*period-aware-no-waiting-walks.*"
                                      r"paper-period-aware-t0-0.3.*trained agents \(with run=\): ppo, ppo-all, sac, "
                                      r"ppo-fixed-period, td3, ppo-wide, ppo-noisy, ppo-lstm, sac-sb3, td3-b2048, "
                                      r"or agent:NAME with run=PATH"),
    (lambda: make_policy("ppo"), r"policy 'ppo' is a trained agent: pass run= .*agent_runs\('ppo', env_id\)"),
    (lambda: make_policy("agent:mine"), r"policy 'agent:mine' is a trained agent: pass run="),
    (lambda: make_policy("ppo", run="x", rrt_iterations=5), r"planner options \['rrt_iterations'\] do not apply"),
    (lambda: make_policy("period-aware", run="x"), r"'period-aware' is a planner; run= is for trained agents"),
    (lambda: policies.describe("nonsense"), r"unknown policy 'nonsense'"),
])
def test_the_factory_says_what_is_wrong(call, message):
    with pytest.raises(ValueError, match=message):
        call()
    assert not policies.is_policy("teleport") and policies.is_policy("ppo-fixed-period")


def test_a_shipped_agent_is_made_by_the_same_factory():
    from footstep_gym.rl import agent_runs

    run = agent_runs("ppo", "FootstepCrossing-v0", REPO / "baselines" / "agents")[0]
    agent = make_policy("ppo", seed=3, run=run)
    assert isinstance(agent, ZooAgent) and agent.name == "ppo" and not agent.fixed_period
    assert make_policy("agent:mine", run=run).name == "agent:mine"


# ---------------------------------------------------------------- no private helpers across modules
def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def cross_module_private_uses(path: Path) -> list[str]:
    """``from footstep_gym.x import _y`` and ``module._y`` (``module`` a footstep_gym module imported here)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    modules: dict[str, str] = {}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("footstep_gym"):
            for alias in node.names:
                if _private(alias.name):
                    found.append(f"{path.name}:{node.lineno}: from {node.module} import {alias.name}")
                elif _is_module(f"{node.module}.{alias.name}"):
                    modules[alias.asname or alias.name] = f"{node.module}.{alias.name}"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("footstep_gym") and alias.asname:
                    modules[alias.asname] = alias.name
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and _private(node.attr) and isinstance(node.value, ast.Name)
                and node.value.id in modules):
            found.append(f"{path.name}:{node.lineno}: {modules[node.value.id]}.{node.attr}")
    return found


def test_no_module_uses_another_modules_private_helpers():
    files = sorted((REPO / "footstep_gym").rglob("*.py")) + sorted((REPO / "baselines").glob("*.py"))
    found = [use for path in files for use in cross_module_private_uses(path)]
    assert not found, "private helpers used across modules (make them public where shared):\n" + "\n".join(found)


def test_the_private_helper_scan_finds_what_it_looks_for(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text("from footstep_gym import config\nfrom footstep_gym.config import _coerce\n"
                      "config._coerce(1)\nconfig.number('x', 1)\n")
    assert cross_module_private_uses(sample) == ["sample.py:2: from footstep_gym.config import _coerce",
                                                 "sample.py:3: footstep_gym.config._coerce"]
