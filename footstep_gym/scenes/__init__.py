"""The scene layer: each scenario's maths written once with an array namespace (``xp``).

Per scenario, pure functions for a cell's parameters from its config, the per-episode draw and the
moving obstacles' poses at time ``t``, called with ``xp = numpy`` by the reference env and with
``xp = jax.numpy`` by the batched backend. Nothing here imports pymunk, JAX or the benchmark layer.
"""
