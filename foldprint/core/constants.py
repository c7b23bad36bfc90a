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

#: Monte-Carlo samples ``foldprint check`` (and everything that runs its estimate by default:
#: the gallery runs the same check) draws for the jam probability. The smallest round count whose Wilson 95 % intervals at
#: the check's two thresholds, p = 0.05 (warning) and p = 0.2 (error), do not overlap: at
#: N = 75 they first separate (0.05 N jams: up to 12.3 %; 0.2 N jams: from 12.6 %) and stay
#: apart for every larger N; 80 gives 0.020-0.122 vs 0.127-0.300 (tests/test_robust.py).
CHECK_SAMPLES = 80

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
#: The jam probability above which ``check`` fails (FP180: the lower end of the 95 %
#: interval above it) and warns (FP181: the estimate above it); our choices, see
#: :data:`CHECK_SAMPLES` for why 80 samples separate them.
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
#: Sigma scales ``check`` also runs (the same samples and seed) to say when its verdict
#: flips inside that range (FP183); the gallery runs the same.
CHECK_SCALES = (0.5, 2.0)
#: The sigma scales ``foldprint robust --sensitivity`` sweeps by default.
SWEEP_SCALES = (0.5, 1.0, 2.0)
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
#: Time step (s) of the trajectory the time-series formats (xdmf, glb) are written from: 10
#: frames a second (viewers interpolate between them); a 20 s mailbox run gives 201 steps,
#: an XDMF/HDF5 pair of 7 MB and a 6 MB GLB (the simulation's default 0.01 s: ~10x both).
ANIMATION_DT_S = 0.1
