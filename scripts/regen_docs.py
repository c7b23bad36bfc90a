"""Regenerate every figure in docs/ that comes from a model run, or check that they are current.

Each generated part of a doc sits between two markers::

    <!-- regen:NAME (scripts/regen_docs.py) -->
    ...
    <!-- /regen:NAME -->

and is rebuilt here from the model of record (foldprint/data/materials.toml, the shipped
templates). Blocks:

  recovery-fold-times   docs/recovery-model.md: fold times of H-1..H-7 at 80/90/100 C, onsets
  timings-fitted        docs/structure-timings.md: the paper's statements the shipped
                        recovery parameters were fitted to, beside the model
  timings-predicted     docs/structure-timings.md: the statements that were not fitted
  timings-summary       docs/structure-timings.md: the ratios of the paper's times to the model's
  sample1-scatter       docs/structure-timings.md: Sample 1 under scatter with arrest (slow:
                        60 Monte-Carlo folds, ~1-3 min)
  origami-simulator     docs/origami-simulator.md: Origami Simulator's examples through
                        simulate, from docs/data/bench_origami_simulator.json

and the figures of FIGURES (written without --check, not compared):

  docs/img/recovery-calibration.png   R(t) of H-1..H-7 at 80/90/100 C and the Fig. 1b spreads
  docs/img/viewer.png                 the README's screenshot of the viewer (scripts/viewer_screenshot.py;
                                      tests/test_viewer_screenshot.py holds its text to the tool's)

Usage:  python scripts/regen_docs.py [--check] [--slow] [--only NAME ...]
  (no --check: rewrite the blocks; --check: exit 1 naming every block whose text or numbers
  differ from a fresh run beyond TOLERANCE; --slow: include the slow blocks)

tests/test_docs_current.py runs the check (the slow block in a test marked slow).
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

#: How far a number in a doc may be from a fresh run (s or the number's unit): the docs
#: print two decimals, so a change in the last printed digit by round-off passes; the
#: Monte-Carlo percentiles of the scatter block may move a little with the platform's
#: floating point (same seed, same draws).
TOLERANCE = {"nominal": 0.011, "scatter": 0.05}
SCATTER_SAMPLES, SCATTER_SEED = 60, 1
_NUM = re.compile(r"-?\d+(?:\.\d+)?")


def _fmt(v, nd=2, unit=" s"):
    return "—" if v is None else f"{v:.{nd}f}{unit}"


def recovery_fold_times() -> str:
    """docs/recovery-model.md: fold times at 80/90/100 C (0.8 mm, from 10 C), onsets at 90 C,
    and what happens at 60 C."""
    from foldprint.model.materials import default_library
    from foldprint.physics.recovery.curve import recovery_curve
    from foldprint.physics.recovery.table import fold_times

    lib = default_library()
    hinges = lib.hinges()
    ft = {m.name: fold_times(m, (80.0, 90.0, 100.0, 60.0)) for m in hinges}
    lines = ["| bath | " + " | ".join(m.name for m in hinges) + " | H-7 − H-1 |",
             "|---|" + "---|" * (len(hinges) + 1)]
    for k, bath in enumerate((80, 90, 100)):
        cells = [f"{ft[m.name][k]:.2f}" for m in hinges]
        spread = ft["H-7"][k] - ft["H-1"][k]
        lines.append(f"| {bath} °C | " + " | ".join(cells) + f" | {spread:.1f} s |")
    on1 = recovery_curve(lib["H-1"], 90.0).onset_time
    on7 = recovery_curve(lib["H-7"], 90.0).onset_time
    never = [m.name for m in hinges if ft[m.name][3] is None]
    slowest = max((m for m in hinges if ft[m.name][3] is not None), key=lambda m: ft[m.name][3])
    lines += ["", f"Onsets (5 % recovery) at 90 °C: H-1 {on1:.2f} s, H-7 {on7:.2f} s. At 60 °C "
              f"{' and '.join(never)} do not fold within 600 s; {slowest.name} takes {ft[slowest.name][3]:.0f} s."]
    return "\n".join(lines)


def _notes(sid: str, v, lib) -> str:
    """The notes cell of one statement: what the model's number is made of."""
    from foldprint.physics.recovery.curve import recovery_curve

    c = v.compare
    curve = lambda m, th=0.8: recovery_curve(lib[m], 90.0, th)  # noqa: E731
    if sid.startswith("fig1b"):
        return v.note
    if sid == "sample1_contact":
        return (f"the printed spiral folds completely ({c['arc_fold_time']:.2f} s); point ROM: "
                f"{c['point_pair'].replace('-', '–')} at {c['point']:.3f} s; under scatter: below")
    if sid == "sample1_stop":
        return (f"point ROM + arrest: motion ends at {c['point_arrest_end']:.2f} s "
                f"({c['point_arrest_end'] - c['point_arrest_contact']:.2f} s after contact, "
                f"{c['point_arrest_frozen']} hinges arrested)")
    if sid == "sample2_whole":
        return "completes, no contact" + (" (point ROM too)" if c.get("point_completed") else "")
    if sid == "sample2_inner_start":
        return f"H-1 {curve('H-1').onset_time:.2f} s, H-2 {curve('H-2').onset_time:.2f} s"
    if sid == "sample2_inner_finish":
        return f"H-1 {curve('H-1').fold_time:.2f} s, H-2 {curve('H-2').fold_time:.2f} s"
    if sid == "fig3b_order":
        t50, t98 = c["t50"], c["t98"]
        return (f"order H-1 < H-4 < H-7 at 50 % ({', '.join(f'{t50[m]:.2f}' for m in ('H-1', 'H-4', 'H-7'))} s) "
                f"and 98 % ({', '.join(f'{t98[m]:.2f}' for m in ('H-1', 'H-4', 'H-7'))} s)")
    if sid == "self_lock":
        g = c["goals"]
        return f"the paper gives snapshots, no times; p6 through hole 1 at {g['hole1']:.2f} s, hole 2 at {g['hole2']:.2f} s"
    if sid == "mailbox_whole":
        g = c["groups"]
        th = c["hinge_thickness_mm"][0]
        return (f"H-3 lips {g['H-3']:.2f}, H-5 {g['H-5']:.2f}, H-6 {g['H-6']:.2f} s, at the template's "
                f"{th:g} mm hinges (our choice); 0.8 mm would give {curve('H-6').fold_time:.2f} s")
    return v.note


