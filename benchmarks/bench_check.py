"""check's jam verdict before and after the sequential test, in one run: every template's
verdict and cost, and the gallery's.

    python benchmarks/bench_check.py [--before REV] [--templates a,b] [--no-gallery] [--jobs 2] [--json]
    python benchmarks/bench_check.py --write-doc   # the table of docs/verdict.md from docs/data/bench_check.json

"Before" is the code of ``REV`` (default: the merge base with ``main``, the fixed-size
check: 80 samples at 1x, 0.5x and 2x), exported with ``git archive`` into a temporary
folder and run from there; "after" is this checkout. Both run the same commands as a user
runs them (a fresh interpreter each: ``python -m foldprint check NAME --json``, then
``foldprint --quiet gallery --jobs N``), one after the other in this run, on the same
templates (``FOLDPRINT_TEMPLATES``). For each: wall seconds, CPU seconds (the command and
its worker processes) and the ratio before / after; for each template the verdict at 1x
(FP180 error / FP181 warning / FP182 pass), the samples used, the jams, the estimate and
its 95 % interval (before: Wilson at 80; after: the test's confidence sequence) and the
verdicts at 0.5x and 2x. The load average is printed: under load, compare ratios and
CPU seconds, not wall seconds. ``--json`` writes ``docs/data/bench_check.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "data" / "bench_check.json"
DOC = ROOT / "docs" / "verdict.md"
BEGIN, END = "<!-- bench_check:begin -->", "<!-- bench_check:end -->"
#: Targets, wall seconds on two idle cores.
TARGETS = {"helix_uniform": 3.0, "helix_graded": 10.0, "miura_3x3": 15.0, "gallery": 30.0}
CODES = {"FP180": "error", "FP181": "warning", "FP182": "pass"}


def _cpu() -> float:
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return c.ru_utime + c.ru_stime


def _export(rev: str, into: Path) -> Path:
    """The package of ``rev`` (and its templates) under ``into``."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "foldprint"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


#: The templates each code runs on: this checkout's, and for an older revision the same files
#: without the tables its loader does not know (``_templates_for``).
TEMPLATES: dict[Path, Path] = {}
#: Template tables added after the fixed-size check; they describe a template (what its
#: description claims, the paper's statements about it), they do not change the verdict.
NEWER_TABLES = ("claims", "paper")


def _templates_for(code_dir: Path) -> Path:
    """This checkout's templates as ``code_dir``'s loader reads them: every ``[table]`` of
    ``NEWER_TABLES`` removed (an older schema refuses unknown keys)."""
    out = code_dir / "templates"
    out.mkdir(exist_ok=True)
    drop = re.compile(r"^\[(?:%s)\]\n(?:(?!\[).*\n)*" % "|".join(NEWER_TABLES), re.M)
    for src in (ROOT / "templates").glob("*.toml"):
        (out / src.name).write_text(drop.sub("", src.read_text()))
    return out


def _run(code_dir: Path, args: list[str]) -> tuple[float, float, int, str]:
    env = dict(os.environ, PYTHONPATH=str(code_dir),
               FOLDPRINT_TEMPLATES=str(TEMPLATES.get(code_dir, ROOT / "templates")))
    c0, t0 = _cpu(), time.perf_counter()
    # cwd: a neutral folder (``-m`` puts the working directory first on the path)
    p = subprocess.run([sys.executable, "-m", "foldprint", *args], env=env, capture_output=True, text=True,
                       cwd=tempfile.gettempdir())
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    if p.returncode not in (0, 1):
        raise SystemExit(f"{args}: exit {p.returncode}: {p.stderr.strip()[-500:]}")
    return wall, cpu, p.returncode, p.stdout


#: A sweep point's one-threshold answer that leaves two verdicts open, by the threshold it asked.
OPEN = {"warning": "above 5 %", "error": "below 20 %"}


