"""Sweeps and optimisation with user hooks on Dask workers (mbs/studies/package.py), against the same law written
as a plain expression (library/examples/hook_friction.mbs, `plain = 1`): a C hook in the shipped binary, a
`module.py:function` imported by each worker, a lambda sent by value; a callable that cannot be pickled is a
usage error before any run, a hook that fails is its variant's message."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.cli import main
from mbs.runtime.build import have_c_compiler
from mbs.runtime.errors import UsageError
from mbs.runtime.hook_implementations import implementation
from mbs.studies import sweep
from mbs.studies.optimize import optimize

pytest.importorskip("distributed")
pytestmark = pytest.mark.skipif(not have_c_compiler(), reason="no C compiler")

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "library" / "examples" / "hook_friction.mbs"
C_LAW = str(ROOT / "library" / "examples" / "hooks" / "friction_law.c")
PY_LAW = f"{ROOT / 'library' / 'examples' / 'hooks' / 'friction_law.py'}:friction_law"
METRICS = ["peak(position)", "final(position)", "rms(friction_force)"]
SPEEDS = {"vb": [0.1, 0.2, 0.3]}


@pytest.fixture(scope="module")
def belt():
    return mbs.load(EXAMPLE)


@pytest.fixture(scope="module")
def plain(belt, dask_client):
    return sweep(belt, "cycles", SPEEDS, fixed={"plain": 1}, metrics=METRICS, t_end=1.0, client=dask_client,
                 hooks={"friction_law": C_LAW})


def law():
    return implementation("friction_law", PY_LAW)


@pytest.mark.parametrize("kind", ["c", "python file", "lambda"])
def test_a_sweep_through_a_hook_measures_what_the_plain_law_gives(belt, plain, dask_client, kind):
    fn = law()
    impl = {"c": C_LAW, "python file": fn, "lambda": lambda w, n, a, b: fn(w, n, a, b)}[kind]
    table = sweep(belt, "cycles", SPEEDS, metrics=METRICS, t_end=1.0, client=dask_client,
                  hooks={"friction_law": impl})
    assert [row.status for row in table.rows] == ["finished"] * 3
    for metric in METRICS:  # the same arithmetic on the same steps: equal to round-off
        np.testing.assert_allclose(table[metric], plain[metric], rtol=1e-12, atol=1e-15)
    assert np.ptp(table["peak(position)"]) > 1e-3  # the speeds do change the motion


def test_a_callable_that_cannot_be_pickled_is_refused_before_any_run(belt, dask_client):
    lock, fn = threading.Lock(), law()

    def locked(w, n, a, b):
        with lock:
            return fn(w, n, a, b)
    with pytest.raises(UsageError, match="hook 'friction_law': the Python callable cannot be sent to the Dask "
                                         "workers .*give 'module.py:function'"):
        sweep(belt, "cycles", SPEEDS, metrics=METRICS, client=dask_client, hooks={"friction_law": locked})


def test_a_hook_that_fails_on_a_worker_is_its_variants_message(belt, dask_client):
    fn = law()

    def slow_fails(w, n, mu_s, mu_k):
        if w < 0.05:
            raise ValueError("below the measured range")
        return fn(w, n, mu_s, mu_k)
    table = sweep(belt, "cycles", {"vb": [0.04, 0.2]}, metrics=METRICS, t_end=1.0, client=dask_client,
                  hooks={"friction_law": slow_fails})
    first, second = table.rows
    assert first.status == "failed" and "hook 'friction_law' failed at t = 0 s" in first.message
    assert "ValueError: below the measured range" in first.message
    assert second.status == "failed" and "results kept up to" in second.message  # it slows below 0.05 m/s later


def test_an_optimisation_through_a_hook_finds_the_plain_laws_optimum(belt, dask_client):
    options = dict(constraints=["peak(position) <= 0.06"], maxiter=3, popsize=4, seed=1, client=dask_client)
    hooked = optimize(belt, "cycles", "-final(position)", {"vb": (0.05, 0.4)}, hooks={"friction_law": law()},
                      **options)
    plain = optimize(belt, "cycles", "-final(position)", {"vb": (0.05, 0.4)}, fixed={"plain": 1},
                     hooks={"friction_law": C_LAW}, **options)
    assert hooked.evaluations == plain.evaluations
    assert hooked.x["vb"] == pytest.approx(plain.x["vb"], rel=1e-12)
    assert hooked.value == pytest.approx(plain.value, rel=1e-10)


def test_mbs_sweep_takes_a_python_hook_file(dask_client, tmp_path, capsys):
    csv = tmp_path / "t.csv"
    argv = ["sweep", str(EXAMPLE), "--param", "vb=0.1,0.3", "--metric", "peak(position)", "--t-end", "0.5",
            "--scheduler", dask_client.scheduler.address, "--out", str(csv)]
    assert main([*argv, "--hook", f"friction_law={PY_LAW}"]) == 0, capsys.readouterr().err
    hooked = csv.read_text()
    assert main([*argv, "--param", "plain=1", "--hook", f"friction_law={C_LAW}"]) == 0, capsys.readouterr().err
    def rows(text):
        lines = [line.split(",")[:2] for line in text.splitlines() if not line.startswith("#")]
        assert lines[0] == ["vb", "peak(position)"]
        return np.array(lines[1:], dtype=float)
    np.testing.assert_allclose(rows(hooked), rows(csv.read_text()), rtol=1e-12)  # round-off
    assert len(rows(hooked)) == 2
