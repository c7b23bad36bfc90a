"""The command line, in-process (``foldprint.cli.commands.main``) and as a subprocess."""

import json
import subprocess
import sys

import pytest

from foldprint.cli.commands import main


def run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_materials_json_contract(capsys, lib):
    code, out, err = run(capsys, "materials", "--temperature", "80", "90", "100", "--json")
    assert code == 0
    data = json.loads(out)
    rows = {r["name"]: r for r in data["materials"]}
    assert list(rows)[:7] == [f"H-{i}" for i in range(1, 8)]
    h1 = rows["H-1"]
    assert h1["role"] == "hinge" and h1["tg_c"] == 32.0
    assert list(h1["fold_time_s"]) == ["80", "90", "100"]
    from foldprint.physics.recovery.curve import fold_time
    assert h1["fold_time_s"]["90"] == pytest.approx(fold_time(lib["H-1"], 90.0), abs=1e-3)
    assert rows["VeroWhite"]["fold_time_s"]["90"] is None


def test_materials_keys_are_temperatures_as_given_and_null_below_tg(capsys):
    code, out, _ = run(capsys, "materials", "-t", "55.0", "-t", "95", "--json")
    data = json.loads(out)
    h7 = next(r for r in data["materials"] if r["name"] == "H-7")
    assert list(h7["fold_time_s"]) == ["55.0", "95"]
    assert h7["fold_time_s"]["55.0"] is None and h7["fold_time_s"]["95"] > 0


def test_materials_table_and_plot(capsys, tmp_path):
    png = tmp_path / "chart.png"
    code, out, err = run(capsys, "materials", "--plot", str(png))
    assert code == 0 and "H-7" in out and png.stat().st_size > 5000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_materials_user_file(capsys, tmp_path):
    f = tmp_path / "m.toml"
    f.write_text('[materials.H-9]\nrole = "hinge"\ntg_c = 80.0\ncolor = "#000000"\n')
    code, out, _ = run(capsys, "materials", "--materials", str(f), "-t", "90", "--json")
    names = [r["name"] for r in json.loads(out)["materials"]]
    assert code == 0 and "H-9" in names


@pytest.mark.parametrize("args,needle", [
    (["materials", "--temperature", "hot"], "--temperature"),
    (["materials", "--materials", "/nonexistent/m.toml"], "/nonexistent/m.toml"),
    (["materials", "--bogus"], "--bogus"),
    (["nosuchcommand"], "nosuchcommand"),
])
def test_bad_input_exits_2_with_one_line(capsys, args, needle):
    code, out, err = run(capsys, *args)
    assert code == 2
    assert needle in err and "Traceback" not in err
    assert out == ""


def test_templates_lists_shipped_designs(capsys):
    code, out, _ = run(capsys, "templates", "--json")
    assert code == 0
    assert isinstance(json.loads(out)["templates"], list)


def test_console_script_and_module_entry_points():
    res = subprocess.run([sys.executable, "-m", "foldprint", "--version"], capture_output=True, text=True)
    assert res.returncode == 0 and res.stdout.startswith("foldprint ")
    res = subprocess.run([sys.executable, "-m", "foldprint", "materials", "-t", "x"], capture_output=True, text=True)
    assert res.returncode == 2 and "Traceback" not in res.stderr


def test_simulate_json_contract_and_exit_codes(capsys, tmp_path):
    code, out, err = run(capsys, "simulate", "helix_graded", "--json", "--plot", str(tmp_path))
    assert code == 0
    r = json.loads(out)
    assert r["design"] == "helix_graded" and r["temperature_c"] == 90.0
    assert r["completed"] is True and r["first_collision"] is None
    assert 5.0 <= r["fold_time_s"] <= 9.0
    assert [h["material"] for h in r["hinges"]][:3] == ["H-1", "H-1", "H-2"]
    assert all(h["fold_time_s"] > 0 for h in r["hinges"])
    assert (tmp_path / "helix_graded_hinge_angles.png").stat().st_size > 5000
    assert (tmp_path / "helix_graded_collision_index.png").stat().st_size > 5000
    assert r["hinge_model"] == "arc" and r["comparison"] is None  # both models agree on it
    code, out, _ = run(capsys, "simulate", "helix_uniform", "--json", "--method", "index2d", "--hinge-model", "point")
    r = json.loads(out)
    assert code == 1 and r["completed"] is False and r["hinge_model"] == "point"
    assert r["first_collision"]["method"] == "index2d" and sorted(r["first_collision"]["panels"]) == ["p4", "p9"]
    # the printed geometry folds it cleanly; the output says the paper's ROM disagrees
    code, out, _ = run(capsys, "simulate", "helix_uniform", "--json")
    r = json.loads(out)
    assert code == 0 and r["hinge_model"] == "arc" and r["comparison"]["hinge_model"] == "point"
    assert r["comparison"]["completed"] is False
    code, out, _ = run(capsys, "simulate", "self_lock", "--json")
    r = json.loads(out)
    assert code == 0 and [g["met"] for g in r["goals"]] == [True, True]
    assert r["goals"][0]["time_s"] < r["goals"][1]["time_s"]


