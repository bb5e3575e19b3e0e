"""Renders as seeded (tile, spp batch) units: resumable and extendable checkpoints that give the
uninterrupted render's bytes, and the same image on any executor (issue 14, renderer side)."""
from __future__ import annotations

import numpy as np
import pytest

from test_render import FLOOR, RECT_LIGHT, SPHERE_LIGHT, scene
from vrlab.render import render, render_gradient_domain

SC = scene(FLOOR + RECT_LIGHT + SPHERE_LIGHT, fov=60, width=40, height=30)     # 1200 px: 2 tiles


class Stop(Exception):
    pass


def _stop_after(calls: int):
    seen = []

    def progress(done, total):
        seen.append(done)
        if len(seen) == calls:
            raise Stop
    return progress


def test_interrupted_render_resumes_to_the_same_bytes(tmp_path):
    path = tmp_path / "ref.npz"
    full = render(SC, 96, "mis-power", rng=3, spp_batch=32)
    with pytest.raises(Stop):                       # killed in the middle of the second batch
        render(SC, 96, "mis-power", rng=3, spp_batch=32, checkpoint=path, progress=_stop_after(3))
    assert path.exists()
    resumed = render(SC, 96, "mis-power", rng=3, spp_batch=32, checkpoint=path)
    np.testing.assert_array_equal(resumed.value, full.value)
    np.testing.assert_array_equal(resumed.stderr, full.stderr)
    again = render(SC, 96, "mis-power", rng=3, spp_batch=32, checkpoint=path)     # finished: nothing to do
    np.testing.assert_array_equal(again.value, full.value)


@pytest.mark.parametrize("estimator", ["mis-power", "cv"])
def test_a_larger_spp_extends_a_finished_checkpoint(tmp_path, estimator):
    from vrlab.estimators import ControlVariate

    est = estimator if estimator == "mis-power" else ControlVariate("lambertian", distribution="light")
    path = tmp_path / "ext.npz"
    render(SC, 64, est, rng=4, spp_batch=32, checkpoint=path)
    extended = render(SC, 128, est, rng=4, spp_batch=32, checkpoint=path)
    direct = render(SC, 128, est, rng=4, spp_batch=32)
    np.testing.assert_array_equal(extended.value, direct.value)
    np.testing.assert_array_equal(extended.stderr, direct.stderr)
    # batches are the units: one batch of 128 is another (equally valid) image
    assert not np.array_equal(render(SC, 128, est, rng=4, spp_batch=128).value, direct.value)


def test_checkpoints_of_other_renders_are_refused(tmp_path, raises_naming):
    path = tmp_path / "a.npz"
    render(SC, 40, "mis-power", rng=1, spp_batch=32, checkpoint=path)          # 32 + a partial batch of 8
    with raises_naming(ValueError, "checkpoint"):
        render(SC, 40, "mis-power", rng=2, spp_batch=32, checkpoint=path)      # another seed
    with raises_naming(ValueError, "checkpoint"):
        render(SC, 40, "light", rng=1, spp_batch=32, checkpoint=path)          # another estimator
    with raises_naming(ValueError, "checkpoint"):
        render(SC, 40, "mis-power", rng=1, spp_batch=16, checkpoint=path)      # another batch size
    with raises_naming(ValueError, "checkpoint"):
        render(SC, 64, "mis-power", rng=1, spp_batch=32, checkpoint=path)      # a partial last batch
    with raises_naming(ValueError, "checkpoint"):
        render(SC, 16, "mis-power", rng=1, spp_batch=32, checkpoint=path)      # fewer samples than stored
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a checkpoint")
    with raises_naming(ValueError, "checkpoint"):
        render(SC, 4, checkpoint=bad)
    with raises_naming(ValueError, "checkpoint"):
        render(SC, 4, checkpoint=tmp_path / "x.png")
    with raises_naming(ValueError, "spp_batch"):
        render(SC, 4, spp_batch=0)


def test_gradient_domain_checkpoints_resume(tmp_path):
    path = tmp_path / "gd.npz"
    full = render_gradient_domain(SC, 64, rng=5, spp_batch=16)
    with pytest.raises(Stop):
        render_gradient_domain(SC, 64, rng=5, spp_batch=16, checkpoint=path, progress=_stop_after(5))
    resumed = render_gradient_domain(SC, 64, rng=5, spp_batch=16, checkpoint=path)
    for a, b in ((full.primal, resumed.primal), (full.dx, resumed.dx), (full.dy, resumed.dy)):
        np.testing.assert_array_equal(a.value, b.value)
    with pytest.raises(ValueError, match="checkpoint"):     # a render's checkpoint is not a gradient render's
        render(SC, 64, rng=5, spp_batch=16, checkpoint=path)


def test_dask_local_cluster_gives_the_same_image():
    distributed = pytest.importorskip("distributed")
    one = render(SC, 8, "mis-power", rng=6)
    two = render(SC, 8, "mis-power", rng=6, workers=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        dask = render(SC, 8, "mis-power", rng=6, executor=client, workers=2)
    for other in (two, dask):
        np.testing.assert_array_equal(one.value, other.value)
        np.testing.assert_array_equal(one.stderr, other.stderr)


def test_a_killed_render_command_resumes_to_the_same_image(tmp_path):
    """``vrlab render --checkpoint``: SIGKILL the process once a batch is saved, rerun the same
    command, and the image is the uninterrupted render's, byte for byte."""
    import signal
    import subprocess
    import sys
    import time

    ckpt, out = tmp_path / "c.npz", tmp_path / "img.npy"
    cmd = [sys.executable, "-m", "vrlab", "render", "cornell_box", "--spp", "192", "--spp-batch", "8",
           "--width", "64", "--height", "64", "--workers", "1", "--checkpoint", str(ckpt), "-o", str(out),
           "--no-progress"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not ckpt.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL and ckpt.exists() and not out.exists()
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    full = render("cornell_box", 192, "mis-power", rng=0, spp_batch=8, width=64, height=64)
    np.testing.assert_array_equal(np.load(out), full.value)


def test_a_resumed_cli_render_counts_only_its_new_samples(capsys, tmp_path):
    """``vrlab render --checkpoint``: extending 2 stored spp to 6 reports spp_resumed = 2 and a
    samples_per_second of the 4 new spp only (x seconds = pixels x 4, not pixels x 6)."""
    import json

    from conftest import run_cli

    ckpt = tmp_path / "c.npz"
    cmd = ["render", "furnace", "--width", "8", "--height", "6", "--workers", "1", "--no-progress", "--spp-batch",
           "1", "--checkpoint", str(ckpt), "--json"]
    code, out, _ = run_cli(capsys, cmd + ["--spp", "2"])
    first = json.loads(out)
    assert code == 0 and first["spp_resumed"] == 0
    assert first["samples_per_second"] * first["seconds"] == pytest.approx(48 * 2, rel=1e-9)
    code, out, err = run_cli(capsys, cmd + ["--spp", "6"])
    res = json.loads(out)
    assert code == 0 and res["spp_resumed"] == 2 and "2 of 6 spp were read" in err
    assert res["samples_per_second"] * res["seconds"] == pytest.approx(48 * 4, rel=1e-9)
