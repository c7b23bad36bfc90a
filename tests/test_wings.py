"""scripts/wings.py rewrites imports and names for a module family moved into a wing; here
on a made-up family (``apps.fam``, ``apps.fam_b`` -> ``apps/fam/main``, ``apps/fam/b``), so
the tests read the same before and after the real move."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def wings():
    spec = importlib.util.spec_from_file_location("wings_script", ROOT / "scripts" / "wings.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclass reads its module's namespace
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def fam(wings):
    moves = [wings.Move("apps.fam", "apps.fam.main"), wings.Move("apps.fam_b", "apps.fam.b")]
    modules = {"foldprint", "foldprint.apps", "foldprint.apps.fam", "foldprint.apps.fam_b",
               "foldprint.apps.pipeline", "foldprint.core", "foldprint.core.constants"}
    return moves, wings._renamer(moves), modules


def test_relative_imports_are_recomputed_for_the_new_place(wings, fam):
    moves, new_name, modules = fam
    src = ("from ..core.constants import A\nfrom .fam_b import B  # why\nfrom . import fam_b, pipeline\n"
           "from .pipeline import (C,\n    D)\n")
    moved = wings.rewrite_python(wings.PKG / "apps" / "fam.py", src, moves, new_name, modules)
    assert moved == ("from ...core.constants import A\nfrom .b import B  # why\n"
                     "from . import b as fam_b\nfrom .. import pipeline\nfrom ..pipeline import (C,\n    D)\n")
    # a module that stays sees the family at its new place, under the names it used
    stays = wings.rewrite_python(wings.PKG / "apps" / "pipeline.py", "from .fam import E\nfrom . import fam\n",
                                 moves, new_name, modules)
    assert stays == "from .fam.main import E\nfrom .fam import main as fam\n"


def test_absolute_names_move_in_code_strings_and_comments(wings, fam):
    moves, new_name, modules = fam
    src = ('import foldprint.apps.fam_b as fb\nfrom foldprint.apps.fam import F\nfrom foldprint.apps import fam_b\n'
           'patch("foldprint.apps.fam.F")  # apps.fam_b and foldprint/apps/fam_b.py\n'
           'apps.fam_b = 1\nx = "apps.fam_bx", "apps/fam.py"\n')
    out = wings.rewrite_python(ROOT / "tests" / "test_x.py", src, moves, new_name, modules)
    assert out == ('import foldprint.apps.fam.b as fb\nfrom foldprint.apps.fam.main import F\n'
                   'from foldprint.apps.fam import b as fam_b\n'
                   'patch("foldprint.apps.fam.main.F")  # apps.fam.b and foldprint/apps/fam/b.py\n'
                   'apps.fam_b = 1\nx = "apps.fam_bx", "apps/fam/main.py"\n')


def test_the_layer_table_row_names_the_wing(wings, fam):
    moves, _, _ = fam
    row = "| 10 | `apps/` | pipeline, fam, fam_b, calibrate | the chain (`pipeline`), a family (`fam` and `fam_b`) |\n"
    assert wings._table_row(row, moves) == ("| 10 | `apps/` | pipeline, fam/main, fam/b, calibrate | the chain "
                                            "(`pipeline`), a family (`fam/main` and `fam/b`) |\n")
    other = "| 3 | `physics/` | fam, fam_b | `fam` |\n"
    assert wings._table_row(other, moves) == other


def test_every_move_leaves_its_layer_and_lands_in_a_documented_wing(wings):
    news = set()
    for old, new in wings.MOVES.items():
        assert old.split(".")[0] == new.split(".")[0], (old, new)  # a wing stays in its layer
        assert 2 <= len(new.split(".")) <= 3 and new not in news, new
        news.add(new)
        if len(new.split(".")) == 3:
            assert new.rpartition(".")[0] in wings.WINGS, new
    leaves = [n.rpartition(".")[2] for n in news]
    assert len(leaves) == len(set(leaves)), "two moved modules share a file name"
