#!/bin/sh
# Builds the generator families `planner quality` is measured on
# (docs/quality.md): training families (tuned on) and held-out families
# (never tuned on). Usage: scripts/quality-sets.sh OUT_DIR [SEEDS]
# Each family is OUT_DIR/{train,heldout}/<family>/<family>-s<seed>.json.
set -eu
out=${1:?usage: quality-sets.sh OUT_DIR [SEEDS]}
seeds=${2:-4}
root=$(cd "$(dirname "$0")/.." && pwd)
planner=${PLANNER:-$root/target/release/planner}
bay="{\"png\": \"$root/crates/world/assets/bay-of-islands.png\", \"metres_per_pixel\": 20}"
family() { # split name first-seed scenario-json
  dir=$out/$1/$2
  mkdir -p "$dir"
  mkdir -p "$out/scenarios"
  sc=$out/scenarios/$2.json
  printf '%s\n' "$4" >"$sc"
  k=0
  while [ $k -lt "$seeds" ]; do
    s=$(($3 + k))
    "$planner" export --seed $s --scenario "$sc" --out "$dir/$2-s$s.json" >/dev/null
    k=$((k + 1))
  done
}
# Training: both charts, 40-128 nodes, both objectives, tight and loose
# budgets, perturbed (wider dynamic spread) snapshots.
family train bc40-mw 1 '{"nodes": 40}'
family train bc40-pc 1 '{"nodes": 40, "objective": {"kind": "paper_cost", "phi1": 0.01, "phi2": 1}}'
family train bi60-mw-loose 1 "{\"nodes\": 60, \"chart\": $bay, \"time_available_s\": 45000}"
family train bi60-pc-tight 1 "{\"nodes\": 60, \"chart\": $bay, \"time_available_s\": 15000, \"objective\": {\"kind\": \"paper_cost\", \"phi1\": 0.01, \"phi2\": 1}}"
family train bc90-mw-tight-perturbed 1 '{"nodes": 90, "dynamic": 40, "sigma_m": 300, "bound_sigma_m": 600, "time_available_s": 15000}'
family train bc64-pc 401 '{"nodes": 64, "objective": {"kind": "paper_cost", "phi1": 0.01, "phi2": 1}}'
family train bi128-pc 1 "{\"nodes\": 128, \"chart\": $bay, \"objective\": {\"kind\": \"paper_cost\", \"phi1\": 0.001, \"phi2\": 1}}"
# Held out: other seeds, sizes, budgets and weights, never tuned on.
family heldout bc30-mw-loose 101 '{"nodes": 30, "time_available_s": 60000}'
family heldout bi100-mw 101 "{\"nodes\": 100, \"chart\": $bay}"
family heldout bc64-pc-perturbed 101 '{"nodes": 64, "dynamic": 30, "sigma_m": 300, "bound_sigma_m": 600, "objective": {"kind": "paper_cost", "phi1": 0.05, "phi2": 0.5}}'
family heldout bi40-pc-tight 101 "{\"nodes\": 40, \"chart\": $bay, \"time_available_s\": 12000, \"objective\": {\"kind\": \"paper_cost\", \"phi1\": 0.01, \"phi2\": 1}}"
