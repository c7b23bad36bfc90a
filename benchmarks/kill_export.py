"""Kill ``foldprint export`` (SIGKILL) N times (default 100) at random moments, half in the write phase; print
the states found after each kill. PYTHONPATH=$PWD python benchmarks/kill_export.py 100"""

import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_export_kill import kill_campaign  # noqa: E402

if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        print(json.dumps(kill_campaign(Path(tmp), int(sys.argv[1]) if len(sys.argv) > 1 else 100, seed=2)))
