#!/bin/sh
# Runs every experiment of docs/paper-reproduction.md: the paper-budget
# Monte Carlo study and one study per knob, 200 runs, seed 1, each into
# OUT_DIR/<name>/ (summary.txt holds the table and the paired PSO − BBO
# comparison the doc quotes). Usage: scripts/paper-reproduction.sh OUT_DIR
set -eu
out=${1:?usage: paper-reproduction.sh OUT_DIR}
root=$(cd "$(dirname "$0")/.." && pwd)
planner=${PLANNER:-$root/target/release/planner}
study() { # name knobs...
  name=$1
  shift
  echo "== $name: $*" >&2
  "$planner" montecarlo --runs 200 --seed 1 --threads 2 "$@" --out "$out/$name" >/dev/null
}
study base
study paper-cost --objective paper-cost
study paper-cost-phi-x1.5 --objective paper-cost --phi1 0.0015 --phi2 1.5
study paper-cost-clamp0.5 --objective paper-cost --pso-velocity-clamp 0.5
study paper-cost-bbo-equal-decodes --objective paper-cost --bbo-generations 565
study paper-cost-density0.2 --objective paper-cost --edge-density 0.2
study bbo-equal-decodes --bbo-generations 565
study pso-equal-decodes --pso-iterations 40
study pso-50-particles --pso-particles 50
study iterations600 --iterations 600
study budget15000 --budget-s 15000
study budget60000 --budget-s 60000
study clamp0.1 --pso-velocity-clamp 0.1
study clamp0.5 --pso-velocity-clamp 0.5
study clamp1.0 --pso-velocity-clamp 1.0
study clamp-none --pso-velocity-clamp none
study walls-clamp --pso-walls clamp
study walls-free --pso-walls free
study walls-free-clamp-none --pso-walls free --pso-velocity-clamp none
study density0.5 --edge-density 0.5
study density0.2 --edge-density 0.2
for f in "$out"/*/summary.txt; do
  echo "$f"
done
