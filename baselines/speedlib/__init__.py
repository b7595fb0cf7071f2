"""How fast footstep_gym is, and whether it holds up: the code behind ``baselines/speed.py`` and
``baselines/soak.py`` (their command lines). Not part of the installed package: the scripts import it
from their own folder (``python baselines/speed.py`` puts ``baselines/`` first on ``sys.path``) and the
tests through pytest's ``pythonpath`` setting (``pyproject.toml``). One job per module:

* :mod:`.settings`: how much a run measures (``Settings``, ``MODES``: smoke / quick / full), its
  ``SECTIONS`` and its progress lines on stderr;
* :mod:`.timing`: ``summary`` (median, IQR, min/max of repetitions), ``tail_summary`` (median, p95,
  p99 of single timings), ``median_ratio_interval`` (bootstrap interval of a ratio of medians,
  episodes resampled in pairs);
* :mod:`.machine`: ``machine_info`` (CPU, cores, OS, versions) and ``loadavg``;
* :mod:`.memory_use`: this process's RSS (``rss_bytes``, ``RssPeak``, ``max_rss_bytes``; no psutil) and
  the memory section (``bench_memory``: one env and the period-aware planner, each figure in a
  process of its own);
* :mod:`.env_rates`: env steps/s in one process (interleaved cells), through ``gym.make_vec`` (sync and
  async) and on another checkout's env (``--compare-with``) (``bench_envs``);
* :mod:`.lipm_rates`: LIPM feasibility checks/s, one command and batched (``bench_lipm``);
* :mod:`.planner_times`: planning time per footstep and success of each planner, timed through the
  evaluation runner's episode loop and warm-up (``bench_planners``);
* :mod:`.tier_rates`: env steps/s and the period-aware planner's time per footstep on every cell of every
  benchmark tier (configs/benchmark.yaml), beside the paper tier (``bench_tiers``);
* :mod:`.ppo_rates`: PPO training throughput beside CartPole (``bench_ppo``);
* :mod:`.targets`: the speed targets' PASS / MISS and the ratios (``evaluate_targets``);
* :mod:`.reports`: the markdown of the speed run's and the soak's results;
* :mod:`.fmt`: formatting of figures and strict JSON (``finite_json``);
* :mod:`.fresh`: a function called in a fresh interpreter (memory probes, the PPO child, the soak's
  process per env);
* :mod:`.soak`: the soak engine (fuzzed steps, the checks after each, the RSS verdict).

Nothing is imported here: ``--compare-with`` loads :mod:`.env_rates` (with :mod:`.settings`,
:mod:`.timing`, :mod:`.fmt`) against another checkout's ``footstep_gym``, and no module imports
torch (the PPO figures come from a child process).
"""