def _verdict(js: dict) -> dict:
    """What a check's JSON says of the jam probability at 1x and at the other scales."""
    r = js["robust"]
    code = next(f["code"] for f in js["findings"] if f["code"] in CODES)
    sweep = {p["scale"]: p for p in js.get("sensitivity") or []}

    def at(p):
        if p.get("verdict") is None and p.get("question") in OPEN:  # a one-threshold answer: two verdicts open
            return OPEN[p["question"]]
        if "verdict" in p:
            return p["verdict"]
        return "error" if p["ci95"][0] > 0.2 else "warning" if p["jam_probability"] > 0.05 else "pass"

    test = r.get("test") or {}
    return {"verdict": CODES[code], "samples": r["samples"], "jams": r["jams"], "estimate": r["jam_probability"],
            "interval": r["ci95"], "truncated": bool(test.get("truncated")), "exit": None,
            "scales": {f"{k:g}x": {"verdict": at(p), "samples": p["samples"], "jams": p["jams"]}
                       for k, p in sorted(sweep.items()) if k != 1.0}}


def _gallery(code_dir: Path, jobs: int) -> tuple[float, float]:
    with tempfile.TemporaryDirectory() as tmp:
        wall, cpu, _, _ = _run(code_dir, ["--quiet", "gallery", "--out", tmp, "--jobs", str(jobs)])
    return wall, cpu


def _templates() -> list[str]:
    return sorted(p.stem for p in (ROOT / "templates").glob("*.toml"))


def _fmt(v: dict) -> str:
    lo, hi = v["interval"]
    sc = ", ".join(f"{k} {s['verdict']} ({s['jams']}/{s['samples']})" for k, s in v["scales"].items())
    return (f"{v['verdict']}{' (truncated)' if v['truncated'] else ''}: {v['jams']}/{v['samples']}, "
            f"{100 * v['estimate']:.1f} % ({100 * lo:.1f}-{100 * hi:.1f} %); {sc}")


def _cell(v: dict) -> str:
    lo, hi = v["interval"]
    sc = " / ".join(f"{s['verdict']} {s['jams']}/{s['samples']}" for s in v["scales"].values())
    return (f"{v['exit']}, **{v['verdict']}**{' (truncated)' if v['truncated'] else ''} {v['jams']}/{v['samples']} "
            f"= {100 * v['estimate']:.1f} % ({100 * lo:.1f}-{100 * hi:.1f} %); 0.5x / 2x: {sc}")