def _measured():
    from foldprint.model.materials import default_library
    from foldprint.simulation.paper_timings import load_statements, measure

    lib = default_library()
    return lib, load_statements(), measure(lib)


def timings_table(role: str, measured=None) -> str:
    """The statements of one role (fitted / predicted) as the docs' table."""
    from foldprint.simulation.paper_timings import verdict

    lib, st, m = measured or _measured()
    lines = ["| id | statement | paper | model (arc) | verdict | notes |", "|---|---|---|---|---|---|"]
    for s in st.items:
        if s.role != role:
            continue
        v = m[s.id]
        paper = {"about": "~", "at_most": "≤ ~", "at_least": "≥ "}.get(s.kind, "")
        paper = f"{paper}{s.value_s:g} s" if s.value_s is not None else s.kind
        lines.append(f"| `{s.id}` | {s.what} | {paper} | {_fmt(v.value_s)} | {verdict(s, v, st.approx_tol_s)} | "
                     f"{_notes(s.id, v, lib)} |")
    return "\n".join(lines)


def timings_summary(measured=None) -> str:
    """The ratios of the paper's structure times to the model's."""
    lib, st, m = measured or _measured()
    s2, mb, s1 = m["sample2_whole"], m["mailbox_whole"], m["sample1_contact"]
    pt = s1.compare["point"]
    tol = st.approx_tol_s

    def within(paper, model):
        return "within" if abs(paper - model) <= tol else "outside"

    return (f"**The paper's structure timings against the model's** (paper / model): Sample 2 "
            f"{7.0 / s2.value_s:.2f} (7 / {s2.value_s:.2f}, {within(7.0, s2.value_s)} the ±{tol:g} s reading), the "
            f"mailbox {11.0 / mb.value_s:.2f} (11 / {mb.value_s:.2f}, with hinges we chose 1.6 mm thick; "
            f"{within(11.0, mb.value_s)} the reading), Sample 1's contact {7.5 / pt:.1f} against the paper's own ROM "
            f"(7.5 / {pt:.3f}) and the factor of the scatter block below against the median contact under scatter.")


