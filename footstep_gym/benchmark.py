"""The benchmark for any method, from Python: :func:`evaluate` runs the protocol for a callable
``observation -> action`` (or a :class:`~footstep_gym.policy.Policy`) and writes the same
``benchmark.json`` as ``python baselines/eval_planner.py --benchmark`` (docs/benchmark.md).

The implementation lives in :mod:`footstep_gym.evaluation.benchmark`; this module is its public address::

    from footstep_gym.benchmark import evaluate

    doc = evaluate(lambda scene, seed: my_act, name="mine", out="runs/bench/mine")
"""

from footstep_gym.evaluation.benchmark import EPISODES, evaluate

__all__ = ["EPISODES", "evaluate"]
