"""Check a design and write its print files from Python, as a notebook would: through the
public API alone (``import foldprint as fp``), no command-line helper.

The inputs come in through the same door the command line uses (``fp.load_input``,
``fp.load_printer``, ``fp.load_scatter``: a path or a template's name, the shipped printer
and scatter model), the evaluation computes each stage once (``fp.Evaluation``: the fold,
the printed part, the jam test, the design rules), and ``ev.export`` writes the part it
already built. ``ev.to_json()`` is the object ``foldprint check --json`` prints.

    python examples/notebook_check_export.py [DESIGN]

writes the print files into output/examples/notebook_check_export/print/ and the check's
JSON beside them (relative to the current folder).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import foldprint as fp
from foldprint.apps import resolve
from foldprint.core.constants import CHECK_SCALES
from foldprint.core.errors import FoldprintError

OUT = Path("output") / "examples" / "notebook_check_export"


def main(name: str = "helix_uniform") -> int:
    # 1. the inputs, resolved as `foldprint check` resolves them
    design, library = fp.load_input(name)
    key, printer = fp.load_printer()  # the default profile (connex260)
    scatter = fp.load_scatter()  # the shipped scatter model
    try:  # a refusal names the input, in the caller's words (the command line says --temperature)
        resolve.check_temperature(600.0)
    except FoldprintError as exc:
        print(f"refused: {exc}")

    # 2. check, with check's defaults: every stage computed now (fp.evaluate), the jam test
    #    sequential at 1x and at each of check's sigma scales (fp.Evaluation(design,
    #    fp.EvalOptions(...)) computes each stage when it is first read instead)
    ev = fp.evaluate(design, library=library, printer=printer, scatter=scatter, scales=CHECK_SCALES)
    for f in ev.findings:
        if f.severity != "info":
            print(f"{f.severity.upper():<7} {f.code} {f.message}")
    r = ev.robust
    print(f"{design.name}: {ev.errors} error(s) on {printer.name}; jam probability {r.jam_probability:.3f} "
          f"(95 % interval {r.ci95[0]:.3f}-{r.ci95[1]:.3f}, {r.samples} samples)")
    print(f"stages computed: {dict(sorted(ev.computed.items()))}")

    # 3. export: the evaluation's printed part (built once, for the check) written as 3MF
    #    and STL, with the print recipe and the manifest, as one set in its own folder
    records = ev.export(OUT / "print", formats=("3mf", "stl"))
    for rec in records:
        print(f"wrote {rec['path']} ({rec['format']})")
    report = OUT / "check.json"  # what `foldprint check --json` prints
    report.write_text(json.dumps(ev.to_json(key), indent=2, allow_nan=False), encoding="utf-8")
    print(f"wrote {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:2]))
