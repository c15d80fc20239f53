#!/usr/bin/env python3
"""What copies from the start would name, measured before building them (issue 72, item 2).

    python benches/start_copies_study.py BASE_DIR VERDICT_JSON NUDGED_JSON COPY_DIR...

BASE_DIR: the plane's map as shipped. COPY_DIR: the same map with the start nudged, one
folder per copy (`--set initial.rate_deg_s=j*1e-3`, j = 1 ... M): each cell of a copy map is
the cell's copy from its start, run through every stage the map has. VERDICT_JSON and
NUDGED_JSON as for benches/transients_study.py.

A cell's start sensitivity s is the share of its copies whose decided verdict (class, and the
period of a periodic one) differs from the map's, the rule of crates/core/src/reduce/escape.rs
(an undecided copy does not count). Over the settled reference cells, split by the nudged
reference into predictable and sensitive ones, the script prints, for two ways of choosing
the cells that would run the copies (every cell; only cells with a neighbour whose verdict
differs), what the issue's targets would read if a cell with s > 0 were held below firm:
the sensitive cells named, the firm share of the settled cells and how many of the firm are
right, and the copies' cost as a share of one map's cells times M.
"""
import json
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from transients_study import FIRM, load, reference_rows  # noqa: E402


def verdicts(folder):
    """(regime, period) per cell, period 0 where not periodic; and the grid's shape."""
    regime = np.load(f"{folder}/regime.npy")
    period = np.load(f"{folder}/period.npy").ravel()
    period = np.where(regime.ravel() == 1, np.nan_to_num(period), 0)
    return list(zip(regime.ravel().tolist(), period.tolist())), regime.shape


def sensitivity(own, copies):
    """Share of the copies whose decided verdict differs from `own` (escape.rs's rule)."""
    decided = [c for c in copies if c[0] not in (0, -1)]
    return sum(1 for c in decided if c != own) / len(copies)


def boundary(cells, shape):
    """Cells with a 4-neighbour whose verdict differs."""
    rows, cols = shape
    out = set()
    for k in range(rows * cols):
        i, j = divmod(k, cols)
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            a, b = i + di, j + dj
            if 0 <= a < rows and 0 <= b < cols and cells[a * cols + b] != cells[k]:
                out.add(k)
    return out


def score(rows, conf, sens_now, s, chosen, right):
    """The targets' counts with cells of `chosen` that have s > 0 held below firm."""
    flagged = {k for k in chosen if s[k] > 0}
    firm = [r for r in rows if conf[r[0]] >= FIRM and r[0] not in flagged]
    sensitive = [r for r in rows if not r[3]]
    named = [
        r for r in sensitive
        if not conf[r[0]] >= FIRM or sens_now[r[0]] > 0 or r[0] in flagged
    ]
    predictable_flagged = [r for r in rows if r[3] and r[0] in flagged]
    return {
        "cells_running_copies": len(chosen),
        "sensitive_named": [len(named), len(sensitive)],
        "firm_of_settled": [len(firm), len(rows), round(100.0 * len(firm) / len(rows), 1)],
        "right_of_firm_class_and_period": [sum(right[r[0]] for r in firm), len(firm)],
        "predictable_flagged": len(predictable_flagged),
    }


def main():
    base, ref_path, nudged_path, copy_dirs = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
    own, shape = verdicts(base)
    copies = [verdicts(d)[0] for d in copy_dirs]
    s = [sensitivity(own[k], [c[k] for c in copies]) for k in range(len(own))]
    conf = np.load(f"{base}/verdict_confidence.npy").ravel()
    regime = np.load(f"{base}/regime.npy")
    sens_now = load(base, "start_sensitivity", regime).ravel()
    rows = reference_rows(json.load(open(ref_path)), json.load(open(nudged_path)), shape)
    right = {k: own[k][0] == c and (c != 1 or own[k][1] == p) for k, c, p, _ in rows}
    every = set(range(len(own)))
    edge = boundary(own, shape)
    out = {
        "map": base,
        "copies": len(copy_dirs),
        "now": score(rows, conf, sens_now, s, set(), right),
        "every_cell": score(rows, conf, sens_now, s, every, right),
        "boundary_cells": score(rows, conf, sens_now, s, edge, right),
        "cells_with_s_above_0": sum(1 for x in s if x > 0),
        "sensitive_cells": [
            f"cell {k}: ref {c}/{p:g}, map {own[k][0]}/{own[k][1]:g}, conf {conf[k]:.3f}, "
            f"s_end {sens_now[k]:.2f}, s_start {s[k]:.2f}, boundary {k in edge}, "
            f"right {right[k]}"
            for k, c, p, ok in rows
            if not ok
        ],
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
