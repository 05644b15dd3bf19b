#!/usr/bin/env python3
"""Meshes every model of ../shared/data/surfaces with a polyhex config (girl.off self-intersects: the
surface conditioning repairs it) and writes docs/RESULTS.md: per model the hex quality, the PolyCube stages' figures and the time
per stage, beside the 2011 paper's Table 1 and the best published PolyCube meshes (figures from
../shared/data/README.md). Each written mesh is cross-checked with ../shared/tools/hexcheck.py. With
--rotated (the default) every model is also meshed turned by a fixed random rotation (seeded by its
name), and the table "Any orientation" compares the two.

  tools/make_results.py [--polyhex build/polyhex] [--config configs/polycube.json] [--out results-out]
                        [--models bunny fandisk ...] [--doc docs/RESULTS.md] [--threads 2] [--no-hexcheck]
                        [--no-rotated | --rotated-models joint fandisk ...]
"""
import argparse, json, os, subprocess, sys, time, zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"

# The 2011 paper's Table 1: (hexes, avg SJ, min SJ, Hausdorff mean x1e-3, Hausdorff max x1e-3).
PAPER = {"casting": (21e3, .845, .195, 1.21, 5.67), "fandisk": (45e3, .959, .251, 1.23, 6.96),
         "bumpy_torus": (35e3, .891, .270, 1.21, 7.86), "fertility": (20e3, .911, .196, 1.06, 4.01),
         "bunny": (81e3, .930, .138, 1.19, 4.01), "carter": (21e3, .823, .177, 1.19, 6.58),
         "femur": (13e3, .930, .334, 1.21, 9.14), "hand": (12e3, .928, .270, .833, 11.5),
         "dragon": (173e3, .882, .002, .694, 28.9), "rockerarm": (18e3, .899, .226, 1.16, 3.95),
         "bimba": (44e3, .905, .257, 1.23, 12.8), "girl": (194e3, .925, .235, .481, 13.2)}
# Best published PolyCube mesh per model in ../shared/data/README.md: (method, min SJ, avg SJ).
BEST = {"bumpy_torus": ("Huang 2014", .335, .929), "casting": ("Gregson 2011", .195, .845),
        "fertility": ("Fang 2016", .396, .930), "bunny": ("Huang 2014", .382, .926),
        "rockerarm": ("Fu 2016", .477, .924), "kitten": ("Fang 2016", .435, .922),
        "joint": ("Fang 2016", .778, .984), "chinese_lion": ("Fang 2016", .289, .910),
        "greek_sculpture": ("Fu 2016", .250, .901), "femur": ("Cherchi 2016", .544, .959),
        "block": ("Cherchi 2016", .179, .955), "dragon": ("Livesu 2015", .102, .905)}


def run_model(args, surf, out):
    if args.reuse and (out / "report.json").exists():
        return 0, 0.0, json.loads((out / "report.json").read_text()), []
    cmd = [args.polyhex, "run", args.config, "--input", str(surf), "--out", str(out), "--no-cache"]
    if args.threads:
        cmd += ["--threads", str(args.threads)]
    for s in args.set or []:
        cmd += ["--set", s]
    t0 = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - t0
    rep = None
    if (out / "report.json").exists():
        rep = json.loads((out / "report.json").read_text())
    return p.returncode, wall, rep, p.stderr.strip().splitlines()[-3:]


def cpu_name():
    """The CPU's model name, as /proc/cpuinfo gives it ("unknown CPU" elsewhere)."""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def rotation_of(name):
    """The fixed random rotation of a model: a uniform quaternion from a generator seeded by its name."""
    import numpy as np
    q = np.random.default_rng(zlib.crc32(name.encode())).normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def write_rotated(surf, dst):
    """dst: an OBJ of the surface turned by rotation_of(its name) (read with meshio, written exactly)."""
    import meshio, numpy as np
    m = meshio.read(str(surf))
    P = np.asarray(m.points, dtype=float)[:, :3] @ rotation_of(surf.stem).T
    tri = np.concatenate([c.data for c in m.cells if c.type == "triangle"])
    dst.parent.mkdir(parents=True, exist_ok=True)
    with open(dst, "w") as f:
        f.writelines("v %.17g %.17g %.17g\n" % tuple(p) for p in P)
        f.writelines("f %d %d %d\n" % tuple(t + 1) for t in tri)


def node_of(n, base):
    """Node `base` of a report, or its copy in the branch the run kept (`base#k`, k = best.chosen)."""
    if base in n:
        return n[base]
    k = n.get("best", {}).get("metrics", {}).get("chosen")
    return n.get(f"{base}#{k}", {}) if k else {}


