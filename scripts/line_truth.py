#!/usr/bin/env python3
"""Diffuse `line` (and `line_isotropic`) truth at 60+ digits, against the references' estimates.

Definition (docs/targets.md): line = ∫₀ᴸ D(ω_p)·2‖ω_p × ω_t‖/‖p‖² dl with D = max(0, ω.z)/π.
With the line's foot f (⟂ ω_t, d = ‖f‖, c = f.z, t = ω_t.z) and u the signed distance from the
foot, p = f + u ω_t, ‖p‖² = d² + u², ω_p.z = (c + t u)/‖p‖, ‖ω_p × ω_t‖ = d/‖p‖:
    line = (2d/π) ∫ (c + t u)/(d² + u²)² du        over the part of [u1, u2] with c + t u > 0,
    line_isotropic = (1/π) ∫ (c + t u)/(d² + u²)^{3/2} du   over the same part.
Antiderivatives:  ∫ (c + t u)/(d²+u²)² du = c·[u/(2d²q) + atan(u/d)/(2d³)] − t/(2q),  q = d² + u²,
                  ∫ (c + t u)/(d²+u²)^{3/2} du = c·u/(d² √q) − t/√q.
Everything is computed from the exact binary values of the inputs in mpmath at `DPS` digits, and
again at DPS + 40: a value whose two evaluations differ by more than 1e-30 relative is reported.

Each diffuse, untextured configuration's `line`, `line_upper` and `line_isotropic` references (at
the drawn inputs and at the f32-rounded ones, `reference_f32_inputs`) are compared with the truth:
per family (the id up to its first '-'), how many lie outside their estimate |ref − truth| > error,
the worst |ref − truth|/error and the worst relative gap (docs/references.md, "The horizon").

Usage: scripts/line_truth.py RAW.jsonl [RAW2.jsonl ...]      (sweep --raw lines, with "config")
       scripts/line_truth.py --eval INPUT.jsonl OUTPUT.jsonl  (linelight eval's input and output)
Options: --family PREFIX (only ids starting with it), --top N (print the N worst), --json FILE
(write per-value rows). About 1 ms per configuration.
"""
import json
import sys
from mpmath import mp, mpf, sqrt, atan, pi

DPS = 60


def f32(x):
    import struct
    return struct.unpack("f", struct.pack("f", x))[0]


def truths(p1, p2, dps):
    """(line, line_isotropic) of the diffuse material for the segment p1 → p2, at `dps` digits."""
    with mp.workdps(dps):
        a = [mpf(x) for x in p1]
        b = [mpf(x) for x in p2]
        e = [b[k] - a[k] for k in range(3)]
        L = sqrt(sum(x * x for x in e))
        w = [x / L for x in e]
        s0 = sum(a[k] * w[k] for k in range(3))
        foot = [a[k] - s0 * w[k] for k in range(3)]
        d2 = sum(x * x for x in foot)
        d = sqrt(d2)
        c, t = foot[2], w[2]
        lo, hi = s0, s0 + L
        if t != 0:
            root = -c / t
            if t > 0:
                lo = max(lo, root)
            else:
                hi = min(hi, root)
        elif c <= 0:
            return mpf(0), mpf(0)
        if not lo < hi or d == 0:
            return mpf(0), mpf(0)

        def F(u):
            q = d2 + u * u
            return c * (u / (2 * d2 * q) + atan(u / d) / (2 * d2 * d)) - t / (2 * q)

        def G(u):
            r = sqrt(d2 + u * u)
            return c * u / (d2 * r) - t / r

        return 2 * d / pi * (F(hi) - F(lo)), (G(hi) - G(lo)) / pi


def truth(p1, p2):
    lo = truths(p1, p2, DPS)
    hi = truths(p1, p2, DPS + 40)
    for x, y in zip(lo, hi):
        if y != 0 and abs(x - y) > mpf("1e-30") * abs(y):
            print(f"warning: truth unsettled at {DPS} digits for {p1} {p2}: {x} {y}", file=sys.stderr)
    return hi


def rows_raw(paths):
    for path in paths:
        with open(path) as fh:
            for line in fh:
                r = json.loads(line)
                yield r["config"], r


def rows_eval(inp, out):
    with open(inp) as a, open(out) as b:
        for la, lb in zip(a, b):
            c, r = json.loads(la), json.loads(lb)
            assert c["id"] == r["id"], (c["id"], r["id"])
            yield c, r


def main(argv):
    family, top, jout = None, 10, None
    args = []
    i = 0
    while i < len(argv):
        if argv[i] == "--family":
            family = argv[i + 1]; i += 2
        elif argv[i] == "--top":
            top = int(argv[i + 1]); i += 2
        elif argv[i] == "--json":
            jout = argv[i + 1]; i += 2
        else:
            args.append(argv[i]); i += 1
    rows = rows_eval(args[1], args[2]) if args[0] == "--eval" else rows_raw(args)
    checked = {}
    outside = {}
    worst = []
    out_rows = []
    for config, r in rows:
        if config.get("material", {}).get("kind") != "diffuse" or config.get("texture"):
            continue
        if family and not config["id"].startswith(family):
            continue
        for inputs, vkey, ekey in [("drawn", "reference", "reference_error"),
                                   ("f32", "reference_f32_inputs", "reference_f32_inputs_error")]:
            refs = r.get(vkey) or {}
            errs = r.get(ekey) or {}
            if not refs:
                continue
            p1, p2 = config["p1"], config["p2"]
            if inputs == "f32":
                p1, p2 = [f32(x) for x in p1], [f32(x) for x in p2]
            tl, ti = truth(p1, p2)
            for target, tv in [("line", tl), ("line_upper", tl), ("line_isotropic", ti)]:
                if target not in refs or isinstance(refs[target], str):
                    continue
                v, e = refs[target], errs[target]
                gap = abs(mpf(v) - tv)
                ratio = float(gap / mpf(e)) if e > 0 else (0.0 if gap == 0 else float("inf"))
                relgap = float(gap / abs(tv)) if tv != 0 else (0.0 if gap == 0 else float("inf"))
                fam = config["id"].split("-")[0]
                key = (fam, target, inputs)
                checked[key] = checked.get(key, 0) + 1
                if gap > e:
                    outside[key] = outside.get(key, 0) + 1
                worst.append((ratio, relgap, config["id"], target, inputs, v, e, float(tv)))
                out_rows.append({"id": config["id"], "target": target, "inputs": inputs, "value": v,
                                 "error": e, "truth": str(tv), "ratio": ratio, "rel": relgap})
    print(f"{'family':24} {'target':15} {'inputs':6} {'values':>7} {'outside':>7} {'worst ratio':>12} {'worst rel':>10}")
    for key in sorted(checked):
        ws = [w for w in worst if (w[2].split("-")[0], w[3], w[4]) == key]
        wr = max(w[0] for w in ws)
        wrel = max(w[1] for w in ws)
        print(f"{key[0]:24} {key[1]:15} {key[2]:6} {checked[key]:7d} {outside.get(key, 0):7d} {wr:12.3g} {wrel:10.3g}")
    print(f"total values {sum(checked.values())}, outside their estimates {sum(outside.values())}")
    worst.sort(reverse=True)
    for w in worst[:top]:
        print("  ratio %.3g rel %.3g %s %s %s value %.15g error %.3g truth %.15g" % w)
    worst.sort(key=lambda w: -w[1])
    print("largest relative gaps:")
    for w in worst[:top]:
        print("  ratio %.3g rel %.3g %s %s %s value %.15g error %.3g truth %.15g" % w)
    if jout:
        with open(jout, "w") as fh:
            for row in out_rows:
                fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
