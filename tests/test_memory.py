"""The loop's heap reserved before it starts (experiment/memory.py)."""

import subprocess
import sys

import pytest

from harmony_cli.experiment.memory import _glibc

ALLOCATE = """
import resource, sys
import numpy as np
from harmony_cli.experiment.memory import reserve_heap
if sys.argv[1] == "reserved":
    assert reserve_heap()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
kept = [np.ones(2**17) for _ in range(40)]  # 40 MB in 1 MB blocks, touched: the heap grows by that much
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(how: str) -> int:
    out = subprocess.run([sys.executable, "-c", ALLOCATE, how], capture_output=True, text=True, check=True)
    return int(out.stdout.split()[-1])


@pytest.mark.skipif(_glibc() is None, reason="the heap reserve needs glibc's allocator")
def test_memory_taken_within_the_reserve_maps_no_fresh_pages():
    plain, reserved = _faults("plain"), _faults("reserved")
    assert plain > 40 * 200  # fresh pages, a fault per 4 kB page (fewer where the kernel maps huge pages)
    assert reserved < plain / 100
