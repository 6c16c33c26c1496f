"""`import vpffd` leaves the process as it found it; the application lives in vpffd.cli."""
import os
import subprocess
import sys

import pytest

import vpffd


def _run(code, **env):
    e = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "OMP_DISPLAY_ENV")}
    e.update(env)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=e, timeout=120)


@pytest.mark.skipif(not vpffd._core.has_openmp(), reason="built without OpenMP")
def test_passive_waits_without_touching_the_environment():
    # OMP_DISPLAY_ENV makes libgomp print the policy it read when it was loaded.
    p = _run("import os, vpffd; print('OMP_WAIT_POLICY' in os.environ)", OMP_DISPLAY_ENV="true")
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "False"
    assert "OMP_WAIT_POLICY = 'PASSIVE'" in p.stderr


@pytest.mark.skipif(not vpffd._core.has_openmp(), reason="built without OpenMP")
def test_the_users_policy_is_kept():
    p = _run("import os, vpffd; print(os.environ['OMP_WAIT_POLICY'])", OMP_WAIT_POLICY="ACTIVE",
             OMP_DISPLAY_ENV="true")
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "ACTIVE"
    assert "OMP_WAIT_POLICY = 'ACTIVE'" in p.stderr


def test_import_vpffd_does_not_import_the_application():
    p = _run("import sys, vpffd; print(sorted(m for m in sys.modules if m.startswith('vpffd.cli')))")
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]"


@pytest.mark.parametrize("old,new,name", [("vpffd.demo", "vpffd.cli.demo", "run_demo"),
                                          ("vpffd.benchmark", "vpffd.cli.benchmark", "run_benchmark")])
def test_old_module_names_work_with_a_deprecation_warning(old, new, name):
    p = _run(f"import warnings; warnings.simplefilter('error')\n"
             f"try:\n    import {old}\nexcept DeprecationWarning as e:\n    print('warned:', e)\n"
             f"warnings.simplefilter('ignore')\nimport {old} as o, {new} as n\nprint(getattr(o, '{name}') is getattr(n, '{name}'))")
    assert p.returncode == 0, p.stderr
    assert f"warned: {old} moved to {new}" in p.stdout
    assert p.stdout.strip().endswith("True")


def test_python_dash_m_runs_the_command():
    p = subprocess.run([sys.executable, "-m", "vpffd", "--version"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert vpffd.__version__ in p.stdout
