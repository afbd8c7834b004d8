#!/usr/bin/env python3
"""Paired differences between rows of finished runs, pooled over several run directories.

An ablation report pairs the rows of *one* ablation directory on (training seed, evaluation
object). A per-object fit evaluates one object per run, so its noise bar needs rows gathered
from several directories (one per object, e.g. `--set data.object=K --out .../objK`). This
script pools them: each ROW is `label=GLOB`, the GLOB matching run directories (those holding a
`metrics.json`); runs are keyed by (evaluated object ids, seed) and every row is paired with the
first on those keys. Several globs for one row are separated by commas.

    python3 results/tools/paired.py \\
        'none=results/sweep-lambda-fit-one/none/seed-*,results/sweep-lambda-fit-objects/obj*/none/seed-*' \\
        'λ=3=results/sweep-lambda-fit-one/3/seed-*,results/sweep-lambda-fit-objects/obj*/3/seed-*'

Prints a markdown table: per row the number of runs, the mean ± SE of max-pool IoU, mesh
Chamfer-L1 (×10) and mesh normal consistency, and the paired difference with the first row
(mean and 2·SE over the shared keys; bold when |Δ| > 2·SE, at least three pairs exist and, for
IoU, |Δ| ≥ 0.005, as in the ablation report).
Standard library only. `--selftest` checks the statistics on known numbers.
"""

import glob
import json
import math
import os
import sys
import tomllib

from stats import mean_se

# (column, value of a metrics.json, scale, least |Δ| called resolved: the ablation report's rule)
METRICS = [
    ("max-pool IoU", lambda m: m["mean_iou"], 1.0, 0.005),
    ("Chamfer-L1 ×10", lambda m: mesh_mean(m, "chamfer_l1"), 10.0, 0.0),
    ("normal consistency", lambda m: mesh_mean(m, "normal_consistency"), 1.0, 0.0),
]

# Fewer pairs than this are never called resolved: two paired differences that happen to agree
# give a 2·SE near zero that says nothing.
MIN_PAIRS = 3


def mesh_mean(m, key):
    """The mean of a mesh metric over categories, weighted by meshes."""
    total, count = 0.0, 0
    for cat in m["per_category"].values():
        mesh = cat.get("mesh") or {}
        if mesh.get(key) is not None and mesh.get("meshes"):
            total += mesh[key] * mesh["meshes"]
            count += mesh["meshes"]
    return total / count if count else float("nan")


def run_key(run_dir, m):
    """(evaluated object ids, seed): what two rows must share to be paired."""
    ids = tuple(
        sorted(o[0] for c in m["per_category"].values() for o in c.get("per_object", []))
    )
    with open(os.path.join(run_dir, "config.toml"), "rb") as f:
        seed = tomllib.load(f)["seed"]
    return ids, seed


def load_row(pattern):
    """The finished runs matching `pattern` (globs separated by commas), keyed by run_key."""
    runs = {}
    dirs = sorted(d for part in pattern.split(",") for d in glob.glob(part))
    for d in dirs:
        path = os.path.join(d, "metrics.json")
        if not os.path.exists(path):
            continue
        m = json.load(open(path, encoding="utf-8"))
        key = run_key(d, m)
        if key in runs:
            sys.exit(f"{pattern}: two runs share object(s) and seed {key}")
        runs[key] = m
    return runs


def fmt_delta(d, two_se, n, least=0.0):
    text = f"{d:+.3f} ({two_se:.3f})"
    resolved = n >= MIN_PAIRS and abs(d) > two_se and abs(d) >= least
    return f"**{text}**" if resolved else text


def table(rows):
    base_label, base = rows[0]
    names = [name for name, _, _, _ in METRICS]
    head = ["row", "runs"] + [f"{n} ± SE" for n in names]
    head += [f"Δ {n} (2·SE)" for n in names] + ["pairs"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for label, runs in rows:
        cells = [label, str(len(runs))]
        for _, get, scale, _ in METRICS:
            mu, se = mean_se([get(m) * scale for m in runs.values()])
            cells.append(f"{mu:.3f} ± {se:.3f}")
        shared = sorted(set(runs) & set(base))
        for _, get, scale, least in METRICS:
            if label == base_label:
                cells.append("–")
                continue
            d, se = mean_se([(get(runs[k]) - get(base[k])) * scale for k in shared])
            cells.append(fmt_delta(d, 2 * se, len(shared), least))
        cells.append("–" if label == base_label else str(len(shared)))
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def selftest():
    mu, se = mean_se([1.0, 2.0, 3.0])
    assert abs(mu - 2.0) < 1e-12 and abs(se - 1 / math.sqrt(3)) < 1e-12, (mu, se)
    assert math.isnan(mean_se([1.0])[1])
    assert fmt_delta(0.5, 0.1, 3).startswith("**")
    assert not fmt_delta(0.05, 0.1, 3).startswith("**")
    assert not fmt_delta(0.5, 0.1, 2).startswith("**"), "two pairs are never resolved"
    assert not fmt_delta(0.004, 0.001, 5, 0.005).startswith("**"), "below the least effect"

    def fake(iou, chamfer, nc):
        mesh = {"meshes": 2, "chamfer_l1": chamfer, "normal_consistency": nc}
        return {"mean_iou": iou, "per_category": {"chair": {"mesh": mesh, "per_object": []}}}

    keys = [(("a",), 0), (("b",), 0), (("b",), 1)]
    base = {k: fake(0.5 + 0.1 * i, 0.02, 0.8) for i, k in enumerate(keys)}
    row = {k: fake(0.6 + 0.1 * i, 0.02, 0.8) for i, k in enumerate(keys)}
    row[(("c",), 0)] = fake(0.9, 0.05, 0.5)  # unpaired: counted in its row's mean only
    text = table([("base", base), ("row", row)])
    last = text.splitlines()[-1]
    assert "**+0.100 (0.000)**" in last and last.endswith("| 3 |"), text
    assert "| row | 4 |" in last, text
    print("paired.py selftest: ok")


def main(argv):
    if argv == ["--selftest"]:
        selftest()
        return
    if len(argv) < 2 or any("=" not in a for a in argv):
        sys.exit(__doc__)
    rows = []
    for spec in argv:
        label, pattern = spec.rsplit("=", 1)
        runs = load_row(pattern)
        if not runs:
            if not rows:
                sys.exit(f"{label} (the row the others are paired with): no finished run matches {pattern}")
            print(f"{label}: no finished run matches {pattern} (left out)", file=sys.stderr)
            continue
        rows.append((label, runs))
    print(table(rows))


if __name__ == "__main__":
    main(sys.argv[1:])
