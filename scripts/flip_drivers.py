"""What drives each template's FP183 flip: the table of docs/robustness-model.md.

    python scripts/flip_drivers.py [--templates a,b] [--json] [--write-doc]

Runs ``python -m foldprint check NAME --json`` for every template (or those named), as a
user runs it (a fresh interpreter each, the default seed, samples and scales), and
prints, for each design whose jam verdict flips inside the sweep (FP183), the verdicts at
1x and at the flipping scale, and for each scatter component probed there (removed, for a
worse flip; kept at its 1x spread, for a better one) its basis, the probe's answer (its
verdict, or the side of the one threshold it asks) and jams, and whether it drives the flip. Also the cost: the samples the jam
tests at 1x and the sweep used beside those the probes used, and the
command's CPU seconds (it and its worker processes). ``--json`` writes
``docs/data/flip_drivers.json``; ``--write-doc`` replaces the table in
``docs/robustness-model.md`` between its markers.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "data" / "flip_drivers.json"
DOC = ROOT / "docs" / "robustness-model.md"
BEGIN, END = "<!-- flip_drivers:begin -->", "<!-- flip_drivers:end -->"


def _cpu() -> float:
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return c.ru_utime + c.ru_stime


def check(name: str) -> dict:
    """One template's ``check --json`` and the CPU seconds it took."""
    env = dict(os.environ, FOLDPRINT_TEMPLATES=str(ROOT / "templates"))
    c0 = _cpu()
    p = subprocess.run([sys.executable, "-m", "foldprint", "check", name, "--json"], env=env, capture_output=True,
                       text=True, cwd=tempfile.gettempdir())
    if p.returncode not in (0, 1):
        raise SystemExit(f"{name}: check exited {p.returncode}: {p.stderr.strip()}")
    out = json.loads(p.stdout)
    tests = sum(s["samples"] for s in out["sensitivity"] or ())
    probes = sum(w["samples"] for fd in out["flip_drivers"] or () for w in fd["probes"])
    return {"design": name, "cpu_s": round(_cpu() - c0, 1), "test_samples": tests, "probe_samples": probes,
            "sensitivity": out["sensitivity"], "flip_drivers": out["flip_drivers"]}


def _answer(w: dict) -> str:
    """A test's answer (a probe's, a sweep point's): its verdict, or the side of the one
    threshold it asked when that leaves two verdicts open."""
    if w.get("undecided"):
        return "undecided at the maximum (on the threshold)"
    if w["verdict"] is not None:
        return w["verdict"]
    return {"warning": "above the warning threshold", "error": "below the error threshold"}[w["question"]]


def table(rows: list[dict]) -> str:
    lines = ["| design | flip | component probed (basis) | in the probe: answer, jams/samples | drives it |",
             "|---|---|---|---|---|"]
    for r in rows:
        for fd in r["flip_drivers"] or ():
            at = {p["scale"]: p for p in r["sensitivity"]}[fd["scale"]]
            flip = (f"{fd['verdict_at_1x']} at 1x, {_answer(at)} at {fd['scale']:g}x "
                    f"({at['jams']}/{at['samples']}); probe: {fd['probe']}")
            for k, w in enumerate(fd["probes"]):
                drives = "**yes**" if w["restores"] else "not known" if w.get("undecided") else \
                    "strongest" if fd["strongest"] == w["component"] else "no"
                lines.append(f"| {'`' + r['design'] + '`' if k == 0 else ''} | {flip if k == 0 else ''} | "
                             f"{w['component']} ({w['basis']}) | {_answer(w)}, {w['jams']}/{w['samples']} | {drives} |")
    cost = "; ".join(f"`{r['design']}` {r['probe_samples']} samples for the probes beside {r['test_samples']} "
                     f"for the tests at 1x and the sweep, {r['cpu_s']:g} CPU-s in all"
                     for r in rows if r["flip_drivers"])
    quiet = ", ".join(f"`{r['design']}`" for r in rows if not r["flip_drivers"])  # nothing probed
    return ("\n".join(lines) + f"\n\n(`python scripts/flip_drivers.py --write-doc`, `foldprint check NAME --json` "
            f"at its defaults. Cost: {cost}. No flip, nothing probed: {quiet or 'none'}.)\n")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--templates", default="", help="comma-separated template names (default: all)")
    ap.add_argument("--json", action="store_true", help=f"write {DATA.relative_to(ROOT)}")
    ap.add_argument("--write-doc", action="store_true", help=f"replace the table in {DOC.relative_to(ROOT)}")
    a = ap.parse_args()
    names = [n for n in a.templates.split(",") if n] or sorted(p.stem for p in (ROOT / "templates").glob("*.toml"))
    rows = []
    for n in names:
        rows.append(check(n))
        print(f"{n}: {rows[-1]['cpu_s']:g} CPU-s, flips: {len(rows[-1]['flip_drivers'] or ())}", file=sys.stderr)
    text = table(rows)
    print(text)
    if a.json:
        DATA.write_text(json.dumps(rows, indent=1) + "\n")
    if a.write_doc:
        doc = DOC.read_text(encoding="utf-8")
        i, j = doc.index(BEGIN) + len(BEGIN), doc.index(END)
        DOC.write_text(doc[:i] + "\n" + text + doc[j:], encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
