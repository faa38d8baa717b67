"""The layers of pyproject.toml's import contract hold: every module imports only from the layers
below its own, so a change that imports upward fails here (shown on a copy of the tree)."""
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).parents[1]
LINT = ["-c", "import sys; from importlinter.cli import lint_imports; sys.exit(lint_imports(no_cache=True, no_logo=True))"]


def lint(tree: Path) -> subprocess.CompletedProcess:
    """``lint-imports`` on the ``nsp`` package under ``tree``, with this checkout's contract."""
    return subprocess.run([sys.executable, *LINT], cwd=ROOT, env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin"},
                          capture_output=True, text=True, timeout=120)


def test_every_module_imports_only_from_the_layers_below_it():
    done = lint(ROOT / "src")
    assert done.returncode == 0 and "1 kept, 0 broken" in done.stdout, done.stdout + done.stderr


def test_an_upward_import_breaks_the_contract(tmp_path):
    shutil.copytree(ROOT / "src" / "nsp", tmp_path / "nsp", ignore=shutil.ignore_patterns("__pycache__", "conf"))
    brush = tmp_path / "nsp" / "brushes" / "base.py"
    brush.write_text(brush.read_text() + "\nfrom nsp.painter.renderer import AnalyticRenderer  # noqa: E402  (a brush reaching up)\n")
    done = lint(tmp_path)
    assert done.returncode == 1 and "nsp.brushes.base -> nsp.painter.renderer" in done.stdout, done.stdout + done.stderr
