"""One policy interface, one factory, one registry of names: ``footstep_gym.policy.Policy``,
``footstep_gym.make_policy``, ``footstep_gym.registry.resolve``.

Every name is listed once with its description: planners in ``footstep_gym.planners.POLICIES`` (``PolicySpec``),
agents in ``footstep_gym.rl.registry.AGENTS`` (``AgentEntry``); a name resolves once into a ``PolicyEntry``.
``import footstep_gym`` imports no RL code. No module reaches into another's private helpers.
"""

from __future__ import annotations

import ast
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

import footstep_gym
from footstep_gym import make_policy, registry
from footstep_gym.planners import POLICIES, PolicySpec
from footstep_gym.policy import Policy
from footstep_gym.rl import AGENTS, AgentEntry, ZooAgent
from footstep_gym.registry import resolve

REPO = Path(__file__).resolve().parents[1]


def test_one_factory_and_one_interface():
    import footstep_gym.evaluation as evaluation
    import footstep_gym.planners as planners

    assert footstep_gym.make_policy is registry.make_policy and "make_policy" in footstep_gym.__all__
    for package in (planners, evaluation):
        assert not hasattr(package, "make_policy") and "make_policy" not in package.__all__
    assert "Policy" not in planners.__all__  # the interface lives in footstep_gym.policy
    for gone in ("footstep_gym.training", "footstep_gym.evaluation.policies", "footstep_gym.evaluation.agents"):
        assert importlib.util.find_spec(gone) is None, gone  # RL code is in footstep_gym.rl
    assert not (REPO / "footstep_gym" / "policies.py").exists()  # the names' registry is footstep_gym/registry.py
    assert issubclass(ZooAgent, Policy)
    for spec in POLICIES.values():
        assert issubclass(spec.planner, Policy)


def test_every_name_is_listed_once_with_a_description():
    assert not set(POLICIES) & set(AGENTS)
    assert registry.policy_names() == (*POLICIES, *AGENTS)
    for name, spec in POLICIES.items():
        entry = resolve(name)
        assert isinstance(spec, PolicySpec) and spec.description and entry.description == spec.description
        privileged = name in ("oracle", "oracle-lookahead")  # the two that read the truth: upper bounds
        assert (entry.kind, entry.spec, entry.reads_truth) == ("planner", spec, privileged)
        assert entry.label == (f"{name} (upper bound)" if privileged else name)
    for name, agent in AGENTS.items():
        entry = resolve(name)
        assert isinstance(agent, AgentEntry) and agent.description and entry.description == agent.description
        assert (entry.kind, entry.agent, entry.reads_truth, entry.is_agent) == ("agent", agent, False, True)
    assert AGENTS["ppo-fixed-period"].algo == "ppo" and AGENTS["ppo-fixed-period"].folder == "ppo-fixed-period"
    assert AGENTS["ppo-all"].folder == "ppo" and AGENTS["ppo-all"].trained_on == "FootstepMix-v0"
    assert resolve("period-aware-no-fallback").description == "period-aware with the addition fallback off"
    assert resolve("paper-period-aware-t0-0.3").description == "paper-period-aware with T0 fixed at 0.3 s"
    assert resolve("agent:mine").kind == "user-agent" and resolve("period-aware") is resolve("period-aware")


@pytest.mark.parametrize("name", [*POLICIES, "period-aware-no-waiting-walks", "fixed-period-no-fallback",
                                  "paper-period-aware-t0-0.25"])
