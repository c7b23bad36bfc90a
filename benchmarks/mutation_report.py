"""What ``benchmarks/mutation.py`` reports: each module's score from its mutants' statuses
and the equivalent mutants (``docs/data/mutation_equivalent.toml``), the 95 % interval of a
sampled score, and the table and survivor list between the ``mutation-table`` markers of
``docs/testing.md``. Nothing here runs a test: ``mutation.py --report-only`` rebuilds the
doc from ``docs/data/mutation.json`` with these functions alone.

A sampled score is an estimate. The sample is a uniform random draw, without replacement,
of the module's mutants; of its ``n`` mutants, ``e`` are explained as equivalent and ``k``
are killed, so the score is ``k / (n - e)``, the share of the module's non-equivalent
mutants the tests kill, and its interval is the exact (Clopper-Pearson) binomial interval
of ``k`` in ``n - e`` trials. Clopper-Pearson covers the true share with at least the
stated probability for every share (Wilson's interval can fall below it near 0 and 1, where
mutation scores live), and a binomial interval is conservative for a draw without
replacement from a finite module, so the interval errs wide, never narrow.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

from scipy.stats import beta

ROOT = Path(__file__).resolve().parent.parent
DATA_JSON = ROOT / "docs" / "data" / "mutation.json"
EQUIVALENT_TOML = ROOT / "docs" / "data" / "mutation_equivalent.toml"
TESTING_MD = ROOT / "docs" / "testing.md"
TABLE_BEGIN, TABLE_END = "<!-- mutation-table:begin -->", "<!-- mutation-table:end -->"
CONFIDENCE = 0.95  # the interval's coverage, as docs/testing.md states it
TARGET = 0.85  # the score every module should reach (docs/testing.md)
INTERVAL_METHOD = "Clopper-Pearson (exact binomial), 95 %"
KILLED_STATUSES = ("killed", "timeout")
SURVIVOR_STATUSES = ("survived", "unconfirmed")


def clopper_pearson(killed: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The exact two-sided binomial interval of a share from ``killed`` successes in ``n``
    trials: each end is the share at which the observed count sits in a tail of
    ``(1 - confidence) / 2``. ``n = 0``: the whole range."""
    if not 0 <= killed <= n:
        raise ValueError(f"killed = {killed} must lie in [0, n = {n}]")
    if n == 0:
        return 0.0, 1.0
    a = (1.0 - confidence) / 2.0
    lo = 0.0 if killed == 0 else float(beta.ppf(a, killed, n - killed + 1))
    hi = 1.0 if killed == n else float(beta.ppf(1.0 - a, killed + 1, n - killed))
    return lo, hi


# ---- equivalent mutants ------------------------------------------------------------------

def load_equivalent(path: Path = EQUIVALENT_TOML) -> list[dict]:
    """The mutants explained as equivalent: [[equivalent]] module, function, to (the
    mutated line as listed), reason."""
    if not path.is_file():
        return []
    return tomllib.loads(path.read_text()).get("equivalent", [])


def equivalent_reason(name: str, m: dict, equivalent: list[dict]) -> str | None:
    for e in equivalent:
        if e["module"] == name and e["function"] == m["function"] and e["to"] == m["to"]:
            return e["reason"]
    return None


# ---- scores ------------------------------------------------------------------------------

def rescore(name: str, entry: dict, equivalent: list[dict]) -> dict:
    """``entry`` with its counts, score and interval recomputed from ``status`` (every
    mutant run: killed | timeout | survived | unconfirmed | not run) and ``survivors``
    (where each survivor is), the equivalent reasons read afresh."""
    status = entry["status"]
    for m in entry["survivors"]:
        m["equivalent"] = equivalent_reason(name, m, equivalent)
        m["confirmed"] = status[m["id"]] == "survived"
    run = [s for s in status.values() if s != "not run"]
    n = len(run)
    killed = sum(s in KILLED_STATUSES for s in run)
    n_eq = sum(m["equivalent"] is not None for m in entry["survivors"])
    scored = n - n_eq
    entry.update({
        "mutants": n, "not_run": len(status) - n, "killed": killed,
        "timeouts": sum(s == "timeout" for s in run), "survived": n - killed,
        "unconfirmed": sum(s == "unconfirmed" for s in run), "equivalent": n_eq,
        "score": round(killed / max(scored, 1), 4), "raw_score": round(killed / max(n, 1), 4),
        "killed_by_new_tests": sorted(k for k in entry.get("first_status", {})
                                      if entry["first_status"][k] in SURVIVOR_STATUSES
                                      and status.get(k) in KILLED_STATUSES),
    })
    if entry.get("mode") == "sample":
        lo, hi = clopper_pearson(killed, scored)
        entry["interval"] = {"method": INTERVAL_METHOD, "low": round(lo, 4), "high": round(hi, 4)}
        first = entry.get("first_status") or status
        k0 = sum(s in KILLED_STATUSES for s in first.values())
        lo0, hi0 = clopper_pearson(k0, scored)
        entry["as_sampled"] = {"killed": k0, "score": round(k0 / max(scored, 1), 4),
                               "low": round(lo0, 4), "high": round(hi0, 4)}
    return entry