def sample1_scatter() -> str:
    """Sample 1 (printed geometry) under the default scatter, each sample with arrest."""
    from foldprint.simulation.paper_timings import sample1_under_scatter

    r = sample1_under_scatter(SCATTER_SAMPLES, SCATTER_SEED)
    c, e, s = r["contact_s"], r["motion_end_s"], r["slow_phase_s"]
    return (f"Under scatter (`robust`'s default scatter model, {r['samples']} samples, seed {r['seed']}, each "
            f"folded with `--after-contact arrest`; median and 5th–95th percentile of the samples that touch): "
            f"{r['touched']} of {r['samples']} samples touch; first contact {c['p50']:.2f} s "
            f"({c['p5']:.2f}–{c['p95']:.2f}), motion end {e['p50']:.2f} s ({e['p5']:.2f}–{e['p95']:.2f}), slow "
            f"phase {s['p50']:.2f} s ({s['p5']:.2f}–{s['p95']:.2f}); {r['still_moving']} still moving at the end "
            f"of the run. The paper's contact at ~7.5 s is {7.5 / c['p50']:.1f} times the median contact; "
            f"measured against its own time to contact, so that the time-scale gap drops out, the paper's slow "
            f"phase is 0.67 of it (5 s after 7.5 s), the model's median {s['p50'] / c['p50']:.2f}.")


def origami_simulator_table() -> str:
    """docs/origami-simulator.md: Origami Simulator's examples through `simulate`, from
    docs/data/bench_origami_simulator.json (benchmarks/bench_origami_simulator.py)."""
    import json

    data = json.loads((ROOT / "docs" / "data" / "bench_origami_simulator.json").read_text(encoding="utf-8"))
    rows = data["results"]
    order = ["completes", "does not complete", "refused", "past the limit", "bug"]
    counts = data["counts"]
    verdicts = counts.get("completes", 0) + counts.get("does not complete", 0)
    blas = data.get("blas_threads", 0)
    lines = [f"`{data['command']}` on {data['patterns']} patterns, each stopped at {data['timeout_s']:g} CPU-s "
             f"({'one BLAS thread' if blas == 1 else f'{blas} BLAS threads' if blas else 'default BLAS threads'}; "
             f"{data['jobs']} at a time on {data['cores']} cores; load {data['load_before'][0]:.1f} before, "
             f"{data['load_after'][0]:.1f} after): **{verdicts} give a verdict** "
             + "(" + ", ".join(f"{counts[k]} {k}" for k in order if k in counts) + ").", "",
             "| refused because | patterns |", "|---|---|"]
    reasons: dict[str, int] = {}
    for r in rows:
        if r["outcome"] == "refused":
            reasons[r["reason"]] = reasons.get(r["reason"], 0) + 1
    lines += [f"| {k} | {v} |" for k, v in sorted(reasons.items(), key=lambda kv: (-kv[1], kv[0]))]
    lines += ["", "| pattern | outcome | CPU s | what foldprint says (first line) |", "|---|---|---|---|"]
    for r in rows:
        said = r.get("message", "").replace("|", "/")
        said = said.split(": ", 2)[-1] if r["outcome"] == "refused" else said
        said = said if len(said) <= 140 else said[:137] + "..."
        if r.get("notes"):
            said += f" (+{len(r['notes'])} reader note(s))"
        lines.append(f"| {r['file']} | {r['outcome']} | {r['cpu_s']:.1f} | {said} |")
    return "\n".join(lines)


