"""vrlab._alloc: freed ray temporaries are reused instead of page-faulted in again."""
import subprocess
import sys

import pytest

CODE = r"""
import resource, sys
import numpy as np
if sys.argv[1] == "tuned":
    from vrlab._alloc import keep_freed_memory
    assert keep_freed_memory() and keep_freed_memory()      # applied, idempotent
a = np.ones(1 << 17)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(20):              # a block of rays: 24 live 1 MB temporaries, then all freed
    tmp = [a * k for k in range(24)]
    del tmp
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", CODE, mode], capture_output=True, text=True, check=True)
    return int(out.stdout.split()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc mallopt")
def test_freed_temporaries_are_reused():
    # 20 blocks x 24 MB: glibc's default trims the freed heap top and faults about 24 MB
    # (6000 pages) in again per block; tuned, the first block's pages are reused
    tuned = _faults("tuned")
    assert tuned < 10_000
    assert _faults("default") > 5 * tuned


NO_SIDE_EFFECT = r"""
import vrlab._alloc as alloc
from vrlab.render import render
render("furnace", 2, width=8, height=6, workers=1, rng=0)
print(alloc._done)
"""


def test_render_leaves_the_calling_process_allocator_alone():
    """render() in a user's process (workers=1) does not retune its allocator; only vrlab's
    own processes (the CLI, render's workers) do."""
    out = subprocess.run([sys.executable, "-c", NO_SIDE_EFFECT], capture_output=True, text=True, check=True)
    assert out.stdout.split()[-1] == "False"
