"""The paper's own footstep commands (Lee et al., Tables 2 and 4) through the env's feasibility check.

The tables are data (``tests/data/paper_table2.csv``, ``paper_table4.csv``, as printed). Each run
of consecutive steps is replayed with :func:`footstep_gym.lipm.check_step`, the verdict
``env.step`` applies, carrying the CoM from step to step as ``env.step`` does (the end state,
relative to the new foot in its frame, starts the next step). A run starts where ``env.reset``
starts an episode: in the steady gait of stepping in place at the nominal period (mirrored
when the run's first step swings the right foot; the env always starts on the right foot).
Table 4 has a gap (steps 21-37 are not printed), so its steps 38-40 start afresh.

**Reading the tables** (docs/model.md §5.3):

* Table 2 prints the lateral step under "S" and the forward step under "L": its "S" column
  alternates in sign from step to step (-8.87, 6.88, -7.62, ...), like Table 4's "L" column,
  while its "L" column is always positive (4.3-7.5 cm, Table 4's forward range). So Table 2's
  two columns are read swapped; Table 4's as printed.
* The sign of the lateral step names the swinging foot: positive = the left foot (it lands
  to the left of the support foot). Consecutive rows alternate, as they must.
* θ is read as printed, counter-clockwise positive like ours (eq. 3 takes it with atan2 in
  the frame of Fig. 5). An outward turn is θ > 0 for the left foot, θ < 0 for the right one.

**What the replay shows:**

* The ZMP check accepts every row of both tables, for our robot and for the ``darwin-op``
  profile alike (the ZMP does not depend on the kinematic limits). The largest offsets are
  6.4 mm forward (row 18) and 14.1 mm sideways (row 21: (5.6, -14.1) mm, the period
  lengthened from 0.40 to 0.68 s in one step) in Table 2, under 1 mm in Table 4, against
  limits of (26, 16.5) mm.
* Our robot (``configs/robot.yaml``) rejects six of Table 2's ten rows kinematically: rows 13,
  17 and 20 turn the new foot inwards by 0.21, 0.28 and 0.36 rad (θ_inner 0.2); rows 14 and 16
  step 6.88 and 6.49 cm sideways (L >= 7 cm: the env clips L to 7 cm and the soles, turned
  outwards, then overlap); row 22 (7.09 cm, turned outwards 0.07 rad) overlaps. It accepts
  all of Table 4.
* The ``darwin-op`` profile (``configs/robots/darwin-op.yaml``: θ_inner 0.4 rad, L from 6 cm,
  no gap between the soles) accepts all of Table 4 and eight rows of Table 2. Rows 14 and
  16 put the new sole on the support sole whatever the stride and turn limits: the new foot
  lands 6.9 and 6.5 cm beside the support foot, 7.3 and 7.5 cm ahead, turned *outwards*
  (0.09, 0.14 rad), so its heel swings in over the 6.6 cm wide support sole. No limit on S,
  L or θ admits them; only a sole at most 57.9 mm wide would (the DARwIn-OP's is 66 mm).
  Read θ the other way round (clockwise positive: those turns inwards, the heels swinging
  out), the ``darwin-op`` profile accepts every row of both tables (row 16 with 1.7 mm of
  sole width to spare; with robot.yaml's 2 mm gap it would overlap): the tables are
  consistent with the paper's robot under that reading only (or with overlapping soles).
"""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import footstep, lipm
from footstep_gym.footstep import LEFT, RIGHT
from footstep_gym.robot import Robot, load_robot

DATA = Path(__file__).parent / "data"
PROFILES = ("default", "darwin-op")


@dataclasses.dataclass(frozen=True)
class Row:
    """One printed row, read as a command of ours."""

    table: int
    step: int
    swing: int  # the foot that moves: LEFT (+1) or RIGHT (-1)
    command: tuple[float, float, float, float, float]  # [S, L, theta, T_SS, T_DS], SI, L > 0 outward

    @property
    def support(self) -> int:
        return -self.swing

    def __str__(self) -> str:
        S, L, theta, t_ss, t_ds = self.command
        return (f"Table {self.table} row {self.step} ({footstep.SIDE_NAMES[self.swing]} foot swings: S={S * 100:.2f} cm, "
                f"L={L * 100:.2f} cm, theta={theta:+.2f} rad, T_SS={t_ss:.2f} s, T_DS={t_ds:.2f} s)")


