"""What an install gives and needs.

* A plain (non-editable) ``pip install .`` into a fresh venv, without the lock, gives working envs and
  planners: the configs live in the repo's top-level ``configs/`` and must install inside the package;
  the base install must not need the extras (pygame-ce, torch, matplotlib, scipy), and the speed tooling
  (``baselines/speedlib``) does not ship.
* The lock, ``constraints.txt`` (parsed, no network): one exact pin per package, each dependency that
  ``pyproject.toml`` declares pinned inside its declared range, torch at the README's and CI's pin, and the
  README's install and ``.ci/run`` installing from it.
* Every third-party module imported by ``footstep_gym/``, ``baselines/`` and ``tests/`` (read by ``ast``) comes
  from a distribution that ``pyproject.toml`` declares, not from another package's dependencies.
"""

from __future__ import annotations

import ast
import os
import re
import shlex
import subprocess
import sys
import textwrap
import tomllib
from importlib import metadata
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

REPO = Path(__file__).resolve().parents[1]
LOCK = REPO / "constraints.txt"

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
    assert default_agents_dir() == Path.cwd() / "baselines" / "agents"
    try:
        agent_runs("ppo", "FootstepDoor-v0")
        raise AssertionError("agent_runs found an agents folder outside a checkout")
    except FileNotFoundError as exc:  # one line saying how to point at the agents
        assert "FOOTSTEP_GYM_AGENTS_DIR" in str(exc) and len(str(exc).splitlines()) == 1, exc
    for missing in ("torch", "pygame", "matplotlib", "scipy"):
        assert missing not in sys.modules, missing
    import importlib.util
    assert importlib.util.find_spec("footstep_gym.bench") is None and importlib.util.find_spec("speedlib") is None
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


def declared(extras: list[str] | None = None) -> list[Requirement]:
    """The requirements of the base install and of ``extras`` (None: every extra), the project's own extras
    (``footstep_gym[rl]`` in ``sbx``) expanded."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    optional = project.get("optional-dependencies", {})
    own = canonicalize_name(project["name"])
    todo, done, out = list(optional) if extras is None else list(extras), set(), []
    reqs = [Requirement(r) for r in project["dependencies"]]
    while True:
        for req in reqs:
            if canonicalize_name(req.name) == own:
                todo += sorted(req.extras)
            else:
                out.append(req)
        todo = [e for e in todo if e not in done]
        if not todo:
            return out
        extra = todo.pop(0)
        assert extra in optional, f"pyproject.toml: no extra {extra!r}"
        done.add(extra)
        reqs = [Requirement(r) for r in optional[extra]]


def locked() -> dict[str, Version]:
    """``constraints.txt`` as {canonical name: pinned version}; fails on a line that is not one exact pin."""
    pins: dict[str, Version] = {}
    for n, raw in enumerate(LOCK.read_text(encoding="utf-8").splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        req = Requirement(line)
        specs = list(req.specifier)
        where = f"constraints.txt:{n}: {line!r}"
        assert not req.extras, f"{where}: pip refuses extras in a constraints file"
        assert len(specs) == 1 and specs[0].operator == "==", f"{where}: not one exact pin (name==version)"
        name = canonicalize_name(req.name)
        assert name not in pins, f"{where}: {name} pinned twice"
        pins[name] = Version(specs[0].version)
    return pins


def test_the_lock_pins_every_declared_dependency_inside_its_range():
    pins = locked()
    reqs = declared()
    assert {"gymnasium", "numpy", "pymunk", "stable-baselines3", "rliable", "jax"} <= {
        canonicalize_name(r.name) for r in reqs}
    missing = sorted({r.name for r in reqs if canonicalize_name(r.name) not in pins})
    assert not missing, (f"constraints.txt pins no version of {missing}, declared in pyproject.toml: write it again "
                         "with the command in its first lines")
    outside = [f"{r} (locked {pins[canonicalize_name(r.name)]})" for r in reqs
               if not r.specifier.contains(pins[canonicalize_name(r.name)], prereleases=True)]
    assert not outside, f"constraints.txt pins versions outside pyproject.toml's ranges: {outside}"
    assert pins["rliable"] == Version("1.2.0")  # archived upstream: its last release, pinned


def test_readme_and_ci_install_from_the_lock_with_its_torch():
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    first = re.search(r"```bash\n(.*?)\n```", readme, re.S).group(1)  # the Quick start's first command
    ci = [line for line in (REPO / ".ci" / "run").read_text(encoding="utf-8").splitlines()
          if re.search(r"pip install .*\.\[dev\]", line)]
    assert len(ci) == 1, ci
    for where, command in (("README's first command", first), (".ci/run", ci[0])):
        words = shlex.split(command)
        assert ("-c", "constraints.txt") in zip(words, words[1:]), f"{where} does not install from the lock: {command}"
        pin = re.search(r"\btorch==(\S+)", command)
        assert pin and Version(pin.group(1)) == locked()["torch"], f"{where}'s torch pin is not the lock's: {command}"


def third_party_imports(folder: Path, local: set[str]) -> dict[str, set[str]]:
    """{top-level module: files importing it} for the absolute imports in ``folder``'s Python files that are
    neither the standard library nor in ``local``."""
    found: dict[str, set[str]] = {}
    for path in sorted(folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top not in sys.stdlib_module_names and top not in local:
                    found.setdefault(top, set()).add(str(path.relative_to(REPO)))
    return found


def test_every_imported_package_is_declared():
    local = {"footstep_gym", "speedlib"} | {p.stem for d in ("baselines", "tests") for p in (REPO / d).glob("*.py")}
    providers = metadata.packages_distributions()
    everything = {canonicalize_name(r.name) for r in declared()}
    dev = {canonicalize_name(r.name) for r in declared(["dev"])}
    imports = {d: third_party_imports(REPO / d, local) for d in ("footstep_gym", "baselines", "tests")}
    assert {"numpy", "gymnasium", "pymunk", "torch", "seaborn"} <= set(imports["footstep_gym"])
    assert {"pytest", "scipy"} <= set(imports["tests"])
    undeclared = []
    for folder, found in imports.items():
        allowed = dev if folder == "tests" else everything
        for module, files in sorted(found.items()):
            dists = {canonicalize_name(d) for d in providers.get(module, [])}
            if not dists & allowed:
                undeclared.append(f"{module} (from {sorted(dists) or 'no installed distribution'}; imported by "
                                  f"{', '.join(sorted(files)[:3])})")
    assert not undeclared, ("imported but not declared in pyproject.toml's dependencies or extras (for tests/: "
                            "the dev extra): " + "; ".join(undeclared))
