import os
import subprocess

import pytest
import torch

# Tests share two cores with each other (pytest -n 2): one thread each, the commands they start too.
torch.set_num_threads(1)
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("HYDRA_FULL_ERROR", "0")


@pytest.fixture
def generator():
    return torch.Generator().manual_seed(0)


@pytest.fixture
def tmpfs(tmp_path):
    """A 3-MB filesystem of its own, where this machine lets the tests mount one (a disk to fill)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(disk)], capture_output=True).returncode:
        pytest.skip("this machine does not let the tests mount a tmpfs; the mocked full disks stand in")
    yield disk
    subprocess.run(["umount", "--lazy", str(disk)], check=True)  # lazy: this process's log handlers still hold files
