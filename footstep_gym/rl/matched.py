"""The same learner across trainers: SB3's PPO and ``ppo-jax`` (Brax's PPO) with matched hyperparameters.

Both train on the same env, the batched JAX scene of :mod:`footstep_gym.jax` (SB3 through
:class:`~footstep_gym.rl.sb3_jax.FootstepSB3VecEnv`, Brax through :class:`~footstep_gym.rl.brax_env.FootstepBraxEnv`),
with the action mapped from ``[-1, 1]`` to the command box by the same float32 arithmetic
(:func:`~footstep_gym.rl.brax_env.action_to_command`, Gymnasium's ``RescaleAction``), and both are validated at the
same env steps (after the same number of PPO updates) on the same validation-split seeds in the reference env
(pymunk), by the same :func:`~footstep_gym.rl.callbacks.play`: what differs is the trainer.

:func:`sb3_hyperparameters` reads SB3 PPO's values from the zoo's entry (``configs/rl/ppo.yml``, the shipped
``ppo`` agents'); :func:`matched_jax_config` writes them as a ``ppo-jax`` config
(:class:`~footstep_gym.rl.ppo_jax.PPOJaxConfig`); :data:`DIFFERENCES` states what Brax's PPO does otherwise. :func:`train_sb3` trains SB3's PPO and returns its curve;
:func:`summarise` and :func:`plot` compare the two trainers' curves.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from footstep_gym.rl.compute import plateaued

#: A validation point: (env steps, training wall time [s], success rate, process CPU time [s]).
Point = tuple[int, float, float, float]

#: What Brax's PPO (0.14) does otherwise than SB3's (2.x) with the values of :func:`matched_jax_config`.
DIFFERENCES = (
    "minibatches: SB3 shuffles single transitions of the rollout; Brax shuffles whole segments of unroll_length "
    "steps (8 segments of 32 steps make SB3's 256-transition minibatch)",
    "advantages: SB3 computes GAE once per rollout (512 steps per env) with the rollout's values; Brax recomputes it "
    "in every minibatch with the current value network, per 32-step segment bootstrapped at its end",
    "a time-limit truncation: SB3 adds gamma * V(last observation) to the step's reward; Brax sets the truncated "
    "step's advantage and value error to 0 and cuts the lambda-return there",
    "observation normalisation: SB3's VecNormalize updates its running mean and variance every env step and clips "
    "to +-10 (epsilon 1e-8); Brax's running statistics update once per PPO update, before its gradient steps, "
    "without clipping",
    "initialisation: SB3 orthogonal (gain sqrt(2) hidden, 0.01 policy head, 1 value head); Brax Lecun-uniform",
    "Adam's epsilon: SB3 1e-5, optax 1e-8",
    "SB3 normalises the advantages per minibatch (std + 1e-8), Brax likewise per minibatch; the value loss is "
    "matched (SB3 vf_coef 0.5 * MSE = Brax 0.5 * vf_loss_coefficient 1.0 * MSE)",
)


def sb3_hyperparameters(env_id: str = "FootstepDoor-v0", conf_file: str | Path | None = None) -> dict[str, Any]:
    """SB3 PPO's hyperparameters for ``env_id`` from the zoo's file (default ``configs/rl/ppo.yml``), SB3's defaults
    filled in for the keys the file leaves out (``max_grad_norm`` 0.5, ``tanh`` activation, ``log_std_init`` 0)."""
    from footstep_gym.rl.training import zoo_entry, zoo_policy_kwargs

    entry = zoo_entry("ppo", env_id, conf_file)
    policy_kwargs = zoo_policy_kwargs(entry)
    arch = policy_kwargs.get("net_arch", {"pi": [64, 64], "vf": [64, 64]})
    normalize = entry.get("normalize", False)
    normalize = eval(normalize) if isinstance(normalize, str) else normalize  # the zoo's string form
    norm_obs = bool(normalize.get("norm_obs", True)) if isinstance(normalize, dict) else bool(normalize)
    norm_reward = bool(normalize.get("norm_reward", True)) if isinstance(normalize, dict) else bool(normalize)
    return {"n_envs": int(entry.get("n_envs", 1)), "n_steps": int(entry.get("n_steps", 2048)),
            "batch_size": int(entry.get("batch_size", 64)), "n_epochs": int(entry.get("n_epochs", 10)),
            "learning_rate": float(entry.get("learning_rate", 3e-4)), "gamma": float(entry.get("gamma", 0.99)),
            "gae_lambda": float(entry.get("gae_lambda", 0.95)), "clip_range": float(entry.get("clip_range", 0.2)),
            "ent_coef": float(entry.get("ent_coef", 0.0)), "vf_coef": float(entry.get("vf_coef", 0.5)),
            "max_grad_norm": float(entry.get("max_grad_norm", 0.5)),
            "pi": list(arch["pi"]), "vf": list(arch["vf"]), "activation": "tanh",
            "log_std_init": float(policy_kwargs.get("log_std_init", 0.0)),
            "norm_obs": norm_obs, "norm_reward": norm_reward,
            "n_timesteps": int(float(entry["n_timesteps"])), "env_kwargs": dict(entry.get("env_kwargs") or {})}


def rollout_steps(sb3: dict[str, Any]) -> int:
    """Env steps per PPO update: ``n_envs * n_steps``."""
    return sb3["n_envs"] * sb3["n_steps"]


def schedule(sb3: dict[str, Any], timesteps: int, points: int) -> tuple[int, int]:
    """``(env steps, env steps between validations)``: ``timesteps`` rounded up so that ``points - 1`` equal chunks
    of whole PPO updates make it (the first validation is at 0 steps)."""
    if points < 2:
        raise ValueError(f"schedule: at least 2 validation points (0 and the end), got {points}")
    update = rollout_steps(sb3)
    per_chunk = math.ceil(math.ceil(timesteps / update) / (points - 1))
    return per_chunk * update * (points - 1), per_chunk * update


def matched_jax_config(sb3: dict[str, Any], env_id: str, env_kwargs: dict[str, Any], timesteps: int, points: int,
                       episodes: int, unroll_length: int = 32) -> Any:
    """The ``ppo-jax`` config of SB3's values (``sb3``: :func:`sb3_hyperparameters`): the same envs, env steps per
    env per update (``n_steps`` as ``n_steps / unroll_length`` segments), minibatch size and count, epochs, learning
    rate, discount, GAE lambda, clip, entropy and value weights, gradient clip, widths, activation, initial std and
    observation normalisation; trained over ``timesteps`` (:func:`schedule`) with ``points`` validations of
    ``episodes`` episodes."""
    from footstep_gym.rl.ppo_jax import parse_config

    if sb3["n_steps"] % unroll_length or sb3["batch_size"] % unroll_length:
        raise ValueError(f"matched_jax_config: unroll_length {unroll_length} must divide n_steps {sb3['n_steps']} "
                         f"and batch_size {sb3['batch_size']}")
    if sb3["norm_reward"]:
        raise ValueError("matched_jax_config: SB3's reward normalisation has no Brax counterpart here")
    total, _ = schedule(sb3, timesteps, points)
    entry = {"env_kwargs": dict(env_kwargs), "num_timesteps": total, "num_envs": sb3["n_envs"],
             "unroll_length": unroll_length, "batch_size": sb3["batch_size"] // unroll_length,
             "num_minibatches": rollout_steps(sb3) // sb3["batch_size"], "num_updates_per_batch": sb3["n_epochs"],
             "learning_rate": sb3["learning_rate"], "entropy_cost": sb3["ent_coef"], "discounting": sb3["gamma"],
             "gae_lambda": sb3["gae_lambda"], "clipping_epsilon": sb3["clip_range"], "reward_scaling": 1.0,
             "max_grad_norm": sb3["max_grad_norm"], "normalize_observations": sb3["norm_obs"],
             "policy_hidden_layer_sizes": sb3["pi"], "value_hidden_layer_sizes": sb3["vf"],
             "activation": sb3["activation"], "init_noise_std": math.exp(sb3["log_std_init"]), "num_evals": points,
             "validation_episodes": episodes, "chunk": sb3["n_envs"], "vf_loss_coefficient": 2.0 * sb3["vf_coef"]}
    return parse_config(entry, env_id, where="matched ppo-jax config")


def rescaled_vec_env(venv: Any) -> Any:
    """``venv`` (an SB3 ``VecEnv`` of footstep envs) taking actions in ``[-1, 1]``, mapped to the command box as
    Gymnasium's ``RescaleAction(-1, 1)`` maps them after SB3's clipping
    (:func:`~footstep_gym.rl.brax_env.action_to_command`)."""
    from gymnasium import spaces
    from stable_baselines3.common.vec_env import VecEnvWrapper

    from footstep_gym.rl.brax_env import action_to_command, rescaling

    gradient, intercept = rescaling(venv.action_space)
    box = spaces.Box(-1.0, 1.0, venv.action_space.shape, np.float32)

    class RescaledActions(VecEnvWrapper):
        def step_async(self, actions: np.ndarray) -> None:
            self.venv.step_async(action_to_command(actions, gradient, intercept, xp=np))

        def reset(self) -> np.ndarray:
            return self.venv.reset()

        def step_wait(self) -> Any:
            return self.venv.step_wait()

    return RescaledActions(venv, action_space=box)


def train_sb3(sb3: dict[str, Any], env_id: str, env_kwargs: dict[str, Any], seed: int, timesteps: int, points: int,
              validation_seeds: Sequence[int], threads: int = 1,
              progress: Callable[[Point], None] | None = None) -> tuple[Any, list[Point]]:
    """Train SB3's PPO with ``sb3``'s values on the JAX scene of ``env_id`` (``n_envs`` envs of
    :class:`~footstep_gym.rl.sb3_jax.FootstepSB3VecEnv`, actions :func:`rescaled_vec_env`, observations
    ``VecNormalize``d as configured) over :func:`schedule`'s env steps; ``(model, curve)``.

    The curve's points are taken at the start of a rollout (after the same number of PPO updates as ppo-jax's
    validations), the first at 0 steps, and at the end: the deterministic policy plays ``validation_seeds`` in the
    reference env (``gym.make(env_id, **env_kwargs)`` under ``RescaleAction(-1, 1)``); wall and CPU times count
    training only. ``progress(point)`` is called at each point.
    """
    import footstep_gym
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecNormalize

    from footstep_gym.rl.callbacks import play
    from footstep_gym.rl.ppo_jax import ValidationClock, validation_env
    from footstep_gym.rl.sb3_jax import FootstepSB3VecEnv

    scenes = {v: k for k, v in footstep_gym.ENV_IDS.items()}
    total, every = schedule(sb3, timesteps, points)
    torch.set_num_threads(threads)
    venv = rescaled_vec_env(FootstepSB3VecEnv(sb3["n_envs"], scenes[env_id], chunk=sb3["n_envs"], **env_kwargs))
    venv = VecNormalize(venv, norm_obs=sb3["norm_obs"], norm_reward=sb3["norm_reward"], gamma=sb3["gamma"])
    ref_env = validation_env(types_namespace(env_id, env_kwargs))
    seeds = [int(s) for s in validation_seeds]

    class Validate(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.next = 0

        def measure(self) -> None:
            def rate() -> float:
                episodes = play(self.model, ref_env, seeds, venv)
                return sum(w for w, _ in episodes) / len(episodes)

            clock.measure(self.num_timesteps, rate)
            self.next += every
            if progress is not None:
                progress(clock.curve[-1])

        def _on_rollout_start(self) -> None:
            if self.num_timesteps >= self.next:
                self.measure()

        def _on_step(self) -> bool:
            return True

        def _on_training_end(self) -> None:
            if self.num_timesteps >= self.next:
                self.measure()

    clock = ValidationClock()
    model = PPO("MlpPolicy", venv, n_steps=sb3["n_steps"], batch_size=sb3["batch_size"], n_epochs=sb3["n_epochs"],
                learning_rate=sb3["learning_rate"], gamma=sb3["gamma"], gae_lambda=sb3["gae_lambda"],
                clip_range=sb3["clip_range"], ent_coef=sb3["ent_coef"], vf_coef=sb3["vf_coef"],
                max_grad_norm=sb3["max_grad_norm"], seed=seed, device="cpu",
                policy_kwargs={"net_arch": {"pi": sb3["pi"], "vf": sb3["vf"]}, "log_std_init": sb3["log_std_init"],
                               "activation_fn": torch.nn.Tanh})
    model.learn(total, callback=Validate())
    ref_env.close()
    venv.close()
    return model, clock.curve


def types_namespace(env_id: str, env_kwargs: dict[str, Any]) -> Any:
    """What :func:`~footstep_gym.rl.ppo_jax.validation_env` reads of a config: ``env_id`` and ``env_kwargs``."""
    from types import SimpleNamespace

    return SimpleNamespace(env_id=env_id, env_kwargs=dict(env_kwargs))


def summarise(curves: dict[str, list[list[Point]]], episodes: int, target: float = 0.9) -> dict[str, Any]:
    """Per trainer (``curves``: trainer -> one curve per seed, points at the same env steps; a run still training
    has fewer): the env steps each seed reached, its latest success, the mean success per point over the seeds that
    reached it, the env steps, wall and CPU time [s] at which each seed first reached ``target`` (None: not yet),
    and whether each curve plateaued (:func:`~footstep_gym.rl.compute.plateaued`). CPU times are None where a
    point has none."""
    out: dict[str, Any] = {}
    for name, runs in curves.items():
        if not runs or not all(runs):
            raise ValueError(f"summarise: no runs of {name}, or a run without a point")
        longest = max(runs, key=len)

        def first(c: list[Point], i: int) -> Any:
            return next((p[i] for p in c if p[2] >= target), None)

        out[name] = {
            "seeds": len(runs), "steps": [p[0] for p in longest],
            "mean_success": [round(float(np.mean([c[i][2] for c in runs if len(c) > i])), 4)
                             for i in range(len(longest))],
            "seeds_per_point": [sum(len(c) > i for c in runs) for i in range(len(longest))],
            "reached_steps": [c[-1][0] for c in runs], "latest_success": [c[-1][2] for c in runs],
            f"steps_to_{target}": [first(c, 0) for c in runs],
            f"wall_s_to_{target}": [None if first(c, 1) is None else round(first(c, 1), 1) for c in runs],
            f"cpu_s_to_{target}": [None if first(c, 3) is None else round(first(c, 3), 1) for c in runs],
            "wall_s": [round(c[-1][1], 1) for c in runs],
            "cpu_s": [None if c[-1][3] is None else round(c[-1][3], 1) for c in runs],
            "plateaued": [plateaued([p[2] for p in c], episodes) for c in runs],
        }
    return out


def plot(curves: dict[str, list[list[Point]]], out: str | Path, title: str) -> Path:
    """A PNG (800 x 400 px) of each trainer's curves (success against env steps): seeds thin, mean thick."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from footstep_gym.rl.training import save_success_figure

    fig, ax = plt.subplots(figsize=(8, 4), dpi=100, layout="constrained")
    for (name, runs), color in zip(curves.items(), ("tab:blue", "tab:orange", "tab:green")):
        for c in runs:
            ax.plot([p[0] / 1e3 for p in c], [p[2] for p in c], color=color, lw=0.8, alpha=0.45)
        n = min(len(c) for c in runs)  # the mean over the points every seed reached
        ax.plot([p[0] / 1e3 for p in runs[0][:n]], np.mean([[p[2] for p in c[:n]] for c in runs], axis=0),
                color=color, lw=2.4, marker="o", ms=3, label=f"{name}: mean of {len(runs)} seeds")
    return save_success_figure(fig, ax, out, title, "validation success (deterministic policy)", legend_size=8)


__all__ = ["DIFFERENCES", "matched_jax_config", "plot", "rescaled_vec_env", "sb3_hyperparameters",
           "schedule", "summarise", "train_sb3"]
