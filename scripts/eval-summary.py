#!/usr/bin/env python3
"""Mean object-map figures over `loci eval objects --json` files (scripts/eval-runs.sh).

usage: scripts/eval-summary.py RUN.json [RUN.json ...]
Prints one row per run (precision, recall, count error, mean centroid error, X-on-Y right,
false positives, misses) and the means.
"""
import json
import os
import sys


def main(paths):
    rows = []
    for path in paths:
        with open(path) as f:
            e = json.load(f)
        name = os.path.basename(path)[:-5]
        if name == "orientations":  # OUT/RUN/orientations.json: name it by its run
            name = os.path.basename(os.path.dirname(path))
        rows.append((name, e))
    keys = ["precision", "recall", "count_error", "mean_centroid_error_m", "on_right"]
    print("%-10s %9s %7s %6s %9s %6s  false positives / missed" %
          ("run", "precision", "recall", "count", "centroid", "X-on-Y"))
    for name, e in rows:
        fps = ",".join(str(i) for i in e["false_positive_ids"])
        print("%-10s %9.3f %7.3f %5.1f%% %8.3fm %6d  [%s] / %s" %
              (name, e["precision"], e["recall"], 100 * e["count_error"],
               e["mean_centroid_error_m"], e["on_right"], fps, ",".join(e["missed"])))
    if not rows:
        return 1
    mean = {k: sum(e[k] for _, e in rows) / len(rows) for k in keys}
    print("%-10s %9.3f %7.3f %5.1f%% %8.3fm %6.1f  (%d runs)" %
          ("mean", mean["precision"], mean["recall"], 100 * mean["count_error"],
           mean["mean_centroid_error_m"], mean["on_right"], len(rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
