"""The measurements of docs/fullbody.md: the nominal gait and the agreement of the env's verdict with the OP3.

The agreement study draws command sequences by :func:`agreement_sequences` (a stated rule, a stated seed), walks
each whole on the OP3, and compares, per sequence, whether the env calls any footstep a fall with whether the OP3
*fails*: falls, or tips (:data:`TIP_MARGIN`: the measured centre of pressure reaches its support sole's edge).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Sequence

import numpy as np

from footstep_gym import footstep
from footstep_gym.footstep import RIGHT
from footstep_gym.fullbody import verdict, walk
from footstep_gym.fullbody.plan import start_feet
from footstep_gym.robot import Robot, load_robot

#: The OP3 *tips* in a footstep whose smallest CoP margin (single support, support sole alone) is below this [m].
TIP_MARGIN = 0.001
#: The families of :func:`agreement_sequences`, drawn in turn.
FAMILIES = ("uniform", "period_cut", "period_gradual", "long_strides", "sharp_turns", "box_edges")
#: Footsteps per sequence: ``WARMUP`` from stepping in place to the family's base command, then the family's.
WARMUP, LENGTH = 2, 8


def _clip(robot: Robot, c: np.ndarray) -> np.ndarray:
    return np.clip(c, robot.command_low, robot.command_high)


def agreement_sequences(robot: Robot, n: int, seed: int) -> list[tuple[str, np.ndarray]]:
    """``n`` sequences of ``LENGTH`` commands, the families of :data:`FAMILIES` in turn, from ``seed``.

    Every sequence starts with ``WARMUP`` steps at the nominal period and side stride that go halfway, then all the
    way, to a base stride ``S0 ~ U(0, 0.08)``; then, by family:

    * ``uniform``: every command uniform in the box;
    * ``period_cut``: the base at ``T_SS ~ U(0.4, 0.6)`` for two steps, then T_SS cut in one step to ``U(0.1, 0.4)``
      and held; ``T_DS ~ U(0.1, 0.3)`` drawn once;
    * ``period_gradual``: as ``period_cut`` but T_SS goes to its new value geometrically over four steps;
    * ``long_strides``: ``S ~ U(0.07, 0.10)``, ``L ~ U(0.1, 0.12)`` per step at a period drawn once;
    * ``sharp_turns``: ``theta`` at ``U(0.6, 1.0)`` of the swinging side's outer limit, alternating with the inner
      limit's, ``S ~ U(0, 0.05)``;
    * ``box_edges``: every field at one end of its range or the other (a coin per field), T_SS and T_DS included.
    """
    rng = np.random.default_rng(seed)
    lo, hi = robot.command_low, robot.command_high
    nominal = robot.nominal_command
    out = []
    for i in range(n):
        family = FAMILIES[i % len(FAMILIES)]
        s0 = rng.uniform(0.0, 0.08)
        seq = [np.array([s0 / 2, nominal[1], 0.0, nominal[3], nominal[4]]),
               np.array([s0, nominal[1], 0.0, nominal[3], nominal[4]])]
        k = LENGTH - WARMUP
        if family == "uniform":
            seq += list(rng.uniform(lo, hi, (k, 5)))
        elif family in ("period_cut", "period_gradual"):
            t0, t1, tds = rng.uniform(0.4, 0.6), rng.uniform(0.1, 0.4), rng.uniform(0.1, 0.3)
            ts = [t0, t0] + ([t1] * (k - 2) if family == "period_cut"
                             else [t0 * (t1 / t0) ** (j / 4) for j in range(1, 5)] + [t1] * (k - 6))
            seq += [np.array([s0, nominal[1], 0.0, t, tds]) for t in ts[:k]]
        elif family == "long_strides":
            tss, tds = rng.uniform(0.3, 0.6), rng.uniform(0.1, 0.3)
            seq += [np.array([rng.uniform(0.07, 0.10), rng.uniform(0.10, 0.12), 0.0, tss, tds]) for _ in range(k)]
        elif family == "sharp_turns":
            for j in range(k):
                swing = 1 if (WARMUP + j) % 2 == 0 else -1  # the env starts on the right foot: the left swings first
                outer = rng.uniform(0.6, 1.0) * robot.turn_outer * swing
                theta = outer if j % 2 == 0 else -swing * robot.turn_inner * rng.uniform(0.6, 1.0)
                seq.append(np.array([rng.uniform(0.0, 0.05), nominal[1], theta, nominal[3], nominal[4]]))
        else:  # box_edges
            for _ in range(k):
                ends = rng.integers(0, 2, 5).astype(bool)
                c = np.where(ends, hi, lo)
                c[2] = 0.0 if rng.integers(0, 2) else c[2] * 0.5  # half the turn box: inside either side's limits
                seq.append(c)
        out.append((family, np.array([_clip(robot, c) for c in seq])))
    return out


def body_failure(result: Any) -> int | None:
    """The first footstep where the OP3 fell or tipped (:data:`TIP_MARGIN`), None if neither."""
    tips = [k for k, m in enumerate(result.cop_margin) if math.isfinite(m) and m < TIP_MARGIN]
    firsts = [k for k in (result.fell_at, tips[0] if tips else None) if k is not None]
    return min(firsts) if firsts else None


def env_failure(commands: np.ndarray, robot: Any) -> tuple[int | None, str | None]:
    """The env's first fall (index, reason) on ``commands``, or (None, None)."""
    v = verdict(commands, robot)
    for k, reason in enumerate(v):
        if reason is not None:
            return k, reason
    return None, None


