"""The bar-and-hinge model on the inputs that stalled or broke it (docs/mechanics.md,
"Flat folds" and "Few nodes per panel"): a crease whose rest angle nears 180 deg, panels
outlined by many vertices or holed many times, a design of one panel, a sheet folded flat,
a pattern whose equilibrium cannot be found. Numpy warnings are errors here: each case
gives a result or a one-line refusal, never a RuntimeWarning."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
import shapely

from foldprint.cli.commands import main
from foldprint.io.load import load_design
from foldprint.physics.barhinge import model as bh
from foldprint.physics.barhinge import equilibrium as bs
from foldprint.physics.barhinge.energy import stretch
from foldprint.physics.hinge_drive import run_times


@pytest.fixture(autouse=True)
def _numpy_errors():
    with np.errstate(divide="raise", invalid="raise", over="raise"), warnings.catch_warnings():  # underflow is benign
        warnings.simplefilter("error", RuntimeWarning)
        yield


def _design(tmp_path, panels, hinges, name="t"):
    """A design from (id, outline, holes) panels and (id, a, b, angle deg, material) hinges."""
    text = f'schema = 1\nname = "{name}"\nroot = "{panels[0][0]}"\n\n[defaults]\nthickness_mm = 0.8\n' \
        'hinge_radius_mm = 2.5\n\n'
    for pid, outline, holes in panels:
        text += f'[[panels]]\nid = "{pid}"\noutline = {json.dumps([list(q) for q in outline])}\n'
        if holes:
            text += f"holes = {json.dumps([[list(q) for q in h] for h in holes])}\n"
    for hid, a, b, deg, mat in hinges:
        text += f'[[hinges]]\nid = "{hid}"\npanels = ["{a}", "{b}"]\nangle_deg = {deg}\nmaterial = "{mat}"\n'
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return load_design(path)


def _square(pid, x0, y0, s=20.0):
    return (pid, ((x0, y0), (x0 + s, y0), (x0 + s, y0 + s), (x0, y0 + s)), ())


@pytest.mark.parametrize("rho,rest", [(3.14159, -3.14159), (-3.1, 3.1), (0.3, 0.1), (3.0, -3.0), (-2.0, 2.5)])
def test_stretch_is_the_departure_modulo_two_pi(rho, rest):
    d = float(stretch(np.array([rho]), np.array([rest]))[0])
    assert -math.pi <= d <= math.pi
    k = (rho - rest - d) / (2 * math.pi)
    assert abs(k - round(k)) < 1e-12  # the same angle
    assert abs(d) <= abs(rho - rest) + 1e-12  # the shorter way round


def test_a_flat_fold_beside_a_moving_flap_converges_without_splitting():
    """octagon_stack between 10.0 and 10.5 s: two flaps lie at 179.99998 deg (their rest a
    hair from atan2's cut at +-pi) while others turn. Before the spring stretch was taken
    modulo 2 pi every Newton step there was cut to 1/32 by the line search: 652 Newton
    iterations and 14 split steps over this half second (5 CPU-s); now one solve."""
    d = load_design("templates/octagon_stack.toml")
    t = run_times(d, 0.01)
    drive = bs.CompliantDrive(d)
    sol = bs.solve_path(d, drive, t[(t >= 10.0) & (t <= 10.5)], drive.model, drive.params)
    assert sol.splits == 0 and not sol.unconverged
    assert sol.iterations <= 10
    dev = stretch(sol.grid_angles, sol.rest)  # a tree with stiff panels: the drive's angles
    assert np.abs(dev).max() < 1e-6
    assert np.degrees(np.abs(sol.rest)).max() > 179.99  # the case is the flat one


def test_a_flap_folded_flat_follows_its_drive_through_180_degrees(tmp_path):
    """A tree: with panels 100x stiffer the equilibrium is the drive's rest angle, also
    where the rest angle is 180 deg (the reported angle may be a round-off past it)."""
    d = _design(tmp_path, [_square("a", 0, 0), _square("b", 20, 0), _square("c", 0, 20)],
                [("ab", "a", "b", 180, "H-1"), ("ac", "a", "c", 90, "H-7")])
    drive = bs.CompliantDrive(d, panel_modulus_mpa=1e5)
    sol = drive.solve(run_times(d, 0.01))
    assert not sol.unconverged
    assert np.abs(stretch(sol.grid_angles, sol.rest)).max() < 1e-6
    assert abs(abs(sol.angles[-1, 0]) - math.pi) < 1e-3


def _wavy(n: int):
    """A 20 x 20 mm square whose left side is a curve of n points (bulging up to 2.5 mm)."""
    side = [(-2.0 * math.sin(math.pi * k / (n - 1)) - 0.5 * math.sin(37 * math.pi * k / (n - 1)),
             20.0 - 20.0 * k / (n - 1)) for k in range(1, n - 1)]
    return ((0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0), *side)


def test_a_panel_of_a_thousand_vertices_gets_a_few_nodes_within_tolerance(tmp_path):
    outline = _wavy(1000)
    d = _design(tmp_path, [("a", outline, ()), _square("b", 20, 0)], [("ab", "a", "b", 90, "H-3")])
    m = bh.build(d)
    a_nodes = m.panel_nodes[0]
    assert len(a_nodes) <= bh.PANEL_POINTS
    coarse = shapely.Polygon(m.nodes[a_nodes][:, :2]).convex_hull  # the nodes cover the outline ...
    ring = shapely.Polygon(outline)
    # ... to the simplification tolerance, 2 % of the panel's 22.5 mm (no doubling needed here)
    assert ring.difference(coarse.buffer(bh.SIMPLIFY * 22.5 + 1e-9)).area == 0.0
    # the fold line's nodes are shared, so the hinge still turns the flap
    sol = bs.CompliantDrive(d).solve(run_times(d, 0.01))
    assert not sol.unconverged and abs(sol.angles[-1, 0] - math.radians(90)) < math.radians(1)


def _holed(n_x: int, n_y: int, half: float):
    holes = []
    for i in range(n_x):
        for j in range(n_y):
            cx, cy = 4 + 4.6 * i, 5 + 9.5 * j
            holes.append(((cx - half, cy - half), (cx - half, cy + half), (cx + half, cy + half), (cx + half, cy - half)))
    return ("a", ((0, 0), (100, 0), (100, 100), (0, 100)), tuple(holes))


_B = ("b", ((100, 0), (140, 0), (140, 100), (100, 100)), ())


def test_aligned_holes_give_no_flat_triangle(tmp_path, monkeypatch):
    """manifold3d joins hole corners on one line into zero-area triangles (the
    RuntimeWarning of the 200-hole panel); the model retriangulates such a panel: no flat
    triangle, and the triangles cover the holed panel's area exactly (shapely's area)."""
    monkeypatch.setattr(bh, "SIMPLIFY", 0.0)
    monkeypatch.setattr(bh, "PANEL_POINTS", 10**6)
    panel = _holed(20, 10, 1.0)
    d = _design(tmp_path, [panel, _B], [("ab", "a", "b", 90, "H-3")])
    m = bh.build(d)
    x, t = m.nodes, m.triangles[m.triangle_panel == 0]
    area = 0.5 * np.linalg.norm(np.cross(x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]), axis=1)
    assert area.min() > 1e-3
    assert area.sum() == pytest.approx(shapely.Polygon(panel[1], panel[2]).area, rel=1e-9)


@pytest.mark.parametrize("half", [1.0, 1.7])
def test_two_hundred_holes_simplify_to_a_few_nodes(tmp_path, half):
    d = _design(tmp_path, [_holed(20, 10, half), _B], [("ab", "a", "b", 90, "H-3")])
    m = bh.build(d)
    assert len(m.panel_nodes[0]) <= bh.PANEL_POINTS


def _cli(capsys, path, *extra):
    code = main(["simulate", str(path), "--mechanics", "bar-hinge", "--method", "fcl", *extra])
    out, err = capsys.readouterr()
    assert code in (0, 1, 2), err
    if code == 2:
        assert len(err.strip().splitlines()) == 1
    return code, out, err


def test_cli_a_single_panel_completes(tmp_path, capsys):
    p = tmp_path / "single.toml"
    p.write_text('schema = 1\nname = "single"\nroot = "a"\n\n[[panels]]\nid = "a"\n'
                 'outline = [[0, 0], [20, 0], [20, 20], [0, 20]]\n')
    code, out, _ = _cli(capsys, p, "--json")
    assert code == 0
    res = json.loads(out)
    assert res["completed"] and res["mechanics"]["fold_springs"] == 0 and res["mechanics"]["max_panel_strain"] == 0


def test_cli_a_holed_panel_folds(tmp_path, capsys):
    """Through the CLI, the holed panel is simplified too: its model keeps a few nodes.
    26 holes (104 hole corners, more than PANEL_POINTS) rather than the model tests' 200:
    the bar-and-hinge path is the same, and the swept check's convex pieces of 200
    holes cost over 100 CPU-s, which is not this test's subject."""
    p = tmp_path / "holes.toml"
    holes = [[list(q) for q in h] for h in _holed(13, 2, 1.0)[2]]
    assert 4 * len(holes) > bh.PANEL_POINTS  # unsimplified, the model would have more nodes than that
    p.write_text('schema = 1\nname = "holes"\nroot = "a"\n\n[[panels]]\nid = "a"\n'
                 f'outline = [[0, 0], [100, 0], [100, 100], [0, 100]]\nholes = {json.dumps(holes)}\n\n'
                 '[[panels]]\nid = "b"\noutline = [[100, 0], [140, 0], [140, 100], [100, 100]]\n\n'
                 '[[hinges]]\nid = "ab"\npanels = ["a", "b"]\nangle_deg = 90\nmaterial = "H-3"\n')
    code, out, _ = _cli(capsys, p, "--json")
    res = json.loads(out)
    assert code == 0 and res["completed"]
    assert res["mechanics"]["nodes"] <= bh.PANEL_POINTS + 2  # the flap adds its two free corners