def read_table(table: int, theta_sign: float = 1.0) -> list[Row]:
    """Table 2 or 4 as commands: Table 2's S and L columns swapped (see the module doc), θ times ``theta_sign``."""
    with open(DATA / f"paper_table{table}.csv", encoding="utf-8") as fh:
        records = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    rows = []
    for rec in records:
        printed_s, printed_l = float(rec["S_cm"]) / 100, float(rec["L_cm"]) / 100
        forward, lateral = (printed_l, printed_s) if table == 2 else (printed_s, printed_l)
        swing = LEFT if lateral > 0 else RIGHT
        command = (forward, abs(lateral), theta_sign * float(rec["theta_rad"]), float(rec["t_ss_s"]),
                   float(rec["t_ds_s"]))
        rows.append(Row(table, int(rec["step"]), swing, command))
    return rows


def runs(rows: list[Row]) -> list[list[Row]]:
    """The rows split into runs of consecutive steps."""
    out: list[list[Row]] = []
    for row in rows:
        if out and row.step == out[-1][-1].step + 1:
            out[-1].append(row)
        else:
            out.append([row])
    return out


def robot_of(profile: str) -> Robot:
    return load_robot() if profile == "default" else load_robot(profile)


@dataclasses.dataclass(frozen=True)
class Verdict:
    row: Row
    kinematic_ok: bool
    zmp_ok: bool
    zmp_offset: complex  # [m], in the support foot's frame


def replay(robot: Robot, rows: list[Row]) -> list[Verdict]:
    """Each run from the env's starting gait, the CoM carried over as ``env.step`` carries it.

    The ZMP offset of a command is computed (and the CoM carried on) whether or not its
    kinematic limits pass: a row's ZMP verdict does not hang on an earlier row's kinematics.
    """
    verdicts = []
    for run in runs(rows):
        com, vel = lipm.steady_state(robot, robot.nominal_command, run[0].support)
        for row in run:
            kin_ok, zmp_ok, p, com, vel = lipm.check_step(robot, com, vel, row.command, row.support)
            verdicts.append(Verdict(row, kin_ok, zmp_ok, p))
    return verdicts


def env_verdict(robot: Robot, row: Row) -> tuple[bool, str]:
    """What the env makes of the row's kinematics: clipped into the action box (as ``env.step`` does), then the
    side's turn limits and the soles' overlap. ``(ok, why not)``."""
    command = np.clip(np.asarray(row.command), robot.command_low, robot.command_high)
    S, L, theta = command[:3]
    lo, hi = footstep.turn_bounds(row.support, robot)
    if not lo - 1e-9 <= theta <= hi + 1e-9:
        return False, "turn"
    if footstep.feet_overlap(S, L, theta, row.support, robot):
        return False, "overlap"
    return True, ""


# ====================================================================== the data
@pytest.mark.parametrize("table", [2, 4])
def test_tables_alternate_feet_and_keep_the_papers_timing(table):
    """The data as read: consecutive rows swing alternate feet; T_DS and T_SS lie in the paper's ranges."""
    rows = read_table(table)
    assert len(rows) == (10 if table == 2 else 6)
    for run in runs(rows):
        for a, b in zip(run, run[1:]):
            assert b.swing == -a.swing, f"{a} and {b} swing the same foot"
    for row in rows:
        S, L, theta, t_ss, t_ds = row.command
        assert 0.04 <= S <= 0.08 and 0.06 <= L <= 0.10, f"{row}: not a forward step of 4-8 cm, 6-10 cm sideways"
        assert 0.1 <= t_ds <= 0.3 and 0.1 <= t_ss <= 0.6, str(row)


def test_replay_starts_where_the_env_starts():
    """``env.reset`` puts the CoM in the steady gait of stepping in place at the nominal period, on the right foot."""
    env = gym.make("FootstepCrossing-v0", crossing_x=5.0)
    env.reset(seed=0)
    snap = env.unwrapped.sensing()
    robot = env.unwrapped.robot
    env.close()
    com, vel = lipm.steady_state(robot, robot.nominal_command, RIGHT)
    assert snap.support_side == RIGHT
    assert np.allclose(snap.com_local, (com.real, com.imag), atol=1e-12)
    assert np.allclose(snap.vel_local, (vel.real, vel.imag), atol=1e-12)


# ====================================================================== the ZMP check
@pytest.mark.parametrize("profile", PROFILES)
@pytest.mark.parametrize("table", [2, 4])
def test_zmp_check_accepts_every_row(table, profile):
    robot = robot_of(profile)
    hx, hy = robot.zmp_half_extent
    verdicts = replay(robot, read_table(table))
    for v in verdicts:
        p = v.zmp_offset
        assert v.zmp_ok, (f"{v.row}: ZMP offset ({p.real * 1e3:.1f}, {p.imag * 1e3:.1f}) mm outside "
                          f"(+-{hx * 1e3:.1f}, +-{hy * 1e3:.1f}) mm ({profile} robot)")
    worst_x = max(abs(v.zmp_offset.real) for v in verdicts)
    worst_y = max(abs(v.zmp_offset.imag) for v in verdicts)
    # Inside the region: Table 2 at worst 6.4 mm forward (row 18), 14.1 mm sideways (row 21); Table 4 under 1 mm.
    bound = (0.008, 0.015) if table == 2 else (0.001, 0.001)
    assert worst_x <= bound[0] and worst_y <= bound[1], (worst_x, worst_y)


