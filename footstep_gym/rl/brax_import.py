"""Brax, imported once for the package (:mod:`.brax_env`, :mod:`.ppo_jax` import it through this module first).

``import brax`` imports MuJoCo's MJX, whose ``mujoco.mjx.warp`` prints ``Failed to import warp: ...`` and
``Failed to import mujoco_warp: ...`` to stdout when NVIDIA Warp is not installed: noise about a backend
footstep_gym never uses. Those two lines are left out; anything else printed while Brax is imported is printed as
it was.
"""

from __future__ import annotations

import contextlib
import io
import sys

#: The starts of the lines ``mujoco.mjx.warp`` prints without NVIDIA Warp (not printed here).
WARP_MESSAGES = ("Failed to import warp:", "Failed to import mujoco_warp:")


def _import_brax() -> None:
    if "brax" in sys.modules:
        return
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            import brax  # noqa: F401
    except ImportError as exc:  # one line saying what to install
        raise ImportError(f"ppo-jax (Brax's PPO) needs Brax: pip install 'footstep_gym[jax-rl]' ({exc})") from exc
    finally:
        kept = [line for line in out.getvalue().splitlines(keepends=True) if not line.startswith(WARP_MESSAGES)]
        sys.stdout.write("".join(kept))


_import_brax()
