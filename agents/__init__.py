"""Learned policies for vcs-env: training, imitation and evaluation, in layers with one way down.

Each layer imports only the layers below it (``tests/test_imports.py`` checks there is no cycle):

1. What a run and a checkpoint are: :mod:`agents.config` (scenario configs and their flags),
   :mod:`agents.runs` (run configs and the run record), :mod:`agents.checkpoint` (one object per
   checkpoint format: SB3 zip, RLlib run), and the pieces a policy runs with: :mod:`agents.vec_env`,
   :mod:`agents.gym_vec`, :mod:`agents.features`, :mod:`agents.shield`, :mod:`agents.policies`.
2. Evaluation: :mod:`agents.evaluate` (the harness, with ``report``, ``probes`` and ``selection``).
3. Training and imitation: :mod:`agents.train` (SB3; ``rllib`` and its env, learner and cluster;
   the periodic evaluation of both; ``collect_states``) and :mod:`agents.imitation` (expert data,
   behaviour cloning, DAgger); then :mod:`agents.experiments` (seed studies).

The ``vcs-env`` commands over them are in :mod:`vcs_cli`. torch, stable-baselines3 and Ray are
imported where they are needed (when a model is built or loaded), not when a module is imported.
"""
