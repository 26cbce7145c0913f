#!/usr/bin/env python3
"""Merges `planner quality` CSVs into a best_known.csv for generated families.

Usage: best-known.py OUT.csv RUN.csv [RUN.csv ...]
Per instance it keeps the best score any run reached or the exact solver
proved (largest weight for max_weight, smallest cost for paper_cost, told
apart by the `-pc` in the family name that scripts/quality-sets.sh gives),
and marks it proved when an exact proof gave it.
"""
import csv
import sys

best = {}
for path in sys.argv[2:]:
    with open(path) as f:
        for row in csv.DictReader(f):
            name = row["instance"]
            cost = "-pc" in name
            cands = []
            if row["optimum"]:
                cands.append((float(row["optimum"]), row["optimum_source"] in ("exact", "best_known_proved")))
            if row["feasible"] == "true":
                cands.append((float(row["score"]), False))
            for value, proved in cands:
                old = best.get(name)
                better = old is None or (value < old[0] - 1e-9 if cost else value > old[0] + 1e-9)
                if better:
                    best[name] = (value, proved or (old is not None and old[1] and abs(old[0] - value) < 1e-9))
                elif proved and abs(old[0] - value) < 1e-9:
                    best[name] = (old[0], True)
with open(sys.argv[1], "w") as out:
    out.write("set,instance,n_nodes,tmax,best_known_score,proved_optimal,source\n")
    for name in sorted(best):
        value, proved = best[name]
        family = name.rsplit("-s", 1)[0]
        out.write(f"{family},{name},0,0,{value!r},{'yes' if proved else 'no'},planner quality runs and exact proofs\n")