def stage_seconds(n):
    """Seconds per node, the copies of a branched node summed under its id."""
    out = {}
    for k, v in n.items():
        if v.get("ran"):
            base = k.split("#")[0]
            out[base] = out.get(base, 0.0) + v["seconds"]
    return out


def hexcheck(mesh, surf):
    p = subprocess.run(["/usr/bin/python3", str(SHARED / "tools" / "hexcheck.py"), str(mesh), "--surface", str(surf), "--json"],
                       capture_output=True, text=True)
    return json.loads(p.stdout) if p.returncode == 0 else None


def summary(figures):
    """Lines of the table's summary: over all models, and over the 28 without girl (the set of earlier runs)."""
    out = []
    for label, names in (("all models", sorted(figures)), ("the 28 without girl", sorted(k for k in figures if k != "girl"))):
        vals = [figures[k] for k in names if figures[k][0] is not None]
        if not vals:
            continue
        mins = sorted(v[0] for v in vals)
        mid = len(mins) // 2
        median = mins[mid] if len(mins) % 2 else (mins[mid - 1] + mins[mid]) / 2
        out.append(f"Over {label} ({len(vals)} meshed): inverted hexes {sum(int(v[2] or 0) for v in vals)}, "
                   f"mean average SJ {sum(v[1] for v in vals) / len(vals):.4f}, median minimum SJ {median:.3f}, "
                   f"lowest minimum {mins[0]:.3f}.")
        out.append("")
    return out



def turned_section(args):
    """With --no-rotated: the doc's "Any orientation" section as it stands (the turned copies of an earlier run)."""
    old = Path(args.doc)
    if not old.exists():
        return []
    lines = old.read_text().split("\n")
    if "## Any orientation" not in lines:
        return []
    i = lines.index("## Any orientation")
    j = next((k for k in range(i + 1, len(lines)) if lines[k].startswith("## ")), len(lines))
    return [""] + lines[i:j - 1]

def feature_cell(q):
    """The quality node's feature fidelity: lines, curve -> mesh / mesh -> curve max in 1e-3 (– before it)."""
    if "feature_curves" not in q:
        return "–"
    if q["feature_curves"] == 0:
        return "0"
    return "{}, {:.1f} / {:.1f}".format(q["feature_curves"], q["feature_curve_to_mesh_max"] * 1e3,
                                        q["feature_mesh_to_curve_max"] * 1e3)


