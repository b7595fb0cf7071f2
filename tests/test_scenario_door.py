"""``FootstepDoor-v0`` (footstep_gym/scenarios/door.py): the revolving door's draws and its scene.

Per seed: the door's starting angle, the robot's start and a randomized door speed, within the ranges of
scenarios/door.yaml read directly. The scene: a wing meets a robot stepping in place at the instant
worked out independently (the CoM by scipy's integration of the LIPM, the rod by its constant rotation),
a robot standing outside never collides, and the half drum closes the door's upper half without a gap
while the rod turns clear of every wall (checked with plain segment geometry written here).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from env_helpers import NOMINAL, moving, read_yaml


# ------------------------------------------------------------------ draws per seed
def test_door_angle_jitter_draws_differ_and_stay_in_range():
    door = read_yaml("scenarios/door.yaml")
    env = gym.make("FootstepDoor-v0")
    angles = []
    for seed in range(12):
        env.reset(seed=seed)
        (rod,) = moving(env)
        angles.append(math.degrees(rod.angle))
        assert rod.angular_velocity == pytest.approx(-math.radians(door["door_speed"]))  # clockwise
    lo = door["door_start_angle"] - door["door_angle_jitter"]
    hi = door["door_start_angle"] + door["door_angle_jitter"]
    assert all(lo <= a <= hi for a in angles)
    assert len(set(angles)) == len(angles)
    assert max(angles) - min(angles) > door["door_angle_jitter"]  # spread over the range


def test_start_jitter_moves_the_robot_within_bounds():
    cfg = read_yaml("scenarios/door.yaml")
    env = gym.make("FootstepDoor-v0")
    centres = []
    for seed in range(10):
        env.reset(seed=seed)
        centres.append(env.unwrapped.sensing().centre)
    centres = np.array(centres)
    assert np.all(np.abs(centres - np.array(cfg["start"])) <= cfg["start_jitter"] + 1e-12)
    assert len({tuple(c) for c in centres}) == len(centres)


def test_randomized_door_speed_is_drawn_within_range_per_seed():
    env = gym.make("FootstepDoor-v0", randomize={"door_speed": [8, 17]})
    speeds = []
    for seed in range(20):
        env.reset(seed=seed)
        (rod,) = moving(env)
        body = next(o.body for o in env.unwrapped.world.obstacles if o.name == rod.name)
        assert body.angular_velocity == rod.angular_velocity
        speeds.append(-math.degrees(rod.angular_velocity))
        assert env.unwrapped.episode_config.door_speed == pytest.approx(speeds[-1])
    assert all(8.0 <= s <= 17.0 for s in speeds)
    assert len(set(speeds)) == len(speeds)
    assert min(speeds) < 10.0 and max(speeds) > 15.0
    # The drawn speed is what the door really does: it turns that fast over a step.
    env.reset(seed=0)
    before = moving(env)[0].angle
    env.step(NOMINAL)
    after = moving(env)[0].angle
    assert math.degrees(before - after) / 0.8 == pytest.approx(speeds[0], rel=1e-9)


# ------------------------------------------------------------------ the door and a robot stepping in place
def lipm_com_path(starts, feet, first_support, t_ss, t_ds, omega, dt=2e-4):
    """CoM path of stepping in place by scipy integration of c'' = omega^2 (c - p(t)).

    ``starts``: the CoM ``(position, velocity)`` at the start of each step (the pendulum
    is unstable, so each step is integrated from the state the env reports rather than
    open loop over many steps). ZMP at the support foot's centre during single support,
    moving linearly to the other foot's centre during double support (the nominal
    schedule, docs/model.md §3). Returns ``(t, c)`` with c of shape (N, 2).
    """
    def rhs(_t, y, pa, pb, t0, tau):
        p = pa + (pb - pa) * (_t - t0) / tau if tau else pa
        return [y[2], y[3], omega ** 2 * (y[0] - p[0]), omega ** 2 * (y[1] - p[1])]

    ts, cs = [], []
    support = first_support
    t0 = 0.0
    for com, vel in starts:
        state = np.array([*com, *vel], dtype=float)
        pa, pb = np.asarray(feet[support]), np.asarray(feet[-support])
        for (start, end, tau, a, b) in ((t0, t0 + t_ss, 0.0, pa, pa), (t0 + t_ss, t0 + t_ss + t_ds, t_ds, pa, pb)):
            sol = solve_ivp(rhs, (start, end), state, args=(a, b, start, tau), dense_output=True,
                            rtol=1e-10, atol=1e-12, method="DOP853")
            grid = np.linspace(start, end, max(2, int(round((end - start) / dt))), endpoint=False)
            ts.append(grid)
            cs.append(sol.sol(grid)[:2].T)
            state = sol.y[:, -1]
        t0 += t_ss + t_ds
        support = -support
    return np.concatenate(ts), np.concatenate(cs)


def rod_distance(points, angle, centre, half_length):
    """Distance from points (N, 2) to the rod's axis segment through ``centre`` at ``angle`` (N,)."""
    u = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    rel = points - np.asarray(centre)
    s = np.clip(np.einsum("nd,nd->n", rel, u), -half_length, half_length)
    return np.linalg.norm(rel - s[:, None] * u, axis=1)


