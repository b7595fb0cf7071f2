"""How fast footstep_gym is, and whether it holds up: the code of ``baselines/benchmark.py`` and
``baselines/soak.py`` (those are their command lines), one job per module:

* :mod:`.settings`: how much the benchmark measures (``Settings``, ``MODES``: smoke / quick / full),
  its ``SECTIONS`` and its progress lines on stderr;
* :mod:`.stats`: ``summary`` (median, IQR, min/max of repetitions), ``tail_summary`` (median, p95,
  p99 of single timings), ``median_ratio_interval`` (bootstrap interval of a ratio of medians,
  episodes resampled in pairs);
* :mod:`.machine`: ``machine_info`` (CPU, cores, OS, versions) and ``loadavg``;
* :mod:`.memory`: this process's RSS (``rss_bytes``, ``RssPeak``, ``max_rss_bytes``; no psutil) and
  the memory section (``bench_memory``: one env and the period-aware planner, each figure in a
  process of its own);
* :mod:`.envs`: env steps/s in one process (interleaved cells), through ``gym.make_vec`` (sync and
  async) and on another checkout's env (``--compare-with``) (``bench_envs``);
* :mod:`.lipm`: LIPM feasibility checks/s, one command and batched (``bench_lipm``);
* :mod:`.planners`: planning time per footstep and success of each planner, timed through the
  evaluation runner's episode loop and warm-up (``bench_planners``);
* :mod:`.tiers`: env steps/s and the period-aware planner's time per footstep on every cell of every
  benchmark tier (configs/benchmark.yaml), beside the paper tier (``bench_tiers``);
* :mod:`.ppo`: PPO training throughput beside CartPole (``bench_ppo``);
* :mod:`.targets`: the targets' PASS / MISS and the ratios (``evaluate_targets``);
* :mod:`.report`: the markdown of the benchmark's and the soak's results;
* :mod:`.fmt`: formatting of figures and strict JSON (``finite_json``);
* :mod:`.fresh`: a function called in a fresh interpreter (memory probes, the PPO child, the soak's
  process per env);
* :mod:`.soak`: the soak engine (fuzzed steps, the checks after each, the RSS verdict).

Nothing is imported here: ``--compare-with`` loads :mod:`.envs` (with :mod:`.settings`,
:mod:`.stats`, :mod:`.fmt`) against another checkout's ``footstep_gym``, and no module imports
torch (the PPO figures come from a child process).
"""
