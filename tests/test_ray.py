"""`--executor ray`: the same generation as Ray tasks, on a local 2-CPU Ray instance."""

from __future__ import annotations

from pathlib import Path

import pytest

ray = pytest.importorskip("ray", reason="Ray is an optional extra: pip install 'dresslog[ray]'")

from dresslog.dataset import generate, load_manifest  # noqa: E402


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.mark.slow
def test_ray_generation_matches_the_process_pool(local_ray, tmp_path: Path) -> None:
    options = {"workers": 2, "test_fraction": 0.5, "overrides": {"duration": 0.3}}
    on_ray = generate("gown", 2, tmp_path / "ray", executor="ray", progress=False, **options)
    assert on_ray.complete and not on_ray.failures
    assert [e.file for e in load_manifest(tmp_path / "ray").trials] == [
        "test/000000.mcap",
        "train/000000.mcap",
    ]
    local = generate("gown", 2, tmp_path / "local", progress=False, **options)
    assert on_ray.content_hash() == local.content_hash()  # same seeds, same bytes
    assert ray.is_initialized()  # a cluster the caller started is left running