@pytest.mark.parametrize("door_speed, start_angle, start", [
    (17.0, 130.0, (0.0, -0.30)),  # the lower wing sweeps down onto a robot below the post
    (8.0, 130.0, (0.0, -0.30)),
    (14.0, 75.0, (0.25, -0.20)),  # the upper wing comes round clockwise onto a robot right of the post
])
def test_door_wing_hits_robot_stepping_in_place_at_predicted_time(door_speed, start_angle, start):
    door = read_yaml("scenarios/door.yaml")
    robot = read_yaml("robot.yaml")
    env = gym.make("FootstepDoor-v0", door_speed=door_speed, door_start_angle=start_angle,
                   door_angle_jitter=0.0, start_jitter=0.0, start=list(start))
    _, info0 = env.reset(seed=0)
    infos = []
    for _ in range(12):
        _, _, terminated, truncated, info = env.step(NOMINAL)
        infos.append(info)
        if terminated or truncated:
            break
    assert info["termination"] == "collision" and info["obstacle"] == "door"
    for earlier in infos[:-1]:
        assert abs(earlier["zmp_offset"][0]) < 1e-9 and abs(earlier["zmp_offset"][1]) < 1e-9

    # Independent reference: the CoM by ODE integration, the rod by its constant rotation.
    half = 0.5 * robot["nominal_side_stride"]
    feet = {-1: (start[0], start[1] - half), +1: (start[0], start[1] + half)}  # right, left; yaw 0
    omega = math.sqrt(robot["gravity"] / robot["com_height"])
    starts = [(i["com"], i["com_vel"]) for i in [info0, *infos[:-1]]]
    t, c = lipm_com_path(starts, feet, -1, robot["nominal_t_ss"], robot["nominal_t_ds"], omega)
    angle = math.radians(start_angle) - math.radians(door_speed) * t
    d = rod_distance(c, angle, door["door_centre"], door["door_radius"])
    touching = d < robot["body_radius"] + 0.5 * door["door_thickness"]
    assert touching.any() and not touching[0]
    t_true = t[np.argmax(touching)]
    assert 0.0 < t_true
    reported = info["time"]
    env_cfg = read_yaml("env.yaml")
    assert t_true - 1e-3 <= reported <= t_true + env_cfg["max_check_interval"] + 1e-3, (reported, t_true)
    # The robot was stepped through whole steps until then: contact lies inside the last one.
    assert reported > 0.8 * (len(infos) - 1) - 1e-9
    env.close()


def test_standing_outside_the_door_never_collides():
    env = gym.make("FootstepDoor-v0", door_speed=17.0)
    env.reset(seed=2)
    for _ in range(40):  # 32 s: the door turns more than a full revolution
        _, _, terminated, truncated, info = env.step(NOMINAL)
        assert not terminated and not truncated and not info["collision"]


# ------------------------------------------------------------------ the revolving door's half drum
def _door_views(**overrides):
    env = gym.make("FootstepDoor-v0", **overrides)
    env.reset(seed=0)
    views = env.unwrapped.world.views()
    env.close()
    return views