def test_the_factory_makes_every_planner_and_variant(name):
    policy = make_policy(name, seed=0)
    assert isinstance(policy, Policy) and policy.name == name and resolve(name).kind == "planner"
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
                                      r"ppo-jax, ppo-jax-2e7, ppo-jax-2e7-structure, ppo-jax-2e7-noise, ppo-structure, ppo-noise, ppo-lstm-noise, "
                                      r"ppo-jax-gru-noise, or agent:NAME with run=PATH; or a policy of your own as module:attr"),
    (lambda: make_policy("ppo"), r"policy 'ppo' is a trained agent: pass run= .*agent_runs\('ppo', env_id\)"),
    (lambda: make_policy("agent:mine"), r"policy 'agent:mine' is a trained agent: pass run="),
    (lambda: make_policy("ppo", run="x", rrt_iterations=5), r"planner options \['rrt_iterations'\] do not apply"),
    (lambda: make_policy("period-aware", run="x"), r"'period-aware' is a planner; run= is for trained agents"),
    (lambda: resolve("nonsense"), r"unknown policy 'nonsense'"),
    (lambda: make_policy("period-aware", algo="ppo"), r"not a trained agent; \['algo'\] do not apply"),
])
def test_the_factory_says_what_is_wrong(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_a_shipped_agent_is_made_by_the_same_factory():
    from footstep_gym.rl import agent_runs

    run = agent_runs("ppo", "FootstepCrossing-v0", REPO / "baselines" / "agents")[0]
    agent = make_policy("ppo", seed=3, run=run)
    assert isinstance(agent, ZooAgent) and agent.name == "ppo" and not agent.fixed_period
    assert make_policy("agent:mine", run=run).name == "agent:mine"


def test_importing_the_package_imports_no_rl_code():
    """``import footstep_gym`` (envs and the policy factory) loads neither footstep_gym.rl nor torch, SB3 or JAX:
    checked in a fresh interpreter, as a user's first import."""
    code = ("import sys, footstep_gym; footstep_gym.make_policy; "
            "print(sorted(m for m in sys.modules if m.startswith('footstep_gym.rl') or m.split('.')[0] in "
            "('torch', 'stable_baselines3', 'sb3_contrib', 'sbx', 'jax', 'rl_zoo3')))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]", proc.stdout
    # ... and the check sees RL code when it is there
    proc = subprocess.run([sys.executable, "-c", "import footstep_gym.rl.registry; " + code], capture_output=True,
                          text=True, timeout=120, cwd=REPO)
    assert "footstep_gym.rl.registry" in proc.stdout, proc.stdout


def test_the_agents_registry_sits_below_what_it_lists():
    """rl/registry.py imports nothing of footstep_gym.rl (neither the loader nor the training); they import it (no
    cycle)."""
    tree = ast.parse((REPO / "footstep_gym" / "rl" / "registry.py").read_text(encoding="utf-8"))
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)} | {
        a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert not {m for m in imported if m and m.startswith("footstep_gym.rl")}, imported
    for module in ("agents", "training"):
        text = (REPO / "footstep_gym" / "rl" / f"{module}.py").read_text(encoding="utf-8")
        assert "from footstep_gym.rl.agents import AGENTS" not in text


def test_the_jax_backend_holds_the_env_and_imports_no_rl():
    """footstep_gym/jax/ is the env: the RL adapters (Brax's, SB3's, the ppo-jax loader) live in footstep_gym/rl/,
    which imports jax/, never the other way (no cycle)."""
    found = []
    for path in sorted((REPO / "footstep_gym" / "jax").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        names = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)} | {
            a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        rl = ("brax", "stable_baselines3", "flax", "torch")
        found += [f"{path.name}: {m}" for m in sorted(filter(None, names))
                  if m.startswith("footstep_gym.rl") or m.split(".")[0] in rl]
    assert not found, found


def test_a_planner_spec_checks_its_class_can_be_built():
    class TwoArgs(Policy):
        def __init__(self, robot, seed=None):
            super().__init__()

        def reset(self, seed=None):
            pass

        def act(self, observation, snapshot):
            return None

    with pytest.raises(TypeError, match=r"cannot be built as TwoArgs\(robot, config, seed, name\).*module:attr"):
        PolicySpec(TwoArgs)
    with pytest.raises(TypeError, match="not a footstep_gym.policy.Policy subclass"):
        PolicySpec(dict)


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
