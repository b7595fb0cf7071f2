"""What the wheel holds, and what ``gymnasium.make_vec`` gives from it, with JAX and without.

* The wheel, built offline from the source tree (``pip wheel --no-deps --no-build-isolation --no-index``), holds
  every package directory of ``footstep_gym/`` with all its modules, and ``configs/`` as ``footstep_gym/configs``;
  installed into a fresh venv (the wheel, plus this venv's packages for its dependencies), its
  ``gym.make_vec("FootstepDoor-v0", num_envs=N)`` is the batched JAX door and steps.
* Without JAX, ``make_vec`` on a scene's id fails in one line naming the ``jax`` extra and
  ``vectorization_mode="sync"``, which gives the reference envs; ``FootstepMix-v0`` has no batched backend:
  ``make_vec`` gives reference Mix envs (each episode one of the scenes), and asking for the batched one is an error.
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import textwrap
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: What a build of the package reads from the source tree.
BUILD_INPUTS = ("pyproject.toml", "setup.py", "README.md", "LICENSE")


def _clean_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items()
            if k not in ("PYTHONPATH", "FOOTSTEP_GYM_CONFIG_DIR", "FOOTSTEP_GYM_AGENTS_DIR", "VIRTUAL_ENV")}


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from a copy of the source tree (the checkout itself is not written to), offline."""
    import shutil

    src = tmp_path_factory.mktemp("src")
    for name in BUILD_INPUTS:
        shutil.copy2(REPO / name, src / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(REPO / "footstep_gym", src / "footstep_gym", ignore=ignore)
    shutil.copytree(REPO / "configs", src / "configs", ignore=ignore)
    out = tmp_path_factory.mktemp("dist")
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                            "--no-index", "-w", str(out), str(src)], capture_output=True, text=True, timeout=300,
                           env=_clean_env())
    assert build.returncode == 0, build.stderr[-3000:]
    (path,) = out.glob("footstep_gym-*.whl")
    return path


def test_the_wheel_holds_every_package_and_the_configs(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    modules = sorted(p.relative_to(REPO).as_posix() for p in (REPO / "footstep_gym").rglob("*.py")
                     if "__pycache__" not in p.parts)
    packages = sorted({str(Path(m).parent) for m in modules})
    assert {"footstep_gym", "footstep_gym/jax", "footstep_gym/rl", "footstep_gym/scenes"} <= set(packages)
    missing = [m for m in modules if m not in names]
    assert not missing, f"modules of the source tree not in the wheel: {missing}"
    no_init = [p for p in packages if f"{p}/__init__.py" not in names]
    assert not no_init, f"package folders without __init__.py (not found by setup.py): {no_init}"
    configs = sorted("footstep_gym/configs/" + p.relative_to(REPO / "configs").as_posix()
                     for p in (REPO / "configs").rglob("*") if p.suffix in (".yaml", ".yml"))
    assert len(configs) > 10 and not [c for c in configs if c not in names], configs


INSTALLED = textwrap.dedent("""
    import sys
    from pathlib import Path
    import numpy as np
    import gymnasium as gym
    import footstep_gym
    import footstep_gym.jax.vector, footstep_gym.jax.autoreset, footstep_gym.scenes
    from footstep_gym.config import config_dir
    venv = Path(sys.argv[1]).resolve()
    assert venv in Path(footstep_gym.__file__).resolve().parents, footstep_gym.__file__
    assert venv in config_dir().resolve().parents and (config_dir() / "scenarios" / "door.yaml").is_file()
    envs = gym.make_vec("FootstepDoor-v0", num_envs=2)
    assert type(envs).__module__ == "footstep_gym.jax.vector", type(envs)
    assert venv in Path(sys.modules[type(envs).__module__].__file__).resolve().parents
    obs, _ = envs.reset(seed=0)
    walk = np.array([[0.05, 0.08, 0.0, 0.6, 0.2]] * 2, dtype=np.float32)
    for _ in range(3):
        obs, reward, terminated, truncated, info = envs.step(walk)
    assert obs.shape == (2, 42) and np.all(np.isfinite(obs)) and info["feasible"].all(), info
    assert np.all(info["steps"] == 3) and not (terminated | truncated).any()
    print("ok")
""")


def test_make_vec_from_the_installed_wheel_steps_the_batched_door(wheel, tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    site = Path(subprocess.run([str(venv / "bin" / "python"), "-c", "import sysconfig; "
                                "print(sysconfig.get_paths()['purelib'])"], capture_output=True, text=True,
                               check=True).stdout.strip())
    # The dependencies (JAX: the jax extra) are this venv's, read after the venv's own packages: a plain path, so
    # this venv's editable install of the checkout (a .pth that runs code) is not taken along.
    (site / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n", encoding="utf-8")
    install = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--target",
                              str(site), str(wheel)], capture_output=True, text=True, timeout=300, env=_clean_env())
    assert install.returncode == 0, install.stderr[-3000:]
    check = subprocess.run([str(venv / "bin" / "python"), "-c", INSTALLED, str(venv)], cwd=tmp_path,
                           env=_clean_env(), capture_output=True, text=True, timeout=300)
    assert check.returncode == 0, check.stderr[-3000:]
    assert check.stdout.strip().endswith("ok"), check.stdout


#: Run with JAX made unimportable (a meta-path finder refusing it, as if it were not installed).
WITHOUT_JAX = textwrap.dedent("""
    import sys
    from importlib.abc import MetaPathFinder

    class NoJax(MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in ("jax", "jaxlib"):
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, NoJax())
    import numpy as np
    import gymnasium as gym
    import footstep_gym
    from footstep_gym.mix import FootstepMixEnv
    try:
        gym.make_vec("FootstepDoor-v0", num_envs=2)
        raise AssertionError("make_vec gave a batched door without JAX")
    except ImportError as exc:
        print("ERROR:", len(str(exc).splitlines()), "line:", exc)
    envs = gym.make_vec("FootstepDoor-v0", num_envs=2, vectorization_mode="sync")
    assert isinstance(envs, gym.vector.SyncVectorEnv), type(envs)
    envs.reset(seed=0)
    envs.step(np.stack([envs.envs[0].unwrapped.robot.nominal_command.astype(np.float32)] * 2))
    mix = gym.make_vec("FootstepMix-v0", num_envs=3)
    assert isinstance(mix, gym.vector.SyncVectorEnv) and all(isinstance(e.unwrapped, FootstepMixEnv) for e in mix.envs)
    _, info = mix.reset(seed=0)
    assert set(info["scene"]) <= {"door", "crossing", "crowd"} and len(set(info["scene"])) > 1, info["scene"]
    try:
        gym.make_vec("FootstepMix-v0", num_envs=3, vectorization_mode="vector_entry_point")
        raise AssertionError("a batched Mix")
    except gym.error.Error as exc:
        print("MIX:", exc)
    assert not [m for m in sys.modules if m.split(".")[0] in ("jax", "jaxlib")]
    print("ok")
""")


def test_without_jax_make_vec_says_what_to_install_or_gives_reference_envs():
    proc = subprocess.run([sys.executable, "-c", WITHOUT_JAX], cwd=REPO, capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[-1] == "ok", proc.stdout
    (error,) = [line for line in lines if line.startswith("ERROR: ")]
    assert error.startswith("ERROR: 1 line: ") and "pip install 'footstep_gym[jax]'" in error, error
    assert 'vectorization_mode="sync"' in error, error
    (mix,) = [line for line in lines if line.startswith("MIX: ")]
    assert "FootstepMix-v0" in mix and "vector entry point" in mix, mix
