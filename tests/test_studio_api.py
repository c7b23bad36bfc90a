"""``foldprint studio``'s API (docs/studio.md) through Starlette's TestClient, and once
through a live uvicorn started as ``foldprint studio``: every endpoint and every refusal
(no token, a wrong one, a foreign Origin, a Host that is not the loopback's, a save path
outside the studio's folder, a malformed edit), a concurrent edit where the newest wins,
and the jam verdict equal to ``foldprint check --json``'s."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx")
with warnings.catch_warnings():  # starlette >= 1.x would rather have httpx2 (the same API)
    warnings.simplefilter("ignore")
    from starlette.testclient import TestClient  # noqa: E402

from foldprint.apps.studio_inputs import resolve_inputs  # noqa: E402
from foldprint.io.load import load_design  # noqa: E402
from foldprint.studio.app import create_app  # noqa: E402

TOKEN = "test-token-not-secret"
PORT = 8765
BASE = f"http://127.0.0.1:{PORT}"
H = {"x-foldprint-token": TOKEN}


@pytest.fixture
def client(tmp_path):
    inputs = resolve_inputs("helix_uniform", out=tmp_path)
    with TestClient(create_app(inputs, TOKEN, PORT), base_url=BASE) as c:
        c.folder = tmp_path
        yield c


def _wait_verdict(c, revision: int, until=lambda v: v["sweep"]["state"] == "done", timeout: float = 120.0) -> dict:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        v = c.get("/api/verdict", headers=H).json()
        if v["state"] == "failed":
            raise AssertionError(v["error"])
        if v["design_revision"] == revision and until(v):
            return v
        time.sleep(0.2)
    raise AssertionError(f"no verdict for revision {revision} in {timeout} s: {v}")


# -- refusals ----------------------------------------------------------------------------

@pytest.mark.parametrize("path", ["/", "/api/design", "/static/studio.js", "/viewer/viewer.js", "/view",
                                  "/api/verdict"])
def test_every_path_wants_the_token(client, path):
    assert client.get(path).status_code == 403
    r = client.get(path, headers={"x-foldprint-token": "wrong"})
    assert r.status_code == 403 and "wrong token" in r.json()["error"]
    r = client.get(path, params={"token": TOKEN + "x"})
    assert r.status_code == 403


def test_foreign_origin_and_host_are_refused(client):
    assert client.get("/api/design", headers=H).status_code == 200
    for origin in ("http://evil.example", "null", f"http://127.0.0.1:{PORT + 1}"):
        r = client.patch("/api/design", headers={**H, "origin": origin}, json={"process": {"bath_c": 80}})
        assert r.status_code == 403 and "Origin" in r.json()["error"]
    r = client.get("/api/design", headers={**H, "origin": BASE})
    assert r.status_code == 200
    for host in ("evil.example", f"evil.example:{PORT}", f"127.0.0.1:{PORT + 1}", "127.0.0.1"):
        r = client.get("/api/design", headers={**H, "host": host})
        assert r.status_code == 403 and "Host" in r.json()["error"]
    for host in (f"localhost:{PORT}", f"[::1]:{PORT}"):
        assert client.get("/api/design", headers={**H, "host": host}).status_code == 200
    r = client.get("/api/design", headers={**H, "sec-fetch-site": "cross-site"})
    assert r.status_code == 403
    assert client.get("/favicon.ico").status_code == 204  # browsers ask on their own


def test_the_printed_url_sets_the_cookie_the_page_uses(client):
    r = client.get("/", params={"token": TOKEN}, follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/"
    cookie = r.headers["set-cookie"]
    assert f"foldprint_studio_{PORT}={TOKEN}" in cookie and "HttpOnly" in cookie and "SameSite=strict" in cookie
    page = client.get("/")  # the client keeps the cookie
    assert page.status_code == 200 and "helix_uniform" in page.text and "/static/studio.js" in page.text
    assert client.get("/static/studio.js").status_code == 200
    assert client.get("/static/../pyproject.toml").status_code in (403, 404)
    assert client.get("/static/secret.txt").status_code == 404
    assert client.get("/viewer/three-viewer.min.js").status_code == 200
    assert client.get("/viewer/..%2F..%2Fpyproject.toml").status_code == 404


def test_body_size_is_limited(client):
    big = b'{"hinges": {}, "x": "' + b"a" * (2 << 20) + b'"}'
    r = client.patch("/api/design", headers={**H, "content-type": "application/json"}, content=big)
    assert r.status_code == 413


# -- the design and its edits ---------------------------------------------------------------

def test_design_edit_undo_redo(client):
    d = client.get("/api/design", headers=H).json()
    assert [h["id"] for h in d["hinges"]] == [f"h{k}" for k in range(1, 10)]
    assert {h["material"] for h in d["hinges"]} == {"H-3"} and d["hinges"][0]["target_deg"] == pytest.approx(90)
    assert len(d["panels"]) == 10 and d["process"]["bath_c"] == 90 and d["revision"] == 1
    r = client.patch("/api/design", headers=H, json={"hinges": {"h3": {"material": "H-7", "target_deg": 80}},
                                                     "process": {"bath_c": 80}})
    assert r.status_code == 200, r.text
    n = r.json()
    assert n["revision"] == 2 and not n["superseded"]
    # simulate --json's keys and check --json's
    assert {"completed", "fold_time_s", "hinges", "contacts", "clearance", "findings", "errors"} <= set(n)
    h3 = next(h for h in n["hinges"] if h["id"] == "h3")
    assert h3["material"] == "H-7" and h3["target_angle_deg"] == pytest.approx(80)
    assert n["temperature_c"] == pytest.approx(80)
    assert all(f.keys() >= {"code", "severity", "message", "where"} for f in n["findings"])
    # the clearance curve's smallest value is not below the searched smallest clearance
    if n["clearance"] is not None:
        assert min(n["clearance_curve"]["distance_mm"]) >= n["clearance"]["distance_mm"] - 1e-6
    d2 = client.get("/api/design", headers=H).json()
    assert d2["hinges"][2]["material"] == "H-7" and d2["process"]["bath_c"] == 80 and d2["can_undo"]
    u = client.post("/api/undo", headers=H).json()
    assert u["revision"] == 3 and {h["material"] for h in u["hinges"]} == {"H-3"} and u["can_redo"]
    assert client.post("/api/redo", headers=H).json()["hinges"][2]["material"] == "H-7"
    r = client.post("/api/redo", headers=H)
    assert r.status_code == 400 and r.json()["error"] == "nothing to redo"


@pytest.mark.parametrize("body, words", [
    (b"{not json", ["not JSON"]),
    (b"[1, 2]", ["JSON object"]),
    (json.dumps({"hinges": {"h99": {"material": "H-2"}}}).encode(), ["h99", "no hinge"]),
    (json.dumps({"hinges": {"h1": {"material": "H-99"}}}).encode(), ["h1", "unknown material 'H-99'"]),
    (json.dumps({"hinges": {"h1": {"colour": "red"}}}).encode(), ["unknown key", "colour"]),
    (json.dumps({"process": {"bath_c": "hot"}}).encode(), ["process.bath_c", "must be a number"]),
    (json.dumps({"process": {"bath_c": 900}}).encode(), ["process.bath_c", "900"]),
    (json.dumps({"hinges": {"h1": {"target_deg": 270}}}).encode(), ["target_deg", "270"]),
    (json.dumps({"options": {"hinge_model": "bent"}}).encode(), ["hinge_model", "arc"]),
    (json.dumps({"options": {"printer": "nope"}}).encode(), ["printer", "nope"]),
    (json.dumps({"revision": 3}).encode(), ["unknown key", "revision"]),
])
def test_a_bad_edit_is_a_one_line_400_and_the_design_stays(client, body, words):
    before = client.get("/api/design", headers=H).json()
    r = client.patch("/api/design", headers={**H, "content-type": "application/json"}, content=body)
    assert r.status_code == 400
    msg = r.json()["error"]
    assert "\n" not in msg and all(w in msg for w in words), msg
    after = client.get("/api/design", headers=H).json()
    assert after == before


def test_a_missing_material_says_what_the_command_line_says(client, tmp_path):
    """The studio's message for an unknown material is the loader's for that design."""
    from foldprint.core.errors import FoldprintError
    from foldprint.io.templates import resolve_design_path
    from foldprint.model.materials import default_library

    from dataclasses import replace

    d = load_design(resolve_design_path("helix_uniform"), default_library())
    with pytest.raises(FoldprintError) as cli:
        d.replace(default_library(), hinges=(replace(d.hinges[0], material="H-99"), *d.hinges[1:]))
    r = client.patch("/api/design", headers=H, json={"hinges": {"h1": {"material": "H-99"}}})
    assert r.json()["error"] == str(cli.value)


def test_concurrent_edits_the_newest_wins(client):
    client.get("/api/nominal", headers=H)
    answers = {}

    def send(material):
        answers[material] = client.patch("/api/design", headers=H,
                                          json={"hinges": {"h1": {"material": material}}}).json()

    threads = [threading.Thread(target=send, args=(m,)) for m in ("H-5", "H-6", "H-7")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    newest = max(answers, key=lambda m: answers[m]["revision"])
    assert sorted(a["revision"] for a in answers.values()) == [2, 3, 4]
    assert all(a["superseded"] == (a["revision"] != 4) for a in answers.values())
    d = client.get("/api/design", headers=H).json()
    assert d["revision"] == 4 and d["hinges"][0]["material"] == newest
    v = client.get("/api/verdict", headers=H).json()
    assert v["design_revision"] == 4  # the stale runs were cancelled


def test_the_verdict_is_checks(client):
    """The decided verdict and the finished state equal ``foldprint check --json``."""
    from foldprint.cli.commands import main

    first = client.get("/api/verdict", headers=H).json()
    assert first["state"] == "running" and first["design_revision"] == 1
    v = _wait_verdict(client, 1)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["-q", "check", "helix_uniform", "--json"])
    check = json.loads(buf.getvalue())
    assert code == 1 and v["verdict"] == check["robust"]["test"]["verdict"] == "error"
    assert v["robust"] == check["robust"]
    assert v["samples"] == check["robust"]["samples"] and v["jams"] == check["robust"]["jams"]
    assert v["check"] == check
    # the player shows the worst scatter sample the test found
    page = client.get("/view", params={"worst": "1"}, headers=H).text
    assert '"worst":{' in page and "#run=worst" in page


def _running_ok(v: dict) -> bool:
    """A running state with samples: its estimate is jams/samples and lies in its interval,
    the confidence sequence check reports at its stop (here at the running count)."""
    from foldprint.simulation.jamtest.verdict import confidence_sequence

    if v["state"] != "running" or not v["samples"]:
        return False
    lo, hi = v["interval"]
    assert 0.0 <= lo <= v["estimate"] <= hi <= 1.0, v
    assert v["estimate"] == pytest.approx(v["jams"] / v["samples"])
    assert (lo, hi) == pytest.approx(confidence_sequence(v["jams"], v["samples"], v["level"]))
    assert hi < 1.0  # it narrows with the samples
    return True


def test_the_running_state_has_samples_estimate_and_interval(tmp_path):
    """Polled while helix_graded's test runs: running states with samples so far, the
    running estimate and its interval; then decided, with ``foldprint check --json``'s
    verdict, samples and interval."""
    from foldprint.cli.commands import main

    inputs = resolve_inputs("helix_graded", out=tmp_path)
    with TestClient(create_app(inputs, TOKEN, PORT), base_url=BASE) as c:
        seen, t0 = [], time.monotonic()
        while time.monotonic() - t0 < 120:
            v = c.get("/api/verdict", headers=H).json()
            assert v["state"] in ("running", "decided"), v
            seen.append(v)
            if v["state"] == "decided":
                break
            time.sleep(0.02)
    running = [v for v in seen if _running_ok(v)]
    assert running, [(v["state"], v["samples"]) for v in seen]
    samples = [v["samples"] for v in seen]
    assert samples == sorted(samples)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["-q", "check", "helix_graded", "--json"])
    check = json.loads(buf.getvalue())["robust"]
    d = seen[-1]
    assert code == 0 and d["state"] == "decided" and d["verdict"] == check["test"]["verdict"] == "pass"
    assert (d["samples"], d["jams"]) == (check["samples"], check["jams"]) and d["samples"] >= running[-1]["samples"]
    assert d["interval"] == pytest.approx(check["test"]["interval"], abs=1e-4) and d["test"] == check["test"]


# -- save, export, assign --------------------------------------------------------------------

@pytest.mark.parametrize("name", ["../out.toml", "/tmp/abs.toml", "sub/dir.toml", "..toml", ".hidden.toml",
                                  "x.txt", "", None, 3, "a\nb.toml"])
def test_save_refuses_names_outside_the_folder(client, name):
    r = client.post("/api/save", headers=H, json={"name": name})
    assert r.status_code == 400 and "\n" not in r.json()["error"]
    assert list(client.folder.iterdir()) == []


def test_save_writes_new_files_and_overwrites_only_when_confirmed(client, tmp_path):
    client.patch("/api/design", headers=H, json={"hinges": {"h2": {"material": "H-6"}}})
    r = client.post("/api/save", headers=H, json={"name": "mine.toml"})
    assert r.status_code == 200
    path = Path(r.json()["path"])
    assert path == client.folder / "mine.toml"
    saved = load_design(path)
    assert [h.material for h in saved.hinges] == ["H-3", "H-6"] + ["H-3"] * 7
    r = client.post("/api/save", headers=H, json={"name": "mine.toml"})
    assert r.status_code == 409 and "exists" in r.json()["error"]
    client.patch("/api/design", headers=H, json={"hinges": {"h2": {"material": "H-1"}}})
    assert client.post("/api/save", headers=H, json={"name": "mine.toml", "overwrite": True}).status_code == 200
    assert load_design(path).hinges[1].material == "H-1"
    outside = tmp_path.parent / f"{tmp_path.name}_outside.toml"
    outside.write_text("keep")
    os.symlink(outside, client.folder / "link.toml")
    r = client.post("/api/save", headers=H, json={"name": "link.toml", "overwrite": True})
    assert r.status_code == 400 and "symbolic link" in r.json()["error"] and outside.read_text() == "keep"
    assert sorted(p.name for p in client.folder.iterdir()) == ["link.toml", "mine.toml"]  # no temp file left


def test_export_writes_the_print_files_and_refuses_a_foreign_folder(client):
    r = client.post("/api/export", headers=H)
    assert r.status_code == 200, r.text
    out = Path(r.json()["out"])
    assert out == (client.folder / "helix_uniform").resolve()
    assert {Path(f["path"]).suffix for f in r.json()["files"]} >= {".3mf", ".stl", ".md"}
    assert all(Path(f["path"]).is_file() for f in r.json()["files"])
    foreign = client.folder / "helix_uniform"
    for f in foreign.iterdir():
        if f.is_file():
            f.unlink()
    (foreign / "thesis.docx").write_text("mine")
    r = client.post("/api/export", headers=H)
    assert r.status_code == 400, r.text
    msg = r.json()["error"]
    assert "\n" not in msg and "helix_uniform" in msg and "thesis.docx" in msg, msg
    assert (foreign / "thesis.docx").read_text() == "mine"


def test_assign_suggests_and_applies_a_choice(client):
    assert client.get("/api/assign", headers=H).json() == {"state": "none"}
    r = client.post("/api/assign", headers=H, json={"budget": 40, "top": 3})
    assert r.status_code == 202 and r.json()["state"] == "running"
    t0 = time.monotonic()
    while (a := client.get("/api/assign", headers=H).json())["state"] == "running":
        assert time.monotonic() - t0 < 120
        time.sleep(0.3)
    assert a["state"] == "done", a
    best = a["result"]["best"]
    assert best and len(best) <= 3
    n = client.post("/api/assign/apply", headers=H, json={"index": 0}).json()
    assert {h["id"]: h["material"] for h in n["hinges"]} == best[0]["assignment"]
    assert n["temperature_c"] == pytest.approx(best[0]["temperature_c"])
    assert client.post("/api/assign/apply", headers=H, json={"index": 99}).status_code == 400
    assert client.post("/api/assign", headers=H, json={"budget": 0}).status_code == 400


def test_the_player_page_is_the_viewer(client):
    r = client.get("/view", headers=H)
    assert r.status_code == 200 and 'id="fold-data"' in r.text and "../viewer/viewer.js" in r.text


def test_the_studio_imports_only_apps_and_core():
    sys.path.insert(0, str(Path(__file__).parent))
    from test_architecture import imports

    bad = [(a, b) for a, b in imports() if a.startswith("foldprint.studio.")
           and not b.startswith(("foldprint.apps.", "foldprint.core.", "foldprint.studio."))]
    assert not bad
    cli = [(a, b) for a, b in imports() if a.startswith("foldprint.cli.") and b.startswith("foldprint.studio")]
    assert not cli


# -- a live server -----------------------------------------------------------------------------

def test_bad_inputs_stop_the_command_with_one_line():
    import socket

    r = subprocess.run([sys.executable, "-m", "foldprint", "studio", "no_such_design", "--no-browser"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stdout == "" and "no_such_design" in r.stderr and len(r.stderr.splitlines()) == 1
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        r = subprocess.run([sys.executable, "-m", "foldprint", "studio", "helix_graded", "--no-browser", "--port",
                            str(port)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and f"--port {port}: the port is in use" in r.stderr and r.stdout == ""


def test_the_command_serves_over_http_and_stops_on_ctrl_c(tmp_path):
    import httpx

    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "foldprint", "studio", "helix_graded", "--no-browser", "--port", "0",
                             "--out", str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env)
    try:
        line = proc.stdout.readline()
        m = re.search(r"(http://127\.0\.0\.1:(\d+))/\?token=(\S+)", line)
        assert m, line + proc.stderr.read()
        base, token = m.group(1), m.group(3)
        assert httpx.get(f"{base}/api/design", timeout=30).status_code == 403
        d = httpx.get(f"{base}/api/design", headers={"x-foldprint-token": token}, timeout=30).json()
        assert d["name"] == "helix_graded"
        events = []
        with httpx.stream("GET", f"{base}/api/verdict/stream", params={"token": token}, timeout=30) as s:
            kind = None
            for raw in s.iter_lines():
                if raw.startswith("event: "):
                    kind = raw[7:]
                elif raw.startswith("data: "):
                    events.append((kind, json.loads(raw[6:])))
                    if kind == "verdict" and events[-1][1]["state"] == "decided":
                        break
        verdicts = [e for k, e in events if k == "verdict"]
        assert verdicts[0]["state"] == "running" and verdicts[-1]["verdict"] == "pass"
        assert any(_running_ok(v) for v in verdicts), verdicts  # the stream carries the running estimate
        samples = [v["samples"] for v in verdicts]
        assert samples == sorted(samples)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0
        assert "stopped" in proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_shutdown_stops_the_running_verdict(tmp_path):
    """Leaving the server while helix_graded's jam test runs cancels the run and waits for
    its thread: after shutdown nothing of the studio keeps folding samples."""
    inputs = resolve_inputs("helix_graded", out=tmp_path)
    guarded = create_app(inputs, TOKEN, PORT)
    studio = guarded.app.state.studio
    with TestClient(guarded, base_url=BASE) as c:
        t0 = time.monotonic()
        while c.get("/api/verdict", headers=H).json()["state"] != "running" and time.monotonic() - t0 < 60:
            time.sleep(0.02)
        job = studio.verdict
        assert job is not None and job.read()["state"] == "running"
    assert not job.thread.is_alive()
    assert job.read()["state"] in ("cancelled", "decided")
