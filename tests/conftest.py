import os

import pytest
import torch

# Tests share two cores with each other (pytest -n 2): one thread each, the commands they start too.
torch.set_num_threads(1)
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("HYDRA_FULL_ERROR", "0")


@pytest.fixture
def generator():
    return torch.Generator().manual_seed(0)
