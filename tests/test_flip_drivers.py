"""What drives a flip of check's jam verdict (FP183, foldprint.simulation.jamtest.flip_drivers), and
what each scatter spread rests on (``basis`` in data/scatter.toml).

The reference case is tests/test_jam_reference.py's: a two-panel strip with one H-7 hinge
and a run just long enough for a hinge in a bath 2.2 C below nominal, so a sample jams
exactly when its bath is colder than the root b* of the recovery model's fold time (no
kinematics, no Monte-Carlo in b*). Its scatter model has the bath (sd 1 C) and a Tg spread
too small to move a fold across the run's end (sd 0.02 C). At 1x the part passes, at 2x
it warns (FP183); the flip can only come from the bath: removing the bath must undo it,
removing Tg must leave it, sample by sample the draws colder than b*.
"""

import json
import math
import tomllib
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq

from foldprint.apps.pipeline import EvalOptions, Evaluation
from foldprint.checks.jam_rules import rule_jam_sensitivity
from foldprint.checks.rules import CheckContext, Thresholds, load_printers
from foldprint.cli.commands import main
from foldprint.core.errors import DesignError
from foldprint.core.modes import JamQuestion, JamVerdict, Side, SpreadBasis
from foldprint.io.design_io import design_to_toml
from foldprint.model.design import strip
from foldprint.model.materials import default_library
from foldprint.physics.recovery.curve import recovery_curve
from foldprint.simulation.jamtest.flip_drivers import FlipDrivers, Probe, undoes, undoes_all
from foldprint.simulation.scatter import KEYS, Scatter, component, default_scatter, draw_samples, scatter_from
from foldprint.simulation.jamtest.verdict import decide, jam_test

DT_S = 0.01  # check's time step (core.constants.CHECK_DT_S)
COLD_C = 2.2  # the run ends when a hinge in a bath this much below nominal reaches 98 %
TG_SD_C = 0.02
P, W, E = JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR


def _t98(lib, bath_c: float, fix_c: float) -> float:
    return recovery_curve(lib["H-7"], bath_c, 0.8, fix_c).fold_time


def _case(cold_c: float, scales: tuple[float, ...]):
    """The strip whose run ends when a hinge in a bath ``cold_c`` below nominal reaches
    98 %, b*, the scatter model, and its evaluation with the sweep ``scales``."""
    lib = default_library()
    d = strip("bath_only", [12.0, 12.0], [90.0], ["H-7"], hinge_thickness=0.8)
    fix_c = d.process.fix_temperature_c
    run = round(_t98(lib, d.process.bath_temperature_c - cold_c, fix_c), 2) + 0.005  # between grid times
    d = replace(d, process=replace(d.process, duration_s=run))
    end = math.ceil(run / DT_S) * DT_S  # a run ends at the first grid time at or past its duration
    b_star = brentq(lambda b: _t98(lib, b, fix_c) - end, 80.0, 90.0, xtol=1e-6)
    sc = Scatter(1.0, 0.0, TG_SD_C, 0.0, 0.0, sources={"bath": "our bath log", "tg": "our DMA"},
                 bases={"bath": SpreadBasis.CHOICE, "tg": SpreadBasis.MEASURED})
    ev = Evaluation(d, EvalOptions(dt=DT_S, scales=scales, workers=1), library=lib, scatter=sc)
    ev.findings  # noqa: B018
    return d, lib, sc, b_star, ev


@pytest.fixture(scope="module")
def case():
    return _case(COLD_C, (0.5, 2.0, 1.0))


def test_the_case_flips_at_twice_the_spreads(case):
    d, _, _, b_star, ev = case
    tests = ev.run_jam_tests()
    # the sweep asks only whether the pass at 1x flips: "above 5 %" leaves a warning and an error open
    assert tests[1.0].decision.verdict == P and tests[2.0].decision.verdicts == (W, E)
    assert tests[2.0].decision.test.question == JamQuestion.WARNING
    assert d.process.bath_temperature_c - 2.4 < b_star < d.process.bath_temperature_c - 2.0


