"""The bar-and-hinge model (docs/mechanics.md): analytic gradient and Hessian against finite
differences, the model built from a design (triangulation, shared fold-line nodes, fold
sign), and the validation cases against independent references: the rigid model with
stiff panels (a strip, the Miura template on its one-DOF path), the closed-form torque
balance of a one-DOF loop, the Kresling truss's two unstrained heights, the hypar's saddle
sign; the CLI and the check findings."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from foldprint.cli.commands import main
from foldprint.core.errors import DesignError, FoldprintError
from foldprint.io.fold_format import design_from_fold
from foldprint.io.load import load_design
from foldprint.model import crease_patterns as cp
from foldprint.model.design import Design, Hinge, Panel, strip
from foldprint.physics.barhinge import equilibrium as bs
from foldprint.physics.barhinge.model import build, diagonal_curvatures, kresling, kresling_heights
from foldprint.physics.barhinge.energy import dihedral, fold_angles
from foldprint.physics.hinge_drive import HingeDrive, run_times
from foldprint.physics.barhinge.stiffness import default_params, hinge_modulus, params_from
from foldprint.physics.viscoelastic import viscoelastic
from foldprint.model.materials import default_library

STIFF = 1e5  # MPa: panels 100x the paper's 1 GPa, for the comparisons with rigid panels


def _fd(f, x, h=1e-6):
    """Central differences of f (returning an array) over the entries of x."""
    out = []
    for a in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp.flat[a] += h
        xm.flat[a] -= h
        out.append((f(xp) - f(xm)) / (2 * h))
    return np.array(out)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.lists(st.floats(-0.4, 0.4), min_size=12, max_size=12))
def test_dihedral_gradient_and_hessian_match_finite_differences(noise):
    x = np.array([[0.5, 1, 0], [0, 0, 0], [1, 0, 0], [0.4, -1, 0.2]]) + np.reshape(noise, (4, 3))
    ijkl = np.array([[0, 1, 2, 3]])
    rho, g, H = dihedral(x, ijkl)
    assert rho[0] == pytest.approx(fold_angles(x, ijkl)[0])
    g_fd = _fd(lambda y: fold_angles(y, ijkl), x)[:, 0]
    H_fd = _fd(lambda y: dihedral(y, ijkl, hessian=False)[1][0], x)
    scale = max(1.0, np.abs(H_fd).max())
    assert np.abs(g[0] - g_fd).max() < 1e-7
    assert np.abs(H[0] - H_fd).max() < 1e-5 * scale
    assert np.abs(H[0] - H[0].T).max() < 1e-9 * scale


def test_energy_gradient_and_hessian_match_finite_differences():
    d = load_design("templates/miura_3x3.toml")
    m = build(d)
    rng = np.random.default_rng(3)
    x = m.nodes + 0.3 * rng.standard_normal(m.nodes.shape)
    k = rng.uniform(0.5, 2.0, m.n_hinges)
    rest = rng.uniform(-1, 1, m.n_hinges)
    U, g, H = m.energy(x, k, rest)
    g_fd = _fd(lambda y: np.array([m.energy(y.reshape(-1, 3), k, rest, hessian=False)[0]]), x.ravel())[:, 0]
    H_fd = _fd(lambda y: m.energy(y.reshape(-1, 3), k, rest, hessian=False)[1], x.ravel())
    assert np.abs(g - g_fd).max() < 1e-5 * max(1.0, np.abs(g).max())
    assert np.abs(H.toarray() - H_fd).max() < 1e-5 * max(1.0, np.abs(H_fd).max())


@pytest.mark.parametrize("name", ["miura_3x3", "self_lock", "helix_graded", "cross_lock_uniform", "mailbox"])
def test_triangulation_covers_every_panel_and_joins_panels_only_on_hinges(name):
    d = load_design(f"templates/{name}.toml")
    m = build(d)
    x = m.nodes
    area = 0.5 * np.linalg.norm(np.cross(x[m.triangles[:, 1]] - x[m.triangles[:, 0]],
                                         x[m.triangles[:, 2]] - x[m.triangles[:, 0]]), axis=1)
    per = np.bincount(m.triangle_panel, weights=area, minlength=len(d.panels))
    assert per == pytest.approx([p.area for p in d.panels], rel=1e-9)  # holes are holes
    # every hinge's fold springs cover its whole length, and only panels on a hinge share nodes
    share = np.bincount(m.spring_hinge[m.fold], weights=m.spring_share[m.fold], minlength=len(d.hinges))
    assert share == pytest.approx(np.ones(len(d.hinges)), rel=1e-9)
    assert len(np.unique(m.triangles)) == len(m.nodes)


def test_non_convex_panel_with_a_hole_is_triangulated_and_bends():
    ell = Panel("L", [[0, 0], [30, 0], [30, 10], [10, 10], [10, 30], [0, 30]], 0.8, "VeroWhite",
                ([[2, 2], [6, 2], [6, 6], [2, 6]],))
    tab = Panel("t", [[30, 0], [40, 0], [40, 10], [30, 10]], 0.8, "VeroWhite")
    d = Design("ell", (ell, tab), (Hinge("h", ("L", "t"), [[30, 0], [30, 10]], math.radians(90), "H-1", 5.0, 0.8),))
    m = build(d)
    x = m.nodes
    area = 0.5 * np.linalg.norm(np.cross(x[m.triangles[:, 1]] - x[m.triangles[:, 0]],
                                         x[m.triangles[:, 2]] - x[m.triangles[:, 0]]), axis=1)
    assert area[m.triangle_panel == 0].sum() == pytest.approx(ell.area)
    assert (~m.fold).sum() > 0 and m.fold.sum() == 1


def test_a_valley_lifts_the_child_toward_plus_z():
    d = strip("s", [10, 10], [90], ["H-1"])
    drive = bs.CompliantDrive(d)
    sol = drive.solve(run_times(d, 0.01))
    assert sol.angles[-1, 0] == pytest.approx(math.pi / 2, rel=1e-3)
    tip = [i for i, p in enumerate(sol.model.nodes) if p[0] > 15]
    assert (sol.x[-1][tip, 2] > 5).all()


def test_hinge_modulus_is_the_materials_relaxation_modulus_at_the_load_time():
    lib = default_library()
    p = default_params()
    assert p.hinge.load_time_s == 1.0 and p.panel_modulus_mpa == 1000.0
    m = lib["H-4"]
    model = viscoelastic(m)
    T = np.linspace(-20, 140, 321)
    E = hinge_modulus(model, T, m.tg_c, p.hinge)
    assert (np.diff(E) <= 1e-9).all()  # hotter is softer
    # the plateaus are the material's moduli
    assert E[0] == pytest.approx(m.glassy_mpa, rel=0.02) and E[-1] == pytest.approx(m.rubbery_mpa, rel=1e-3)
    # the relaxation modulus at 1 s, independently: E_r + dE sum g exp(-t / (a_T tau))
    tau, g = model.spectrum()
    a = 10.0 ** float(model.log10_shift(m.tg_c))
    want = m.rubbery_mpa + (m.glassy_mpa - m.rubbery_mpa) * float(np.sum(g * np.exp(-1.0 / (a * tau))))
    assert float(hinge_modulus(model, m.tg_c, m.tg_c, p.hinge)) == pytest.approx(want, rel=1e-12)
    # a Tg scattered by 3 C moves the whole curve by 3 C: exactly on the WLF side of T_ref,
    # closely on the Arrhenius side (its shift depends on the absolute temperature)
    moved = hinge_modulus(model, T + 3.0, m.tg_c + 3.0, p.hinge)
    wlf = T >= model.reference_c
    assert moved[wlf] == pytest.approx(E[wlf], rel=1e-9)
    assert moved == pytest.approx(E, rel=1e-4)


def test_mechanics_data_errors_name_the_file_and_the_key():
    good = {"hinge": {"load_time_s": 1.0, "poisson": 0.3},
            "panel": {"modulus_mpa": 1000, "poisson": 0.3, "bending_coefficient": 0.5},
            "check": {"panel_strain_limit": 0.01}}
    with pytest.raises(DesignError, match=r"my\.toml \[panel\]: 'modulus_mpa' must be > 0"):
        params_from({**good, "panel": {"modulus_mpa": -1, "poisson": 0.3, "bending_coefficient": 0.5}}, "my.toml")
    with pytest.raises(DesignError, match=r"my\.toml \[hinge\]: \['glassy_mpa', 'width_c'\] are no longer"):
        params_from({**good, "hinge": {"load_time_s": 1.0, "poisson": 0.3, "glassy_mpa": 1, "width_c": 5}},
                    "my.toml")
    with pytest.raises(DesignError, match="missing table"):
        params_from({}, "my.toml")


def _compare_with_rigid(d):
    times = run_times(d, 0.01)
    comp = bs.CompliantDrive(d, panel_modulus_mpa=STIFF)
    sol = comp.solve(times)
    return sol, sol.grid_angles, HingeDrive(d).angles(sol.grid)


def test_strip_with_stiff_panels_follows_the_rigid_model_within_one_percent():
    d = strip("s", [10, 12, 10, 8], [90, -60, 120], ["H-1", "H-4", "H-7"])
    sol, ca, ra = _compare_with_rigid(d)
    target = np.abs([h.angle for h in d.hinges])
    assert (np.abs(ca - ra) <= 0.01 * target).all()
    assert not sol.unconverged


def test_miura_with_stiff_panels_stays_on_the_rigid_folding_path():
    """Rigid-foldable: at every solved time each interior vertex's straight and zigzag
    creases satisfy the one-DOF relation tan(|rho_h|/2) = cos(gamma) tan(|rho_z|/2) within
    1.5 % of the target angle, and closer as the panels stiffen (the relation is the rigid
    limit's); the final angles are the rigid model's, within 1 % of the target angle; the
    panels barely strain, less as they stiffen."""
    d = load_design("templates/miura_3x3.toml")
    sol, ca, ra = _compare_with_rigid(d)
    target = np.abs([h.angle for h in d.hinges])
    assert (np.abs(ca[-1] - ra[-1]) <= 0.01 * target).all()
    gamma = math.atan2(20.0, 8.0)
    straight = [k for k, h in enumerate(d.hinges) if abs(abs(h.angle_deg) - 24.2) < 0.1]
    zigzag = [k for k, h in enumerate(d.hinges) if abs(abs(h.angle_deg) - 60) < 0.1]

    def off_path(angles):
        z = np.abs(angles[:, zigzag]).mean(axis=1)
        pred = 2 * np.arctan(math.cos(gamma) * np.tan(z / 2))
        folded = z > math.radians(5)
        assert folded.sum() > 20
        return float((np.abs(np.abs(angles[:, straight])[folded] - pred[folded, None])
                      / target[straight][None]).max())

    off = off_path(ca)
    assert off <= 0.015
    # near rigid: the panels' strain is a small share of the strain limit and falls as they stiffen
    assert sol.max_strain < 0.01 * sol.strain_limit
    stiffer = bs.CompliantDrive(d, panel_modulus_mpa=10 * STIFF).solve(run_times(d, 0.01))
    assert off_path(stiffer.grid_angles) < off / 2
    assert stiffer.max_strain < sol.max_strain / 3


def _two_hinge_loop(mat_a="H-1", mat_b="H-7", angle=90.0):
    """Two panels joined by two collinear hinges (a slot between them): a hinge graph with
    one loop and one degree of freedom, both hinges at the same angle. Panel b has a vertex
    on h1, so h1 is two fold springs sharing its stiffness."""
    a = Panel("a", [[0, 0], [20, 0], [20, 20], [0, 20]], 0.8, "VeroWhite")
    b = Panel("b", [[20, 0], [40, 0], [40, 20], [20, 20], [20, 4]], 0.8, "VeroWhite")
    r = math.radians(angle)
    return Design("loop2", (a, b), (Hinge("h1", ("a", "b"), [[20, 0], [20, 8]], r, mat_a, 5.0, 0.8),
                                    Hinge("h2", ("a", "b"), [[20, 12], [20, 20]], r, mat_b, 5.0, 0.8)))


def test_one_dof_loop_settles_at_the_stiffness_weighted_balance():
    """rho = (k1 rho1 + k2 rho2) / (k1 + k2): the closed form of two springs on one degree
    of freedom. While the low-Tg hinge is rubbery and the high-Tg one glassy the balance
    sits next to the glassy hinge's (unrecovered) angle: the stiffer hinge holds."""
    d = _two_hinge_loop()
    sol = bs.CompliantDrive(d, panel_modulus_mpa=STIFF).solve(run_times(d, 0.01))
    assert sorted(sol.model.spring_share[sol.model.fold].round(6)) == [0.5, 0.5, 1.0]
    k, r = sol.stiffness, sol.rest
    balance = (k[:, 0] * r[:, 0] + k[:, 1] * r[:, 1]) / k.sum(axis=1)
    moving = np.abs(r[:, 0] - r[:, 1]) > math.radians(2)
    assert moving.sum() > 5
    ang = sol.grid_angles
    for j in (0, 1):
        assert np.abs(ang[moving, j] - balance[moving]).max() < 0.01 * np.abs(r[moving]).max()
    # somewhere the rubbery low-Tg hinge has recovered far more than the glassy one, and the pair
    # stays nearer the glassy hinge's angle: k_glassy / k_rubbery of tens to hundreds
    w = np.nonzero(moving & (k[:, 1] > 10 * k[:, 0]))[0]
    assert len(w)
    assert (np.abs(ang[w, 0] - r[w, 1]) < np.abs(ang[w, 0] - r[w, 0])).all()
    # the rigid loop tracker takes the unweighted compromise instead
    rigid = HingeDrive(d).angles(sol.grid[w])[:, 0]
    assert (np.abs(rigid - 0.5 * (r[w, 0] + r[w, 1])) < 1e-3).all()


def test_kresling_tower_is_bistable_at_the_closed_form_heights():
    """All bars are unstrained at two heights: |b_k t_k|^2 = h^2 + 2R^2 (1 - cos phi) and
    |b_k+1 t_k|^2 = h^2 + 2R^2 (1 - cos(phi - 2 pi/n)) keep their lengths when
    sin(phi - pi/n) is unchanged: phi2 = pi + 2 pi/n - phi1, h2^2 = h1^2 + 2R^2 (cos phi2 - cos phi1).
    Pressed down under displacement control the tower passes an energy barrier and lands
    on the second height unstrained; released on either side of the barrier it snaps to
    the nearer state."""
    n, R, h1, phi1 = 6, 20.0, 35.0, math.radians(70)
    phi2 = math.pi + 2 * math.pi / n - phi1
    h2 = math.sqrt(h1**2 + 2 * R**2 * (math.cos(phi2) - math.cos(phi1)))
    m = kresling(n, R, h1, phi1)
    assert kresling_heights(n, R, h1, phi1) == pytest.approx((h2, phi2))
    zero = np.zeros(1)
    top_z = 3 * np.arange(n, 2 * n) + 2
    hs = np.linspace(h1, h2, 61)
    path = bs.displacement_path(m, top_z, np.repeat(hs[:, None], n, axis=1), zero, zero)
    assert all(eq.converged for eq in path)
    energy = [eq.energy for eq in path]
    twist = [math.atan2(eq.x[n, 1], eq.x[n, 0]) for eq in path]
    energy = np.array(energy)
    barrier = energy.max()
    assert barrier > 1.0  # N mm: a real barrier between the states
    assert energy[0] < 1e-9 * barrier and energy[-1] < 1e-6 * barrier
    assert twist[-1] == pytest.approx(phi2 - 2 * math.pi if phi2 > math.pi else phi2, abs=1e-3)
    peak = int(np.argmax(energy))
    assert 0 < peak < len(hs) - 1
    # released (top free) a little before and after the barrier's height: snaps to the nearer state
    for idx, h_end in ((peak - 5, h1), (peak + 5, h2)):
        eq = bs.equilibrium(m, path[idx].x, zero, zero, max_iter=200)
        assert eq.converged
        assert eq.x[n:, 2].mean() == pytest.approx(h_end, abs=1e-4)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_pleated_hypar_twists_into_a_saddle_of_the_diagonals_sign(sign):
    """A valley line lifts the sheet on both sides, a mountain line lowers it: with the
    (+x, +y) diagonal valley the sheet's height along that diagonal (u) curves down and
    along the other (v) up, z ~ a u^2 + b v^2 with a < 0 < b; swapping the diagonals'
    assignment flips it."""
    d = design_from_fold(cp.hypar(4, 80.0, diagonal_deg=20.0 * sign, material="H-3"))
    sol = bs.CompliantDrive(d).solve(run_times(d, 0.01))
    a, b = diagonal_curvatures(sol.model.nodes, sol.x[-1])
    assert sign * a < -1e-4 and sign * b > 1e-4
    assert sol.max_bending > math.radians(0.2)  # the panels twist: no rigid folding exists


def test_halving_the_solve_grid_moves_the_angles_by_under_one_percent(monkeypatch):
    d = load_design("templates/miura_3x3.toml")
    t = run_times(d, 0.01)
    a1 = bs.CompliantDrive(d).angles(t)
    monkeypatch.setattr(bs, "GRID_ANGLE_RAD", bs.GRID_ANGLE_RAD / 2)
    monkeypatch.setattr(bs, "GRID_LOG_K", bs.GRID_LOG_K / 2)
    a2 = bs.CompliantDrive(d).angles(t)
    assert np.abs(a1 - a2).max() < 0.01 * math.radians(60)


def test_simulate_cli_bar_hinge_reports_panel_strain_per_step(capsys):
    code = main(["simulate", "miura_3x3", "--mechanics", "bar-hinge", "--json", "--method", "fcl",
                 "--duration", "4"])
    out, err = capsys.readouterr()
    assert code == 0, err
    r = json.loads(out)
    mech = r["mechanics"]
    assert mech["model"] == "bar-hinge" and mech["nodes"] == 16 and mech["fold_springs"] == 12
    steps = mech["steps"]
    assert len(steps["time_s"]) == len(steps["max_panel_strain"]) == len(steps["max_panel_bending_deg"]) > 10
    assert max(steps["max_panel_strain"]) == pytest.approx(mech["max_panel_strain"], abs=1e-6)
    assert {p["id"] for p in mech["panels"]} == {p["id"] for p in r.get("panels", [])} or len(mech["panels"]) == 9
    code = main(["simulate", "miura_3x3", "--json", "--duration", "1"])
    assert json.loads(capsys.readouterr()[0])["mechanics"] == {"model": "rigid"}


def test_cli_rejects_an_unknown_mechanics(capsys):
    assert main(["simulate", "miura_3x3", "--mechanics", "soft"]) == 2
    err = capsys.readouterr()[1]
    assert "--mechanics" in err and "bar-hinge" in err and len(err.strip().splitlines()) == 1


def test_check_says_a_rigidly_locked_pattern_needs_the_compliant_model(capsys):
    code = main(["check", "cross_lock_uniform", "--samples", "0", "--json"])
    r = json.loads(capsys.readouterr()[0])
    codes = {f["code"]: f for f in r["findings"]}
    assert code == 1 and "FP190" in codes and "--mechanics bar-hinge" in codes["FP190"]["hint"]
    code = main(["check", "cross_lock_uniform", "--samples", "0", "--json", "--mechanics", "bar-hinge"])
    r = json.loads(capsys.readouterr()[0])
    codes = {f["code"]: f for f in r["findings"]}
    assert "FP190" not in codes and codes["FP191"]["severity"] in ("info", "warning")


def test_guard_refuses_a_design_too_large_for_the_solver(monkeypatch):
    from foldprint.physics.barhinge import solve_cost as barhinge_cost
    from foldprint.simulation.simulate import simulate

    monkeypatch.setattr(barhinge_cost, "MAX_MECHANICS_NODES", 10)
    with pytest.raises(FoldprintError, match="--mechanics bar-hinge refused: 36 panel vertices"):
        simulate(load_design("templates/miura_3x3.toml"), mechanics="bar-hinge")


def test_monte_carlo_samples_fold_the_bar_and_hinge_model_on_their_own_curves():
    from foldprint.simulation.robust import default_scatter, draw_samples, jam_probability, outcome_of, sample_drive
    from foldprint.simulation.simulate import simulate
    from foldprint.model.materials import default_library

    d = load_design("templates/miura_3x3.toml")
    r = jam_probability(d, 3, 5, mechanics="bar-hinge", workers=1, dt=0.02)
    assert r.mechanics == "bar-hinge" and r.nominal.compliant is not None
    lib = default_library()
    for o, smp in zip(r.outcomes, draw_samples(d, default_scatter(), 3, 5)):
        res = simulate(d, dt=0.02, method="fcl", drive=sample_drive(d, lib, smp), mechanics="bar-hinge")
        assert outcome_of(res) == o
        # its own scattered curves: mid-fold it is not the nominal fold
        assert np.abs(res.compliant.at(1.5) - r.nominal.compliant.at(1.5)).max() > 1e-3
    assert jam_probability(d, 3, 5, workers=1, dt=0.02).mechanics == "rigid"


def test_xdmf_series_and_viewer_carry_the_panel_strain(tmp_path, capsys):
    import meshio

    from foldprint.apps.pipeline import EvalOptions, Evaluation
    from foldprint.model.materials import default_library
    from foldprint.render.viewer import viewer_data

    assert main(["export", "miura_3x3", "--format", "xdmf", "--mechanics", "bar-hinge", "--out", str(tmp_path),
                 "--json"]) == 0
    capsys.readouterr()
    with meshio.xdmf.TimeSeriesReader(str(tmp_path / "miura_3x3_fold.xdmf")) as r:  # a real reader
        r.read_points_cells()
        steps = [r.read_data(k) for k in range(r.num_steps)]
    ev = Evaluation(load_design("templates/miura_3x3.toml"), EvalOptions(mechanics="bar-hinge"))
    sol, frames = ev.animation.compliant, ev.frames
    panel = steps[0][2]["panel"][0]
    for k in (0, len(steps) // 3, len(steps) - 1):
        t, _, cells = steps[k]
        strain = cells["panel_strain"][0]
        j = int(np.searchsorted(sol.grid, t, side="right")) - 1
        assert strain[panel >= 0] == pytest.approx(sol.panel_strain[j][panel[panel >= 0]], rel=1e-5, abs=1e-12)
        assert (strain[panel < 0] == 0).all()
    assert frames.panel_strain.shape == (len(frames.times), 9)
    data = viewer_data(ev.animation, default_library())
    assert data["mechanics"]["strain"] == pytest.approx(list(sol.panel_strain.max(axis=1)))
    assert viewer_data(Evaluation(load_design("templates/miura_3x3.toml")).animation,
                       default_library())["mechanics"] is None


def test_a_pattern_whose_creases_lag_but_finish_is_not_called_locked(capsys):
    assert main(["check", "miura_3x3", "--samples", "0", "--json"]) == 0
    assert "FP190" not in {f["code"] for f in json.loads(capsys.readouterr()[0])["findings"]}
