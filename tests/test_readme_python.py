"""The README's "A push from Python" block runs as written: a simulation, a figure from the
result and the files of `biped push` (checked: the figure exists, the summary's hit time is the
one the block prints, the CSV has the columns the README names)."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _block() -> str:
    text = README.read_text(encoding="utf-8")
    section = text.split("## A push from Python", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.DOTALL).group(1)


@pytest.mark.slow
def test_readme_python_section_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(_block(), "README.md", "exec"), {"__name__": "readme"})  # noqa: S102
    assert (tmp_path / "grf.png").stat().st_size > 1000
    run = tmp_path / "runs" / "from-python"
    summary = json.loads((run / "summary.json").read_text())
    assert f"{summary['block_contact_time_s']}" in out.getvalue()
    assert "0.082" in out.getvalue()  # the README's comment
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
