"""Tolerances and defaults shared by every stage.

Units inside foldprint: mm, s, degrees Celsius, radians.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerance:
    """One tolerance object for the whole package (trimesh's ``tol`` idea)."""

    length: float = 1e-6  # mm: coordinates closer than this are the same point
    area: float = 1e-9  # mm^2: polygons smaller than this are degenerate
    angle: float = 1e-9  # rad
    time: float = 1e-3  # s: contact times are refined to this
    time_eps: float = 1e-12  # s: round-off allowed when comparing sample times
    contact: float = 0.01  # mm: panels this close count as touching (3D swept check)


tol = Tolerance()

#: Recovery ratio that defines "folded" (paper: 98 %, theta = 91.8 deg for a 90 deg hinge).
FOLD_LEVEL = 0.98
#: Recovery ratio that defines the onset of a fold (our choice, used for reports only).
ONSET_LEVEL = 0.05
#: How long the recovery model looks ahead before it calls a hinge "does not fold" (s).
RECOVERY_HORIZON_S = 600.0
#: Step in ln(reduced time) between the nodes of the table the batch recovery curves (the
#: Monte-Carlo's) read the relaxation sum from (``physics.recovery.relaxation.relaxation_table``).
#: Our choice: 55 000 nodes (0.9 MB) from 1e-13 tau_1 to 50 tau_16; max |dR| 5.5e-9 against
#: the exact sum (3x the step: 4.9e-8, 10x: 5.5e-7; < 2e-8 asserted in
#: tests/test_recovery_batch.py), every template's Monte-Carlo outcomes unchanged
#: (benchmarks/bench_relaxation_table.py).
RELAXATION_TABLE_STEP = 1e-3

#: The most Monte-Carlo samples ``foldprint check`` (and the gallery, which runs the same
#: check) draws for its jam verdict, a sequential test that stops as soon as the answer is
#: known at its stated error rates (:mod:`foldprint.simulation.jamtest.verdict`, ``docs/verdict.md``);
#: ``--samples N`` sets it. Our choice: 400 (25 chunks) is about 2.4x the test's largest
#: average sample number (167, at a jam probability near 4.6 %, the warning test's
#: hardest case, where 7.6 % of runs reach the maximum; under 1 % do at the edges of the
#: indifference regions, and the error rates hold with the truncation:
#: ``benchmarks/bench_verdict.py``, ``docs/verdict.md``), and a marginal design gets up to
#: 5x the 80 samples of a fixed-size check whose 95 % intervals at 5 % and 20 % just part.
CHECK_SAMPLES = 400
#: The most samples a probe of what drives a flip folds (FP183; at most the test's own
#: maximum). Our choice: a probe that crosses neither boundary of its threshold's test by
#: then is reported undecided (its p is on the threshold) and claims nothing, so the cap
#: changes no error rate of a probe's answer (those of the untruncated SPRT, at most 5 %);
#: it only makes more probes undecided: at the edges of the warning test's indifference
#: region 11 % (p = 2.5 %) and 8 % (p = 7.5 %) of probes end undecided at 200, against under
#: 1 % at 400 (tests/test_verdict.py). Measured effect on the templates: docs/robustness-model.md.
PROBE_MAX_SAMPLES = 200
#: The sequential test of each jam threshold theta (warning :data:`JAM_WARN_ABOVE`, error
#: :data:`JAM_ERROR_ABOVE`): Wald's SPRT of p <= theta - delta against p >= theta + delta,
#: with delta = min(JAM_TEST_RELATIVE_HALF_WIDTH x theta, JAM_TEST_MAX_HALF_WIDTH): at the
#: defaults 0.025 against 0.075 (warning) and 0.15 against 0.25 (error). Our choice: a
#: half-width of half the threshold where the threshold is small (a 5 % question is about
#: factors: 2.5 % is clearly fine, 7.5 % clearly not; a fixed 5 points would put the lower
#: hypothesis at 0, which no finite number of samples proves), capped at 5 points where
#: it is large (a 1-in-4 jam should not pass a 20 % test). Narrower regions cost samples:
#: the average sample number grows as 1 / delta^2 (docs/verdict.md).
JAM_TEST_RELATIVE_HALF_WIDTH = 0.5
JAM_TEST_MAX_HALF_WIDTH = 0.05
#: The smallest half-width (a threshold of 0 or 1 still gives a test that ends): our choice.
JAM_TEST_MIN_HALF_WIDTH = 0.005
#: Error rates of each threshold's test (our choice, the usual 5 %): alpha, the chance of
#: saying "above" when p is at or below the lower end of its indifference region; beta,
#: of saying "below" when p is at or above the upper end (strict bounds: the boundaries
#: are log(1 / alpha) and log(beta), :class:`foldprint.simulation.jamtest.verdict.Sprt`).
JAM_TEST_ALPHA = 0.05
JAM_TEST_BETA = 0.05
#: Level of the interval reported beside the verdict (an anytime-valid confidence
#: sequence: valid at the data-dependent stopping time of the test).
JAM_INTERVAL_LEVEL = 0.95

#: Defaults for a design that does not say (the paper's helix, Mao et al. 2015, Fig. 2).
DEFAULT_THICKNESS_MM = 0.8
DEFAULT_DEPTH_MM = 6.0
DEFAULT_HINGE_RADIUS_MM = 5.0
DEFAULT_PANEL_MATERIAL = "VeroWhite"
#: Hinge material of a FOLD crease that names none (our choice: H-3, the material of the
#: paper's uniform helix, sample 1).
DEFAULT_HINGE_MATERIAL = "H-3"

#: Process defaults: the paper's protocol (program at 90 C, fix at 10 C, recover at 90 C).
DEFAULT_PROGRAM_C = 90.0
DEFAULT_FIX_C = 10.0
DEFAULT_BATH_C = 90.0
DEFAULT_DURATION_S = 20.0

#: Time step (s) of a simulation that is not given one (``simulate``, the kinematics, the
#: Monte-Carlo samples, the material search).
DEFAULT_DT_S = 0.01
#: Seed of every Monte-Carlo run that is not given one (``robust``, ``assign``): a fixed
#: seed, so the same design gives the same answer.
DEFAULT_SEED = 0

#: Seed of the Monte-Carlo samples ``foldprint check`` draws by default (a fixed seed: the
#: same design gives the same verdict), and the time step (s) of its nominal simulation and
#: of every sample. The gallery runs the same check with these and :data:`CHECK_SAMPLES`.
CHECK_SEED = DEFAULT_SEED
CHECK_DT_S = DEFAULT_DT_S
#: The jam probability above which ``check`` fails (FP180) and warns (FP181); our choices.
#: Each is tested sequentially with the error rates and indifference regions above.
JAM_ERROR_ABOVE = 0.2
JAM_WARN_ABOVE = 0.05
#: Monte-Carlo samples ``foldprint robust`` (and :func:`~foldprint.simulation.robust.jam_probability`)
#: draws by default.
ROBUST_SAMPLES = 60
#: ``foldprint assign``: assignments reported, most simulations the search may run, and
#: Monte-Carlo samples per finalist (``--objective robust``).
ASSIGN_TOP = 3
ASSIGN_BUDGET = 600
ASSIGN_SAMPLES = 40
#: The formats ``export`` writes when none is asked for (the files a printer needs).
EXPORT_FORMATS = ("3mf", "prusa3mf", "stl")
#: The formats a figure (``--plot``) is written in: those matplotlib's Agg canvas writes
#: without another package (jpg, tiff and webp need Pillow, pgf a LaTeX install; raw and
#: rgba are pixel dumps no viewer opens); tests/test_calibrate.py checks matplotlib lists them.
PLOT_FORMATS = ("png", "svg", "pdf")
#: Sigma scales ``check`` also runs (the same draws and seed, the same sequential test at
#: each) to say when its verdict flips inside that range (FP183); the gallery runs the same.
CHECK_SCALES = (0.5, 2.0)
#: The sigma scales ``foldprint robust --sensitivity`` sweeps by default.
SWEEP_SCALES = (0.5, 1.0, 2.0)
#: Decimals of a second every text output prints a time with (fold times, contacts,
#: clearances; ``core.display.seconds``): 0.01 s, the default time step. Our choice: the
#: contact times are refined to 1 ms (``tol.time``), but a model whose inputs scatter
#: (``docs/robustness-model.md``) moves them by more than that.
TIME_DECIMALS = 2
#: Decimals the JSON outputs round a time or probability to (0.1 ms; our choice: below any
#: time step, so the rounding never shows in a printed time, ``core.display.seconds``).
JSON_DECIMALS = 4
#: Poses sampled along a fold for its smallest clearance (check, the gallery and assign's
#: confirmed finalists): an even spread over the run, refined exactly between the two
#: nearest samples (:func:`foldprint.collision.clearance.min_clearance`).
CLEARANCE_SAMPLES = 200
#: Scattered folds ``simulate`` runs to say whether the nominal fold's smallest clearance
#: is marginal (:mod:`foldprint.simulation.margin`): the first samples ``check`` draws.
#: Our choice: one Monte-Carlo chunk (16); a design whose samples jam with probability p
#: shows no touching sample with probability (1 - p)^16: 17 % at p = 0.1, 3 % at p = 0.2
#: (docs/simulation.md has its effect on the templates).
MARGIN_SAMPLES = 16
#: Most non-adjacent panel pairs the margin screen searches (our choice, to keep ``simulate``
#: a matter of seconds): each sample's closest approach is an exact search over 200 poses of
#: every such pair, measured ~0.25 CPU-us a pair and pose (benchmarks/guard_peaks.py:
#: ``simulate`` on a 250-panel strip, 30,876 pairs, 30 CPU-s screened, against 13 CPU-s for a
#: 1000-panel strip not screened); at 20,000 pairs (about 200 panels in a strip) the 16
#: samples cost about 16 CPU-s. Above it the screen is left out and ``simulate`` says so;
#: ``check`` still runs the jam test.
MARGIN_MAX_PAIRS = 20_000
#: Time step (s) of the trajectory the time-series formats (xdmf, glb) are written from: 10
#: frames a second (viewers interpolate between them); a 20 s mailbox run gives 201 steps,
#: an XDMF/HDF5 pair of 7 MB and a 6 MB GLB (the simulation's default 0.01 s: ~10x both).
ANIMATION_DT_S = 0.1
