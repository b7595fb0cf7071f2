"""A plain (non-editable) ``pip install .`` into a fresh venv gives working envs and planners.

The configs live in the repo's top-level ``configs/`` and must install inside the package;
the base install must not need the extras (pygame-ce, torch, matplotlib, scipy).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHECK = textwrap.dedent("""
    import gymnasium as gym, numpy as np, footstep_gym, sys
    from pathlib import Path
    from footstep_gym.config import config_dir
    from footstep_gym import make_policy
    repo = Path(sys.argv[1]).resolve()
    assert repo not in Path(footstep_gym.__file__).resolve().parents, footstep_gym.__file__
    assert (config_dir() / "robot.yaml").is_file() and repo not in config_dir().resolve().parents, config_dir()
    assert (config_dir() / "rl" / "ppo.yml").is_file() and (config_dir() / "scenarios" / "door.yaml").is_file()
    for env_id in ("FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0", "FootstepMix-v0"):
        env = gym.make(env_id)
        obs, _ = env.reset(seed=0)
        obs, r, term, trunc, info = env.step(env.unwrapped.robot.nominal_command.astype(np.float32))
        assert info["feasible"] and np.all(np.isfinite(obs)), env_id
    env = gym.make("FootstepCrossing-v0")
    obs, _ = env.reset(seed=1)
    policy = make_policy("period-aware", env.unwrapped.robot, seed=1)
    command = policy.act(obs, env.unwrapped.sensing())
    assert env.action_space.contains(np.asarray(command, dtype=np.float32))
    from footstep_gym.rl import agent_runs, default_agents_dir  # installed; the agents are not (run outside the repo)
    assert default_agents_dir() == Path.cwd() / "baselines" / "agents" and agent_runs("ppo", "FootstepDoor-v0") == []
    for missing in ("torch", "pygame", "matplotlib", "scipy"):
        assert missing not in sys.modules, missing
    e = gym.make("FootstepDoor-v0", render_mode="rgb_array")
    e.reset(seed=0)
    try:
        e.render()
        raise AssertionError("rendered without pygame-ce installed")
    except gym.error.DependencyNotInstalled as exc:
        assert "footstep_gym[render]" in str(exc), exc
    print("ok")
""")


def test_plain_pip_install_in_a_fresh_venv(tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = str(venv / "bin" / "python")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "FOOTSTEP_GYM_CONFIG_DIR", "FOOTSTEP_GYM_AGENTS_DIR", "VIRTUAL_ENV")}
    install = subprocess.run([py, "-m", "pip", "install", "-q", str(REPO)], cwd=tmp_path, env=env,
                             capture_output=True, text=True, timeout=900)
    assert install.returncode == 0, install.stderr[-3000:]
    check = subprocess.run([py, "-c", CHECK, str(REPO)], cwd=tmp_path, env=env, capture_output=True, text=True,
                           timeout=300)
    assert check.returncode == 0, check.stderr[-3000:]
    assert check.stdout.strip().endswith("ok")