def test_zmp_check_accepts_tables_2_and_4_under_either_sign_of_theta():
    """The ZMP verdict does not hang on the reading of θ's sign either."""
    robot = load_robot()
    for table in (2, 4):
        for v in replay(robot, read_table(table, theta_sign=-1.0)):
            assert v.zmp_ok, f"{v.row} (θ read clockwise): ZMP offset {v.zmp_offset * 1e3} mm"


# ====================================================================== the kinematic limits
#: Rows each robot rejects, and why (``env_verdict``): θ outside the side's turn limits, or the soles overlapping.
REJECTED = {
    ("default", 2): {13: "turn", 14: "overlap", 16: "overlap", 17: "turn", 20: "turn", 22: "overlap"},
    ("default", 4): {},
    ("darwin-op", 2): {14: "overlap", 16: "overlap"},
    ("darwin-op", 4): {},
}


@pytest.mark.parametrize("profile", PROFILES)
@pytest.mark.parametrize("table", [2, 4])
def test_kinematic_limits_reject_exactly_the_rows_named(table, profile):
    robot = robot_of(profile)
    expected = REJECTED[(profile, table)]
    for v in replay(robot, read_table(table)):
        ok, why = env_verdict(robot, v.row)
        if v.row.step in expected:
            assert not ok and why == expected[v.row.step], f"{v.row}: expected rejected ({expected[v.row.step]}), got {ok, why}"
        else:
            assert ok and v.kinematic_ok, f"{v.row}: rejected ({why}) by the {profile} robot"


def test_our_robot_rejects_table_2_for_its_turn_and_side_limits():
    """Rows 13, 17, 20 turn the new foot inwards beyond θ_inner = 0.2 rad; rows 14 and 16 step less than 7 cm
    sideways (the env clips L to 7 cm, and the outward-turned soles overlap there)."""
    robot = load_robot()
    rows = {r.step: r for r in read_table(2)}
    for step, inward in ((13, 0.21), (17, 0.28), (20, 0.36)):
        row = rows[step]
        assert -row.swing * row.command[2] == pytest.approx(inward), str(row)  # > 0: towards the support foot
        assert inward > robot.turn_inner
    for step in (14, 16):
        assert rows[step].command[1] < robot.stride_side[0], str(rows[step])


def test_no_stride_or_turn_limit_admits_rows_14_and_16_on_the_darwin_op_sole():
    """The overlap is the sole's geometry, not a limit: with every stride and turn allowed the soles of rows 14 and 16
    still overlap at the DARwIn-OP's 104 x 66 mm (no gap); a sole of at most 57.9 mm would clear both (row 14 alone:
    64.2 mm)."""
    loose = load_robot({"profile": "darwin-op", "stride_front": [-0.2, 0.2], "stride_side": [0.01, 0.2],
                        "turn_inner": 1.0, "turn_outer": 1.0})
    assert (loose.foot_length, loose.foot_width, loose.foot_clearance) == (0.104, 0.066, 0.0)
    rows = {r.step: r for r in read_table(2)}
    for step in (14, 16):
        row = rows[step]
        S, L, theta = row.command[:3]
        assert row.swing * theta > 0, f"{row}: turned outwards"
        assert footstep.feet_overlap(S, L, theta, row.support, loose), str(row)
        for width, overlaps in ((0.0579, False), (0.0580, step == 16)):
            narrow = load_robot({"profile": "darwin-op", "foot_width": width})
            assert bool(footstep.feet_overlap(S, L, theta, row.support, narrow)) == overlaps, (str(row), width)


def test_darwin_op_accepts_every_row_if_theta_is_read_clockwise():
    """Under the other reading of θ's sign, the overlapping rows turn inwards (their heels swing out) and the
    ``darwin-op`` profile accepts both tables whole: its limits are what that reading needs (θ_inner >= 0.30 for
    Table 4, L from 6.49 cm, no 2 mm gap for Table 2 row 16)."""
    robot = load_robot("darwin-op")
    for table in (2, 4):
        for v in replay(robot, read_table(table, theta_sign=-1.0)):
            assert v.kinematic_ok and v.zmp_ok, f"{v.row} (θ read clockwise), darwin-op: {env_verdict(robot, v.row)}"
    default = load_robot()
    rejected = [v.row.step for v in replay(default, read_table(4, theta_sign=-1.0)) if not v.kinematic_ok]
    assert rejected == [38, 39, 40]  # inward turns of 0.28-0.30 rad: beyond our θ_inner
