"""Running the docs' tutorials (docs/tutorials/*.py, Jupytext percent files) as notebooks:
each is read by jupytext and executed top to bottom by nbclient in a fresh IPython kernel,
with TUMBLE_DOCS_QUICK=1 (the short version), as a reader's Jupyter would run it."""
import os
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TUTORIALS = ROOT / "docs" / "tutorials"


def tutorial_paths():
    return sorted(TUTORIALS.glob("t[0-9][0-9]_*.py"))


def run_tutorial(name, timeout=1800):
    """Execute docs/tutorials/<name>.py as a notebook; returns the executed notebook.
    A cell that raises (an ``assert`` of a physics claim included) fails the run with
    nbclient's CellExecutionError, which names the cell and shows the traceback.
    ``timeout`` is per cell: generous, since on a cold Numba cache the first cell that steps
    a world compiles the step (minutes)."""
    import jupytext
    from nbclient import NotebookClient

    nb = jupytext.read(TUTORIALS / f"{name}.py")
    env = dict(TUMBLE_DOCS_QUICK="1", MPLBACKEND="module://matplotlib_inline.backend_inline")
    old = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        NotebookClient(nb, timeout=timeout, kernel_name="python3",
                       resources={"metadata": {"path": str(TUTORIALS)}}).execute()
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return nb


def stdout(nb):
    """Everything the notebook's cells printed, in order."""
    out = []
    for cell in nb.cells:
        for o in cell.get("outputs", []):
            if o.get("output_type") == "stream" and o.get("name") == "stdout":
                out.append(o["text"])
    return "".join(out)


def outputs_of_type(nb, mime):
    """The outputs (display data and results) carrying ``mime``, in order."""
    return [o["data"][mime] for cell in nb.cells for o in cell.get("outputs", [])
            if o.get("output_type") in ("display_data", "execute_result")
            and mime in o.get("data", {})]


def number(text, pattern):
    """The number a regular expression's first group matches in ``text`` (the first match)."""
    m = re.search(pattern, text)
    assert m, f"no match for {pattern!r} in the output:\n{text}"
    return float(m.group(1))
