"""What the studio's loop costs on a warm server (docs/studio.md, "Speed").

1. **An edit of one hinge** (``PATCH /api/design`` changing one hinge's material, the
   answer being the nominal fold, the clearance and its curve, the design rules): for
   every shipped template and a 100-panel staircase (and there, edits of the bath, which
   change every hinge's fold: nothing of the clearance search is taken over), the edit's work in the session
   (:meth:`Session.apply` and :meth:`Session.nominal`, what the route runs in its thread),
   after one edit that warmed the process; the median and min of ``--edits`` edits, each
   to a material the design has not had (nothing cached), and the median CPU time (the
   edit runs in one thread: on a loaded machine the steadier figure). Beside it, today's command-line
   path for the same answer: ``foldprint simulate NAME --json`` as a fresh process.
   Targets: < 0.3 s for the shipped templates, < 1 s for the 100-panel design.
2. **The verdict over HTTP** on a live ``foldprint studio helix_graded`` (uvicorn, the
   background jam test in its process pool): an edit away and one back to helix_graded's
   materials; from the second PATCH sent, the time to its answer, to the first verdict
   state of its revision on the event stream, to its first running state with samples (the
   running estimate and interval), and to the decided verdict. Targets: first
   state < 0.5 s, decided < 5 s.

``python benchmarks/bench_studio.py [--edits 5] [--json] [--write docs/data/bench_studio.json]
[--docs docs/studio.md]`` (``--docs``: rewrite the block between ``<!-- bench:studio -->``
markers from the figures; ``--from FILE``: take them from a JSON written before instead of
measuring). The targets are for 2 idle cores: the output records the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
TARGET_PATCH_S, TARGET_PATCH_100_S, TARGET_FIRST_STATE_S, TARGET_DECIDED_S = 0.3, 1.0, 0.5, 5.0
GRADES = ["H-1", "H-2", "H-3", "H-4", "H-5", "H-6", "H-7"]


def staircase(n: int = 100):
    from foldprint.model.design import strip

    return strip(f"stairs{n}", [6.0] * n, [90.0 if i % 2 == 0 else -90.0 for i in range(n - 1)],
                 ["H-3"] * (n - 1), depth=6.0, radius=3.0, thickness=0.8, hinge_thickness=0.8)


def edits(design, n_edits: int, bath: bool = False) -> dict:
    """The edit's work in a session: ``n_edits`` edits of the first hinge, each to another
    grade (with ``bath``: of the bath temperature instead, which changes every hinge's fold,
    so the next revision takes over no clearance bound, ``apps.studio_reuse``)."""
    from foldprint.apps.studio_session import Session
    from foldprint.model.materials import default_library
    from foldprint.model.printers import default_printer_key, load_printers

    lib = default_library()
    s = Session(design, lib, load_printers(), default_printer_key())
    s.nominal(*s.current())  # warm: the process's caches, the design's derived data
    h = design.hinges[0]
    times, cpu = [], []
    for k in range(n_edits):
        mat = [g for g in GRADES if g != h.material][k % 6]
        edit = {"process": {"bath_c": 80.0 + k}} if bath else {"hinges": {h.id: {"material": mat}}}
        t0, c0 = time.perf_counter(), time.process_time()
        rev, entry = s.apply(edit)
        s.nominal(rev, entry)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return {"design": design.name + (" (bath edits)" if bath else ""), "panels": len(design.panels), "edits": n_edits,
            "median_s": round(statistics.median(times), 4), "min_s": round(min(times), 4),
            "cpu_median_s": round(statistics.median(cpu), 4)}


def cli_simulate(name: str) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "foldprint", "simulate", name, "--json"], capture_output=True, check=False,
                   env=dict(os.environ, PYTHONPATH=str(ROOT)))
    return round(time.perf_counter() - t0, 3)


def live_verdict(tmp: Path) -> dict:
    """The verdict's latencies on a live ``foldprint studio helix_graded``."""
    import httpx

    proc = subprocess.Popen([sys.executable, "-m", "foldprint", "studio", "helix_graded", "--no-browser", "--port",
                             "0", "--out", str(tmp)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            env=dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1"))
    try:
        m = re.search(r"(http://127\.0\.0\.1:\d+)/\?token=(\S+)", proc.stdout.readline())
        base, h = m.group(1), {"x-foldprint-token": m.group(2)}
        with httpx.Client(base_url=base, headers=h, timeout=120) as c:
            c.get("/api/nominal")
            _until_decided(c, c.get("/api/design").json()["revision"])  # warm: the pool's first run
            c.patch("/api/design", json={"hinges": {"h1": {"material": "H-2"}}})
            _until_decided(c, c.get("/api/design").json()["revision"])
            out: dict = {}
            seen: list = []  # (time, state) of every verdict event, read in a thread of its own
            ready = threading.Event()

            def read():
                with httpx.stream("GET", f"{base}/api/verdict/stream", headers=h, timeout=120) as s:
                    kind = None
                    for line in s.iter_lines():
                        ready.set()
                        if line.startswith("event: "):
                            kind = line[7:]
                        elif line.startswith("data: ") and kind == "verdict":
                            v = json.loads(line[6:])
                            seen.append((time.perf_counter(), v))
                            if v["state"] == "decided" and v["design_revision"] == out.get("revision"):
                                return

            reader = threading.Thread(target=read, daemon=True)
            reader.start()
            ready.wait(30)
            time.sleep(0.5)
            t0 = time.perf_counter()
            answer = c.patch("/api/design", json={"hinges": {"h1": {"material": "H-1"}}})
            out["patch_s"] = round(time.perf_counter() - t0, 4)
            out["revision"] = rev = answer.json()["revision"]
            reader.join(300)
            mine = [(t, v) for t, v in seen if v["design_revision"] == rev]
            out["first_state_s"] = round(mine[0][0] - t0, 4)
            est = [(t, v) for t, v in mine if v["state"] == "running" and v.get("interval")]
            out["first_estimate_s"] = round(est[0][0] - t0, 4) if est else None  # samples, estimate, interval
            out["running_states"] = len(est)
            t, v = next((t, v) for t, v in mine if v["state"] == "decided")
            out.update(decided_s=round(t - t0, 4), verdict=v["verdict"], samples=v["samples"])
        return out
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def _until_decided(c, rev: int, timeout: float = 300.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        v = c.get("/api/verdict").json()
        if v["design_revision"] == rev and v["state"] in ("decided", "failed"):
            return
        time.sleep(0.1)


def table(out: dict) -> str:
    """The docs' block: one row per design, then the live verdict's latencies."""
    la = out["load_average"]
    lines = [f"Measured with load average {la[0]:g} (1 min) on {out['cores']} cores"
             + (" (a shared machine: the load inflates the wall times, not the CPU column)"
                if la[0] > out["cores"] else "") + ":", "",
             "| design | panels | edit, median wall | edit, CPU | `simulate --json` (CLI) | ratio |", "|---|---|---|---|---|---|"]
    for r in out["edits"] + [out["edit_100_panels"]] + ([out["bath_100_panels"]] if "bath_100_panels" in out else []):
        cli = r.get("cli_simulate_s")
        lines.append(f"| {r['design']} | {r['panels']} | {r['median_s']:.3f} s | {r['cpu_median_s']:.3f} s | "
                     + (f"{cli:.2f} s | {r['ratio_to_cli']:.3f} |" if cli else "- | - |"))
    lv = out["live_helix_graded"]
    est = lv.get("first_estimate_s")
    lines += ["", f"Live `foldprint studio helix_graded`, from the PATCH sent: answer {lv['patch_s']:.2f} s, first "
              f"verdict state {lv['first_state_s']:.2f} s, "
              + (f"first running estimate and interval {est:.2f} s ({lv['running_states']} running states with "
                 f"samples), " if est is not None else "")
              + f"decided ({lv['verdict']}, {lv['samples']} samples) {lv['decided_s']:.2f} s."]
    return "\n".join(lines)


def write_docs(doc: Path, out: dict) -> None:
    text = doc.read_text(encoding="utf-8")
    start, end = "<!-- bench:studio (benchmarks/bench_studio.py) -->", "<!-- /bench:studio -->"
    head, rest = text.split(start, 1)
    _, tail = rest.split(end, 1)
    doc.write_text(f"{head}{start}\n{table(out)}\n{end}{tail}", encoding="utf-8")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--edits", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--write", type=Path, default=None)
    ap.add_argument("--docs", type=Path, default=None)
    ap.add_argument("--from", dest="source", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.source is not None:
        out = json.loads(a.source.read_text(encoding="utf-8"))
        if a.docs is not None:
            write_docs(a.docs, out)
        print(table(out))
        return 0
    from foldprint.io.load import load_design
    from foldprint.io.templates import list_templates, resolve_design_path

    load0 = os.getloadavg()
    rows = []
    for t in list_templates():
        r = edits(load_design(resolve_design_path(t["name"])), a.edits)
        r["cli_simulate_s"] = cli_simulate(t["name"])
        r["ratio_to_cli"] = round(r["median_s"] / r["cli_simulate_s"], 3)
        rows.append(r)
    big = edits(staircase(100), a.edits)
    big_bath = edits(staircase(100), a.edits, bath=True)
    with tempfile.TemporaryDirectory() as tmp:
        live = live_verdict(Path(tmp))
    out = {"edits": rows, "edit_100_panels": big, "bath_100_panels": big_bath, "live_helix_graded": live,
           "targets_s": {"patch_templates": TARGET_PATCH_S, "patch_100_panels": TARGET_PATCH_100_S,
                         "first_state": TARGET_FIRST_STATE_S, "decided": TARGET_DECIDED_S},
           "load_average": [round(x, 2) for x in (*load0, *os.getloadavg())], "cores": os.cpu_count()}
    if a.write is not None:
        a.write.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    if a.docs is not None:
        write_docs(a.docs, out)
    if a.json:
        print(json.dumps(out, indent=1))
    else:
        for r in rows + [big, big_bath]:
            print(f"{r['design']:<22} {r['panels']:>4} panels  edit {r['median_s']:.3f} s (min {r['min_s']:.3f}, "
                  f"CPU {r['cpu_median_s']:.3f})"
                  + (f"  cli simulate {r['cli_simulate_s']:.2f} s" if "cli_simulate_s" in r else ""))
        print(f"helix_graded live: {live}")
        print(f"load average before/after: {out['load_average']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
