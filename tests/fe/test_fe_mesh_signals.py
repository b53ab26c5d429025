"""Meshing with gmsh leaves the process's signals as Python set them."""

import subprocess
import sys

import pytest

pytest.importorskip("gmsh")

SCRIPT = """
import threading
from cyclomesh.fe.mesh import Refinement, mesh_disk

def ignored():
    for line in open("/proc/self/status"):
        if line.startswith("SigIgn"):
            return bool(int(line.split()[1], 16) & (1 << 12))  # SIGPIPE = 13

assert ignored()
refine = Refinement(
    points=[(0.0, 0.0)], h_fine=1e-3, fine_radius=1e-3, h_far=2e-3, grow_radius=3e-3
)
nodes, _ = mesh_disk((0.0, 0.0), 4e-3, refine)
assert nodes.shape[-1] > 10
assert ignored(), "main thread"
worker = threading.Thread(target=mesh_disk, args=((0.0, 0.0), 4e-3, refine))
worker.start(); worker.join()
assert ignored(), "thread"
print("ok")
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/status")
def test_meshing_keeps_sigpipe_ignored():
    """gmsh.initialize resets SIGPIPE to terminate the process; cyclomesh sets it back to
    ignored, so that a broken pipe (a killed pool worker) is BrokenPipeError, not death by
    signal (exit 141), in a process that has meshed (a fresh interpreter: the main thread
    and another one)."""
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "ok"
