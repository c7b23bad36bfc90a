"""Progress on stderr (a long run says it is alive): what runs, done of total, a rate and the time left
(at most, for a sequential test, with "decided" once it stops); nothing with --json,
--quiet or when stderr is not a terminal."""

from __future__ import annotations

import io
import json
import sys
import time

import pytest

from foldprint.cli import printing, progress
from foldprint.cli.commands import main


class _TTY(io.StringIO):
    def isatty(self):
        return True


def test_stage_progress_shows_samples_rate_time_left_and_decided(monkeypatch):
    err = _TTY()
    monkeypatch.setattr(sys, "stderr", err)
    with progress.stage_progress("check demo: jam tests") as cb:
        cb("jam test at 1x", 16, 400)
        time.sleep(0.25)
        cb("jam test at 1x", 32, 400)
        time.sleep(0.25)
        cb("jam test at 2x", 16, 400)
        time.sleep(0.25)
        cb("jam test at 1x", 57, 57)  # decided at 57 of at most 400
        time.sleep(0.25)
    text = err.getvalue()
    for needle in ("check demo: jam tests", "jam test at 1x", "jam test at 2x", "57/400", "/s", "decided",
                   "at most 0:"):
        assert needle in text, needle


@pytest.mark.parametrize("silent,quiet,tty", [(True, False, True), (False, True, True), (False, False, False)])
def test_progress_is_silent_for_json_quiet_or_a_pipe(monkeypatch, silent, quiet, tty):
    monkeypatch.setattr(sys, "stderr", _TTY() if tty else io.StringIO())
    monkeypatch.setitem(printing.OUTPUT_STATE, "quiet", quiet)
    with progress.stage_progress("x", silent) as a, progress.samples_progress("y", silent) as b:
        assert a is None and b is None


def test_check_reports_its_jam_tests_on_a_terminal(monkeypatch, capsys):
    """A real check on a terminal: the stages appear with "decided"; with --json stdout
    holds the JSON alone and stderr no progress."""
    err = _TTY()
    monkeypatch.setattr(sys, "stderr", err)
    assert main(["check", "helix_uniform"]) == 1
    text = err.getvalue()
    assert "check helix_uniform" in text and "jam test at 1x" in text and "jam test at 0.5x" in text
    assert "decided" in text
    capsys.readouterr()
    err.truncate(0)
    err.seek(0)
    assert main(["check", "helix_uniform", "--json", "--no-sensitivity"]) == 1
    out = capsys.readouterr().out
    assert json.loads(out)["robust"]["test"]["verdict"] == "error"
    assert "jam test" not in err.getvalue()
