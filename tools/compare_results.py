#!/usr/bin/env python3
"""Compares two output folders of tools/make_results.py (a base run and a run of a change, on one machine)
model by model, and checks the whole-table rules a change is judged by:
  - no inverted hex; no minimum scaled Jacobian more than 0.05 below the base's, no average more than 0.003
    below it (issue 25's "no model's figures falling");
  - the total time, new over base;
  - the CAD-like models (issue 23's list) whose Hausdorff max is at most 0.5 hex edges, in each run.
Models present in only one folder are listed and left out of the rules; turned copies (OUT/rotated/<model>)
are compared as "<model> (turned)".

  tools/compare_results.py BASE NEW [--markdown FILE]
  tools/compare_results.py --self-test     (checks the rules on made-up reports; run by ctest)
"""
import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_results import node_of  # noqa: E402  (the kept branch's node: one definition)

MIN_FALL = 0.05
AVG_FALL = 0.003
HAUSDORFF_BAR = 0.5  # hex edges
CAD = ("fandisk", "casting", "carter", "joint", "block", "mambo_B0", "mambo_S3", "cuboid_screw_thread",
       "cuboid_torus_with_step", "cuboid_tray_with_step", "encrusted_cube", "7-connected", "8-connected",
       "conjoined_twins", "in-volume_knot", "in-volume_twist")


def figures(report_path):
    """min, avg, hexes, inverted, Hausdorff max in hex edges, seconds, attempts of one run's report.json."""
    r = json.loads(Path(report_path).read_text())
    n = r["nodes"]
    q = node_of(n, "quality").get("metrics", {})
    if "sj_min" not in q:
        return None
    h = q.get("hex_edge") or 0
    return {"min": q["sj_min"], "avg": q["sj_avg"], "hexes": q.get("hexes", 0), "inverted": q.get("inverted", 0),
            "haus_h": q["hausdorff_max"] / h if h > 0 else None, "seconds": r.get("seconds", 0.0),
            "attempts": len(r.get("retry", {}).get("attempts", [])) or 1}


def runs(folder):
    """{name: report path} of a make_results output folder, turned copies as "<model> (turned)"."""
    out = {}
    root = Path(folder)
    for sub, suffix in ((root, ""), (root / "rotated", " (turned)")):
        if sub.is_dir():
            for d in sorted(sub.iterdir()):
                if (d / "report.json").is_file():
                    out[d.name + suffix] = d / "report.json"
    return out


def compare(base, new):
    """(rows, verdict): one row per model in both folders, and the rules' findings."""
    a, b = runs(base), runs(new)
    rows, fell, inverted, only = [], [], [], sorted(set(a) ^ set(b))
    t_base = t_new = 0.0
    cad_ok = [0, 0]
    cad_total = 0
    for name in sorted(set(a) & set(b)):
        x, y = figures(a[name]), figures(b[name])
        if x is None or y is None:
            only.append(name + " (no mesh)")
            continue
        rows.append((name, x, y))
        t_base += x["seconds"]
        t_new += y["seconds"]
        if y["inverted"] > 0:
            inverted.append(name)
        why = []
        if y["min"] < x["min"] - MIN_FALL:
            why.append(f"min {x['min']:.3f} -> {y['min']:.3f}")
        if y["avg"] < x["avg"] - AVG_FALL:
            why.append(f"avg {x['avg']:.4f} -> {y['avg']:.4f}")
        if why:
            fell.append(f"{name}: " + ", ".join(why))
        if name in CAD:
            cad_total += 1
            cad_ok[0] += x["haus_h"] is not None and x["haus_h"] <= HAUSDORFF_BAR
            cad_ok[1] += y["haus_h"] is not None and y["haus_h"] <= HAUSDORFF_BAR
    verdict = {"models": len(rows), "fell": fell, "inverted": inverted, "only_in_one": only,
               "seconds": (t_base, t_new), "time_ratio": t_new / t_base if t_base > 0 else None,
               "cad_hausdorff_met": tuple(cad_ok), "cad_models": cad_total}
    return rows, verdict


