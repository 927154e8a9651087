"""experiments/examples/study.ipynb runs top to bottom (nbclient, a fresh kernel) on a tiny study:
its tables have the rows the study defines, the figure is drawn, and its results go to the
repository's results/ even when Jupyter starts the kernel in the notebook's folder."""
import json
import re
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
    assert len(tables) == 4                     # cells, slopes, comparisons, runs of the reopened folder
    rows = [t["data"]["text/html"].split("<tbody>")[1].count("<tr>") for t in tables]
    assert rows == [2 * 2 * 2, 2 * 2, 2 * 1 * 2, 2 * 2 * 2]  # scenes x samplers (- baseline) x spp
    claims = re.findall(r"<td>([^<]*)</td>\s*</tr>", tables[2]["data"]["text/html"])  # last column
    assert len(claims) == 4 and set(claims) <= {"better", "worse", "no difference", "not resolved"}
    images = [o for c in nb.cells for o in c.get("outputs", []) if "image/png" in o.get("data", {})]
    assert images, "the convergence figure is shown"
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["experiment"] == "example-notebook"


def test_notebook_results_do_not_land_beside_it(monkeypatch):
    setup = nbformat.read(NOTEBOOK, as_version=4).cells[1]
    monkeypatch.chdir(NOTEBOOK.parent)              # where Jupyter starts the kernel
    monkeypatch.delenv("DRTLAB_RESULTS", raising=False)
    names: dict = {}
    exec(setup.source, names)
    assert names["OUT"] == REPO / "results" / "example-notebook"
