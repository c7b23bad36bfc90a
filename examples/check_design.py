"""Run the design-rule checks on a design and print what they find.

    python examples/check_design.py [DESIGN]      (default: the self_lock template)

DESIGN is a .toml or .fold file or a template name (``foldprint templates`` lists them).
(``foldprint check DESIGN`` does the same and exits 1 when a rule fails with an error.)
"""

import sys

from foldprint.io.load import load_design
from foldprint.apps.pipeline import evaluate
from foldprint.io.templates import resolve_design_path

design = load_design(resolve_design_path(sys.argv[1] if len(sys.argv) > 1 else "self_lock"))
# simulate the printed part once, build it, estimate its jam probability under scatter
# (20 Monte-Carlo samples), then run every design rule on those results
evaluation = evaluate(design, samples=20)
findings = evaluation.findings
for f in findings:
    print(f"{f.severity.upper():8s} {f.code}  {f.message}" + (f"  ({f.hint})" if f.hint else ""))
errors = sum(f.severity == "error" for f in findings)
print(f"{design.name}: {errors} error(s), {len(findings) - errors} other finding(s)")
if evaluation.robust is not None:
    lo, hi = evaluation.robust.ci95
    print(f"jam probability {evaluation.robust.jam_probability:.0%} (95 % interval {lo:.0%}-{hi:.0%})")
