"""Design-rule checks: each rule on a crafted design, and the templates' verdicts."""

import json
from pathlib import Path

import pytest

from foldprint.checks.jam_rules import rule_jam_probability, rule_jam_sensitivity
from foldprint.checks.rules import CheckContext, Thresholds, load_printers
from foldprint.cli.commands import main
from foldprint.core.constants import CHECK_SAMPLES
from foldprint.model.design import Process, strip
from foldprint.io.load import load_design
from foldprint.model.materials import default_library
from foldprint.physics.recovery.curve import fold_time
from foldprint.core.modes import HingeModel
from foldprint.apps.pipeline import evaluate
from foldprint.simulation.robust import wilson


def run_checks(design, printer=None):
    """Every rule on the pipeline's evaluation (no Monte-Carlo: those rules are tested below)."""
    return list(evaluate(design, printer=printer, samples=0).findings)

TEMPLATES = Path(__file__).resolve().parent.parent / "templates"


def codes(findings, severity=None):
    return {f.code for f in findings if severity is None or f.severity == severity}


def test_good_strip_has_no_errors():
    d = strip("ok", [20, 20], [90], ["H-3"])
    assert codes(run_checks(d), "error") == set()


def test_build_volume():
    d = strip("huge", [300, 10], [90], ["H-3"])
    f = run_checks(d)
    assert "FP100" in codes(f, "error")
    big = load_printers()["connex3_500"]
    assert "FP100" not in codes(run_checks(d, big))


def test_thin_wall_and_fused_slots():
    d = strip("thin", [20, 20], [90], ["H-3"], thickness=0.3)
    assert "FP110" in codes(run_checks(d), "error")


def test_programming_strain():
    d = strip("tight", [20, 20], [90], ["H-3"], radius=1.0)  # 0.8 / 2 = 40 % > 25 %
    f = [x for x in run_checks(d) if x.code == "FP130"]
    assert f and f[0].where["hinge"] == "h1" and "1.60 mm" in f[0].hint


def test_temperatures_against_tg():
    d = strip("cold", [20, 20, 20], [90, 90], ["H-1", "H-7"],
              process=Process(program_temperature_c=60, fix_temperature_c=10, bath_temperature_c=60))
    f = run_checks(d)
    bath = [x for x in f if x.code == "FP151"]
    prog = [x for x in f if x.code == "FP150"]
    assert [x.where["hinge"] for x in bath] == ["h2"] and [x.where["hinge"] for x in prog] == ["h2"]


def test_fold_time_within_duration():
    d = strip("short", [20, 20], [90], ["H-7"], process=Process(duration_s=3.0))
    f = [x for x in run_checks(d) if x.code == "FP160"]
    needs = fold_time(default_library()["H-7"], 90.0, 0.8)
    assert f and f"needs {needs:.2f} s" in f[0].message and needs > 3.0


@pytest.mark.parametrize("name", ["helix_graded", "mailbox"])
def test_good_templates_pass(name):
    f = run_checks(load_design(TEMPLATES / f"{name}.toml"))
    assert codes(f, "error") == set(), [x.message for x in f if x.severity == "error"]
    assert "FP172" in codes(f)  # the clearance margin is reported