def doc_table(out: dict) -> str:
    """The table of docs/verdict.md from a run's JSON: the fixed-size check beside the sequential test."""
    rows = "".join(f"| `{name}` | {_cell(r['before'])} | {_cell(r['after'])} | {r['before']['cpu_s']:.1f} / "
                   f"{r['after']['cpu_s']:.1f} ({r['cpu_ratio']:.2f}x) |\n" for name, r in out["checks"].items())
    g = out.get("gallery")
    tail = ("" if g is None else
            f"\nThe gallery (`foldprint --quiet gallery --jobs 2`, every template): fixed 80 samples "
            f"{g['before']['wall_s']} s wall, {g['before']['cpu_s']} CPU-s; sequential test {g['after']['wall_s']} s "
            f"wall, {g['after']['cpu_s']} CPU-s ({g['cpu_ratio']}x fewer CPU-s).\n")
    return ("| template | fixed 80 samples: exit, verdict at 1x, jams/samples = estimate (95 % Wilson) | sequential "
            "test: exit, verdict at 1x, jams/samples used = estimate (95 % confidence sequence) | CPU-s fixed / "
            "sequential |\n"
            "|---|---|---|---|\n" + rows + tail +
            f"\n(fixed 80 samples: the code of {out['before_rev'][:10]}; sequential test: {out['after_rev']}; load "
            f"average {out['load_avg_1min']:.1f} "
            f"at the start, {out.get('load_avg_1min_end', 0):.1f} at the end, on {out['cpus']} CPUs: wall seconds "
            "under load mean little, CPU seconds and their ratios do.)\n")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", default=None, help="git revision of the fixed-size check (default: merge base with main)")
    ap.add_argument("--templates", default=None, help="comma-separated names (default: every template)")
    ap.add_argument("--no-gallery", action="store_true")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", action="store_true", help=f"write {DATA.relative_to(ROOT)}")
    ap.add_argument("--write-doc", action="store_true", help=f"only write the table of {DOC.relative_to(ROOT)} "
                    f"from {DATA.relative_to(ROOT)}")
    a = ap.parse_args()
    if a.write_doc:
        doc = DOC.read_text(encoding="utf-8")
        i, j = doc.index(BEGIN) + len(BEGIN), doc.index(END)
        DOC.write_text(doc[:i] + "\n" + doc_table(json.loads(DATA.read_text())) + doc[j:], encoding="utf-8")
        return 0
    rev = a.before or subprocess.run(["git", "-C", str(ROOT), "merge-base", "HEAD", "main"], check=True,
                                     capture_output=True, text=True).stdout.strip()
    names = a.templates.split(",") if a.templates else _templates()
    out = {"before_rev": rev, "after_rev": subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                                                          capture_output=True, text=True).stdout.strip(),
           "cpus": os.cpu_count(), "load_avg_1min": os.getloadavg()[0], "checks": {}, "gallery": None}
    print(f"before: {rev[:10]} (fixed 80 samples), after: {out['after_rev']} (sequential test); "
          f"load average {out['load_avg_1min']:.2f} on {out['cpus']} CPUs")
    with tempfile.TemporaryDirectory() as tmp:
        before = _export(rev, Path(tmp))
        TEMPLATES[before] = _templates_for(before)
        for name in names:
            row = {}
            for label, code_dir in (("before", before), ("after", ROOT)):
                wall, cpu, code, stdout = _run(code_dir, ["check", name, "--json"])
                v = _verdict(json.loads(stdout))
                v.update(exit=code, wall_s=round(wall, 2), cpu_s=round(cpu, 2))
                row[label] = v
            row["cpu_ratio"] = round(row["before"]["cpu_s"] / max(row["after"]["cpu_s"], 1e-9), 2)
            row["wall_ratio"] = round(row["before"]["wall_s"] / max(row["after"]["wall_s"], 1e-9), 2)
            out["checks"][name] = row
            print(f"{name:20s} before {row['before']['wall_s']:6.1f} s wall {row['before']['cpu_s']:6.1f} CPU-s | "
                  f"after {row['after']['wall_s']:6.1f} s wall {row['after']['cpu_s']:6.1f} CPU-s | "
                  f"CPU ratio {row['cpu_ratio']:.2f}" + (f" (target {TARGETS[name]:g} s wall idle)"
                                                         if name in TARGETS else ""), flush=True)
            print(f"    before: {_fmt(row['before'])}\n    after:  {_fmt(row['after'])}", flush=True)
        if not a.no_gallery:
            g = {}
            for label, code_dir in (("before", before), ("after", ROOT)):
                wall, cpu = _gallery(code_dir, a.jobs)
                g[label] = {"wall_s": round(wall, 1), "cpu_s": round(cpu, 1)}
            g["cpu_ratio"] = round(g["before"]["cpu_s"] / g["after"]["cpu_s"], 2)
            g["wall_ratio"] = round(g["before"]["wall_s"] / g["after"]["wall_s"], 2)
            out["gallery"] = g
            print(f"gallery (--jobs {a.jobs}): before {g['before']['wall_s']} s wall {g['before']['cpu_s']} CPU-s | "
                  f"after {g['after']['wall_s']} s wall {g['after']['cpu_s']} CPU-s | CPU ratio {g['cpu_ratio']}, "
                  f"wall ratio {g['wall_ratio']} (target {TARGETS['gallery']:g} s wall idle)")
    out["load_avg_1min_end"] = os.getloadavg()[0]
    print(f"load average at the end {out['load_avg_1min_end']:.2f}")
    if a.json:
        DATA.write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
