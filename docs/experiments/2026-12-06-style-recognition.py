#!/usr/bin/env python3
"""Style recognition from rotations, without training a network: the
experiment of docs/experiments/2026-12-06-style-recognition.md.

    python3 2026-12-06-style-recognition.py SET1_DATA [SET2_DATA]

Per clip, features of its joints' local rotations (the Hips' without
heading): per joint the mean and spread of the rotation vector, the mean
and 90th percentile of the angular speed, the log of the mean angular
acceleration; the root's mean ground speed and height spread over the
median Hips height; the log duration. Each content's takes are
standardised by that content's mean and spread; a linear discriminant
(pooled within-style covariance, shrunk 30 % toward its mean variance)
names the style. Reads BVH with scripts/inbetween-benchmark's reader.
"""
import collections
import importlib.machinery
import importlib.util
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
_loader = importlib.machinery.SourceFileLoader(
    "ib", os.path.join(HERE, "..", "..", "scripts", "inbetween-benchmark"))
ib = importlib.util.module_from_spec(importlib.util.spec_from_loader("ib", _loader))
_loader.exec_module(ib)


def logmap(r):
    """Rotation vectors of rotation matrices (..., 3, 3)."""
    a = np.arccos(np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1, 1))
    w = np.stack([r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0],
                  r[..., 1, 0] - r[..., 0, 1]], -1)
    s = np.sin(a)
    return w * np.where(s > 1e-6, a / (2 * s + 1e-12), 0.5)[..., None]


def features(path):
    b = ib.Bvh(path)
    pos, rot = b.world()
    dt, n = b.frame_time, len(pos)
    loc = np.empty_like(rot)
    for j, p in enumerate(b.parents):
        loc[:, j] = rot[:, j] if p < 0 else np.transpose(rot[:, p], (0, 2, 1)) @ rot[:, j]
    fwd = rot[:, 1, :, 2]  # the Hips (joint 1; joint 0 is Bandai Namco's static joint_Root)
    yaw = np.arctan2(fwd[:, 0], fwd[:, 2])
    ry = np.zeros((n, 3, 3))
    ry[:, 0, 0] = ry[:, 2, 2] = np.cos(yaw)
    ry[:, 0, 2], ry[:, 2, 0], ry[:, 1, 1] = np.sin(yaw), -np.sin(yaw), 1
    loc[:, 1] = np.transpose(ry, (0, 2, 1)) @ rot[:, 1]
    rv = logmap(loc[:, 1:])
    f = list(rv.mean(0).ravel()) + list(rv.std(0).ravel())
    step = np.transpose(loc[:-1, 1:], (0, 1, 3, 2)) @ loc[1:, 1:]
    av = np.linalg.norm(logmap(step), axis=-1) / dt
    f += list(av.mean(0)) + list(np.percentile(av, 90, axis=0))
    acc = np.linalg.norm(np.diff(rv, n=2, axis=0), axis=-1) / dt ** 2
    f += list(np.log1p(acc.mean(0)))
    hip = np.median(pos[:, 1, 1])
    ground = np.linalg.norm(np.diff(pos[:, 1, [0, 2]], axis=0), axis=1) / dt
    return np.array(f + [ground.mean() / hip, pos[:, 1, 1].std() / hip, np.log(n * dt)])


def lda(ztr, labels, shrink=0.3):
    classes = sorted(set(labels))
    cent = np.array([ztr[labels == c].mean(0) for c in classes])
    w = sum((ztr[labels == c] - m).T @ (ztr[labels == c] - m) for c, m in zip(classes, cent))
    w = w / len(ztr)
    w = (1 - shrink) * w + shrink * np.eye(len(w)) * np.trace(w) / len(w)
    wi = np.linalg.inv(w)
    return lambda z: classes[int(np.argmax([-(z - m) @ wi @ (z - m) for m in cent]))]


def skeleton_key(path):
    offs = []
    for line in open(path):
        t = line.split()
        if t and t[0] == "OFFSET":
            offs.append(tuple(round(float(x), 2) for x in t[1:4]))
        if t and t[0] == "MOTION":
            break
    return hash(tuple(offs))


def evaluate(data, folds):
    names = sorted(n for n in os.listdir(data) if n.endswith(".bvh"))
    x = np.array([features(os.path.join(data, n)) for n in names])
    content = np.array([n.split("_")[1] for n in names])
    style = np.array([n.split("_")[2] for n in names])
    actor = np.array([skeleton_key(os.path.join(data, n)) for n in names])
    fold = (np.arange(len(names)) if folds == 0
            else np.random.default_rng(0).permutation(len(names)) % folds)
    out = collections.Counter()
    for k in sorted(set(fold)):
        te, tr = fold == k, fold != k
        ztr, stats = np.empty_like(x[tr]), {}
        for c in set(content[tr]):
            m = content[tr] == c
            stats[c] = (x[tr][m].mean(0), x[tr][m].std(0) + 1e-6)
            ztr[m] = (x[tr][m] - stats[c][0]) / stats[c][1]
        g = ztr.std(0) + 1e-6
        name = lda(ztr / g, style[tr])
        for i in np.where(te)[0]:
            if content[i] not in stats:
                out["no other take of its content"] += 1
                continue
            out["takes"] += 1
            out["right"] += name((x[i] - stats[content[i]][0]) / stats[content[i]][1] / g) == style[i]
    # Leave one content out: each content standardised by its own takes.
    z = np.empty_like(x)
    for c in set(content):
        m = content == c
        z[m] = (x[m] - x[m].mean(0)) / (x[m].std(0) + 1e-6)
    for c in sorted(set(content)):
        te, tr = content == c, content != c
        if te.sum() < 3:
            continue
        g = z[tr].std(0) + 1e-6
        name = lda(z[tr] / g, style[tr])
        out["loco takes"] += te.sum()
        out["loco right"] += sum(name(z[i] / g) == style[i] for i in np.where(te)[0])
    groups = {a: sorted(set(style[actor == a])) for a in set(actor)}
    return out, groups


def main():
    for i, data in enumerate(sys.argv[1:3]):
        folds = 0 if i == 0 else 10
        out, groups = evaluate(data, folds)
        print(f"{data}: {'leave-one-take-out' if folds == 0 else '10-fold'} "
              f"{out['right'] / out['takes']:.3f} of {out['takes']} takes "
              f"({out['no other take of its content']} alone in their content); "
              f"leave-one-content-out {out['loco right'] / out['loco takes']:.3f} "
              f"of {out['loco takes']}")
        print("  styles by skeleton:", sorted(groups.values()))


if __name__ == "__main__":
    main()
