"""Compiled kernels work on a fresh machine and where nothing can be cached.

The generated chain kernels are written into a cache directory that a new user does not
have yet (``~/.cache/mtmetrology/kernels``), and numba's own ``cache=True`` looks for a
writable place when a kernel is decorated.  Each case runs in a fresh interpreter with its
own environment: a cache directory that does not exist yet (created, parents included),
and a home directory and cache variables pointing at a plain file, under which nothing can
be created even as root (the kernels are compiled in memory, silently).  In every case the
compiled results equal the numpy backend's.
"""

import json
import os
import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("numba")

# Forces the generated chain kernel (a CMM: the smallest program), the interpreted
# Jacobian kernel and the batched sphere-fit kernel; prints their largest differences
# from the numpy backend and whether the generated kernel was imported from the cache.
SCRIPT = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    if "--no-numba-cache" in sys.argv:
        # numba finds no writable cache location at all (read-only install and home):
        # its decorator raises "cannot cache function ...: no locator available".
        from numba.core import caching
        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
        impl._locator_classes = []
    from mtmetrology.kinematics import Machine
    from mtmetrology.kinematics import chain
    from mtmetrology.fitting import batch

    m = Machine.load("cmm-moving-bridge")
    rng = np.random.default_rng(1)
    lo = np.array([m.axes[a].travel[0] for a in m.axis_names])
    hi = np.array([m.axes[a].travel[1] for a in m.axis_names])
    q = lo + (hi - lo) * rng.random((40, m.n_axes))
    theta = 50.0 * rng.standard_normal((64, 1, m.n_params)) * m.parameter_scales
    m.chain.compiled_min_pairs = 0
    m.chain.compiled_min_trials = 1
    m.chain.generated_min_pairs = 0
    chain.BACKEND = "numba"
    generated = m.evaluate(q, theta).position
    jac = m.evaluate(q, theta, d_params=True).d_params
    chain.BACKEND = "numpy"
    ref = m.evaluate(q, theta)
    ref_jac = m.evaluate(q, theta, d_params=True).d_params

    centre = rng.normal(size=(3000, 1, 3))
    u = rng.normal(size=(3000, 25, 3))
    pts = centre + 10.0 * u / np.linalg.norm(u, axis=-1, keepdims=True)
    pts += 1e-3 * rng.normal(size=pts.shape)
    batch.BACKEND = "numba"
    fit_compiled = batch.fit_spheres(pts).radii
    batch.BACKEND = "numpy"
    fit_numpy = batch.fit_spheres(pts).radii
    print(json.dumps({
        "position": float(np.abs(generated - ref.position).max()),
        "jacobian": float(np.abs(jac - ref_jac).max()),
        "radius": float(np.abs(fit_compiled - fit_numpy).max()),
        "from_cache": any(k.startswith("_mtmetrology_chain_") for k in sys.modules),
    }))
    """
)


def run_fresh(env_overrides: dict[str, str], *args: str) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "XDG_"))}
    env.pop("MTMETROLOGY_CACHE_DIR", None)
    env.update(env_overrides)
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stderr == "", done.stderr[-2000:]  # silent for the user
    return json.loads(done.stdout)


def assert_agree(result: dict) -> None:
    assert result["position"] < 1e-9
    assert result["jacobian"] < 1e-12
    assert result["radius"] < 1e-9


def test_a_missing_cache_directory_is_created(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    result = run_fresh({"HOME": str(home)})
    assert_agree(result)
    assert result["from_cache"]
    kernels = list((home / ".cache" / "mtmetrology" / "kernels").glob("chain_*.py"))
    assert len(kernels) == 1


def test_the_cache_directory_variables_are_honoured(tmp_path):
    result = run_fresh(
        {
            "HOME": str(tmp_path),
            "XDG_CACHE_HOME": str(tmp_path / "xdg" / "deeper"),
        }
    )
    assert_agree(result)
    kernels = tmp_path / "xdg" / "deeper" / "mtmetrology" / "kernels"
    assert len(list(kernels.glob("chain_*.py"))) == 1
    explicit = tmp_path / "explicit" / "cache"
    result = run_fresh({"HOME": str(tmp_path), "MTMETROLOGY_CACHE_DIR": str(explicit)})
    assert len(list((explicit / "kernels").glob("chain_*.py"))) == 1


@pytest.mark.parametrize("numba_cache", [True, False], ids=["numba-in-tree", "numba-nowhere"])
def test_nothing_writable_compiles_in_memory(tmp_path, numba_cache):
    """HOME and every cache variable at a plain file: nothing can be created under it."""
    plain = tmp_path / "a-file"
    plain.write_text("not a directory\n")
    env = {
        "HOME": str(plain),
        "XDG_CACHE_HOME": str(plain),
        "MTMETROLOGY_CACHE_DIR": str(plain),
        "NUMBA_CACHE_DIR": str(plain),
    }
    result = run_fresh(env, *([] if numba_cache else ["--no-numba-cache"]))
    assert_agree(result)
    assert not result["from_cache"]
    assert plain.read_text() == "not a directory\n"
