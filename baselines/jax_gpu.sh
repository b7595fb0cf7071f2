#!/usr/bin/env bash
# The batched JAX backend's GPU figures in one run: steps/s of each scene at N up to 65,536, then ppo-jax's time to
# 0.95 validation success on the door (one seed). Needs JAX with a CUDA backend in the active Python (for example
# pip install -c constraints.txt "jax[cuda12]" at the pinned JAX version); it stops with one line if JAX sees no GPU.
#
#     bash baselines/jax_gpu.sh [OUT]        # OUT: where the tables and the run go (default runs/jax_gpu)
#
# Writes OUT/speed_<scene>.txt (baselines/jax_speed.py), OUT/ppo_jax_door.log and OUT/ppo-jax/ (the run, not shipped).
set -euo pipefail
OUT=${1:-runs/jax_gpu}
PY=${PYTHON:-python}
backend=$("$PY" -c "import jax; print(jax.default_backend())")
if [ "$backend" != "gpu" ]; then
  echo "jax_gpu.sh: JAX's backend is '$backend', not 'gpu': install JAX with CUDA (jax[cuda12]) first" >&2
  exit 2
fi
mkdir -p "$OUT"
"$PY" -c "import jax; print(jax.devices())" | tee "$OUT/devices.txt"
for scene in door crossing crowd; do
  "$PY" baselines/jax_speed.py --scene "$scene" --sizes 1,1024,4096,16384,65536 --workloads random,walk \
      --repeats 3 --reference-steps 2000 | tee "$OUT/speed_$scene.txt"
done
"$PY" baselines/train_jax.py --env FootstepDoor-v0 --seeds 1 --runs-dir "$OUT/ppo-jax" | tee "$OUT/ppo_jax_door.log"
