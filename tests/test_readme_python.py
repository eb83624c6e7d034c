"""The Python blocks of the front page and of the getting-started page run as written.

- docs/getting-started.md, "A push from Python": a simulation, a figure from the result and the
  files of `biped push` (checked: the figure exists, the summary's hit time is the one the block
  prints, the CSV has the columns the page names);
- docs/getting-started.md, "The controller from Python": it prints what it says (run as a script,
  it shows the torques and the legs' shares summing to the desired wrench);
- README.md, "From Python": prints the hit time and writes the run's files.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GETTING_STARTED = ROOT / "docs" / "getting-started.md"


def _block(page: Path = GETTING_STARTED, heading: str = "## A push from Python") -> str:
    text = page.read_text(encoding="utf-8")
    section = text.split(heading, 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.DOTALL).group(1)


def _run(code: str, name: str) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, name, "exec"), {"__name__": "readme"})  # noqa: S102
    return out.getvalue()


@pytest.mark.slow
def test_readme_python_section_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    printed = _run(_block(), "getting-started.md")
    assert (tmp_path / "grf.png").stat().st_size > 1000
    run = tmp_path / "runs" / "from-python"
    summary = json.loads((run / "summary.json").read_text())
    assert f"{summary['block_contact_time_s']}" in printed
    assert "0.082" in printed  # the page's comment
    with open(run / "trajectory.csv") as f:
        head = next(csv.reader(f))
    for col in (
        "left_grf_x",
        "left_grf_y",
        "left_grf_z",
        "left_cop_x",
        "left_cop_y",
        "right_grf_z",
        "right_cop_y",
        "whole_body_com_z",
        "central_body_com_z",
    ):
        assert col in head


@pytest.mark.slow
def test_controller_block_prints_what_it_says(monkeypatch, tmp_path):
    import numpy as np

    monkeypatch.chdir(tmp_path)
    lines = _run(_block(heading="## The controller from Python"), "getting-started.md").splitlines()
    assert len(lines) == 4, lines
    assert lines[0].startswith("{'left_") and lines[0].count(":") == 12  # 12 joints by name
    assert lines[1] == "(6, 6) (6,)"
    desired, shares = (np.array(json.loads(line)) for line in lines[2:4])
    assert desired.shape == shares.shape == (6,) and np.abs(desired).max() > 100  # N, N m
    np.testing.assert_allclose(shares, desired, atol=0.011)  # both rounded to 0.01


@pytest.mark.slow
def test_readme_block_runs(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    printed = _run(_block(README, "## From Python"), "README.md")
    summary = json.loads((tmp_path / "runs" / "from-python" / "summary.json").read_text())
    assert printed.strip() == f"{summary['block_contact_time_s']}" and "0.082" in printed
    assert (tmp_path / "runs" / "from-python" / "trajectory.csv").is_file()