def fmt(x, spec=".3f"):
    return "–" if x is None else format(x, spec)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--polyhex", default=str(ROOT / "build" / "polyhex"))
    ap.add_argument("--config", default=str(ROOT / "configs" / "polycube.json"))
    ap.add_argument("--out", default=str(ROOT / "results-out"))
    ap.add_argument("--models", nargs="*")
    ap.add_argument("--doc", default=str(ROOT / "docs" / "RESULTS.md"))
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--set", action="append", help="id.param=value passed to every run")
    ap.add_argument("--no-hexcheck", action="store_true")
    ap.add_argument("--reuse", action="store_true", help="reuse OUT/<model>/report.json where it exists (regenerate the doc only)")
    ap.add_argument("--no-rotated", action="store_true", help="do not mesh the turned copies")
    ap.add_argument("--rotated-models", nargs="*", help="mesh turned copies of these models only (default: all)")
    args = ap.parse_args()

    surfaces = sorted((SHARED / "data" / "surfaces").iterdir())
    if args.models:
        surfaces = [p for p in surfaces if p.stem in args.models]
    rows, stage_rows, check_rows, rot_rows = [], [], [], []

    def frames_run(rep):
        o = rep["nodes"].get("orient", {}).get("metrics", {})
        return o.get("branches", 1), rep["nodes"].get("best", {}).get("metrics", {}).get("chosen", 1)

    def rotated_row(args, name, surf, rep):
        q0 = rep["nodes"]["quality"]["metrics"]
        rsurf = Path(args.out) / "rotated" / (name + ".obj")
        if not (args.reuse and rsurf.exists()):
            write_rotated(surf, rsurf)
        code, wall, rr, tail = run_model(args, rsurf, Path(args.out) / "rotated" / name)
        print(f"{name} (turned): exit {code}, {wall:.1f} s", file=sys.stderr)
        if rr is None or rr.get("status") != "ok":
            return f"| {name} | failed: {(rr or {}).get('error', ' '.join(tail)).replace('|', '/')[:160]} |" + " |" * 9
        q = rr["nodes"]["quality"]["metrics"]
        ok = (q["inverted"] == 0 and q["sj_min"] >= 0.9 * q0["sj_min"] and q["sj_avg"] >= q0["sj_avg"] - 0.01
              and abs(q["hexes"] / q0["hexes"] - 1) <= 0.15)
        rotated_ok.append(ok)
        b0, c0 = frames_run(rep)
        b, c = frames_run(rr)
        return "| {} | {} / {} / {} | {} / {} / {} | {:.2f} | {:+.4f} | {:+.1f} | {} of {} / {} of {} | {:.1f} / {:.1f} | {} |".format(
            name, fmt(q0["sj_min"]), fmt(q0["sj_avg"]), q0["hexes"], fmt(q["sj_min"]), fmt(q["sj_avg"]), q["hexes"],
            q["sj_min"] / q0["sj_min"] if q0["sj_min"] > 0 else float("nan"), q["sj_avg"] - q0["sj_avg"],
            100 * (q["hexes"] / q0["hexes"] - 1), c0, b0, c, b, rep["seconds"], rr["seconds"], "yes" if ok else "**no**")

    rotated_ok = []
    figures = {}  # model -> (sj_min, sj_avg, inverted), for the summary
    for surf in surfaces:
        name = surf.stem
        out = Path(args.out) / name
        code, wall, rep, tail = run_model(args, surf, out)
        print(f"{name}: exit {code}, {wall:.1f} s", file=sys.stderr)
        if rep is None or rep.get("status") != "ok":
            err = (rep or {}).get("error", " ".join(tail))
            rows.append(f"| {name} | failed: {err.replace('|', '/')[:160]} |" + " |" * 13)
            continue
        n = rep["nodes"]
        q = n.get("quality", {}).get("metrics", {})
        m = lambda node, key: node_of(n, node).get("metrics", {}).get(key)
        align = m("rotate", "alignment")
        paper = PAPER.get(name)
        best = BEST.get(name)
        retry = rep.get("retry")
        attempts = "1"
        if retry:
            each = [fmt(a.get("sj_min")) + (f" ({int(a['inverted'])} inv.)" if a.get("inverted") else "")
                    for a in retry["attempts"]]
            attempts = " / ".join(each) + ("" if len(each) == 1 else f"; kept {retry['chosen'] + 1}")
        figures[name] = (q.get("sj_min"), q.get("sj_avg"), q.get("inverted"))
        cond = n.get("condition", {}).get("metrics", {})
        conditioning = "–" if not cond else (
            "as read" if cond.get("passed_through") else
            (cond.get("repair") if cond.get("repair") != "none" else "") +
            (" + " if cond.get("repair") != "none" and cond.get("remeshed") else "") +
            (f"remeshed ({cond['input']['tessellation_ratio']:.1f}x finer)" if cond.get("remeshed") else ""))
        rows.append("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
            name, conditioning, m("tets", "tets"), m("segment", "charts"), q.get("hexes"), q.get("inverted"),
            fmt(q.get("sj_min")), fmt(q.get("sj_avg")), fmt(q.get("irregular_pct"), ".1f"),
            fmt(q.get("hausdorff_mean", 0) * 1e3, ".2f") + " / " + fmt(q.get("hausdorff_max", 0) * 1e3, ".1f"),
            feature_cell(q),
            f"{rep['seconds']:.1f}", attempts,
            "–" if paper is None else f"{paper[2]:.3f} / {paper[1]:.3f}",
            "–" if best is None else f"{best[1]:.3f} / {best[2]:.3f} ({best[0]})"))
        stage_rows.append("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
            name, fmt(align[-1] if align else None), m("segment", "charts"), m("segment", "corners"),
            f"{m('segment', 'splits_multi_orientation')}/{m('segment', 'splits_wedge')}/{m('segment', 'splits_ramp')}/{m('segment', 'splits_order_cycle')}",
            f"{m('polycube', 'inverted_tets_before_untangle')} -> {m('polycube', 'inverted_tets')} ({m('polycube', 'flat_tets')} flat)",
            fmt(m("polycube", "distortion")), m("polycube", "flipped_after_rounding"),
            fmt(m("polycube", "planarity_error"), ".0e"),
            " ".join(f"{k}={v:.1f}" for k, v in stage_seconds(n).items())))
        if not args.no_rotated and (not args.rotated_models or name in args.rotated_models):
            rot_rows.append(rotated_row(args, name, surf, rep))
        mesh = out / "hex.vtk"
        if not args.no_hexcheck and mesh.exists():
            hc = hexcheck(mesh, surf)
            if hc:
                check_rows.append("| {} | {} / {} | {:.2e} | {:.2e} | {} / {} | {:.2f} / {:.2f} | {:.1f} / {:.1f} |".format(
                    name, fmt(hc["sj_min"], ".6f"), fmt(q.get("sj_min"), ".6f"), abs(hc["sj_min"] - q["sj_min"]),
                    abs(hc["sj_avg"] - q["sj_avg"]), hc["inverted"], q["inverted"],
                    hc["hausdorff_mean"] * 1e3, q["hausdorff_mean"] * 1e3,
                    hc["hausdorff_max"] * 1e3, q["hausdorff_max"] * 1e3))

    doc = ["# Results on the shared models", "",
           f"Generated by `tools/make_results.py --config {os.path.relpath(args.config, ROOT)}` on {time.strftime('%Y-%m-%d')}"
           f" ({cpu_name()}, {os.cpu_count()} cores; the machine is shared, so times are indicative; the meshes"
           " depend on the CPU, whose BLAS kernels change the last bits of the sparse factorizations: compare"
           " figures from one machine, docs/speed.md).", "",
           "Hex quality as `../shared/tools/hexcheck.py` defines it (Verdict scaled Jacobian with centre term; irregular ="
           " interior edge valence != 6 or boundary vertex with != 4 boundary quads; Hausdorff relative to the input's bbox"
           " diagonal, in 1e-3). `paper` is the 2011 paper's Table 1 (min / avg SJ), `best` the best published PolyCube mesh"
           " listed in `../shared/data/README.md` (min / avg SJ). `attempts`: the SJ min of each attempt of the config's"
           " `retry` block (tools/cli_run.h) and the one kept; `time s` is the time of all attempts.", "",
           " `conditioning`: what the surface conditioning did (`as read`: passed through bit for bit; the repair; remeshed"
           " to the tet size when the input was more than 4 times finer).", "",
           " `features`: the input's crease lines (count) and the max distances from them to the hex boundary's edges"
           " and from the hex boundary's feature edges back to them, in 1e-3 of the diagonal (quality node,"
           " nodes/algorithms/feature_fidelity.h; `–`: a run before it).", "",
           "| model | conditioning | tets | charts | hexes | inverted | SJ min | SJ avg | irregular % | Hausdorff mean / max (1e-3) | features: lines, curve -> mesh / mesh -> curve max (1e-3) | time s | attempts | paper min / avg | best min / avg |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"] + rows + [""] + summary(figures) + [
           "", "## PolyCube stages", "",
           "| model | alignment after §4 | charts | corners | splits (multi-orientation / wedge / ramp / order cycle) | inverted tets of the map: final solve -> untangled (flat: 4 vertices on a plane or 3 on an edge) | map distortion (median) | chart pairs out of order | planarity error | seconds per stage |",
           "|---|---|---|---|---|---|---|---|---|---|"] + stage_rows + (turned_section(args) if args.no_rotated else [
           "", "## Any orientation", "",
           "Each model turned by a fixed random rotation (a uniform quaternion from a generator seeded by the CRC-32 of"
           " its name, `rotation_of` in tools/make_results.py) and meshed with the same config. `frames`: the branch kept"
           " of the frames run (original / turned). Done when (issue 22): no inverted hex, turned minimum SJ at least 0.9"
           " of the original's, average at least the original's minus 0.01, hexes within 15 %.", "",
           "| model | original min / avg / hexes | turned min / avg / hexes | min ratio | avg diff | hexes diff % | frames kept of run (original / turned) | time s (original / turned) | met |",
           "|---|---|---|---|---|---|---|---|---|"] + rot_rows + ([""] + [f"Met on {sum(rotated_ok)} of {len(rotated_ok)} turned models."] if rotated_ok else [])) + [
           "", "## Cross-check with hexcheck.py", "",
           "Both measure the distances from 100,000 points sampled by area on each surface (exact point-to-triangle"
           " distances), each with its own generator: the means agree closely, the maxima are the farthest sample"
           " of each and differ where the farthest region is small.", "",
           "| model | SJ min hexcheck / ours | SJ min diff | SJ avg diff | inverted hexcheck / ours | Hausdorff mean hexcheck / ours (1e-3) | Hausdorff max hexcheck / ours (1e-3) |",
           "|---|---|---|---|---|---|---|"] + check_rows + [""]
    Path(args.doc).parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(args.doc + ".tmp")
    tmp.write_text("\n".join(doc))
    tmp.replace(args.doc)
    print(f"wrote {args.doc}", file=sys.stderr)


if __name__ == "__main__":
    main()