def _flat_grid_fold(n: int) -> dict:
    """An n x n FOLD sheet, every crease folded flat (+-180 deg, alternating)."""
    s = 20.0
    vid = lambda i, j: j * (n + 1) + i  # noqa: E731
    edges, assign, angle = [], [], []
    for j in range(n + 1):
        for i in range(n):
            edges.append([vid(i, j), vid(i + 1, j)])
            b = j in (0, n)
            assign.append("B" if b else ("V" if j % 2 else "M"))
            angle.append(0 if b else (180 if j % 2 else -180))
    for i in range(n + 1):
        for j in range(n):
            edges.append([vid(i, j), vid(i, j + 1)])
            b = i in (0, n)
            assign.append("B" if b else ("V" if i % 2 else "M"))
            angle.append(0 if b else (180 if i % 2 else -180))
    return {"file_spec": 1.1, "frame_unit": "mm",
            "vertices_coords": [[s * i, s * j] for j in range(n + 1) for i in range(n + 1)],
            "faces_vertices": [[vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)]
                               for j in range(n) for i in range(n)],
            "edges_vertices": edges, "edges_assignment": assign, "edges_foldAngle": angle}


def test_cli_a_sheet_folded_flat_gets_a_verdict(tmp_path, capsys):
    p = tmp_path / "flat4.fold"
    p.write_text(json.dumps(_flat_grid_fold(4)))
    code, out, err = _cli(capsys, p)
    assert code == 1 and "internal error" not in err