def confusion(env_fail: Sequence[bool], body_fail: Sequence[bool]) -> dict[str, Any]:
    """The 2 x 2 counts (env verdict x full body) and the rates."""
    e, b = np.asarray(env_fail, bool), np.asarray(body_fail, bool)
    tp, tn = int(np.sum(e & b)), int(np.sum(~e & ~b))
    fp, fn = int(np.sum(e & ~b)), int(np.sum(~e & b))
    n = len(e)
    return {"n": n, "env_fall_body_fail": tp, "env_fall_body_walks": fp, "env_ok_body_fail": fn,
            "env_ok_body_walks": tn, "agreement": round((tp + tn) / n, 3) if n else math.nan,
            "env_ok_and_body_walks_given_env_ok": round(tn / (tn + fn), 3) if tn + fn else math.nan,
            "body_fails_given_env_fall": round(tp / (tp + fp), 3) if tp + fp else math.nan}


def swing_speeds(robot: Robot, commands: np.ndarray) -> np.ndarray:
    """Each footstep's swing-foot travel (from where that foot stood to where the command puts it) over T_SS [m/s]."""
    feet = dict(start_feet(robot))
    support = RIGHT
    out = []
    for S, L, theta, t_ss, _ in np.asarray(commands, dtype=float):
        new = footstep.place_foot_scalar(feet[support], support, S, L, theta)
        old = feet[-support]
        out.append(math.hypot(new[0] - old[0], new[1] - old[1]) / t_ss)
        feet[-support] = new
        support = -support
    return np.array(out)


def checked_failure(commands: np.ndarray, robot: Robot, max_swing_speed: float = math.inf) -> int | None:
    """The env's first fall on ``commands``, or an earlier footstep whose swing speed exceeds ``max_swing_speed``."""
    env_at, _ = env_failure(commands, robot)
    fast = np.flatnonzero(swing_speeds(robot, commands) > max_swing_speed)
    firsts = [k for k in (env_at, int(fast[0]) if len(fast) else None) if k is not None]
    return min(firsts) if firsts else None


def calibrate(records: Sequence[dict[str, Any]], robot: Robot, scales: Sequence[float],
              speeds: Sequence[float]) -> tuple[float, float]:
    """``(zmp_region_scale, max_swing_speed)`` of the grid whose :func:`checked_failure` agrees most with the OP3
    (fell or not) on ``records``; ties go to the scale nearest the profile's own, then to the fastest swing."""
    best, best_key = None, None
    swing = [swing_speeds(robot, rec["commands"]) for rec in records]
    for s in scales:
        r = dataclasses.replace(robot, zmp_region_scale=s)
        env_at = [env_failure(rec["commands"], r)[0] for rec in records]  # the env's verdict: once per scale
        for v in speeds:
            agree = 0
            for rec, at, sp in zip(records, env_at, swing):
                fast = np.flatnonzero(sp > v)
                failed = at is not None or len(fast) > 0
                agree += failed == rec["body_fell"]
            key = (agree, -abs(s - robot.zmp_region_scale), v)
            if best_key is None or key > best_key:
                best, best_key = (float(s), float(v)), key
    return best


#: The calibration's candidate ZMP region scales and swing-speed limits [m/s] (inf: none).
SCALES = tuple(round(0.3 + 0.05 * i, 2) for i in range(15))  # 0.30 .. 1.00
SPEEDS = tuple(round(0.3 + 0.1 * i, 1) for i in range(13)) + (math.inf,)  # 0.3 .. 1.5 m/s


