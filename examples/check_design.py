"""Run the design-rule checks on a design and print what they find.

    python examples/check_design.py [DESIGN]      (default: the self_lock template)

DESIGN is a .toml or .fold file or a template name (``foldprint templates`` lists them).
(``foldprint check DESIGN`` does the same and exits 1 when a rule fails with an error.)
"""

import sys

from foldprint.checks import run_checks
from foldprint.load import load_design
from foldprint.templates import resolve_design_path

design = load_design(resolve_design_path(sys.argv[1] if len(sys.argv) > 1 else "self_lock"))
findings = run_checks(design)
for f in findings:
    print(f"{f.severity.upper():8s} {f.code}  {f.message}" + (f"  ({f.hint})" if f.hint else ""))
errors = sum(f.severity == "error" for f in findings)
print(f"{design.name}: {errors} error(s), {len(findings) - errors} other finding(s)")
