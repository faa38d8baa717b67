"""The docs site builds strictly (a broken link, a missing page or an API name that no longer exists
fails), offline, with the API reference generated from the docstrings."""
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).parents[1]


def test_the_docs_site_builds_strictly_with_the_api_reference(tmp_path):
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300, env=dict(os.environ, NO_MKDOCS_2_WARNING="1"))
    assert done.returncode == 0, done.stderr[-3000:]
    api = (tmp_path / "api" / "index.html").read_text()
    assert "nsp.api.paint" in api and "Painting" in api and "render" in api
    assert (tmp_path / "img" / "demo.png").is_file()
