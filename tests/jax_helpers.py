"""What the JAX backend's replay tests share: the float64 tolerances (docs/jax.md states them) and the check of a
batch of replayed episodes (footstep_gym.jax.replay.compare's agreements)."""

#: Observation tolerance of a float64 replay: the observation is float32, so one float32 ulp of the largest slot
#: (|x| < 4) plus what a few float64 ulps can turn into.
OBS_TOL_64 = 1e-6
#: Reward tolerance of a float64 replay.
REWARD_TOL_64 = 1e-9
#: [m] the clearance at the sweep's checks: the same instants and distances up to float64 rounding.
CLEARANCE_TOL_64 = 1e-12


def check_replays(agreements, outcomes: set) -> None:
    """Each replayed episode ended as the reference's did (or at a documented near-tie), its observations, rewards and
    sweep clearances within the float64 tolerances; the reference's endings are added to ``outcomes``."""
    for a in agreements:
        assert a.same or a.near_tie, a
        assert a.obs_error <= OBS_TOL_64 and a.reward_error <= REWARD_TOL_64, a
        assert a.clearance_error <= CLEARANCE_TOL_64, a
        outcomes.add(a.reference[0])
