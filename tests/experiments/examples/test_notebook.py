"""experiments/examples/study.ipynb runs top to bottom (nbclient, a fresh kernel) on a tiny study:
its tables have the rows the study defines and the figure is drawn."""
import json
from pathlib import Path

import pytest

from repo_paths import REPO

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

NOTEBOOK = REPO / "experiments" / "examples" / "study.ipynb"
TINY = ('{"resolution": [12, 9], "spp": [1, 4], "samples_per_cell": 8, "gt_spp": 256, '
        '"gt_batch_spp": 64}')


def test_notebook_runs_on_a_tiny_study(tmp_path):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    setup = nb.cells[1]
    assert "SIZE = " in setup.source and "OUT = " in setup.source
    # The same notebook, made tiny: only its settings cell changes.
    setup.source = (f'from pathlib import Path\nimport drtlab\nOUT = Path({str(tmp_path / "out")!r})\n'
                    f'SIZE = {TINY}')
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert not errors, errors
    tables = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "execute_result" and "text/html" in o.get("data", {})]
    assert len(tables) == 3                     # cells, slopes, per-cell runs summary
    cells_html = tables[0]["data"]["text/html"]
    body = cells_html.split("<tbody>")[1]
    assert body.count("<tr>") == 2 * 2 * 2                  # scenes x samplers x spp
    images = [o for c in nb.cells for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
    assert images, "the convergence figure is shown"
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["experiment"] == "example-notebook"
