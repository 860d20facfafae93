"""`mbs compile`: two models' standalone C linked into one program, each under its own prefix, with its
default parameters and initial state; files with the user's umask."""

import os
import subprocess

import numpy as np
import pytest

import mbs
from mbs.cli import main
from mbs.runtime.build import compiler_command, have_c_compiler
from mbs.runtime.workspace import Workspace

pytestmark = pytest.mark.skipif(not have_c_compiler(), reason="needs a C compiler")

MAIN = r"""
#include <stdio.h>
#include "pendulum.h"
#include "double_pendulum.h"

int main(void)
{
    double w1[PENDULUM_NWORK + 1], w2[DOUBLE_PENDULUM_NWORK + 1];
    double xd1[PENDULUM_NX], xd2[DOUBLE_PENDULUM_NX];
    int i, s1 = pendulum_rhs(0.0, pendulum_initial_state(), pendulum_default_parameters(), xd1, w1);
    int s2 = double_pendulum_rhs(0.0, double_pendulum_initial_state(), double_pendulum_default_parameters(),
                                 xd2, w2);
    printf("%d %d\n", s1, s2);
    for (i = 0; i < PENDULUM_NX; i++) printf("%.17g\n", xd1[i]);
    for (i = 0; i < DOUBLE_PENDULUM_NX; i++) printf("%.17g\n", xd2[i]);
    printf("%s %s\n", pendulum_state_name(0), double_pendulum_state_name(1));
    return 0;
}
"""


def python_rhs(path):
    compiled = mbs.load(path).compile()
    data = Workspace(compiled)
    return data.rhs(0.0, compiled.x0), compiled.x_names


def test_two_models_link_into_one_program(tmp_path):
    old = os.umask(0o022)
    try:
        for name in ("pendulum", "double_pendulum"):
            assert main(["compile", f"library/examples/{name}.mbs", "-o", str(tmp_path)]) == 0
    finally:
        os.umask(old)
    assert oct((tmp_path / "pendulum.c").stat().st_mode & 0o777) == "0o644"
    assert oct((tmp_path / "libpendulum.so").stat().st_mode & 0o777) == "0o755"
    (tmp_path / "main.c").write_text(MAIN)
    program = tmp_path / "both"
    build = subprocess.run([*compiler_command(), "-std=c99", "-Wall", "-Wextra", "-Werror", "-I", str(tmp_path),
                            str(tmp_path / "main.c"), str(tmp_path / "pendulum.c"),
                            str(tmp_path / "double_pendulum.c"), "-o", str(program), "-lm"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    lines = subprocess.run([str(program)], capture_output=True, text=True, check=True).stdout.splitlines()
    assert lines[0] == "0 0"
    (rhs1, names1), (rhs2, names2) = (python_rhs(f"library/examples/{n}.mbs") for n in ("pendulum", "double_pendulum"))
    got = np.array([float(v) for v in lines[1:-1]])
    np.testing.assert_allclose(got, np.concatenate([rhs1, rhs2]), rtol=1e-12, atol=1e-12)
    assert lines[-1].split() == [names1[0], names2[1]]
