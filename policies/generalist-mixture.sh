# The wide mixture of the generalist's later stages (C, E, F; sourced by policies/generalist.sh and
# results/generalist/stage-f/run.sh): the first stage's mixture plus crossing jitter and dynamic
# obstacle counts. Every entry is one or more scenarios (agents.config.mixture_scenarios).
MIX_WIDE=(
  "circle-8-v0:n_robots=4-12/4,jitter=0.1-0.5/0.2"
  "circle-16-v0:jitter=0.1-0.3/0.2"
  "circle-24-v0"
  "swap-v0:n_robots=6-10/4"
  "crossing-v0:n_robots=8-12/2,jitter=0.1-0.2/0.1"
  "crowd-5-v0:n_obstacles=3-8"
  "crowd-5-v0:obstacle_speed=1.0-1.5"
  "crowd-10-v0:n_obstacles=9-12"
  "crowd-20-v0:n_obstacles=14-22/2"
  "dynamic-v0:n_robots=2-6/2"
  "dynamic-v0:n_obstacles=4-8/2"
  "dynamic-v0:obstacle_speed=0.6-1.2"
)