# ---- the doc -----------------------------------------------------------------------------

def _pct(x: float) -> str:
    return f"{100 * x:.1f} %"


def _changed(entry: dict) -> bool:
    """The module's source is no longer the one its mutants were made from."""
    import hashlib

    src = ROOT / entry["source"]
    return src.is_file() and entry.get("source_sha256") != hashlib.sha256(src.read_bytes()).hexdigest()


def table(modules: dict) -> str:
    rows = ["| module | tests | mutants | sampled | killed | equivalent | score | 95 % interval | CPU-s |",
            "|---|---|---:|---:|---:|---:|---:|---|---:|"]
    for e in modules.values():
        if "mutants" not in e:
            continue
        tests = ", ".join(Path(t).stem.removeprefix("test_") for t in e["tests"])
        cpu = sum(v or 0.0 for v in e["cpu_s"].values())
        if e.get("mode") == "sample":
            sampled = f"{e['mutants']} (seed {e['sample']['seed']})"
            ci = f"{_pct(e['interval']['low'])} – {_pct(e['interval']['high'])}"
            if e["killed_by_new_tests"]:
                a = e["as_sampled"]
                ci += (f" (as sampled: {_pct(a['score'])}, {_pct(a['low'])} – {_pct(a['high'])})")
        else:
            sampled, ci = "all", "none: every mutant run"
        partial = " (partial)" if e["not_run"] or e["unconfirmed"] else ""
        below = " **below target**" if e["score"] < TARGET else ""
        if _changed(e):  # the score is the older code's: draw its mutants again (--sample N --seed S)
            sampled += ", source changed since"
        rows.append(f"| `{e['source']}` | {tests} | {e['population']} | {sampled} | {e['killed']} "
                    f"| {e['equivalent']} | {_pct(e['score'])}{partial}{below} | {ci} | {cpu:.0f} |")
    return "\n".join(rows)


def survivors_md(modules: dict) -> str:
    out = []
    for e in modules.values():
        for m in e.get("survivors", []):
            why = (f"equivalent: {m['equivalent']}" if m["equivalent"]
                   else "**not yet killed**" if m["confirmed"] else "survived mutmut's selection, not yet confirmed")
            out.append(f"- `{m['where']}` `{m['function']}`: `{m['from']}` -> `{m['to']}` ({why})")
    return "\n".join(out) or "- none"


def new_tests_md(modules: dict) -> str:
    out = []
    for e in modules.values():
        if e.get("killed_by_new_tests"):
            out.append(f"- `{e['source']}`: {len(e['killed_by_new_tests'])} of the sample's survivors "
                       f"({', '.join(f'`{k}`' for k in e['killed_by_new_tests'])})")
    return "\n".join(out)


def write_docs(modules: dict, path: Path = TESTING_MD) -> bool:
    """Replace the block between the markers of ``path``; False when it has none."""
    if not path.is_file():
        return False
    text = path.read_text()
    if TABLE_BEGIN not in text or TABLE_END not in text:
        return False
    head, rest = text.split(TABLE_BEGIN, 1)
    tail = rest.split(TABLE_END, 1)[1]
    new = new_tests_md(modules)
    block = (f"{TABLE_BEGIN}\n{table(modules)}\n\n"
             + (f"Killed by tests written for a sample's survivors (the score counts them; the "
                f"\"as sampled\" interval is the estimate for mutants no test was written for):\n\n{new}\n\n"
                if new else "")
             + f"Surviving mutants:\n\n{survivors_md(modules)}\n{TABLE_END}")
    path.write_text(head + block + tail)
    return True


def load_data(path: Path = DATA_JSON) -> dict:
    return json.loads(path.read_text()) if path.is_file() else {}


def save_data(data: dict, path: Path = DATA_JSON) -> None:
    path.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
