"""Model tests run single-threaded: the graphs are tiny, and ``make test`` already runs two
pytest workers on two cores — intra-op threads on top only oversubscribe (10-50x slower
when the machine is busy)."""

from __future__ import annotations

import pytest
import torch


@pytest.fixture(autouse=True)
def one_torch_thread():
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)