@pytest.mark.parametrize("args,needle", [
    (["simulate", "nosuchdesign"], "nosuchdesign"),
    (["simulate", "helix_graded", "--method", "magic"], "--method"),
    (["simulate", "helix_graded", "--dt", "0"], "--dt"),
    (["simulate", "helix_graded", "--hinge-model", "spring"], "--hinge-model"),
])
def test_simulate_bad_input(capsys, args, needle):
    code, out, err = run(capsys, *args)
    assert code == 2 and needle in err and out == "" and "Traceback" not in err


def test_export_json_lists_files(capsys, tmp_path):
    code, out, _ = run(capsys, "export", "helix_graded", "--out", str(tmp_path), "--format", "3mf,stl", "--json")
    assert code == 0
    r = json.loads(out)
    fmts = sorted({f["format"] for f in r["files"]})
    assert fmts == ["3mf", "manifest", "recipe", "stl"]
    three = next(f for f in r["files"] if f["format"] == "3mf")
    mats = {b["material"] for b in three["bodies"]}
    assert mats == {"H-1", "H-2", "H-3", "H-4", "H-5", "H-6", "H-7", "VeroWhite"}
    stl_total = sum(b["volume_mm3"] for f in r["files"] if f["format"] == "stl" for b in f["bodies"])
    assert stl_total == pytest.approx(sum(b["volume_mm3"] for b in three["bodies"]), rel=1e-9)
    for f in r["files"]:
        assert (tmp_path / f["path"].split("/")[-1]).exists()


def test_export_state_is_parsed_like_the_other_modes(capsys, tmp_path):
    code, out, _ = run(capsys, "export", "self_lock", "--out", str(tmp_path / "a"), "--format", "stl",
                       "--state", "Programmed", "--json")
    assert code == 0 and json.loads(out)["state"] == "programmed"
    code, _, err = run(capsys, "export", "self_lock", "--out", str(tmp_path / "b"), "--state", "flat")
    assert code == 2 and "--state must be permanent or programmed, got 'flat'" in err
    assert not (tmp_path / "b").exists()


def test_export_to_unwritable_place_exits_2_and_writes_nothing(capsys, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, out, err = run(capsys, "export", "helix_graded", "--out", str(blocker / "sub"))
    assert code == 2 and "file" in err and "Traceback" not in err and out == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_materials_plot_model_and_the_models_tg(capsys, tmp_path):
    png = tmp_path / "model.png"
    code, out, err = run(capsys, "materials", "--plot-model", str(png), "-t", "90", "--json")
    assert code == 0 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20000
    data = json.loads(out)
    h1 = next(r for r in data["materials"] if r["name"] == "H-1")
    from foldprint.model.materials import default_library
    from foldprint.physics.viscoelastic import viscoelastic
    v = viscoelastic(default_library()["H-1"])
    assert h1["tan_delta_peak_c"] == pytest.approx(v.tan_delta_peak_c, abs=1e-3)
    assert h1["shift_reference_c"] == 32.0 and (h1["glassy_mpa"], h1["rubbery_mpa"]) == (1500.0, 5.0)
    # the two differ for the shipped grades, and the listing says so
    assert data["notes"] and f"{v.tan_delta_peak_c - 32.0:+.1f} C" in data["notes"][0]


def test_materials_plot_model_refuses_a_format_before_writing(capsys, tmp_path):
    bad = tmp_path / "model.bmp"
    code, out, err = run(capsys, "materials", "--plot-model", str(bad))
    assert code == 2 and "--plot-model" in err and ".png" in err and not bad.exists()
