"""nsp as users install it: a wheel, pip-installed into a fresh venv, not this checkout. Its
commands run from any folder."""
import json
import subprocess
import sys
import sysconfig
from pathlib import Path

ROOT = Path(__file__).parents[1]


def test_a_wheel_carries_its_configs_and_its_commands_run_outside_the_checkout(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", str(ROOT),
                    "-w", str(tmp_path / "wheel")], check=True, capture_output=True, cwd=tmp_path)
    wheel = next((tmp_path / "wheel").glob("nsp-*.whl"))
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, capture_output=True)
    python = venv / "bin" / "python"
    site = Path(subprocess.run([python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                               check=True, capture_output=True, text=True).stdout.strip())
    # The dependencies (torch, Lightning, Hydra …) are this environment's, offline: its site-packages
    # joins the path as a plain dir, so this checkout's editable install (a hook in a .pth) stays out.
    (site / "dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    subprocess.run([python, "-m", "pip", "install", "-q", "--no-deps", str(wheel)], check=True, capture_output=True)

    def run(*args: str) -> str:
        done = subprocess.run([python, *args], cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        return done.stdout

    assert run("-c", "import nsp; print(nsp.__file__)").startswith(str(site))
    run("-m", "nsp.paint", "strokes=6", "work_size=32", "render_size=64", "animation_size=32", "progress=false",
        "hydra.run.dir=painting")
    run("-m", "nsp.render", "strokes=painting/strokes.json", "size=48", "out=again.png")
    run("-m", "nsp.train", "renderer=dcgan", "brush=tape", "model.size=32", "model.channel_mult=0.125", "data.batch_size=8",
        "data.epoch_size=16", "data.val_size=8", "data.test_size=8", "data.num_workers=0", "trainer.max_steps=2",
        "trainer.enable_progress_bar=false", "hydra.run.dir=training")
    run("-m", "nsp.report", "training")
    assert run("-m", "nsp.app", "--help").startswith("usage: python -m nsp.app")  # its config in the wheel too
    assert json.loads((tmp_path / "painting" / "metrics.json").read_text())["strokes"] == 6
    assert (tmp_path / "again.png").is_file() and (tmp_path / "training" / "report.md").is_file()
    assert json.loads((tmp_path / "training" / "metrics.json").read_text())["status"] == "completed"