def markdown(rows, v):
    def h(x):
        return "–" if x is None else f"{x:.2f}"
    out = ["| model | min | avg | hexes | inverted | Hausdorff max (h) | attempts | s |", "|---|---|---|---|---|---|---|---|"]
    for name, x, y in rows:
        out.append(f"| {name} | {x['min']:.3f} -> {y['min']:.3f} | {x['avg']:.4f} -> {y['avg']:.4f} | "
                   f"{x['hexes']} -> {y['hexes']} | {x['inverted']} -> {y['inverted']} | {h(x['haus_h'])} -> "
                   f"{h(y['haus_h'])} | {x['attempts']} -> {y['attempts']} | {x['seconds']:.0f} / {y['seconds']:.0f} |")
    out.append("")
    tb, tn = v["seconds"]
    ratio = f"{v['time_ratio']:.2f}" if v["time_ratio"] is not None else "–"
    out.append(f"{v['models']} models compared. Time {tb:.0f} s -> {tn:.0f} s ({ratio}x).")
    out.append(f"Inverted hexes in the new run: {', '.join(v['inverted']) or 'none'}.")
    out.append(f"Figures falling (min by more than {MIN_FALL}, avg by more than {AVG_FALL}): "
               f"{'; '.join(v['fell']) or 'none'}.")
    if v["cad_models"]:
        out.append(f"CAD-like models with Hausdorff max <= {HAUSDORFF_BAR} h: {v['cad_hausdorff_met'][0]} -> "
                   f"{v['cad_hausdorff_met'][1]} of {v['cad_models']}.")
    if v["only_in_one"]:
        out.append(f"Not compared: {', '.join(v['only_in_one'])}.")
    return "\n".join(out) + "\n"


def self_test():
    """The rules on made-up reports: a fall of the minimum and of the average, an inverted hex, a CAD model
    coming under the Hausdorff bar, a model in one folder only. Returns 0 when every check holds."""
    def report(d, sj_min, sj_avg, inverted=0, haus=0.004, seconds=10.0, branch=False):
        q = {"metrics": {"sj_min": sj_min, "sj_avg": sj_avg, "hexes": 100, "inverted": inverted,
                         "hausdorff_max": haus, "hex_edge": 0.01}}
        nodes = {"best": {"metrics": {"chosen": 2}}, "quality#2": q} if branch else {"quality": q}
        d.mkdir(parents=True)
        (d / "report.json").write_text(json.dumps({"nodes": nodes, "seconds": seconds,
                                                   "retry": {"attempts": [{}]}}))
    with tempfile.TemporaryDirectory() as t:
        base, new = Path(t) / "base", Path(t) / "new"
        report(base / "bunny", 0.60, 0.950)
        report(new / "bunny", 0.54, 0.950, seconds=5)            # min down 0.06: falls
        report(base / "kitten", 0.60, 0.950)
        report(new / "kitten", 0.56, 0.9475, seconds=5)          # within both bounds
        report(base / "fandisk", 0.50, 0.970, haus=0.007)
        report(new / "fandisk", 0.50, 0.966, haus=0.004, seconds=5, branch=True)  # avg down 0.004; under the bar
        report(base / "rotated" / "joint", 0.60, 0.980)
        report(new / "rotated" / "joint", 0.70, 0.990, inverted=1, seconds=5)
        report(base / "hand", 0.6, 0.95)
        rows, v = compare(base, new)
        checks = [
            (v["models"] == 4, "four models compared"),
            (any(f.startswith("bunny: min") for f in v["fell"]), "bunny's minimum fell"),
            (not any(f.startswith("kitten") for f in v["fell"]), "kitten within the bounds"),
            (any(f.startswith("fandisk: avg") for f in v["fell"]), "fandisk's average fell (kept branch's quality)"),
            (v["inverted"] == ["joint (turned)"], "the turned joint has an inverted hex"),
            (v["cad_hausdorff_met"] == (0, 1) and v["cad_models"] == 1, "fandisk came under the Hausdorff bar"),
            (v["only_in_one"] == ["hand"], "hand is in the base only"),
            (abs(v["time_ratio"] - 0.5) < 1e-12, "time ratio 0.5"),
            ("| bunny | 0.600 -> 0.540 |" in markdown(rows, v), "the table row"),
        ]
        bad = [what for ok, what in checks if not ok]
        for what in bad:
            print("compare_results self-test failed:", what)
        return 1 if bad else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("base", nargs="?")
    ap.add_argument("new", nargs="?")
    ap.add_argument("--markdown", help="also write the table and the findings to this file")
    ap.add_argument("--self-test", action="store_true")
    args = ap.parse_args()
    if args.self_test:
        return self_test()
    if not args.base or not args.new:
        ap.error("BASE and NEW are required")
    for f in (args.base, args.new):
        if not Path(f).is_dir():
            ap.error(f"{f}: not a folder")
    rows, v = compare(args.base, args.new)
    text = markdown(rows, v)
    sys.stdout.write(text)
    if args.markdown:
        Path(args.markdown).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
