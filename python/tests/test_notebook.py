"""The notebook of docs/examples runs from top to bottom on the installed package."""

from __future__ import annotations

import nbclient
import nbformat

from conftest import REPO


def test_the_example_notebook_runs_from_top_to_bottom(tmp_path):
    path = REPO / "docs" / "examples" / "python.ipynb"
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()  # raises CellExecutionError on the first cell that fails
    printed = "".join(
        o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "stream"
    )
    assert "K =" in printed and "lambda1_per_s" in printed
    assert (tmp_path / "record.csv").is_file()
