"""The choice between the compiled kernels and their numpy versions (:mod:`drake_sot.kernels`)."""

import os
import subprocess
import sys

import pytest

from drake_sot import kernels

CODE = "from drake_sot import kernels; print(kernels.BACKEND)"


def _run(code: str, **env: str) -> subprocess.CompletedProcess:
    environment = {k: v for k, v in os.environ.items() if k != kernels.ENVIRONMENT}
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env={**environment, **env}
    )


def test_the_suite_runs_on_the_compiled_kernels_unless_numpy_is_asked_for():
    # make test builds them (pip install -e .): a build that failed is a failure here, not a quiet
    # fallback, so that CI tests what users get.
    if os.environ.get(kernels.ENVIRONMENT) == "numpy":
        assert kernels.BACKEND == "numpy" and kernels.compiled is None
    else:
        assert kernels.BACKEND == "compiled", kernels.REASON


def test_numpy_asked_for_is_taken_silently():
    result = _run(CODE, DRAKE_SOT_KERNELS="numpy")
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["numpy"]
    assert result.stderr == ""


def test_a_compiled_module_that_cannot_be_imported_falls_back_in_one_line():
    blocked = "import sys; sys.modules['drake_sot.kernels._compiled'] = None; " + CODE
    result = _run(blocked)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["numpy"]
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "running on the numpy kernels" in lines[0] and "imported" in lines[0]


def test_a_module_built_from_other_sources_is_not_used(monkeypatch, capsys):
    if kernels.compiled is None:
        pytest.skip(f"no compiled module to compare: {kernels.REASON}")
    monkeypatch.setattr(kernels, "source_hash", lambda folder: "0" * 16)
    module, reason = kernels._load()
    assert module is None and "other sources" in reason
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "rebuild" in lines[0] and "numpy kernels" in lines[0]


@pytest.mark.parametrize("value", ["fortran", "\udcff", "x" * 10_000])
def test_an_unknown_choice_is_named_in_one_line(monkeypatch, capsys, value):
    monkeypatch.setattr(kernels.os, "environ", {kernels.ENVIRONMENT: value})
    kernels._load()
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines and kernels.ENVIRONMENT in lines[0] and "none of compiled, numpy" in lines[0]
    assert len(lines[0]) < 300
