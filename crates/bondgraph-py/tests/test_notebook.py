"""The notebook in docs/ runs from top to bottom and finds the fault it simulates."""

import re

import pytest

from conftest import ROOT


def test_the_tour_notebook_runs_and_names_the_dead_zone():
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("matplotlib")
    notebook = nbformat.read(ROOT / "docs" / "python_tour.ipynb", as_version=4)
    client = nbclient.NotebookClient(
        notebook, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(ROOT / "docs")}}
    )
    client.execute()
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    text = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    # The dead zone triples at 10 s; the estimates read up to half a window (250 samples)
    # ahead.
    first = float(re.search(r"first alarm at t = ([0-9.]+) s", text).group(1))
    assert 9.75 <= first < 10.5, text
    assert "candidates: link w" in text, text
    shown = [o["data"] for o in outputs if o.output_type in ("execute_result", "display_data")]
    assert any("text/html" in d and "<table>" in d["text/html"] for d in shown), "the model's FSM"
    assert any("image/png" in d for d in shown), "the residuals' plot"