#: name -> (doc, builder, slow)
BLOCKS = {
    "recovery-fold-times": ("docs/recovery-model.md", recovery_fold_times, False),
    "timings-fitted": ("docs/structure-timings.md", lambda m=None: timings_table("fitted", m), False),
    "timings-predicted": ("docs/structure-timings.md", lambda m=None: timings_table("predicted", m), False),
    "timings-summary": ("docs/structure-timings.md", timings_summary, False),
    "sample1-scatter": ("docs/structure-timings.md", sample1_scatter, True),
    "origami-simulator": ("docs/origami-simulator.md", origami_simulator_table, False),
}


def recovery_figure(path: Path) -> None:
    from foldprint.model.materials import default_library
    from foldprint.render.figures import plot_recovery_calibration

    plot_recovery_calibration(default_library(), path)


def viewer_screenshot(path: Path) -> None:
    """docs/img/viewer.png and the text it shows (docs/img/viewer.json), by
    scripts/viewer_screenshot.py (a one-design gallery, headless Chromium)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("viewer_screenshot", ROOT / "scripts" / "viewer_screenshot.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.PNG == path
    mod.main([])


#: doc figure -> builder (written on every run without --check)
FIGURES = {"docs/img/recovery-calibration.png": recovery_figure, "docs/img/viewer.png": viewer_screenshot}


def _span(text: str, name: str) -> tuple[int, int]:
    """Where the block's lines are: from the line after its start marker to its end marker."""
    start = re.search(rf"<!-- regen:{re.escape(name)} \(scripts/regen_docs.py\) -->\n", text)
    end = re.search(rf"^<!-- /regen:{re.escape(name)} -->", text, re.M)
    if not start or not end or end.start() < start.end():
        raise SystemExit(f"regen_docs: block {name!r} has no markers in its doc")
    return start.end(), end.start()


def current(name: str) -> str:
    doc = (ROOT / BLOCKS[name][0]).read_text(encoding="utf-8")
    a, b = _span(doc, name)
    return doc[a:b].rstrip("\n")


def build(names) -> dict[str, str]:
    """Fresh text of each block (the structure timings measured once for all of them)."""
    measured = None
    out = {}
    for n in names:
        fn = BLOCKS[n][1]
        if n.startswith("timings-"):
            measured = measured or _measured()
            out[n] = fn(measured)
        else:
            out[n] = fn()
    return out


def differences(old: str, new: str, tol: float) -> list[str]:
    """How ``old`` differs from ``new``: words must be equal, numbers within ``tol``."""
    split_old, split_new = _NUM.split(old), _NUM.split(new)
    if split_old != split_new:
        return ["the text differs (not only its numbers)"]
    out = []
    for a, b in zip(_NUM.findall(old), _NUM.findall(new)):
        if abs(float(a) - float(b)) > tol:
            out.append(f"{a} is now {b}")
    return out


def check(names) -> dict[str, list[str]]:
    fresh = build(names)
    return {n: d for n in names
            if (d := differences(current(n), fresh[n], TOLERANCE["scatter" if BLOCKS[n][2] else "nominal"]))}


def write(names) -> None:
    fresh = build(names)
    for n in names:
        path = ROOT / BLOCKS[n][0]
        doc = path.read_text(encoding="utf-8")
        a, b = _span(doc, n)
        path.write_text(doc[:a] + fresh[n] + "\n" + doc[b:], encoding="utf-8")
        print(f"wrote {BLOCKS[n][0]}: {n}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--slow", action="store_true", help="include the slow blocks (Monte-Carlo)")
    ap.add_argument("--only", nargs="*", choices=sorted(BLOCKS))
    args = ap.parse_args(argv)
    names = args.only or [n for n, (_, _, slow) in BLOCKS.items() if args.slow or not slow]
    if not args.check:
        write(names)
        if not args.only:
            for rel, fn in FIGURES.items():
                fn(ROOT / rel)
                print(f"wrote {rel}")
        return 0
    bad = check(names)
    for n, d in bad.items():
        print(f"{BLOCKS[n][0]}: block {n} is stale: {'; '.join(d[:5])} (run python scripts/regen_docs.py"
              f"{' --slow' if BLOCKS[n][2] else ''})")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
