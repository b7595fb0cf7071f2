"""Episodes of the reference env replayed in the JAX backend: the check that the two are one env.

:func:`record` plays an episode in the reference env (``gymnasium.make``) with a policy's commands and keeps
where it started (feet, the obstacles and the scene's draws), the actions exactly as sent, and every step's observation, reward and ending.
:func:`replay` starts the JAX env from the same place, feeds it the same actions (batched: ``vmap`` over
episodes, ``lax.scan`` over steps) and :func:`compare` says, per episode, whether it ended the same way at the
same step and how far apart the observations and rewards were. Where it did not, :func:`compare` reports the
reference's margin at that step (the nearest clearance to the body, the ZMP's margin, the goal distance's
margin): a *near-tie* is a disagreement where that margin is below :data:`NEAR_TIE` metres.

Policies (``kind``): ``planner`` (the period-aware planner, through ``make_policy``), ``walk`` (open-loop
random walks near the nominal gait, float32: forward strides, turns, period changes, so episodes reach the
obstacles, hit them and fall) and ``fuzz`` (float32 actions uniform over a box 20 % wider than the action box, so
most are clipped and many fall at once).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Iterable

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym.jax.env import TERMINATION_CODES, FootstepJaxEnv
from footstep_gym.jax.scenes import SCENES

KINDS = ("planner", "walk", "fuzz")
#: [m] a disagreement whose reference margin (clearance, ZMP margin, goal distance - tolerance) is below this is
#: a near-tie: the two envs' arithmetic (XLA's libm against the C library's) differs by ulps, so a contact,
#: a ZMP limit or the goal met within this margin may go either way.
NEAR_TIE = 1e-6
#: [m] the same on the float32 path, whose positions (metres) carry ~1e-7 m of rounding per operation.
NEAR_TIE_32 = 1e-4
#: Outcome names: the reference's terminations and the truncation.
OUTCOMES = ("goal", "collision", "fall", "truncated")


@dataclass
class Episode:
    """One reference episode: its start, the actions sent and what each step returned."""

    env_id: str
    env_kwargs: dict
    seed: int
    kind: str
    feet: np.ndarray  # (2, 3): right, left
    start: dict  # the obstacles and the scene's draws at reset (``Scene.reference_start``)
    config: Any  # the episode's scenario config (its randomize keys drawn)
    actions: np.ndarray  # (T, 5), the dtype sent
    obs: np.ndarray  # (T + 1, D) float32
    rewards: np.ndarray  # (T,)
    outcome: str  # one of OUTCOMES
    margins: list = field(default_factory=list)  # per step: (clearance, zmp_margin, goal distance - tolerance)
    tier_cell: str | None = None  # the tier cell the reference drew (None: the JAX env's first)


def _walk_actions(rng: np.random.Generator, low: np.ndarray, high: np.ndarray, n: int) -> np.ndarray:
    """Open-loop walk: from stepping in place, strides and period drift (bounded random walks), turns small."""
    cmd = np.array([0.0, 0.08, 0.0, 0.6, 0.2])
    drift = np.array([0.012, 0.006, 0.03, 0.05, 0.02])
    target_s = rng.uniform(0.03, 0.1)
    out = []
    for _ in range(n):
        cmd = cmd + rng.normal(0.0, 1.0, 5) * drift
        cmd[0] += 0.3 * (target_s - cmd[0])
        cmd[2] *= 0.7
        cmd = np.clip(cmd, low, high)
        out.append(cmd.copy())
    return np.asarray(out, dtype=np.float32)


def record(env_id: str, seed: int, kind: str, env_kwargs: dict | None = None, max_steps: int | None = None
           ) -> Episode:
    """Play one episode of ``env_id`` (reference env) with ``kind``'s commands from ``reset(seed=seed)``."""
    if kind not in KINDS:
        raise ValueError(f"record: kind must be one of {KINDS}, got {kind!r}")
    kwargs = dict(env_kwargs or {})
    env = gym.make(env_id, **kwargs)
    u = env.unwrapped
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng([seed, KINDS.index(kind)])
    limit = u.episode_config.max_steps if max_steps is None else max_steps
    low, high = u.robot.command_low, u.robot.command_high
    policy = None
    if kind == "planner":
        policy = footstep_gym.make_policy("period-aware", u.robot, seed)
        policy.reset(seed)
        planned = None
    elif kind == "walk":
        planned = _walk_actions(rng, low, high, limit)
    else:
        span = high - low
        planned = rng.uniform(low - 0.1 * span, high + 0.1 * span, (limit, 5)).astype(np.float32)
    start = (np.array([u.feet[-1], u.feet[1]], dtype=np.float64), SCENES[u.scenario_name].reference_start(u))
    actions, observations, rewards, margins = [], [obs], [], []
    outcome = "truncated"
    for i in range(limit):
        action = policy.act(obs, u.sensing()) if policy is not None else planned[i]
        actions.append(np.array(action))
        obs, reward, terminated, truncated, info = env.step(action)
        observations.append(obs)
        rewards.append(reward)
        clearance = info["clearance"]
        margins.append((np.inf if clearance is None else clearance, info["zmp_margin"],
                        u._goal_dist - u.episode_config.goal_tolerance))
        if terminated or truncated:
            outcome = info["termination"] if terminated else "truncated"
            break
    else:
        outcome = "cut"  # max_steps given shorter than the episode: it goes on
    env.close()
    return Episode(env_id, kwargs, seed, kind, start[0], start[1], u.episode_config, np.asarray(actions),
                   np.asarray(observations, dtype=np.float32), np.asarray(rewards, dtype=np.float64), outcome, margins,
                   u.tier_cell)