def test_the_flip_is_the_baths_alone(case):
    """Removing the bath at 2x undoes the flip (no sample jams: Tg alone cannot make a fold
    miss the run's end); removing Tg leaves it: the samples jam exactly where the 2x bath
    draw is colder than b*, as the reference says, and the verdict stays the flipped one."""
    d, _, sc, b_star, ev = case
    (fd,) = ev.flip_drivers
    assert fd.scale == 2.0 and fd.worse and fd.flipped is ev.run_jam_tests()[2.0]
    by = {pr.component.key: pr for pr in fd.probes}
    assert sorted(by) == ["bath", "tg"]  # components at zero spread are not folded again
    assert [pr.component.key for pr in fd.drivers] == ["bath"] and fd.strongest is None
    bath, tg = by["bath"], by["tg"]
    assert bath.restores and bath.verdicts == (P,) and bath.result.jams == 0
    assert bath.result.samples == 57  # no jam: the warning test accepts "below" after 57 (docs/verdict.md)
    assert bath.result.scatter == sc.scaled(2.0).without("bath")
    # a probe asks only the flip's threshold (5 %): without Tg the part is still above it, and the
    # probe stops there, leaving a warning and an error open
    assert not tg.restores and tg.verdicts == (W, E) and tg.result.decision.verdict is None
    assert tg.result.decision.test.question == JamQuestion.WARNING
    assert tg.result.decision.warning.side == Side.ABOVE and tg.result.samples == tg.result.decision.warning.at
    assert (bath.spread, tg.spread, bath.probe_spread, tg.probe_spread) == (2.0, 2 * TG_SD_C, 0.0, 0.0)
    assert (bath.basis, tg.basis) == (SpreadBasis.CHOICE, SpreadBasis.MEASURED) and tg.source == "our DMA"
    n = tg.result.samples
    baths = np.array([s.bath_c for s in draw_samples(d, sc.scaled(2.0).only(["bath"]), n, ev.options.seed)])
    clear = np.abs(baths - b_star) > 0.02  # a draw within round-off of the root may go either way
    got = np.array([o.jammed for o in tg.result.outcomes])
    assert clear.sum() >= n - 2 and got[clear].tolist() == (baths < b_star)[clear].tolist()
    assert got.sum() >= 3  # "above 5 %" needs k log 3 + (n - k) log(0.925 / 0.975) >= log 20: 3 jams at least


def test_fp183_names_the_driver_and_what_it_rests_on(case):
    *_, ev = case
    (f,) = [f for f in ev.findings if f.code == "FP183"]
    assert f.severity == "warning"
    assert "at 2x the flip is driven by the bath temperature (bath, our choice, not measured;" in f.message
    assert "without it the test passes: 0.0 %" in f.message and "(tg," not in f.message
    assert "spreads nobody measured (bath: our choice, not measured)" in f.hint
    out = ev.to_json()
    (j,) = out["flip_drivers"]
    assert (j["scale"], j["verdict_at_1x"], j["verdict"], j["verdicts"], j["drivers"], j["strongest"], j["probe"]) == (
        2.0, "pass", None, ["warning", "error"], ["bath"], None, "removed")
    assert {w["component"]: (w["basis"], w["restores"], w["question"], w["verdict"], w["verdicts"])
            for w in j["probes"]} == {"bath": ("choice", True, "warning", "pass", ["pass"]),
                                      "tg": ("measured", False, "warning", None, ["warning", "error"])}
    assert out["robust"]["scatter"]["tg"]["basis"] == "measured"


