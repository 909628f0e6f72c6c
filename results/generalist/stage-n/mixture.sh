# The mixture of the stage-N rounds (policies/generalist.sh's entries plus the rounds' jittered circle-24
# entry), pinned here for the record scripts of this directory (round5.sh, parked-flag/run.sh,
# arrival-speed/run.sh) so they keep reproducing what was run if the recipe's mixture changes. Sourced.
MIX=(
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
  "circle-24-v0:jitter=0.1-0.2/0.1"
)