def test_paper_rom_collision_names_panels_and_time(capsys):
    """With the paper's point hinges the uniform helix collides (Fig. 3c): FP170 names it."""
    code = main(["check", "helix_uniform", "--hinge-model", "point", "--samples", "0", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1 and not out["ok"] and out["hinge_model"] == "point"
    coll = [f for f in out["findings"] if f["code"] == "FP170"]
    assert coll and set(coll[0]["where"]["panels"]) == {"p4", "p9"} and " s " in coll[0]["message"]


def test_jam_probability_decides_the_helices(capsys):
    """The paper's two helices, told apart before printing: at the shipped geometry and the
    default scatter, the graded helix passes the pre-print check and the uniform one fails
    on its jam probability, each by check's sequential test (at most CHECK_SAMPLES samples, stopped when decided)."""
    assert main(["check", "helix_uniform", "--json", "--no-sensitivity"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert [f["code"] for f in out["findings"] if f["severity"] == "error"] == ["FP180"]
    test = out["robust"]["test"]
    assert test["verdict"] == "error" and test["max_samples"] == CHECK_SAMPLES and not test["truncated"]
    assert out["robust"]["samples"] == test["samples"] < CHECK_SAMPLES  # a clear case stops early
    assert test["error"]["accepted"] == "above" and test["error"]["at_samples"] == test["samples"]
    assert out["sensitivity"] is None
    assert main(["check", "helix_graded", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["robust"]["test"]["verdict"] == "pass" and out["robust"]["test"]["warning"]["accepted"] == "below"
    # the default sweep (0.5x, 1x, 2x, the same draws, each its own test): FP183 exactly
    # when the verdict a scale earns differs from the one at 1x
    sweep = {p["scale"]: p for p in out["sensitivity"]}
    assert sorted(sweep) == [0.5, 1.0, 2.0] and sweep[1.0]["jams"] == out["robust"]["jams"]
    flips = {sweep[k]["verdict"] for k in (0.5, 2.0)} - {sweep[1.0]["verdict"]}
    assert any(f["code"] == "FP183" for f in out["findings"]) == bool(flips)


class _Fake:
    """A stand-in robust result with k jams in n samples (of the printed geometry)."""

    hinge_model = HingeModel.ARC

    def __init__(self, k, n):
        self.samples, self.jams, self.jam_probability, self.ci95 = n, k, k / n, wilson(k, n)

    def collisions(self):
        return [(("p1", "p2"), self.jams)] if self.jams else []

    @property
    def outcomes(self):  # each jam a p1-p2 collision, the rest complete
        from foldprint.core.modes import JamReason
        from foldprint.simulation.robust import Outcome

        return [Outcome(True, JamReason.COLLISION, ("p1", "p2"), 1.0, None)] * self.jams + \
            [Outcome(False, None, None, None, 2.0)] * (self.samples - self.jams)


@pytest.mark.parametrize("k,n,code", [(0, 20, "FP182"), (1, 20, "FP182"), (2, 20, "FP181"), (3, 20, "FP181"), (12, 20, "FP180"),
                                      (20, 20, "FP180")])
def test_jam_thresholds(k, n, code):
    ctx = CheckContext(strip("x", [20, 20], [90], ["H-3"]), default_library(), load_printers()["connex260"],
                       robust=_Fake(k, n), thresholds=Thresholds(error=0.2, warning=0.05))
    (f,) = rule_jam_probability(ctx)
    assert f.code == code
    lo = wilson(k, n)[0]
    assert (f.severity == "error") == (lo > 0.2)


class _Point:
    def __init__(self, scale, k, n):
        self.scale, self.result = scale, _Fake(k, n)


class _Tested(_Fake):
    """A stand-in for check's result: the sequential test on k jams then n - k clean samples."""

    def __init__(self, k, n, test=None):
        from foldprint.simulation.jamtest.verdict import decide, jam_test

        self.decision = decide([True] * k + [False] * (n - k), test or jam_test())
        super().__init__(self.decision.jams, self.decision.samples)
        self.ci95 = self.decision.interval


@pytest.mark.parametrize("k,n,code", [(0, 400, "FP182"), (3, 400, "FP181"), (6, 400, "FP180"), (20, 400, "FP180")])
def test_sequential_verdict_is_the_finding(k, n, code):
    """With check's test the finding is the test's verdict (not a reading of the interval):
    3 jams first then clean samples is a warning (the warning test accepts "above" at 3
    jams, the error test "below" later), 6 jams in a row an error at sample 6, none a pass
    at sample 57; the message names the test, its samples and maximum."""
    r = _Tested(k, n)
    ctx = CheckContext(strip("x", [20, 20], [90], ["H-3"]), default_library(), load_printers()["connex260"],
                       robust=r, thresholds=Thresholds(error=0.2, warning=0.05))
    (f,) = rule_jam_probability(ctx)
    assert f.code == code
    assert "sequential test" in f.message and f"decided after {r.decision.samples} of at most 400" in f.message
    assert r.samples == {0: 57, 3: r.decision.samples, 6: 6, 20: 6}[k]


def test_sequential_sweep_flips_by_verdict():
    """FP183 with check's test compares the tests' verdicts, not the intervals."""
    lib, pr = default_library(), load_printers()["connex260"]
    one, two = _Tested(0, 400), _Tested(6, 400)
    pts = (type("P", (), {"scale": 1.0, "result": one})(), type("P", (), {"scale": 2.0, "result": two})())
    ctx = CheckContext(strip("x", [20, 20], [90], ["H-3"]), lib, pr, robust=one, sweep=pts)
    (f,) = rule_jam_sensitivity(ctx)
    assert f.code == "FP183" and f.severity == "warning" and "fails (FP180) at 2x" in f.message


@pytest.mark.parametrize("at_half,at_one,at_two,expect", [
    (0, 0, 0, None),  # passes everywhere: nothing to say
    (20, 20, 20, None),  # fails everywhere
    (0, 0, 12, "warning"),  # passes at 1x, fails at 2x
    (0, 3, 3, "info"),  # warning at 1x and 2x, passes at 0.5x: only better inside the range
    (0, 12, 20, "info"),  # fails at 1x, passes at 0.5x
    (2, 3, 3, None),  # warning at every scale
])
def test_verdict_flip_inside_the_swept_range(at_half, at_one, at_two, expect):
    """FP183 compares the verdict (FP180/181/182) at each swept scale with the one at 1x."""
    ctx = CheckContext(strip("x", [20, 20], [90], ["H-3"]), default_library(), load_printers()["connex260"],
                       robust=_Fake(at_one, 20), thresholds=Thresholds(error=0.2, warning=0.05),
                       sweep=(_Point(0.5, at_half, 20), _Point(1.0, at_one, 20), _Point(2.0, at_two, 20)))
    found = rule_jam_sensitivity(ctx)
    (main_finding,) = rule_jam_probability(ctx)
    assert "0.5x" in main_finding.message and "2x" in main_finding.message
    if expect is None:
        assert found == []
    else:
        (f,) = found
        flipped = "2x" if expect == "warning" else "0.5x"
        assert f.code == "FP183" and f.severity == expect and f"at {flipped}:" in f.message


def test_user_printer_profile(tmp_path, capsys):
    f = tmp_path / "p.toml"
    f.write_text('[printers.tiny]\nname = "Tiny"\nbuild_mm = [30, 30, 30]\nmin_wall_mm = 0.5\nmin_gap_mm = 0.2\n')
    code = main(["check", "helix_graded", "--printers", str(f), "--printer", "tiny", "--samples", "0", "--json",
                 "--no-sensitivity"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1 and any(x["code"] == "FP100" for x in out["findings"])
