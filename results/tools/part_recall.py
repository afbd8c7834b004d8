#!/usr/bin/env python3
"""Where a prediction loses or adds surface: recall and precision per height band.

An analysis of finished runs, not a metric of the evaluation (the report's numbers are the
max-pool IoU, Chamfer-L1, normal consistency; see README "Evaluation"). It answers one question
the sampling ablation raised: does an assignment rule lose the thin parts (legs, a swivel base)
that the paper's boundary-aware rule exists to keep?

For every test mesh a run wrote (`<row>/seed-*/meshes/<synset>/<object>_v<view>.ply`) and the
ground-truth mesh of its object (`<dataset>/meshes/<synset>/<object>.obj`, the same unit-cube
frame, y up), both surfaces are sampled (3000 ground-truth points to query, 12000 to query
against, 6000 predicted points; fixed seeds). With `cut = -0.5 + 0.35` (the lower 35 % of the unit height: a procedural chair's legs
or base, below its seat):

  leg_recall     share of ground-truth points below `cut` within one voxel (1/32) of a predicted point
  top_recall     the same above `cut` (seat and back)
  leg_precision  share of predicted points below `cut` within one voxel of a ground-truth point

A leg the prediction dropped lowers leg_recall; a blob around the legs lowers leg_precision.
Rows are paired with the first row on (seed, object), views averaged, and the mean difference is
printed with twice its standard error, as the ablation report does.

    python3 results/tools/part_recall.py datasets/ablation-chair results/ablation-sampling/full-model \
        results/ablation-sampling/no-boundary-aware > part_recall.csv
    python3 results/tools/part_recall.py --selftest datasets/ablation-chair

`--selftest` checks the measure on answers known in advance: each ground-truth mesh as its own
prediction scores 1 everywhere, and the same mesh with everything below the cut removed
loses its leg recall (below 0.5) and keeps its top recall.

Needs numpy and trimesh (`.ci/run` installs both).
"""
import collections
import csv
import glob
import math
import os
import sys

import numpy as np
import trimesh

from stats import mean_se

VOXEL = 1.0 / 32
CUT = -0.5 + 0.35


def sample(mesh, n):
    points, _ = trimesh.sample.sample_surface(mesh, n, seed=0)
    return np.asarray(points, dtype=np.float32)


def near(a, b):
    """For each point of a: is a point of b within one voxel?"""
    if len(b) == 0:
        return np.zeros(len(a), bool)
    out = np.empty(len(a), bool)
    for i in range(0, len(a), 1000):
        d = ((a[i:i + 1000, None, :] - b[None, :, :]) ** 2).sum(-1)
        out[i:i + 1000] = d.min(1) < VOXEL * VOXEL
    return out


def share(mask):
    return float(mask.mean()) if len(mask) else float("nan")


def gt_points(mesh):
    """The ground truth's query points (recall) and a denser sample to query against (precision:
    a thin leg holds few of 3000 points, and a correct prediction there must find one near)."""
    return sample(mesh, 3000), sample(mesh, 12000)


def scores(gt, pred):
    query, dense = gt
    low_gt, top_gt = query[query[:, 1] < CUT], query[query[:, 1] >= CUT]
    low_pred = pred[pred[:, 1] < CUT]
    return {
        "leg_recall": share(near(low_gt, pred)),
        "top_recall": share(near(top_gt, pred)),
        "leg_precision": share(near(low_pred, dense)),
    }


def gt_mesh(dataset, synset, obj):
    return trimesh.load(os.path.join(dataset, "meshes", synset, obj + ".obj"), force="mesh")


def selftest(dataset):
    for path in sorted(glob.glob(os.path.join(dataset, "meshes", "*", "*.obj")))[:6]:
        mesh = trimesh.load(path, force="mesh")
        gt = gt_points(mesh)
        same = scores(gt, sample(mesh, 6000))
        assert all(v > 0.99 for v in same.values()), (path, same)
        # Below the cut removed: split the faces finely, drop those with a vertex below it.
        v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=0.005)
        legless = trimesh.Trimesh(v, f[v[f][:, :, 1].min(1) >= CUT])
        cut = scores(gt, sample(legless, 6000))
        assert cut["leg_recall"] < 0.5 and cut["top_recall"] > 0.99, (path, cut)
        print(f"{os.path.basename(path)}: itself {same}, without legs {cut}")
    print("selftest passed")


def main(dataset, rows):
    keys = ["leg_recall", "top_recall", "leg_precision"]
    gts, table = {}, collections.defaultdict(dict)
    out = csv.writer(sys.stdout)
    out.writerow(["row", "seed", "object", "view"] + keys)
    for row in rows:
        name = os.path.basename(row.rstrip("/"))
        for path in sorted(glob.glob(os.path.join(row, "seed-*", "meshes", "*", "*.ply"))):
            seed = path.split("seed-")[1].split(os.sep)[0]
            synset = os.path.basename(os.path.dirname(path))
            obj, view = os.path.basename(path)[:-4].rsplit("_v", 1)
            if obj not in gts:
                gts[obj] = gt_points(gt_mesh(dataset, synset, obj))
            s = scores(gts[obj], sample(trimesh.load(path, force="mesh"), 6000))
            table[name][(seed, obj, view)] = s
            out.writerow([name, seed, obj, view] + [f"{s[k]:.4f}" for k in keys])
    names = [os.path.basename(r.rstrip("/")) for r in rows]
    base = table[names[0]]
    print(file=sys.stderr)
    print("| row | meshes | " + " | ".join(keys) + " | " + " | ".join(f"Δ {k} (2·SE)" for k in keys) + " |", file=sys.stderr)
    print("|---" * (2 + 2 * len(keys)) + "|", file=sys.stderr)
    for name in names:
        rows_ = table[name]
        cells = []
        for k in keys:
            m, se = mean_se([v[k] for v in rows_.values() if not math.isnan(v[k])])
            cells.append(f"{m:.3f} ± {se:.3f}")
        for k in keys:
            if name == names[0]:
                cells.append("–")
                continue
            pairs = collections.defaultdict(list)
            for key, v in rows_.items():
                if key in base and not math.isnan(v[k]) and not math.isnan(base[key][k]):
                    pairs[key[:2]].append(v[k] - base[key][k])
            m, se = mean_se([sum(d) / len(d) for d in pairs.values()])
            resolved = abs(m) > 2 * se
            cell = f"{m:+.3f} ({2 * se:.3f})"
            cells.append(f"**{cell}**" if resolved else cell)
        print(f"| {name} | {len(rows_)} | " + " | ".join(cells) + " |", file=sys.stderr)


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--selftest":
        selftest(sys.argv[2])
    elif len(sys.argv) >= 3:
        main(sys.argv[1], sys.argv[2:])
    else:
        sys.exit(__doc__)