@dataclass
class Replayed:
    """The JAX env's run of the episodes: per step observations ``(N, T + 1, D)``, rewards, terminations
    (codes), truncations and clearances [m] (``inf`` on a fall, as the reference's margins) ``(N, T)``."""

    obs: np.ndarray
    rewards: np.ndarray
    termination: np.ndarray
    truncated: np.ndarray
    clearance: np.ndarray
    obstacle: np.ndarray  # (N, T): the shape hit (its index among the cell's walls, then the rods; -1 none)


def max_steps(episodes: list[Episode]) -> int:
    """The longest any of ``episodes`` could have run (their configs' ``max_steps``)."""
    return max(e.config.max_steps for e in episodes)


def episode_start(jenv: FootstepJaxEnv, config: Any, start: dict) -> tuple[Any, Any]:
    """``(rods, scene)``: a reference episode's obstacles and scene state from its ``start``
    (``Scene.reference_start``) and scenario ``config`` (its ``randomize`` keys as drawn)."""
    return jenv.scene.start_from(start, jenv.scene.cell_params(dataclasses.replace(config, randomize={})), config)


def episode_params(jenv: FootstepJaxEnv, episodes: list[Episode]) -> Any:
    """Params with one cell per episode (in order): its scenario config (its ``randomize`` keys as drawn) and its
    tier cell's env config."""
    return jenv.make_params([(dataclasses.replace(e.config, randomize={}),
                              jenv.cell_configs[cell_index(jenv, e.tier_cell)][1]) for e in episodes])


def cell_index(jenv: FootstepJaxEnv, tier_cell: str | None) -> int:
    """The index of the reference's tier cell ``tier_cell`` among ``jenv``'s cells; 0 where it is not one of them
    (``None`` included) and the cells share their walls (an episode's settings come from its own config)."""
    if tier_cell in jenv.cells:
        return jenv.cells.index(tier_cell)
    if jenv.per_cell_walls:
        raise ValueError(f"replay: the episode's tier cell {tier_cell!r} is not one of the JAX env's {jenv.cells}, "
                         f"whose cells have walls of their own")
    return 0


def replay(jenv: FootstepJaxEnv, episodes: list[Episode], pad_to: int = 0) -> Replayed:
    """Run ``episodes``' actions in ``jenv`` from their starts, all at once (their actions share a dtype), each
    episode its own cell of the params (:func:`episode_params`); ``pad_to``: run at least this many steps (one
    compiled function serves batches of any episode length)."""
    if len({e.actions.dtype for e in episodes}) != 1:
        raise ValueError("replay: the episodes' actions must share a dtype (replay each kind apart)")
    dt = jenv.dtype
    n_steps = max(pad_to, *(len(e.actions) for e in episodes))
    nominal = np.asarray(jenv.robot.nominal_command, episodes[0].actions.dtype)
    actions = np.stack([np.concatenate([e.actions, np.tile(nominal, (n_steps - len(e.actions), 1))])
                        for e in episodes])
    rods, scene = zip(*(episode_start(jenv, e.config, e.start) for e in episodes))
    stack = lambda *x: jnp.stack(x)  # noqa: E731
    rods, scene = (jax.tree.map(stack, *x) for x in (rods, scene))
    params = episode_params(jenv, episodes)
    feet = jnp.asarray(np.stack([e.feet for e in episodes]), dt)
    keys = jax.random.split(jax.random.key(0), len(episodes))
    cells = jnp.arange(len(episodes), dtype=jnp.int32)
    state, obs0 = jax.vmap(jenv.start_state, in_axes=(0, 0, 0, 0, None, 0))(keys, feet, rods, scene, params, cells)
    out = _run(jenv, state, jnp.asarray(actions), params)
    obs, rew, term, trunc, clear, hit = (np.asarray(x) for x in out)
    obs = np.concatenate([np.asarray(obs0)[:, None], np.swapaxes(obs, 0, 1)], axis=1)
    clear = np.where(np.isnan(clear), np.inf, clear)
    return Replayed(obs, np.swapaxes(rew, 0, 1), np.swapaxes(term, 0, 1), np.swapaxes(trunc, 0, 1),
                    np.swapaxes(clear, 0, 1), np.swapaxes(hit, 0, 1))


