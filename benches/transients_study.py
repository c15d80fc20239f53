#!/usr/bin/env python3
"""Score a map folder against a plane's kept converged reference (both subgrids of the
verdict study), split by its nudged reference into predictable and sensitive cells.

    python benches/transients_study.py MAP_DIR VERDICT_JSON [NUDGED_JSON]

VERDICT_JSON: the plane's verdict study (docs/bench/verdict.json for the forcing plane,
docs/bench/verdict/<plane>/verdict.json for the others); NUDGED_JSON: its nudged reference
(`pendulum-atlas-lab nudged`, docs/bench/nudged/<plane>/nudged.json). A settled cell
(both reference runs decide alike) is predictable where the nudged run gives the reference's
verdict and, where periodic, its period. Prints one JSON: the counts the issue's targets
name (right on predictable cells, periods on predictable periodic cells, firm share and
firm right over the settled cells, sensitive cells not firm or with start_sensitivity > 0)
and the wrong predictable cells.
"""
import json
import sys

import numpy as np

FIRM = 0.9


def load(folder, name, like):
    try:
        return np.load(f"{folder}/{name}.npy")
    except FileNotFoundError:
        return np.full(like.shape, np.nan)


def reference_rows(v, nudged, shape):
    """(map cell, regime, period, predictable) per settled reference cell."""
    thin = v["thin"]
    rows = []
    # Subgrid A takes every `thin`th value of each axis from the first, B from the
    # (thin/2 + 1)th (benches/src/verdict.rs); C order.
    for i, (sub, offset) in enumerate((("reference", 0), ("second", thin // 2))):
        r = v[sub]
        axes = [range(offset, n, thin) for n in shape]
        cells = [a * shape[1] + b for a in axes[0] for b in axes[1]]
        n = nudged["runs"][i] if nudged else None
        for j, (k, reg, per, ok) in enumerate(zip(cells, r["regime"], r["period"], r["is_settled"])):
            if not ok:
                continue
            predictable = True
            if n is not None:
                same_class = n["regime"][j] == reg
                same_period = reg != 1 or n["period"][j] == per
                predictable = same_class and same_period
            rows.append((k, int(reg), per, predictable))
    return rows


def pct(a, b):
    return round(100.0 * a / b, 1) if b else None


def main():
    folder, ref_path = sys.argv[1], sys.argv[2]
    nudged = json.load(open(sys.argv[3])) if len(sys.argv) > 3 else None
    v = json.load(open(ref_path))
    regime = np.load(f"{folder}/regime.npy")
    shape = regime.shape
    regime = regime.ravel()
    period = np.load(f"{folder}/period.npy").ravel()
    conf = np.load(f"{folder}/verdict_confidence.npy").ravel()
    sens = load(folder, "start_sensitivity", regime).ravel()
    tau = load(folder, "transient_s", regime).ravel()
    rows = reference_rows(v, nudged, shape)
    right = {k: regime[k] == c for k, c, _, _ in rows}
    period_ok = {k: c != 1 or (regime[k] == 1 and period[k] == p) for k, c, p, _ in rows}
    pred = [r for r in rows if r[3]]
    sensitive = [r for r in rows if not r[3]]
    pred_periodic = [r for r in pred if r[1] == 1]
    firm = [r for r in rows if conf[r[0]] >= FIRM]
    named = [r for r in sensitive if not conf[r[0]] >= FIRM or sens[r[0]] > 0]
    out = {
        "map": folder,
        "reference": ref_path,
        "nudged": sys.argv[3] if nudged else None,
        "settled": len(rows),
        "predictable": len(pred),
        "right_of_predictable": [sum(right[r[0]] for r in pred), pct(sum(right[r[0]] for r in pred), len(pred))],
        "period_right_of_predictable_periodic": [
            sum(period_ok[r[0]] for r in pred_periodic),
            len(pred_periodic),
            pct(sum(period_ok[r[0]] for r in pred_periodic), len(pred_periodic)),
        ],
        "firm_of_settled": [len(firm), pct(len(firm), len(rows))],
        "right_of_firm": [sum(right[r[0]] for r in firm), pct(sum(right[r[0]] for r in firm), len(firm))],
        "sensitive_named": [len(named), len(sensitive), pct(len(named), len(sensitive))],
        "right_of_settled": [sum(right.values()), pct(sum(right.values()), len(rows))],
        "after_transient": int(sum(np.isfinite(tau[k]) and regime[k] == 1 for k, _, _, _ in rows)),
        "wrong_predictable": [
            f"cell {k}: ref {c}/{p:g}, map {regime[k]}/{period[k]:g}, conf {conf[k]:.3f}, "
            f"s {sens[k]:.2f}, tau {tau[k]:.1f}"
            for k, c, p, ok in pred
            if not (right[k] and period_ok[k])
        ],
        "sensitive_cells": [
            f"cell {k}: ref {c}/{p:g}, map {regime[k]}/{period[k]:g}, conf {conf[k]:.3f}, s {sens[k]:.2f}"
            for k, c, p, ok in sensitive
        ],
    }
    print(json.dumps(out, indent=1, default=int))


if __name__ == "__main__":
    main()