def agreement_records(robot_name: str, n: int, seed: int, progress: Any = None) -> list[dict[str, Any]]:
    """Walk every sequence of :func:`agreement_sequences` whole on the OP3; one record per sequence."""
    robot = load_robot(robot_name)
    records = []
    for i, (family, commands) in enumerate(agreement_sequences(robot, n, seed)):
        env_at, reason = env_failure(commands, robot_name)
        res = walk(commands, robot=robot_name)
        margins = [None if not math.isfinite(m) else round(float(m), 5) for m in res.cop_margin]
        records.append({"index": i, "family": family, "commands": commands.round(6).tolist(),
                        "env_fall_at": env_at, "env_fall": reason, "body_fell": res.fell, "body_fell_at": res.fell_at,
                        "body_fail": res.fell, "body_failed_at": body_failure(res), "cop_margin": margins,
                        "ik_residual": res.ik_residual,
                        "foot_error": [round(float(e), 5) for e in res.foot_error], "wall_time": res.wall_time,
                        "sim_time": res.sim_time})
        if progress is not None:
            progress(i, records[-1])
    return records


def agreement_report(records: Sequence[dict[str, Any]], robot_name: str) -> dict[str, Any]:
    """Confusion matrices (all, per family, per half) and the calibration fitted on one half and reported on the
    other: sequence ``i`` is in the fitting half when ``(i // len(FAMILIES)) % 2 == 0`` (every family in both)."""
    robot = load_robot(robot_name)
    for rec in records:
        rec["commands"] = np.asarray(rec["commands"], dtype=float)
    env = [r["env_fall_at"] is not None for r in records]
    fell = [r["body_fell"] for r in records]
    tipped = [r["body_failed_at"] is not None for r in records]
    fit = [r for r in records if (r["index"] // len(FAMILIES)) % 2 == 0]
    held = [r for r in records if (r["index"] // len(FAMILIES)) % 2 == 1]
    scale, speed = calibrate(fit, robot, SCALES, SPEEDS)
    calibrated = dataclasses.replace(robot, zmp_region_scale=scale)
    body_held = [r["body_fell"] for r in held]
    out = {
        "all_fell": confusion(env, fell), "all_fell_or_tipped": confusion(env, [a or b for a, b in zip(fell, tipped)]),
        "per_family": {f: confusion([e for e, r in zip(env, records) if r["family"] == f],
                                    [b for b, r in zip(fell, records) if r["family"] == f]) for f in FAMILIES},
        "per_env_reason": {},
        "calibration": {
            "rule": "the (zmp_region_scale, max swing speed) of {} x {} m/s whose verdict (the env's first fall, or a "
                    "footstep whose swing travel / T_SS exceeds the speed) agrees most with 'the OP3 fell' on the "
                    "fitting half (sequence i with (i // 6) % 2 == 0); ties to the scale nearest the profile's {}, "
                    "then the fastest".format(list(SCALES), [str(v) for v in SPEEDS], robot.zmp_region_scale),
            "fitted_scale": scale, "fitted_max_swing_speed": speed,
            "fit_before": confusion([env[r["index"]] for r in fit], [r["body_fell"] for r in fit]),
            "held_out_before": confusion([env[r["index"]] for r in held], body_held),
            "held_out_after": confusion([checked_failure(r["commands"], calibrated, speed) is not None for r in held],
                                        body_held)},
    }
    for reason in ("zmp", "swing", "overlap", "turn_limit"):
        rs = [r for r in records if r["env_fall"] == reason]
        out["per_env_reason"][reason] = {"sequences": len(rs), "body_fell": sum(r["body_fell"] for r in rs)}
    for rec in records:
        rec["commands"] = rec["commands"].tolist()
    return out


#: The steady strides [m] and single-support times [s] of :func:`swing_grid` (docs/fullbody.md §1).
SWING_STRIDES = (0.03, 0.06, 0.08, 0.1)
SWING_T_SS = (0.15, 0.2, 0.3, 0.4, 0.5)
#: Footsteps of each :func:`steady_ramp` held at its command.
SWING_HOLD = 6


def steady_ramp(robot: Robot, S: float, t_ss: float, hold: int = SWING_HOLD, t_ds: float | None = None) -> np.ndarray:
    """Stepping in place, then half the stride ``S`` [m], then T_SS cut from the nominal to ``t_ss`` [s] over four
    steps at that stride (geometrically, so that the LIPM accepts it), then ``hold`` steps of ``[S, nominal L, 0,
    t_ss, t_ds]``; ``t_ds`` [s] (``None``: the nominal) is cut from the nominal alongside T_SS."""
    L, t_n, t_dn = robot.nominal_side_stride, robot.nominal_t_ss, robot.nominal_t_ds
    t_ds = t_dn if t_ds is None else t_ds
    cmds = [[0.0, L, 0.0, t_n, t_dn], [S / 2, L, 0.0, t_n, t_dn]]
    cuts = zip(np.geomspace(t_n, t_ss, 5)[1:], np.geomspace(t_dn, t_ds, 5)[1:])
    cmds += [[S, L, 0.0, float(a), float(b)] for a, b in cuts]
    cmds += [[S, L, 0.0, t_ss, t_ds]] * hold
    return np.array(cmds)


def swing_grid(robot: Robot | str = "op3-lipm", limited: Robot | str = "op3") -> list[dict[str, Any]]:
    """Each (stride, T_SS) of :data:`SWING_STRIDES` x :data:`SWING_T_SS`: :func:`steady_ramp` walked on the OP3
    with ``robot``'s plan; whether it fell, the smallest CoP margin over the held steps, the env's verdict with
    ``robot`` and with ``limited`` (the swing's floor)."""
    rob, lim = (r if isinstance(r, Robot) else load_robot(r) for r in (robot, limited))
    out = []
    for S in SWING_STRIDES:
        for t_ss in SWING_T_SS:
            cmds = steady_ramp(rob, S, t_ss)
            res = walk(cmds, robot=rob)
            held = res.cop_margin[len(cmds) - SWING_HOLD:]
            out.append({"S": S, "t_ss": t_ss, "floor": round(float(footstep.swing_time_floor(lim, S, math)), 4),
                        "fell": res.fell, "fell_at": res.fell_at,
                        "held_min_cop_margin_mm": (round(1000 * float(np.nanmin(held)), 2)
                                                   if np.any(np.isfinite(held)) else None),
                        "tipped": bool(res.fell or not np.all(held >= TIP_MARGIN)),
                        "env": next((v for v in verdict(cmds, rob) if v), None),
                        "env_limited": next((v for v in verdict(cmds, lim) if v), None)})
    return out


#: The double-support times [s] of :func:`double_support_grid`, around op3's shortest (``t_ds``'s lower end).
DS_T_DS = (0.2, 0.15, 0.11, 0.1, 0.08, 0.05, 0.02)
#: :func:`double_support_grid` holds each stride at its swing floor (up to 10 ms) and at this many times it.
DS_FLOOR_SHARES = (1.0, 1.25)


def double_support_grid(robot: Robot | str = "op3-lipm", limited: Robot | str = "op3") -> list[dict[str, Any]]:
    """Each stride of :data:`SWING_STRIDES` at T_SS its swing floor under ``limited`` (up to 10 ms) times each of
    :data:`DS_FLOOR_SHARES`, and each T_DS of :data:`DS_T_DS`: :func:`steady_ramp` walked on the OP3 with
    ``robot``'s plan (its T_DS range widened to the grid's); whether it fell, the smallest CoP margin over the held
    steps, the gait's speed ``S / (T_SS + T_DS)``, and the env's verdict with ``robot``'s LIPM."""
    rob, lim = (r if isinstance(r, Robot) else load_robot(r) for r in (robot, limited))
    wide = dataclasses.replace(rob, t_ds=(min(min(DS_T_DS), rob.t_ds[0]), max(max(DS_T_DS), rob.t_ds[1])))
    out = []
    for S in SWING_STRIDES:
        floor = math.ceil(round(footstep.swing_time_floor(lim, S, math) * 100, 6)) / 100
        for share in DS_FLOOR_SHARES:
            t_ss = round(floor * share, 2)
            for t_ds in DS_T_DS:
                cmds = steady_ramp(wide, S, t_ss, t_ds=t_ds)
                res = walk(cmds, robot=wide)
                held = res.cop_margin[len(cmds) - SWING_HOLD:]
                out.append({"S": S, "t_ss": t_ss, "floor_share": share, "t_ds": t_ds,
                            "speed": round(S / (t_ss + t_ds), 4), "fell": res.fell, "fell_at": res.fell_at,
                            "held_min_cop_margin_mm": (round(1000 * float(np.nanmin(held)), 2)
                                                       if np.any(np.isfinite(held)) else None),
                            "tipped": bool(res.fell or not np.all(held >= TIP_MARGIN)),
                            "env": next((v for v in verdict(cmds, wide) if v), None)})
    return out