def _run(jenv: FootstepJaxEnv, state: Any, actions: jax.Array, params: Any) -> tuple:
    fn = getattr(jenv, "_replay_fn", None)
    if fn is None:
        step = jax.vmap(jenv.step, in_axes=(0, 0, 0, None))

        def run(state, actions, params):
            def body(carry, a):
                s, key = carry
                key, k_step = jax.random.split(key)
                s, obs, reward, _, truncated, info = step(jax.random.split(k_step, a.shape[0]), s, a, params)
                return (s, key), (obs, reward, info["termination"], truncated, info["clearance"], info["obstacle"])

            return jax.lax.scan(body, (state, jax.random.key(1)), jnp.swapaxes(actions, 0, 1))[1]

        fn = jenv._replay_fn = jax.jit(run)
    return fn(state, actions, params)


@dataclass
class Agreement:
    """How one replayed episode compares: the reference's and the JAX env's ending (outcome, step), the
    largest observation, reward and clearance differences over the steps both took (the clearance, the
    smallest gap at the sweep's checks, shows the checks were made at the same instants; ``inf`` where one is
    finite and the other not), and where the endings differ, the reference's margin at the first step that
    differs (``near_tie``: below the threshold of :func:`compare`)."""

    seed: int
    kind: str
    reference: tuple[str, int]
    jax: tuple[str, int]
    obs_error: float
    reward_error: float
    clearance_error: float = 0.0
    margin: float = np.nan
    near_tie: bool = False

    @property
    def same(self) -> bool:
        return self.reference == self.jax


def _ending(termination: np.ndarray, truncated: np.ndarray, limit: int) -> tuple[str, int]:
    names = {v: k for k, v in TERMINATION_CODES.items()}
    for i, (code, trunc) in enumerate(zip(termination[:limit], truncated[:limit])):
        if code:
            return names[int(code)], i + 1
        if trunc:
            return "truncated", i + 1
    return "cut", limit


def compare(episodes: list[Episode], replayed: Replayed, near_tie: float = NEAR_TIE) -> list[Agreement]:
    """Per episode, the :class:`Agreement` of the reference run and the replay (``near_tie``: the margin [m]
    below which a disagreement is a near-tie)."""
    out = []
    for i, e in enumerate(episodes):
        n = len(e.actions)
        ref = (e.outcome, n)
        got = _ending(replayed.termination[i], replayed.truncated[i], n)
        both = min(ref[1], got[1])
        obs_err = float(np.max(np.abs(replayed.obs[i, :both + 1] - e.obs[:both + 1])))
        rew_err = float(np.max(np.abs(replayed.rewards[i, :both] - e.rewards[:both]), initial=0.0))
        ref_clear = np.array([m[0] for m in e.margins[:both]], dtype=np.float64)
        jax_clear = replayed.clearance[i, :both]
        same_inf = (ref_clear == jax_clear) & np.isinf(ref_clear)
        with np.errstate(invalid="ignore"):  # inf - inf where both are inf: counted as equal
            clear_err = float(np.max(np.where(same_inf, 0.0, np.abs(ref_clear - jax_clear)), initial=0.0))
        a = Agreement(e.seed, e.kind, ref, got, obs_err, rew_err, clear_err)
        if not a.same:
            step = both - 1  # the first step whose ending differs
            clearance, zmp, goal = e.margins[step]
            a.margin = float(min(abs(clearance), abs(zmp), abs(goal)))
            a.near_tie = a.margin < near_tie
        out.append(a)
    return out


def record_many(env_id: str, seeds: Iterable[int], kind: str, env_kwargs: dict | None = None,
                max_steps: int | None = None) -> list[Episode]:
    """:func:`record` for each seed."""
    return [record(env_id, s, kind, env_kwargs, max_steps) for s in seeds]