@pytest.mark.slow
def test_a_grid_whose_equilibrium_cannot_be_found_stops_its_path():
    """A 6 x 6 sheet with every crease folded flat both ways has no folding motion: the
    panels crumple, Newton fails at some step even at the deepest halving, and the path
    holds there (listed), instead of 2^8 halvings per remaining step."""
    from foldprint.io.fold_format import design_from_fold

    d = design_from_fold(_flat_grid_fold(6))
    sol = bs.CompliantDrive(d).solve(run_times(d, 0.01))
    assert len(sol.unconverged) <= 1
    if sol.unconverged:
        k = int(np.searchsorted(sol.grid, sol.unconverged[0]))
        assert np.array_equal(sol.x[k], sol.x[-1])  # held from the failed step on
        assert sol.splits <= bs.MAX_SPLIT * 2


def test_the_rigid_margin_screen_is_left_out_of_a_compliant_loop_pattern_only():
    """Under bar-hinge the screen's rigid scattered folds would track a loop pattern's
    closure rigidly (the 10 x 10 Miura sheet: 201 dense SVDs after the fold completed);
    a tree keeps the screen (its compliant angles are its drive's), and rigid runs are as before."""
    from foldprint.simulation.margin import left_out

    miura, helix = load_design("templates/miura_3x3.toml"), load_design("templates/helix_graded.toml")
    assert "--mechanics bar-hinge" in left_out(miura, "bar-hinge")
    assert left_out(miura, "rigid") is None and left_out(miura) is None
    assert left_out(helix, "bar-hinge") is None


def test_the_equilibrium_path_is_bounded_at_the_time_budget(guard_defaults):
    """Steps that split are known only as they come (a 4-panel strip with a 0.01 mm panel
    folded to 179.99 deg took 38 CPU-s): past the time budget the path is refused, saying
    how far it got; under it the same path is solved to the end."""
    from pathlib import Path

    from foldprint.core import guards

    d = load_design(Path(__file__).resolve().parents[1] / "templates" / "miura_3x3.toml")
    guards.set_time_budget(1e-6)
    with pytest.raises(guards.ResourceError, match=r"miura_3x3.toml: the bar-and-hinge equilibrium path refused after "
                                                   r"[0-9.e+-]+ \w+ of CPU, over the 1e-06 s time budget \(solved to "
                                                   r"[0-9.e-]+ s of 20 s, \d+ Newton iterations, \d+ split steps before it\); "
                                                   r"use --mechanics rigid, or lift the budget"):
        bs.CompliantDrive(d).solve()
    guards.set_time_budget(None)
    sol = bs.CompliantDrive(d).solve()
    assert not sol.unconverged and sol.iterations > 0