def _world_segment(view, angle=None):
    """World endpoints of a segment view (its body turned to ``angle``, default its own)."""
    ang = view.angle if angle is None else angle
    c, s = math.cos(ang), math.sin(ang)
    px, py = view.position
    a = np.array([px + c * view.a[0] - s * view.a[1], py + s * view.a[0] + c * view.a[1]])
    b = np.array([px + c * view.b[0] - s * view.b[1], py + s * view.b[0] + c * view.b[1]])
    return a, b


def _point_segment_distance(p, a, b):
    """Distance from points p (N, 2) to segments a-b (each (N, 2) or (2,))."""
    p, a, b = np.broadcast_arrays(np.atleast_2d(p), np.atleast_2d(a), np.atleast_2d(b))
    ab = b - a
    denom = (ab * ab).sum(axis=1)
    u = np.where(denom > 0, ((p - a) * ab).sum(axis=1) / np.where(denom > 0, denom, 1.0), 0.0)
    u = np.clip(u, 0.0, 1.0)
    return np.linalg.norm(p - (a + u[:, None] * ab), axis=1)


def _segment_segment_distance(p1, p2, q1, q2):
    """Distance between segments p1-p2 (N, 2) and q1-q2 (N, 2) in the plane: 0 if they cross,
    else the least of the four endpoint-to-segment distances."""
    p1, p2, q1, q2 = np.broadcast_arrays(*(np.atleast_2d(np.asarray(v, dtype=float)) for v in (p1, p2, q1, q2)))

    def cross(o, a, b):
        return (a[:, 0] - o[:, 0]) * (b[:, 1] - o[:, 1]) - (a[:, 1] - o[:, 1]) * (b[:, 0] - o[:, 0])

    d1, d2 = cross(q1, q2, p1), cross(q1, q2, p2)
    d3, d4 = cross(p1, p2, q1), cross(p1, p2, q2)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    ends = np.minimum.reduce([_point_segment_distance(p1, q1, q2), _point_segment_distance(p2, q1, q2),
                              _point_segment_distance(q1, p1, p2), _point_segment_distance(q2, p1, p2)])
    return np.where(crossing, 0.0, ends)


def test_segment_distance_helper_known_numbers():
    """The plain-geometry helpers the drum tests rely on."""
    assert _segment_segment_distance([0, 0], [1, 0], [0.5, 0.3], [0.5, 2.0])[0] == pytest.approx(0.3)
    assert _segment_segment_distance([0, 0], [1, 0], [0.5, -1.0], [0.5, 1.0])[0] == 0.0  # crossing
    assert _segment_segment_distance([0, 0], [1, 0], [2.0, 0.0], [3.0, 0.0])[0] == pytest.approx(1.0)
    assert _segment_segment_distance([0, 0], [1, 0], [1.3, 0.4], [2.0, 2.0])[0] == pytest.approx(0.5)


def test_door_drum_closes_the_upper_half_without_a_gap():
    """Default door: every point of the half circle of the drum's radius above the corridor's top
    line lies within wall_thickness / 2 + 1 mm of a drum wall's centre line (in, or all but touching,
    its material), so no body gets between the drum's walls."""
    door = read_yaml("scenarios/door.yaml")
    views = _door_views()
    drum = [v for v in views if v.name.startswith("drum_")]
    assert len(drum) == door["drum_segments"]
    assert all(v.static and v.kind == "segment" for v in drum)
    half_t = 0.5 * door["wall_thickness"]
    radius = door["door_radius"] + 0.5 * door["door_thickness"] + door["wall_gap"] + half_t
    cx, cy = door["door_centre"]
    top = door["corridor_y"][1]
    a0 = math.asin(top / radius)
    ang = np.linspace(a0, math.pi - a0, 4001)
    pts = np.stack([cx + radius * np.cos(ang), cy + radius * np.sin(ang)], axis=1)
    assert np.all(pts[:, 1] >= cy + top - 1e-9)
    dist = np.full(len(pts), np.inf)
    for v in drum:
        a, b = _world_segment(v)
        dist = np.minimum(dist, _point_segment_distance(pts, a, b))
        # each wall lies on the upper side of the corridor's top line
        assert min(a[1], b[1]) >= cy + top - 1e-9
    assert dist.max() <= half_t + 1e-3, dist.max()
    # the drum meets the corridor's upper walls: their inner ends lie in drum material
    for name in ("wall_top_left", "wall_top_right"):
        (wall,) = [v for v in views if v.name == name]
        a, b = _world_segment(wall)
        inner = a if abs(a[0] - cx) < abs(b[0] - cx) else b
        assert min(_point_segment_distance(inner, *_world_segment(v))[0] for v in drum) <= half_t
    # ... while the corridor below stays open: along its middle line a robot's body clears every wall
    body_radius = read_yaml("robot.yaml")["body_radius"]
    x0, x1 = door["corridor_x"]
    mid = cy + 0.5 * (door["corridor_y"][0] + top)
    line = np.stack([np.linspace(cx + x0, cx + x1, 721), np.full(721, mid)], axis=1)
    for v in views:
        if v.static:
            assert _point_segment_distance(line, *_world_segment(v)).min() - v.radius > body_radius, v.name


