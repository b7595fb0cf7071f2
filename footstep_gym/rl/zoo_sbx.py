"""rl_zoo3 with sbx's (JAX) SAC and TD3 registered: ``python -m footstep_gym.rl.zoo_sbx <rl_zoo3.train args>``.

`sbx <https://github.com/araffin/sbx>`_ (PyPI ``sbx-rl``) re-implements stable-baselines3's
off-policy algorithms in JAX with SB3's API (``learn``, ``predict``, ``save``/``load``), several
times faster on a CPU. rl_zoo3 only knows SB3's classes: this module puts sbx's into the zoo's
tables before running the zoo's own ``train()``, under names of their own (:data:`SBX_ALGOS`),
so that a run's folder (``<log>/sac_sbx/<EnvId>_<k>/``), its ``args.yml`` (``algo: sac_sbx``)
and the hyperparameter file (``configs/rl/sac_sbx.yml``) say which implementation trained it:

* ``rl_zoo3.utils.ALGOS`` (the classes; ``rl_zoo3.train`` builds ``--algo``'s choices from it
  and ``rl_zoo3.exp_manager`` makes and loads the models from it: the same dict object);
* ``rl_zoo3.hyperparams_opt.HYPERPARAMS_SAMPLER`` / ``HYPERPARAMS_CONVERTER`` (``-optimize``:
  the zoo's own samplers of SB3's SAC and TD3; they sample no torch object, sbx takes them as
  they are).

Everything else (``-optimize``, ``--eval-env-kwargs``, the saved layout) is the zoo's. The
command line is the zoo's, e.g.::

    XLA_FLAGS=--xla_force_host_platform_device_count=1 python -m footstep_gym.rl.zoo_sbx --algo sac_sbx \\
        --env FootstepDoor-v0 --gym-packages footstep_gym --conf-file configs/rl/sac_sbx.yml --num-threads 1 \\
        --seed 1 -f runs/sbx

A run loads back with ``sbx.SAC.load`` (:class:`footstep_gym.rl.agents.ZooAgent` does so from
``args.yml``'s algorithm). JAX's own threads: :func:`limit_jax_threads` (called here before
JAX is imported) keeps XLA's CPU backend to one device and, unless ``XLA_FLAGS`` says
otherwise, to one compute thread, as ``--num-threads 1`` does for torch.
"""

from __future__ import annotations

import os
import sys

#: Our rl_zoo3 algorithm name -> sbx's class name.
SBX_ALGOS = {"sac_sbx": "SAC", "td3_sbx": "TD3"}
#: The zoo's optuna sampler/converter each one borrows (SB3's algorithm of the same name).
_SAMPLER_OF = {"sac_sbx": "sac", "td3_sbx": "td3"}


def limit_jax_threads() -> None:
    """One XLA host device and single-threaded Eigen kernels unless ``XLA_FLAGS`` already sets them.

    Has an effect only before JAX is first imported (XLA reads the flags then).
    """
    flags = os.environ.get("XLA_FLAGS", "")
    extra = []
    if "xla_force_host_platform_device_count" not in flags:
        extra.append("--xla_force_host_platform_device_count=1")
    if "xla_cpu_multi_thread_eigen" not in flags:
        extra.append("--xla_cpu_multi_thread_eigen=false")
    if extra:
        os.environ["XLA_FLAGS"] = " ".join([flags, *extra]).strip()


def import_sbx():
    """The ``sbx`` module (JAX's threads limited first); ``ImportError`` saying how to install it otherwise."""
    if "jax" not in sys.modules:
        limit_jax_threads()
    try:
        import sbx
    except ImportError as exc:
        raise ImportError("the sbx (JAX) algorithms need the sbx-rl package: pip install 'footstep_gym[sbx]' "
                          f"(or pip install sbx-rl): {exc}") from exc
    return sbx


def register() -> None:
    """Put sbx's SAC and TD3 into rl_zoo3's algorithm and optuna tables (idempotent)."""
    sbx = import_sbx()
    from rl_zoo3 import hyperparams_opt, utils

    for name, cls in SBX_ALGOS.items():
        utils.ALGOS[name] = getattr(sbx, cls)
        hyperparams_opt.HYPERPARAMS_SAMPLER[name] = hyperparams_opt.HYPERPARAMS_SAMPLER[_SAMPLER_OF[name]]
        hyperparams_opt.HYPERPARAMS_CONVERTER[name] = hyperparams_opt.HYPERPARAMS_CONVERTER[_SAMPLER_OF[name]]


def main() -> None:
    """``rl_zoo3.train``'s command line (``sys.argv``) with the sbx algorithms registered."""
    register()
    from rl_zoo3.train import train

    train()


if __name__ == "__main__":
    main()
