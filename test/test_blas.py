"""pmr_ros runs its small-matrix work on one BLAS thread unless the user chose (pmr_ros._blas)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

PROBE = """
import json, os, sys
{before}
import pmr_ros
from threadpoolctl import threadpool_info
import numpy
threads = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
print(json.dumps({{"env": os.environ.get("OPENBLAS_NUM_THREADS"), "threads": threads}}))
"""


def _probe(before: str, **env: str) -> dict:
    clean = {
        k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
    }
    out = subprocess.run(
        [sys.executable, "-c", PROBE.format(before=before)],
        env={**clean, **env},
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.parametrize("before", ["", "import numpy"], ids=["pmr_ros first", "numpy first"])
def test_importing_pmr_ros_leaves_one_blas_thread(before):
    seen = _probe(before)
    assert seen["env"] == "1" and seen["threads"] and set(seen["threads"]) == {1}


def test_a_users_choice_of_threads_is_kept():
    seen = _probe("", OPENBLAS_NUM_THREADS="2")
    assert seen["env"] == "2" and set(seen["threads"]) == {2}