@pytest.mark.parametrize("segments", [None, 6, 16, 40])  # None: the config's own drum_segments
def test_door_drum_is_a_closed_chain_and_the_rod_never_touches_it(segments):
    """For every drum_segments that validates, the walls chain end to end from one upper wall to the
    other, and over a full revolution the rod keeps clear of every wall (drum and corridor)."""
    door = read_yaml("scenarios/door.yaml")
    if segments is None:
        segments = door["drum_segments"]
    views = _door_views(drum_segments=segments)
    drum = [v for v in views if v.name.startswith("drum_")]
    assert len(drum) == segments
    cx, cy = door["door_centre"]
    ends = [_world_segment(v) for v in drum]
    # order the walls by the angle of their midpoints around the door centre, then chain them
    ends.sort(key=lambda ab: math.atan2(0.5 * (ab[0][1] + ab[1][1]) - cy, 0.5 * (ab[0][0] + ab[1][0]) - cx))
    for (a, b), (c, d) in zip(ends, ends[1:]):  # neighbours share a vertex
        assert min(np.linalg.norm(p - q) for p in (a, b) for q in (c, d)) < 1e-9
    walls = {v.name: v for v in views if v.static}
    first, last = ends[0], ends[-1]
    for name, piece in (("wall_top_right", first), ("wall_top_left", last)):
        wa, wb = _world_segment(walls[name])
        assert _segment_segment_distance(wa, wb, piece[0], piece[1])[0] < 1e-9, name

    (rod,) = [v for v in views if v.name == "door"]
    assert not rod.static and rod.angular_velocity != 0.0
    t = np.linspace(0.0, 2 * math.pi / abs(rod.angular_velocity), 7201)
    angle = rod.angle + rod.angular_velocity * t
    c, s = np.cos(angle), np.sin(angle)
    px, py = rod.position
    ra = np.stack([px + c * rod.a[0] - s * rod.a[1], py + s * rod.a[0] + c * rod.a[1]], axis=1)
    rb = np.stack([px + c * rod.b[0] - s * rod.b[1], py + s * rod.b[0] + c * rod.b[1]], axis=1)
    assert len(walls) == segments + 3
    for name, wall in walls.items():
        wa, wb = _world_segment(wall)
        gap = _segment_segment_distance(ra, rb, wa, wb) - rod.radius - wall.radius
        assert gap.min() > 0.0, (name, gap.min())


def test_door_drum_segments_validation():
    from footstep_gym.errors import ConfigError

    with pytest.raises(ConfigError, match="drum_segments") as err:
        gym.make("FootstepDoor-v0", drum_segments=3)
    assert isinstance(err.value, ValueError)
    # 5 chords of the 0.54 m drum sag 26 mm, more than the 20 mm wall_gap: into the rod's sweep
    with pytest.raises(ConfigError, match="drum_segments"):
        gym.make("FootstepDoor-v0", drum_segments=5)


def test_door_without_drum_has_no_drum_walls():
    views = _door_views(drum_segments=0)
    names = {v.name for v in views}
    assert not any(n.startswith("drum_") for n in names)
    assert names == {"door", "wall_bottom", "wall_top_left", "wall_top_right"}