def test_check_cli_says_a_measured_driver_is_measured(case, tmp_path, capsys):
    """The same case through `foldprint check --scatter FILE`: a bath spread given as
    measured is named so, and the hint asks for margin, not for a measurement."""
    d, *_ = case
    f, s = tmp_path / "strip.toml", tmp_path / "scatter.toml"
    f.write_text(design_to_toml(d))
    s.write_text('[shared.bath]\nsd_c = 1.0\nbasis = "measured"\nsource = "our bath, logged"\n'
                 f"[hinge.tg]\nsd_c = {TG_SD_C}\n"
                 "[shared.heat_transfer]\nsigma_ln = 0\n[hinge.thickness]\nsd_mm = 0\n[hinge.heat_transfer]\nsigma_ln = 0\n")
    assert main(["check", str(f), "--scatter", str(s), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (fp,) = [x for x in out["findings"] if x["code"] == "FP183"]
    assert "driven by the bath temperature (bath, measured;" in fp["message"]
    assert fp["hint"].startswith("the spreads that drive the flip are not our choices")
    assert out["flip_drivers"][0]["drivers"] == ["bath"]
    sc = out["robust"]["scatter"]
    assert (sc["bath"]["basis"], sc["bath"]["source"]) == ("measured", "our bath, logged")
    assert sc["tg"]["basis"] == "choice" and str(s) in sc["tg"]["source"]  # a spread without a basis: a choice


def test_no_flip_no_drivers(case):
    """Without a flip (or without the sweep) nothing is folded again."""
    d, lib, sc, _, _ = case
    ev = Evaluation(d, EvalOptions(dt=DT_S, scales=(0.5, 1.0), workers=1), library=lib, scatter=sc)
    assert not any(f.code == "FP183" for f in ev.findings)
    assert ev.flip_drivers == () and ev.to_json()["flip_drivers"] == []
    ev = Evaluation(d, EvalOptions(dt=DT_S, workers=1), library=lib, scatter=sc)
    assert ev.flip_drivers == () and ev.to_json()["flip_drivers"] is None


@pytest.mark.parametrize("base,flipped,without,expect", [
    (P, W, P, True), (P, W, W, False), (P, E, W, False), (P, E, P, True),
    (W, E, W, True), (W, E, P, True), (W, E, E, False),
    (E, P, E, True), (E, P, W, False), (W, P, E, True), (W, P, W, True), (W, P, P, False),
])
def test_a_removal_undoes_a_flip_when_it_is_back_at_the_1x_verdict_or_past_it(base, flipped, without, expect):
    assert undoes(base, flipped, without) is expect


def test_undoes_refuses_a_non_flip():
    with pytest.raises(ValueError):
        undoes(W, W, P)


class _Tested:
    """A stand-in for a jam test: k jams then n - k clean samples, through check's test."""

    def __init__(self, k, n):
        self.decision = decide([True] * k + [False] * (n - k), jam_test())
        self.samples, self.jams = self.decision.samples, self.decision.jams
        self.jam_probability, self.ci95 = self.decision.estimate, self.decision.interval

    def collisions(self):
        return []


def _probe(key, result, base, flipped, basis):
    return Probe(component(key), 1.0, 0.0, basis, "", result, undoes(base.decision.verdict, flipped.decision.verdict,
                                                                       result.decision.verdict))


def test_when_no_component_undoes_the_flip_alone_the_strongest_is_named():
    """A pass at 1x and an error at 2x (6 of 6 jam); removed one at a time, no component
    brings the pass back: the removal that lowers the estimate most is named as the
    strongest, with what it rests on, and said not to drive the flip alone."""
    base, flipped = _Tested(0, 400), _Tested(6, 400)
    assert (base.decision.verdict, flipped.decision.verdict) == (P, E)
    rms = (_probe("bath", _Tested(6, 400), base, flipped, SpreadBasis.CHOICE),
           _probe("h_local", _Tested(3, 400), base, flipped, SpreadBasis.CHOICE),  # a warning: 3 jams first
           _probe("thickness", _Tested(4, 400), base, flipped, SpreadBasis.DATASHEET))
    fd = FlipDrivers(2.0, base, flipped, rms)
    assert fd.drivers == () and fd.strongest is rms[1]
    assert fd.toward_base(rms[0]) == 0 and fd.toward_base(rms[1]) > fd.toward_base(rms[2]) > 0
    pts = tuple(type("P", (), {"scale": k, "result": r})() for k, r in ((1.0, base), (2.0, flipped)))
    ctx = CheckContext(strip("x", [20, 20], [90], ["H-3"]), default_library(), load_printers()["connex260"],
                       robust=base, thresholds=Thresholds(), sweep=pts, flip_drivers=(fd,))
    (f,) = rule_jam_sensitivity(ctx)
    assert "at 2x no one component undoes the flip alone: it needs several together" in f.message
    assert "the one that moves the estimate most toward the verdict at 1x is the heat transfer: local (h_local, " \
           "our choice, not measured; without it the test warns:" in f.message
    assert "h_local: our choice, not measured" in f.hint
    nowhere = FlipDrivers(2.0, base, flipped, rms[:1])  # the one removal moves nothing
    assert nowhere.strongest is None
    ctx = replace(ctx, flip_drivers=(nowhere,))
    assert "none of them moves the estimate back toward the verdict at 1x" in rule_jam_sensitivity(ctx)[0].message


def test_a_better_flip_is_driven_by_the_spread_whose_shrinking_passes_the_part():
    """A run so short that the strip warns at 1x and passes at 0.5x (FP183 info): kept at
    its 1x spread (Tg at 0.5x), the bath brings the warning back, sample by sample the
    draws colder than b*; Tg kept at its 1x spread (the bath at 0.5x) leaves the pass."""
    d, _, sc, b_star, ev = _case(1.3, (0.5, 1.0))
    tests = ev.run_jam_tests()
    assert (tests[1.0].decision.verdict, tests[0.5].decision.verdict) == (W, P)
    (fd,) = ev.flip_drivers
    assert fd.scale == 0.5 and not fd.worse
    by = {pr.component.key: pr for pr in fd.probes}
    assert [pr.component.key for pr in fd.drivers] == ["bath"]
    assert (by["bath"].probe_spread, by["tg"].probe_spread) == (1.0, TG_SD_C)
    assert by["bath"].result.scatter == replace(sc.scaled(0.5), bath_sd_c=1.0)
    assert by["bath"].verdicts == (W, E) and by["tg"].verdicts == (P,)
    for key, bath_sd in (("bath", 1.0), ("tg", 0.5)):  # each probe's jams: its bath draws colder than b*
        r = by[key].result
        baths = np.array([s.bath_c for s in draw_samples(d, sc.only(["bath"]).scaled(bath_sd), r.samples,
                                                          ev.options.seed)])
        clear = np.abs(baths - b_star) > 0.02
        got = np.array([o.jammed for o in r.outcomes])
        assert clear.sum() >= r.samples - 2 and got[clear].tolist() == (baths < b_star)[clear].tolist()
    (f,) = [f for f in ev.findings if f.code == "FP183"]
    assert f.severity == "info"
    assert ("at 0.5x the flip is driven by the bath temperature (bath, our choice, not measured; with it at its 1x "
            "spread the test does not pass (above 5 %):") in f.message
    assert "each scatter component in turn at its 1x spread, the others at 0.5x, the same draws" in f.message
    assert ev.to_json()["flip_drivers"][0]["probe"] == "kept at its 1x spread"


def test_a_better_flip_moves_toward_the_worse_1x_verdict():
    """An error at 1x, a pass at 0.5x: removing a component undoes it when the error comes
    back; the strongest removal is the one that raises the estimate most."""
    base, flipped = _Tested(6, 400), _Tested(0, 400)
    rms = (_probe("tg", _Tested(3, 400), base, flipped, SpreadBasis.CHOICE),
           _probe("bath", _Tested(6, 400), base, flipped, SpreadBasis.MEASURED))
    fd = FlipDrivers(0.5, base, flipped, rms)
    assert not fd.worse and [pr.component.key for pr in fd.drivers] == ["bath"]
    assert fd.toward_base(rms[0]) > 0


def test_the_shipped_spreads_state_their_basis():
    """Every shipped spread says what it rests on; the local heat transfer is our choice,
    the thickness a datasheet's, the correlation's error the literature's."""
    sc = default_scatter()
    assert {k: sc.basis(k) for k in KEYS} == {
        "bath": SpreadBasis.CHOICE, "h_shared": SpreadBasis.LITERATURE, "tg": SpreadBasis.CHOICE,
        "thickness": SpreadBasis.DATASHEET, "h_local": SpreadBasis.CHOICE}
    assert sc.scaled(2.0).without("tg").bases == sc.bases  # the sweep and removals keep them
    assert {k: v["basis"] for k, v in sc.to_json().items()}["thickness"] == "datasheet"


def test_the_shipped_file_must_state_every_basis():
    from importlib import resources

    text = (resources.files("foldprint") / "data" / "scatter.toml").read_text(encoding="utf-8")
    data = tomllib.loads(text.replace('basis = "literature"\n', ""))
    with pytest.raises(DesignError, match=r"missing shared\.heat_transfer\.basis"):
        scatter_from(data, "scatter.toml")
    data = tomllib.loads(text)
    del data["hinge"]["tg"]["source"]
    with pytest.raises(DesignError, match=r"missing hinge\.tg\.source"):
        scatter_from(data, "scatter.toml")


@pytest.mark.parametrize("value", ['"guess"', "1", '"Measured"', "true"])
def test_a_bad_basis_exits_2_naming_file_and_key(tmp_path, capsys, value):
    f = tmp_path / "s.toml"
    f.write_text(f"[shared.bath]\nsd_c = 1.0\nbasis = {value}\n")
    assert main(["robust", "helix_graded", "--samples", "2", "--scatter", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(f) in err[0] and "shared.bath.basis" in err[0] and "'measured'" in err[0]


def test_a_user_basis_alone_retags_the_shipped_spread(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[hinge.heat_transfer]\nbasis = "measured"\nsource = "our PIV study"\n')
    from foldprint.simulation.scatter import load_scatter

    sc = load_scatter(f)
    assert sc == default_scatter() and sc.basis("h_local") == SpreadBasis.MEASURED
    assert sc.sources["h_local"] == "our PIV study" and sc.basis("bath") == SpreadBasis.CHOICE


class _Probed(_Tested):
    """A probe's one-threshold test (undecided at its maximum) on k jams spread evenly over n samples."""

    def __init__(self, k, n, question, max_samples):
        test = jam_test(max_samples=max_samples).probing(question)
        stream = [i * k // n != (i + 1) * k // n for i in range(n)]
        self.decision = decide(stream, test)
        self.samples, self.jams = self.decision.samples, self.decision.jams
        self.jam_probability, self.ci95 = self.decision.estimate, self.decision.interval


def test_a_probe_on_its_threshold_is_undecided_not_a_driver():
    """A probe whose p sits on the 5 % threshold (1 jam in 20, evenly, for 400 samples)
    crosses neither boundary of its test: it ends undecided at the maximum, claims nothing
    (not a driver, all three verdicts open), and FP183 names it as undecided, its hint
    saying the flip may rest on its unmeasured spread; a clear probe still decides early."""
    base, flipped = _Tested(0, 400), _Tested(6, 400)
    on = _Probed(20, 400, JamQuestion.WARNING, 400)
    d = on.decision
    assert d.decided and d.undecided_at_max and d.samples == 400 and d.verdict is None
    assert d.verdicts == (P, W, E) and d.warning.side is None and d.truncated
    clear = _Probed(40, 160, JamQuestion.WARNING, 400)  # one jam in four: above 5 % after a few jams
    assert clear.decision.verdicts == (W, E) and clear.samples < 30 and not clear.decision.undecided_at_max
    back = _Probed(0, 400, JamQuestion.WARNING, 400)  # no jam: below 5 % after 57
    assert back.decision.verdicts == (P,) and back.samples == 57
    rms = (Probe(component("h_local"), 1.0, 0.0, SpreadBasis.CHOICE, "", on, undoes_all(P, E, d.verdicts)),
           Probe(component("bath"), 1.0, 0.0, SpreadBasis.MEASURED, "", back, undoes_all(P, E, back.decision.verdicts)))
    fd = FlipDrivers(2.0, base, flipped, rms)
    assert fd.drivers == (rms[1],)  # the undecided probe is no driver; the measured bath is
    pts = tuple(type("P", (), {"scale": k, "result": r})() for k, r in ((1.0, base), (2.0, flipped)))
    ctx = CheckContext(strip("x", [20, 20], [90], ["H-3"]), default_library(), load_printers()["connex260"],
                       robust=base, thresholds=Thresholds(), sweep=pts, flip_drivers=(fd,))
    (f,) = rule_jam_sensitivity(ctx)
    assert ("undecided: the heat transfer: local (h_local, our choice, not measured; without it the test is "
            "undecided at its maximum of 400 samples (p on the 5 % threshold): 5.0 %") in f.message
    assert f.hint.startswith("the flip may rest on spreads nobody measured (h_local")
