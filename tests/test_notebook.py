"""The beam-slider notebook (issue 23) runs from build to figures in a Jupyter kernel."""

import shutil
from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "beam_slider" / "beam_slider.ipynb"


def test_the_beam_slider_notebook_executes_and_draws_its_figures(tmp_path):
    shutil.copy(NOTEBOOK, tmp_path)
    nb = nbformat.read(tmp_path / NOTEBOOK.name, as_version=4)
    # Raises CellExecutionError (with the cell and its traceback) if any cell fails.
    NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()
    outputs = [o for cell in nb.cells if cell.cell_type == "code" for o in cell.outputs]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 2  # the loads and the energy books
    # The model and the dataset show themselves.
    texts = " ".join(o.get("data", {}).get("text/plain", "") for o in outputs)
    assert "flexdyn.Model `beam slider`" in texts and "xarray.Dataset" in texts
    assert (tmp_path / "beam_slider.nc").is_file()
