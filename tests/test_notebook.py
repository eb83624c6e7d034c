"""examples/push_and_envelope.ipynb runs from top to bottom in a fresh kernel (nbclient), so the
notebook never goes stale; its printed results are checked against what the project measures."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

nbclient = pytest.importorskip("nbclient", reason="the test extra's nbclient is not installed")
nbformat = pytest.importorskip("nbformat")
pytest.importorskip("ipykernel")

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "push_and_envelope.ipynb"
SRC = str(Path(__file__).resolve().parents[1] / "src")


@pytest.mark.slow
def test_notebook_runs_and_says_what_it_claims(tmp_path, monkeypatch):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    # the kernel imports biped from this checkout, like the rest of the suite
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([SRC, os.environ.get("PYTHONPATH", "")]))
    nbclient.NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()
    text = "\n".join(
        out.get("text", "")
        for cell in nb.cells
        if cell.cell_type == "code"
        for out in cell.get("outputs", [])
    )
    assert "the block hits at 0.082 s" in text
    weight = float(text.split("the biped weighs ")[1].split(" N")[0])
    carried = float(text.split("both feet carry ")[1].split(" N")[0])
    assert abs(carried - weight) < 0.05 * weight  # at rest again, the feet carry its weight
    directions = [ln for ln in text.splitlines() if ln.startswith("direction ")]
    assert len(directions) == 8
    errors = [
        out for cell in nb.cells for out in cell.get("outputs", []) if out.get("output_type") == "error"
    ]
    assert not errors
